// WorkGate: at most max_running turns at once, at most max_waiting callers waiting, the next one
// refused at once with RESOURCE_EXHAUSTED; a released turn lets a waiter in.

#include "server/service/runtime/work_gate.h"

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <optional>
#include <thread>
#include <utility>

namespace waymark::service {
namespace {

// Polls `condition` (another thread is getting there); fails after a generous bound so a bug
// shows as a failure, not a hang.
template <typename Condition>
bool Eventually(Condition condition) {
  for (int i = 0; i < 10000 && !condition(); ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  return condition();
}

TEST(WorkGateTest, RunsUpToTheLimitQueuesUpToTheLimitAndRefusesTheRest) {
  WorkGate gate(2, 1);
  absl::StatusOr<WorkGate::Turn> first = gate.Enter("jobs");
  absl::StatusOr<WorkGate::Turn> second = gate.Enter("jobs");
  ASSERT_TRUE(first.ok() && second.ok());
  EXPECT_EQ(gate.running(), 2);

  std::atomic<bool> third_ran{false};
  std::thread third([&] {
    absl::StatusOr<WorkGate::Turn> turn = gate.Enter("jobs");
    EXPECT_TRUE(turn.ok()) << turn.status();
    third_ran = true;
  });
  ASSERT_TRUE(Eventually([&] { return gate.waiting() == 1; }));
  EXPECT_FALSE(third_ran);

  absl::StatusOr<WorkGate::Turn> fourth = gate.Enter("feature extractions");
  ASSERT_FALSE(fourth.ok());
  EXPECT_EQ(fourth.status().code(), absl::StatusCode::kResourceExhausted);
  EXPECT_EQ(fourth.status().message(),
            "server overloaded: 2 feature extractions running and 1 waiting; retry later");

  { WorkGate::Turn released = *std::move(first); }  // a moved-to turn releases once
  third.join();
  EXPECT_TRUE(third_ran);
  EXPECT_EQ(gate.waiting(), 0);
  EXPECT_EQ(gate.running(), 1);  // `second`; the third's turn ended with its thread
}

TEST(WorkGateTest, NoWaitingRoomRefusesAsSoonAsAllRun) {
  WorkGate gate(1, 0);
  absl::StatusOr<WorkGate::Turn> turn = gate.Enter("jobs");
  ASSERT_TRUE(turn.ok());
  EXPECT_EQ(gate.Enter("jobs").status().code(), absl::StatusCode::kResourceExhausted);
}

TEST(WorkGateTest, LimitsAreAtLeastOneRunningAndNoNegativeWaiting) {
  WorkGate gate(0, -5);
  EXPECT_EQ(gate.max_running(), 1);
  EXPECT_EQ(gate.max_waiting(), 0);
}

}  // namespace
}  // namespace waymark::service
