// The follow of a trajectory in a shared map as the store keeps it (map_follow_codec.h): a round
// trip keeps every sample and count, damaged bytes are DATA_LOSS, and the warnings a map's
// doubts call for (issue 38: the software says when it is unsure).

#include "server/service/slam/map_follow_codec.h"

#include <gtest/gtest.h>

#include <limits>
#include <string>
#include <utility>

namespace waymark::service {
namespace {

StoredFollow TwoSamples() {
  StoredFollow follow;
  laser_slam::OriginSample tie;
  tie.scan = 7;
  tie.stamp = 10.5;
  tie.origin = laser_slam::Pose2{1.0, -2.0, 0.3};
  laser_slam::OriginSample matched = tie;
  matched.scan = 22;
  matched.stamp = 14.25;
  matched.matched = true;
  matched.map_pose = laser_slam::Pose2{4.0, 5.0, -1.0};
  follow.samples = {tie, matched};
  follow.stats.set_tried(12);
  follow.stats.set_matched(9);
  follow.stats.set_weak(2);
  follow.stats.set_ambiguous(1);
  return follow;
}

TEST(MapFollowCodecTest, ARoundTripKeepsEverySampleAndCount) {
  const StoredFollow follow = TwoSamples();
  absl::StatusOr<StoredFollow> back = DecodeFollow(EncodeFollow(follow));
  ASSERT_TRUE(back.ok()) << back.status();
  ASSERT_EQ(back->samples.size(), 2u);
  EXPECT_EQ(back->samples[0].scan, 7u);
  EXPECT_FALSE(back->samples[0].matched);
  EXPECT_EQ(back->samples[1].stamp, 14.25);
  EXPECT_TRUE(back->samples[1].matched);
  EXPECT_EQ(back->samples[1].map_pose.y, 5.0);
  EXPECT_EQ(back->samples[1].origin.theta, 0.3);
  EXPECT_EQ(back->stats.SerializeAsString(), follow.stats.SerializeAsString());
  EXPECT_EQ(back->search.tried(), 0u);  // a follow stored before the searches were kept
}

// What the searches found up to the tie is stored with the tie, before any sample.
TEST(MapFollowCodecTest, TheSearchesUpToTheTieAreKeptWithoutSamples) {
  StoredFollow tie;
  tie.search.set_tried(164);
  tie.search.set_matched(78);
  tie.search.set_ambiguous(29);
  absl::StatusOr<StoredFollow> back = DecodeFollow(EncodeFollow(tie));
  ASSERT_TRUE(back.ok()) << back.status();
  EXPECT_TRUE(back->samples.empty());
  EXPECT_EQ(back->search.SerializeAsString(), tie.search.SerializeAsString());
  StoredFollow followed = TwoSamples();
  followed.search = tie.search;
  back = DecodeFollow(EncodeFollow(followed));
  ASSERT_TRUE(back.ok()) << back.status();
  EXPECT_EQ(back->samples.size(), 2u);
  EXPECT_EQ(back->search.ambiguous(), 29u);
}

TEST(MapFollowCodecTest, DamagedBytesAndBadSamplesAreDataLoss) {
  EXPECT_EQ(DecodeFollow(std::string("\xff\xff\xff\xff garbage", 12)).status().code(),
            absl::StatusCode::kDataLoss);
  StoredFollow backwards = TwoSamples();
  std::swap(backwards.samples[0], backwards.samples[1]);
  EXPECT_EQ(DecodeFollow(EncodeFollow(backwards)).status().code(), absl::StatusCode::kDataLoss);
  StoredFollow nan = TwoSamples();
  nan.samples[1].map_pose.x = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(DecodeFollow(EncodeFollow(nan)).status().code(), absl::StatusCode::kDataLoss);
}

TEST(MapFollowCodecTest, TheMapSaysWhenItIsUnsureOfARobot) {
  v1::MapTrajectory searching;
  searching.mutable_search()->set_tried(5);
  searching.mutable_search()->set_matched(2);
  EXPECT_EQ(MapTrajectoryWarning(searching), "");
  searching.mutable_search()->set_ambiguous(1);
  EXPECT_NE(MapTrajectoryWarning(searching).find("1 of 5 searches found look-alike places"),
            std::string::npos)
      << MapTrajectoryWarning(searching);

  v1::MapTrajectory followed;
  followed.set_tied_in(true);
  followed.mutable_follow()->set_tried(9);  // too few to say
  followed.mutable_follow()->set_weak(9);
  EXPECT_EQ(MapTrajectoryWarning(followed), "");
  followed.mutable_follow()->set_tried(20);
  followed.mutable_follow()->set_matched(10);  // half held: no doubt
  EXPECT_EQ(MapTrajectoryWarning(followed), "");
  followed.mutable_follow()->set_matched(6);
  followed.mutable_follow()->set_weak(11);
  followed.mutable_follow()->set_ambiguous(3);
  EXPECT_NE(MapTrajectoryWarning(followed).find("only 6 of 20 follow-up matches held (11 off the "
                                                "map, 3 between look-alike places)"),
            std::string::npos)
      << MapTrajectoryWarning(followed);

  // Tied in after searches that found look-alike places: it may be at one of them, whatever its
  // follow-up matches say (a half-turned robot in a floor with point symmetry matches as well).
  v1::MapTrajectory among_twins;
  among_twins.set_tied_in(true);
  among_twins.mutable_search()->set_tried(164);
  among_twins.mutable_search()->set_matched(78);
  EXPECT_EQ(MapTrajectoryWarning(among_twins), "");
  among_twins.mutable_search()->set_ambiguous(29);
  among_twins.mutable_follow()->set_tried(99);
  among_twins.mutable_follow()->set_matched(53);
  EXPECT_EQ(MapTrajectoryWarning(among_twins),
            "tied in after 29 of its 164 searches found look-alike places: it may be at one of "
            "them");
  among_twins.mutable_follow()->set_matched(20);
  const std::string both = MapTrajectoryWarning(among_twins);
  EXPECT_EQ(both.find("tied in after 29 of its 164"), 0u) << both;
  EXPECT_NE(both.find("; only 20 of 99 follow-up matches held"), std::string::npos) << both;
}

}  // namespace
}  // namespace waymark::service
