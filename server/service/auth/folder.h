#ifndef WAYMARK_SERVER_SERVICE_AUTH_FOLDER_H_
#define WAYMARK_SERVER_SERVICE_AUTH_FOLDER_H_

// Every header of server/service/auth/ includes this: it compiles only in a target that links
// waymark_service_auth, which defines WAYMARK_SERVICE_AUTH for itself and for every target that
// links it. A folder links only the folders it may use (server/service/CMakeLists.txt), so one that
// includes a header of a folder it may not use does not build.

#ifndef WAYMARK_SERVICE_AUTH
#error "server/service/auth/ headers need waymark_service_auth linked (server/service/CMakeLists.txt)"
#endif

#endif  // WAYMARK_SERVER_SERVICE_AUTH_FOLDER_H_
