#include "client/lib/retry.h"

#include <gtest/gtest.h>

namespace waymark::client {
namespace {

TEST(RetryTest, BackoffGrowsExponentiallyUpToTheCap) {
  RetryOptions options;
  options.initial_backoff = absl::Milliseconds(100);
  options.backoff_multiplier = 2;
  options.max_backoff = absl::Milliseconds(500);
  EXPECT_EQ(BackoffDelay(options, 1), absl::Milliseconds(100));
  EXPECT_EQ(BackoffDelay(options, 2), absl::Milliseconds(200));
  EXPECT_EQ(BackoffDelay(options, 3), absl::Milliseconds(400));
  EXPECT_EQ(BackoffDelay(options, 4), absl::Milliseconds(500));
  EXPECT_EQ(BackoffDelay(options, 40), absl::Milliseconds(500));
}

TEST(RetryTest, JitterStaysWithinItsBand) {
  for (int i = 0; i < 200; ++i) {
    const absl::Duration d = Jitter(absl::Milliseconds(1000), 0.2);
    EXPECT_GE(d, absl::Milliseconds(800));
    EXPECT_LE(d, absl::Milliseconds(1200));
  }
  EXPECT_EQ(Jitter(absl::Milliseconds(1000), 0), absl::Milliseconds(1000));
}

TEST(RetryTest, OnlyUnavailableIsRetryable) {
  EXPECT_TRUE(IsRetryable(absl::UnavailableError("wifi")));
  EXPECT_FALSE(IsRetryable(absl::DeadlineExceededError("slow")));
  EXPECT_FALSE(IsRetryable(absl::NotFoundError("no db")));
  EXPECT_FALSE(IsRetryable(absl::InternalError("bug")));
  EXPECT_FALSE(IsRetryable(absl::OkStatus()));
}

}  // namespace
}  // namespace waymark::client
