// The recognition parameters a request may override (server/service/crossing/params.h).

#include <gtest/gtest.h>

#include "server/crossing/options.h"
#include "server/service/crossing/params.h"

namespace waymark::service {
namespace {

// Issue 34: the global path's false-alarm bound is set per request (and per database) like the
// NFA path's, and checked like every other parameter.
TEST(CrossingParamsTest, TheGlobalPathsFalseAlarmBoundIsARequestOverride) {
  const crossing::RecognitionOptions database;
  v1::RecognitionParams request;
  absl::StatusOr<crossing::RecognitionOptions> unchanged =
      ResolveRecognitionOptions(database, request);
  ASSERT_TRUE(unchanged.ok()) << unchanged.status();
  EXPECT_EQ(unchanged->max_log10_global_efa, database.max_log10_global_efa);
  request.set_max_log10_global_efa(-4.0);
  absl::StatusOr<crossing::RecognitionOptions> stricter =
      ResolveRecognitionOptions(database, request);
  ASSERT_TRUE(stricter.ok()) << stricter.status();
  EXPECT_EQ(stricter->max_log10_global_efa, -4.0);
  request.set_max_log10_global_efa(1e9);
  EXPECT_EQ(ResolveRecognitionOptions(database, request).status().code(),
            absl::StatusCode::kInvalidArgument);
}

}  // namespace
}  // namespace waymark::service
