#ifndef WAYMARK_STORAGE_STORE_UTIL_H_
#define WAYMARK_STORAGE_STORE_UTIL_H_

// Small things every store needs the same way, on SQLite and on PostgreSQL.

#include <chrono>
#include <string>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/string_view.h"

namespace waymark::storage {

// Wall-clock unix seconds: what created_at / updated_at columns hold.
inline double NowSeconds() {
  return std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
}

// A name or id in an error message, quoted so an empty or odd one is visible.
inline std::string Quoted(absl::string_view text) { return absl::StrCat("\"", text, "\""); }

// Creates the directory a database file (or its lock file) goes in, so `--db var/x.db` works on a
// fresh checkout. Nothing to do for ":memory:" or a bare file name. INTERNAL naming the directory
// when it cannot be created.
absl::Status EnsureParentDirectory(const std::string& file_path);

}  // namespace waymark::storage

#endif  // WAYMARK_STORAGE_STORE_UTIL_H_
