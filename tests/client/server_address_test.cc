// --server without a port means the server's default port (issue 15: `--server 127.0.0.1` dialled
// port 0).
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "client/cli/server_address.h"

namespace waymark::cli {
namespace {

using ::testing::HasSubstr;

std::string Completed(const std::string& target) {
  absl::StatusOr<std::string> completed = WithDefaultPort(target);
  EXPECT_TRUE(completed.ok()) << target << ": " << completed.status();
  return completed.value_or("");
}

TEST(DefaultPortTest, AHostWithoutAPortGetsTheDefaultPort) {
  EXPECT_EQ(Completed("127.0.0.1"), "127.0.0.1:50051");
  EXPECT_EQ(Completed("robot-hub.lab"), "robot-hub.lab:50051");
  EXPECT_EQ(Completed("[::1]"), "[::1]:50051");
  EXPECT_EQ(Completed("::1"), "[::1]:50051");  // a bare IPv6 address cannot carry a port
  EXPECT_EQ(Completed("fe80::2"), "[fe80::2]:50051");
  EXPECT_EQ(Completed("dns:///robot-hub"), "dns:///robot-hub:50051");
  EXPECT_EQ(Completed("dns:robot-hub"), "dns:robot-hub:50051");
  EXPECT_EQ(Completed("dns://10.0.0.1/robot-hub"), "dns://10.0.0.1/robot-hub:50051");
  EXPECT_EQ(Completed("ipv4:10.0.0.1,10.0.0.2:7"), "ipv4:10.0.0.1:50051,10.0.0.2:7");
  EXPECT_EQ(Completed("ipv6:[::1]"), "ipv6:[::1]:50051");
}

TEST(DefaultPortTest, AddressesWithAPortAndSocketsAreUntouched) {
  for (const char* target :
       {"127.0.0.1:50051", "localhost:7", "[::1]:9000", "dns:///robot-hub:443",
        "ipv4:127.0.0.1:5", "unix:/run/waymark.sock", "unix:relative.sock",
        "unix-abstract:waymark", "xds:///waymark"}) {
    EXPECT_EQ(Completed(target), target);
  }
}

TEST(DefaultPortTest, RefusesWhatCannotBeDialled) {
  for (const char* target : {"", "127.0.0.1:0", "host:70000", "host:", "host:http", ":50051",
                             "[::1", "[::1]x", "[]:5"}) {
    absl::StatusOr<std::string> completed = WithDefaultPort(target);
    ASSERT_FALSE(completed.ok()) << target << " -> " << *completed;
    EXPECT_EQ(completed.status().code(), absl::StatusCode::kInvalidArgument);
    EXPECT_THAT(completed.status().message(), HasSubstr("expected HOST[:PORT]")) << target;
  }
  EXPECT_THAT(WithDefaultPort("127.0.0.1:0").status().message(),
              HasSubstr("port '0' is not a number in 1..65535"));
}

}  // namespace
}  // namespace waymark::cli
