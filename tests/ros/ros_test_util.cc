#include "tests/ros/ros_test_util.h"

#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <fstream>
#include <sstream>

namespace waymark::testing {

TempFolder::TempFolder() {
  std::string pattern = (std::filesystem::temp_directory_path() / "waymark-ros-XXXXXX").string();
  if (mkdtemp(pattern.data()) == nullptr) ADD_FAILURE() << "mkdtemp failed";
  path_ = pattern;
}

TempFolder::~TempFolder() {
  std::error_code ec;
  std::filesystem::remove_all(path_, ec);
}

int RunProgram(const std::vector<std::string>& argv) {
  const pid_t pid = fork();
  if (pid < 0) return -1;
  if (pid == 0) {
    std::vector<char*> args;
    for (const std::string& a : argv) args.push_back(const_cast<char*>(a.c_str()));
    args.push_back(nullptr);
    execvp(args[0], args.data());
    _exit(127);
  }
  int status = 0;
  if (waitpid(pid, &status, 0) < 0) return -1;
  return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
}

WrittenMessages::WrittenMessages() {
  const std::string dir = folder_.path().string();
  const std::string here = std::string(WAYMARK_SOURCE_DIR) + "/tests/ros/";
  EXPECT_EQ(RunProgram({kDebianPython, here + "write_ros1_messages.py", dir}), 0)
      << "write_ros1_messages.py failed (python3-rosbag, python3-sensor-msgs, python3-nav-msgs, "
         "python3-tf2-msgs from scripts/install-deps.sh?)";
  EXPECT_EQ(RunProgram({"node", here + "write_cdr_messages.js", dir}), 0)
      << "write_cdr_messages.js failed (tests/js/node_modules from scripts/install-deps.sh?)";
}

std::string WrittenMessages::Read(const std::string& name) const {
  std::ifstream in(folder_.path() / name, std::ios::binary);
  std::stringstream buffer;
  buffer << in.rdbuf();
  return buffer.str();
}

}  // namespace waymark::testing
