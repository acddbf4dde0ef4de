#ifndef WAYMARK_STORAGE_STATUS_MACROS_H_
#define WAYMARK_STORAGE_STATUS_MACROS_H_

// Early returns for the stores' .cc files (include only there): they keep each method a straight
// list of steps; the Transaction destructor undoes the partial work when one fails.

#include <utility>

#include "absl/status/status.h"

#define WAYMARK_STORAGE_CONCAT_INNER(a, b) a##b
#define WAYMARK_STORAGE_CONCAT(a, b) WAYMARK_STORAGE_CONCAT_INNER(a, b)
#define RETURN_IF_ERROR(expr)                                         \
  do {                                                                \
    if (absl::Status _status = (expr); !_status.ok()) return _status; \
  } while (false)
#define ASSIGN_OR_RETURN(lhs, expr) \
  ASSIGN_OR_RETURN_IMPL(WAYMARK_STORAGE_CONCAT(_status_or_, __LINE__), lhs, expr)
#define ASSIGN_OR_RETURN_IMPL(tmp, lhs, expr) \
  auto tmp = (expr);                          \
  if (!tmp.ok()) return tmp.status();         \
  lhs = std::move(*tmp)

#endif  // WAYMARK_STORAGE_STATUS_MACROS_H_
