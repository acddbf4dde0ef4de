#ifndef WAYMARK_SERVER_SERVICE_LIVE_FOLDER_H_
#define WAYMARK_SERVER_SERVICE_LIVE_FOLDER_H_

// Every header of server/service/live/ includes this: it compiles only in a target that links
// waymark_service_live, which defines WAYMARK_SERVICE_LIVE for itself and for every target that
// links it. A folder links only the folders it may use (server/service/CMakeLists.txt), so one that
// includes a header of a folder it may not use does not build.

#ifndef WAYMARK_SERVICE_LIVE
#error "server/service/live/ headers need waymark_service_live linked (server/service/CMakeLists.txt)"
#endif

#endif  // WAYMARK_SERVER_SERVICE_LIVE_FOLDER_H_
