#ifndef WAYMARK_SERVER_SERVICE_LIVE_LIVE_PAGE_H_
#define WAYMARK_SERVER_SERVICE_LIVE_LIVE_PAGE_H_

// The live view's own page (GET /): plain JavaScript and a canvas, no build step, embedded in the
// binary so a container needs no file beside it. It speaks the same Foxglove WebSocket protocol
// as any other viewer (subscribes to /sessions, then to the chosen session's grid, pose, scan,
// trajectory and confidence), with the page's own ?token= passed on.

#include "absl/strings/string_view.h"
#include "server/service/live/folder.h"

namespace waymark::service::live {

absl::string_view LivePage();

}  // namespace waymark::service::live

#endif  // WAYMARK_SERVER_SERVICE_LIVE_LIVE_PAGE_H_
