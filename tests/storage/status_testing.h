#ifndef WAYMARK_TESTS_STORAGE_STATUS_TESTING_H_
#define WAYMARK_TESTS_STORAGE_STATUS_TESTING_H_

// Assertions on absl::Status / absl::StatusOr that print the status when they fail (gtest 1.12
// has no status matchers).

#include <utility>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "gtest/gtest.h"

namespace waymark::storage::testing {

inline const absl::Status& StatusOf(const absl::Status& status) { return status; }
template <typename T>
const absl::Status& StatusOf(const absl::StatusOr<T>& status_or) {
  return status_or.status();
}

// The code of a Status or StatusOr: EXPECT_EQ(CodeOf(store->Get(...)),
// absl::StatusCode::kNotFound).
template <typename T>
absl::StatusCode CodeOf(const T& status) {
  return StatusOf(status).code();
}

}  // namespace waymark::storage::testing

#define WAYMARK_TEST_CONCAT_INNER(a, b) a##b
#define WAYMARK_TEST_CONCAT(a, b) WAYMARK_TEST_CONCAT_INNER(a, b)

#define EXPECT_OK(expr)                                                          \
  do {                                                                           \
    const auto& _result = (expr);                                                \
    EXPECT_TRUE(_result.ok()) << ::waymark::storage::testing::StatusOf(_result); \
  } while (false)

#define ASSERT_OK(expr)                                                          \
  do {                                                                           \
    const auto& _result = (expr);                                                \
    ASSERT_TRUE(_result.ok()) << ::waymark::storage::testing::StatusOf(_result); \
  } while (false)

#define ASSERT_OK_AND_ASSIGN(lhs, expr) \
  ASSERT_OK_AND_ASSIGN_IMPL(WAYMARK_TEST_CONCAT(_status_or_, __LINE__), lhs, expr)
#define ASSERT_OK_AND_ASSIGN_IMPL(tmp, lhs, expr)                      \
  auto tmp = (expr);                                                   \
  ASSERT_TRUE(tmp.ok()) << ::waymark::storage::testing::StatusOf(tmp); \
  lhs = std::move(*tmp)

#endif  // WAYMARK_TESTS_STORAGE_STATUS_TESTING_H_
