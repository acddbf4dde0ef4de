// The README's tour, run as written: every `$W ...` command of its ```sh blocks that needs no
// placeholder input (your photos, a camera, a keyboard) runs against a real server from a copy of
// the repository's layout (build/, ../shared), and must succeed; the output the README quotes must
// be what the commands print. A README edit that breaks a command, or a code change that breaks
// the README, fails here. Skipped when ../shared is absent.

#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_replace.h"
#include "absl/strings/strip.h"
#include "tests/support/server_process.h"

namespace waymark {
namespace {

namespace fs = std::filesystem;

struct ReadmeBlocks {
  std::vector<std::string> commands;   // `$W ...` lines, continuations joined
  std::vector<std::string> variables;  // `NAME=value` lines, in order
  std::vector<std::string> quoted_output;  // lines of the un-labelled ``` blocks
};

std::string ReadText(const fs::path& path) {
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

ReadmeBlocks ParseReadme(const std::string& text) {
  ReadmeBlocks blocks;
  std::istringstream in(text);
  std::string line;
  enum { kProse, kShell, kOutput, kOther } state = kProse;
  std::string pending;  // a command continued with a trailing backslash
  while (std::getline(in, line)) {
    if (absl::StartsWith(line, "```")) {
      if (state != kProse) {
        state = kProse;
      } else if (line == "```sh") {
        state = kShell;
      } else if (line == "```") {
        state = kOutput;
      } else {
        state = kOther;
      }
      continue;
    }
    if (state == kOutput) blocks.quoted_output.push_back(line);
    if (state != kShell) continue;
    std::string code(absl::StripAsciiWhitespace(line.substr(0, line.find("  #"))));
    if (!pending.empty()) code = absl::StrCat(pending, " ", code);
    pending.clear();
    if (absl::EndsWith(code, "\\")) {
      pending = std::string(absl::StripSuffix(code, "\\"));
      continue;
    }
    if (absl::StartsWith(code, "$W ")) {
      blocks.commands.push_back(code);
    } else if (code.find('=') != std::string::npos && code.find(' ') == std::string::npos) {
      blocks.variables.push_back(code);
    }
  }
  return blocks;
}

// Why a command cannot run unattended here, or empty when it can.
std::string WhyNotRunnable(const std::string& command) {
  if (absl::StrContains(command, "~/")) return "needs the reader's own folders";
  if (absl::StrContains(command, "photo")) return "needs the reader's photos";
  // `recognize --camera N` opens a camera; `vo run --camera NAME` only names intrinsics.
  if (absl::StartsWith(command, "$W recognize ") && absl::StrContains(command, "--camera ")) {
    return "needs a camera";
  }
  if (absl::StartsWith(command, "$W robot ")) return "interactive (keyboard)";
  return "";
}

TEST(ReadmeCommandsTest, TourCommandsRunAsWrittenAndPrintWhatTheReadmeQuotes) {
  const fs::path shared = WAYMARK_SHARED_DIR;
  if (!fs::exists(shared / "data")) GTEST_SKIP() << "no ../shared/data beside the repository";
  const ReadmeBlocks readme = ParseReadme(ReadText(fs::path(WAYMARK_SOURCE_DIR) / "README.md"));
  ASSERT_FALSE(readme.commands.empty()) << "no `$W ...` commands found in README.md";

  // A repository-shaped work directory: build/ and ../shared as the README assumes.
  const fs::path root = testing::MakeTempDir("readme");
  const fs::path repo = root / "repo";
  fs::create_directories(repo);
  fs::create_directory_symlink(WAYMARK_BINARY_DIR, repo / "build");
  fs::create_directory_symlink(shared, root / "shared");

  auto server = testing::ServerProcess::Start(testing::ServerBinary(), (root / "w.db").string());
  ASSERT_TRUE(server.ok()) << server.status();

  std::string prelude = absl::StrCat("cd '", repo.string(), "' && export WAYMARK_SERVER=",
                                     (*server)->address(), " && W=build/bin/waymark");
  for (const std::string& variable : readme.variables) {
    if (!absl::StartsWith(variable, "W=")) absl::StrAppend(&prelude, " && ", variable);
  }

  std::string all_output;
  int ran = 0;
  for (const std::string& command : readme.commands) {
    const std::string why_not = WhyNotRunnable(command);
    if (!why_not.empty()) {
      std::cerr << "[ skipped ] " << command << " (" << why_not << ")\n";
      continue;
    }
    std::cerr << "[ running ] " << command << "\n";
    const std::string shell = absl::StrCat(prelude, " && ", command, " 2>&1");
    FILE* pipe = popen(shell.c_str(), "r");
    ASSERT_NE(pipe, nullptr);
    std::string output;
    char buffer[4096];
    size_t n;
    while ((n = fread(buffer, 1, sizeof(buffer), pipe)) > 0) output.append(buffer, n);
    const int status = pclose(pipe);
    EXPECT_EQ(status, 0) << command << "\n" << output;
    all_output += output;
    ++ran;
  }
  // The tour's laser, exploration and visual odometry commands need nothing but ../shared.
  EXPECT_GE(ran, 4) << "fewer README commands ran than the tour has (did its blocks change?)";

  // What the README quotes as output, minus timings (they depend on the machine), must appear.
  for (const std::string& quoted : readme.quoted_output) {
    if (absl::StrContains(quoted, "session ")) {
      // "session ID: 7374 scans processed ...": the id is new each run. A VO run's "... in 5.56 s"
      // is a timing, and its keyframe count may differ on a loaded machine: neither is compared.
      std::string tail = quoted.substr(quoted.find(": ") + 2);
      if (const size_t at = tail.rfind(" in "); at != std::string::npos && absl::EndsWith(tail, " s")) {
        tail.resize(at);
      }
      if (const size_t at = tail.rfind(", "); at != std::string::npos &&
                                              absl::EndsWith(tail, " keyframes)")) {
        tail.resize(at);
      }
      EXPECT_TRUE(absl::StrContains(all_output, tail)) << "README quotes: " << tail;
    } else if (absl::StartsWith(quoted, "translational") || absl::StartsWith(quoted, "rotational")) {
      EXPECT_TRUE(absl::StrContains(all_output, quoted)) << "README quotes: " << quoted;
    }
  }
  fs::remove_all(root);
}

}  // namespace
}  // namespace waymark
