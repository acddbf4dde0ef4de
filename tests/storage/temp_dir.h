#ifndef WAYMARK_TESTS_STORAGE_TEMP_DIR_H_
#define WAYMARK_TESTS_STORAGE_TEMP_DIR_H_

// A fresh directory per test, removed afterwards, so file-backed tests never see each other's
// databases (ctest may run them in parallel).

#include <stdlib.h>

#include <filesystem>
#include <string>
#include <system_error>

#include "gtest/gtest.h"

namespace waymark::storage::testing {

class TempDir {
 public:
  TempDir() {
    std::string pattern =
        (std::filesystem::temp_directory_path() / "waymark_storage_test_XXXXXX").string();
    if (mkdtemp(pattern.data()) == nullptr) ADD_FAILURE() << "mkdtemp failed for " << pattern;
    path_ = pattern;
  }
  ~TempDir() {
    std::error_code ignored;
    std::filesystem::remove_all(path_, ignored);
  }
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;

  // A path inside the directory (not created).
  std::string File(const std::string& name) const { return (path_ / name).string(); }
  const std::filesystem::path& path() const { return path_; }

 private:
  std::filesystem::path path_;
};

}  // namespace waymark::storage::testing

#endif  // WAYMARK_TESTS_STORAGE_TEMP_DIR_H_
