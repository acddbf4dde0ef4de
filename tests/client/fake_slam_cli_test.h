#ifndef WAYMARK_TESTS_CLIENT_FAKE_SLAM_CLI_TEST_H_
#define WAYMARK_TESTS_CLIENT_FAKE_SLAM_CLI_TEST_H_

// The fixture of the `waymark slam ...` command tests: a fake SLAM service on a local port, a
// temporary folder, the command line run against the service, and a CARMEN log to replay.

#include <gtest/gtest.h>

#include <fstream>
#include <string>
#include <utility>
#include <vector>

#include "tests/client/carmen_test_log.h"
#include "tests/client/fake_slam_service.h"
#include "tests/client/test_util.h"

namespace waymark::testing {

class FakeSlamCliTest : public ::testing::Test {
 protected:
  CliResult Run(std::vector<std::string> args) {
    return RunWaymark(server_.address(), std::move(args));
  }

  // A log of `scans` laser lines (MakeLog) in the temporary folder; its path.
  std::string WriteLog(int scans) {
    const auto path = dir_.path() / "test.clf";
    std::ofstream(path) << MakeLog(scans);
    return path.string();
  }

  ScopedTempDir dir_;
  FakeSlamServer server_;
};

}  // namespace waymark::testing

#endif  // WAYMARK_TESTS_CLIENT_FAKE_SLAM_CLI_TEST_H_
