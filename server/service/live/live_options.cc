#include "server/service/live/live_options.h"

#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"

namespace waymark::service::live {

absl::Status ParseLiveAddress(const std::string& address, LiveOptions* options) {
  const size_t colon = address.rfind(':');
  const std::string host = colon == std::string::npos ? "" : address.substr(0, colon);
  const std::string port = colon == std::string::npos ? address : address.substr(colon + 1);
  int value = -1;
  if (!absl::SimpleAtoi(port, &value) || value < 0 || value > 65535) {
    return absl::InvalidArgumentError(absl::StrCat(
        "--live \"", address, "\": expected PORT or HOST:PORT (a port 0-65535; 0 picks one)"));
  }
  if (host.find(':') != std::string::npos || host.find('[') != std::string::npos) {
    return absl::InvalidArgumentError(
        absl::StrCat("--live \"", address, "\": IPv6 addresses are not supported; use IPv4"));
  }
  options->host = host.empty() ? "127.0.0.1" : host;
  options->port = value;
  return absl::OkStatus();
}

}  // namespace waymark::service::live
