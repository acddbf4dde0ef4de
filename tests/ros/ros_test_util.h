#ifndef WAYMARK_TESTS_ROS_ROS_TEST_UTIL_H_
#define WAYMARK_TESTS_ROS_ROS_TEST_UTIL_H_

// What tests/ros shares: a temporary folder, and the messages ROS's own serializers wrote into it.

#include <filesystem>
#include <string>
#include <vector>

namespace waymark::testing {

// A fresh folder under the system's temp dir, removed on destruction.
class TempFolder {
 public:
  TempFolder();
  ~TempFolder();
  const std::filesystem::path& path() const { return path_; }

 private:
  std::filesystem::path path_;
};

// Runs `argv` (no shell), its output into the test log; the exit code.
int RunProgram(const std::vector<std::string>& argv);

// The messages write_ros1_messages.py (genpy) and write_cdr_messages.js (Foxglove) wrote: one file
// per message, NAME.ros1 and NAME.cdr. Fails the test (ADD_FAILURE) when a writer fails.
class WrittenMessages {
 public:
  WrittenMessages();
  std::string Read(const std::string& name) const;

 private:
  TempFolder folder_;
};

// The python3 that has Debian's ROS packages (/usr/bin/python3: a pyenv shim on PATH may not).
inline const char* kDebianPython = "/usr/bin/python3";

}  // namespace waymark::testing

#endif  // WAYMARK_TESTS_ROS_ROS_TEST_UTIL_H_
