#include "client/common/output.h"

#include <gtest/gtest.h>

#include <sstream>

#include "client/lib/status_util.h"

namespace waymark::cli {
namespace {

TEST(TableTest, AlignsColumnsAndRightAlignsNumbers) {
  Table table({{"crossing"}, {"views", true}});
  table.AddRow({"A", "12"});
  table.AddRow({"Main-Street", "3"});
  std::ostringstream out;
  table.Print(out);
  EXPECT_EQ(out.str(),
            "crossing     views\n"
            "A               12\n"
            "Main-Street      3\n");
}

TEST(FormatTest, NumbersPercentagesAndBytes) {
  EXPECT_EQ(FormatNumber(12.345, 2), "12.35");
  EXPECT_EQ(FormatNumber(std::nullopt), "-");
  EXPECT_EQ(FormatPercent(0.5), "50.0%");
  EXPECT_EQ(FormatPercent(std::nullopt), "-");
  EXPECT_EQ(FormatBytes(512), "512 B");
  EXPECT_EQ(FormatBytes(51200), "50.0 KiB");
  EXPECT_EQ(FormatBytes(int64_t{3} << 20), "3.0 MiB");
  EXPECT_EQ(FormatBytes(int64_t{5} << 40), "5120.0 GiB");
  EXPECT_TRUE(OptionalJson(std::nullopt).is_null());
  EXPECT_EQ(OptionalJson(0.25), 0.25);
}

TEST(ReportErrorTest, CodeNameMessageAndContext) {
  std::ostringstream out, err;
  CommandContext context{GlobalOptions{}, out, err};
  EXPECT_NE(ReportError(context, absl::NotFoundError("no database 'x'"), "q/A/1.png"), 0);
  EXPECT_EQ(err.str(), "error: NOT_FOUND: no database 'x' (q/A/1.png)\n");
  EXPECT_EQ(out.str(), "");

  std::ostringstream err2;
  CommandContext remote{GlobalOptions{}, out, err2};
  remote.globals.server = "robot-hub:50051";
  ReportError(remote, absl::DeadlineExceededError("no answer"));
  EXPECT_EQ(err2.str(), "error: DEADLINE_EXCEEDED: no answer [server robot-hub:50051]\n");
}

TEST(ReportErrorTest, AnUnreachableServerIsNamedWithTheAddressDialled) {
  std::ostringstream out, err;
  CommandContext context{GlobalOptions{}, out, err};
  context.globals.server = "robot-hub:50051";
  ReportError(context, client::ToAbslStatus(grpc::Status(grpc::StatusCode::UNAVAILABLE,
                                                         "failed to connect to all addresses")));
  EXPECT_EQ(err.str(),
            "error: UNAVAILABLE: failed to connect to all addresses: is the server running at "
            "robot-hub:50051? (--server HOST[:PORT] or WAYMARK_SERVER names another)\n");
}

TEST(ReportErrorTest, AnUnavailableDeviceIsNotBlamedOnTheServer) {
  std::ostringstream out, err;
  CommandContext context{GlobalOptions{}, out, err};
  ReportError(context, absl::UnavailableError("/dev/ttyUSB0 hung up (device disconnected)"));
  EXPECT_EQ(err.str(), "error: UNAVAILABLE: /dev/ttyUSB0 hung up (device disconnected)\n");
}

}  // namespace
}  // namespace waymark::cli
