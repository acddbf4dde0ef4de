// Many robots on one crossing database, through the real server: some enroll new views (unary and
// bulk) while others recognize continuously, or several enroll the same images at once. Afterwards every enrolled view is there exactly once,
// no recognition saw half a view (every view it names has its crossing and its cluster), the
// incremental clusters equal a from-scratch rebuild, and a server killed with SIGKILL comes back
// with exactly the same database.

#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>
#include <signal.h>

#include <atomic>
#include <filesystem>
#include <map>
#include <mutex>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include "tests/support/crossing_test_client.h"
#include "tests/support/server_process.h"
#include "tests/support/synthetic_scene.h"
#include "waymark/v1/crossing.grpc.pb.h"

namespace waymark {
namespace {

using testing::CropView;
using testing::Ctx;
using testing::EnrollRequest;
using testing::MakePanorama;
using testing::RecognizeRequest;
using testing::ServerProcess;
using Client = testing::CrossingTestClient;

constexpr char kDatabase[] = "shared";
// Crossing 0 is enrolled before the robots start, so recognition has something to find at once.
// Crossings 1..kUnaryEnrollers enroll one EnrollView call at a time, the last one in a BulkEnroll
// stream.
constexpr int kUnaryEnrollers = 2;
constexpr int kCrossings = 1 + kUnaryEnrollers + 1;
constexpr int kBulkCrossing = kCrossings - 1;
constexpr int kViewsPerCrossing = 8;  // headings 0, 45, ..., 315
constexpr int kRecognizers = 3;
constexpr uint32_t kSeedBase = 900;

double Heading(int k) { return 45.0 * k; }

std::string CrossingName(int crossing) { return "crossing-" + std::to_string(crossing); }

// What a recognition named: the best view and every candidate, as (view, crossing id, crossing
// name, cluster id; 0 = none, kUnchecked for the best view, whose cluster the answer omits).
constexpr int64_t kUnchecked = -1;
struct Reference {
  int64_t view_id;
  int64_t crossing_id;
  std::string crossing;
  int64_t cluster_id;
};

// The parts of the database that must survive: views per crossing and the clusters.
struct Snapshot {
  int views = 0;
  int64_t keypoints = 0;
  std::map<std::string, int> views_per_crossing;
  std::map<std::string, int64_t> crossing_ids;
  std::set<std::pair<int64_t, int>> clusters;  // (centre view, members)
  std::set<int64_t> cluster_ids;
};

void ExpectSame(const Snapshot& actual, const Snapshot& expected) {
  EXPECT_EQ(actual.views, expected.views);
  EXPECT_EQ(actual.keypoints, expected.keypoints);
  EXPECT_EQ(actual.views_per_crossing, expected.views_per_crossing);
  EXPECT_EQ(actual.crossing_ids, expected.crossing_ids);
  EXPECT_EQ(actual.clusters, expected.clusters);
  EXPECT_EQ(actual.cluster_ids, expected.cluster_ids);
}

class ConcurrentEnrollTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = testing::MakeTempDir("waymark-concurrent");
    for (int c = 0; c < kCrossings; ++c) panoramas_.push_back(MakePanorama(kSeedBase + c));
    StartServer();
  }
  void TearDown() override {
    if (HasFailure()) {
      if (server_) std::cerr << "server log:\n" << server_->Log();
      return;  // the files stay for inspection
    }
    server_.reset();
    std::filesystem::remove_all(dir_);
  }

  void StartServer() {
    auto server = ServerProcess::Start(testing::ServerBinary(), dir_ + "/waymark.db");
    ASSERT_TRUE(server.ok()) << server.status();
    server_ = std::move(*server);
    client_ = std::make_unique<Client>(server_->address());
  }

  Snapshot Stats() {
    v1::GetDatabaseStatsRequest request;
    request.set_name(kDatabase);
    v1::DatabaseStats stats;
    const grpc::Status status = (*client_)->GetDatabaseStats(Ctx().get(), request, &stats);
    EXPECT_TRUE(status.ok()) << status.error_message();
    Snapshot snapshot;
    snapshot.views = stats.database().views();
    snapshot.keypoints = stats.keypoints();
    for (const v1::Crossing& c : stats.crossing_list()) {
      snapshot.views_per_crossing[c.name()] = c.views();
      snapshot.crossing_ids[c.name()] = c.id();
    }
    for (const v1::ClusterInfo& c : stats.clusters()) {
      snapshot.clusters.insert({c.center_view_id(), c.members()});
      snapshot.cluster_ids.insert(c.id());
    }
    return snapshot;
  }

  std::string dir_;
  std::vector<cv::Mat> panoramas_;
  std::unique_ptr<ServerProcess> server_;
  std::unique_ptr<Client> client_;
};

TEST_F(ConcurrentEnrollTest, EnrollWhileRecognizingKeepsEveryViewOnceAndAnswersConsistent) {
  v1::CreateDatabaseRequest create;
  create.set_name(kDatabase);
  v1::CrossingDatabase created;
  ASSERT_TRUE((*client_)->CreateDatabase(Ctx().get(), create, &created).ok());

  // Every view id a unary enrollment returned, with its crossing id.
  std::mutex mutex;
  std::map<int64_t, int64_t> enrolled_views;
  std::set<int64_t> enrolled_clusters;
  auto enroll_unary = [&](int crossing) {
    for (int k = 0; k < kViewsPerCrossing; ++k) {
      v1::EnrollViewResponse response;
      const grpc::Status status = (*client_)->EnrollView(
          Ctx().get(), EnrollRequest(kDatabase, crossing, Heading(k), panoramas_[crossing]),
          &response);
      ASSERT_TRUE(status.ok()) << CrossingName(crossing) << ": " << status.error_message();
      std::lock_guard<std::mutex> lock(mutex);
      EXPECT_TRUE(enrolled_views.emplace(response.view_id(), response.crossing_id()).second)
          << "view id " << response.view_id() << " returned twice";
      enrolled_clusters.insert(response.cluster_id());
    }
  };
  enroll_unary(0);

  // Queries 20 degrees off every enrolled heading of every crossing, encoded once.
  std::vector<v1::RecognizeRequest> queries;
  for (int c = 0; c < kCrossings; ++c) {
    for (int k = 0; k < kViewsPerCrossing; k += 2) {
      queries.push_back(RecognizeRequest(kDatabase, CropView(panoramas_[c], Heading(k) + 20)));
    }
  }

  std::atomic<bool> enrolling{true};
  std::vector<Reference> references;
  std::map<grpc::StatusCode, int> recognize_codes;
  int recognized = 0;
  std::vector<std::thread> recognizers;
  for (int r = 0; r < kRecognizers; ++r) {
    recognizers.emplace_back([&, r] {
      // At least one full pass over the queries, and on until the enrollments are done.
      for (size_t i = r; enrolling || i < queries.size() + r; ++i) {
        v1::RecognizeResponse response;
        const grpc::Status status =
            (*client_)->RecognizeCrossing(Ctx().get(), queries[i % queries.size()], &response);
        std::lock_guard<std::mutex> lock(mutex);
        recognize_codes[status.error_code()]++;
        if (!status.ok()) continue;
        if (response.recognized()) {
          ++recognized;
          references.push_back(
              {response.view_id(), response.crossing_id(), response.crossing(), kUnchecked});
        }
        for (const v1::Candidate& c : response.candidates()) {
          references.push_back({c.view_id(), c.crossing_id(), c.crossing(), c.cluster_id()});
        }
      }
    });
  }

  std::vector<std::thread> enrollers;
  for (int c = 1; c <= kUnaryEnrollers; ++c) enrollers.emplace_back(enroll_unary, c);
  enrollers.emplace_back([&] {
    auto ctx = Ctx(300);
    v1::BulkEnrollResponse summary;
    auto writer = (*client_)->BulkEnroll(ctx.get(), &summary);
    for (int k = 0; k < kViewsPerCrossing; ++k) {
      ASSERT_TRUE(writer->Write(
          EnrollRequest(kDatabase, kBulkCrossing, Heading(k), panoramas_[kBulkCrossing])));
    }
    writer->WritesDone();
    const grpc::Status status = writer->Finish();
    ASSERT_TRUE(status.ok()) << status.error_message();
    EXPECT_EQ(summary.views(), kViewsPerCrossing);
    EXPECT_EQ(summary.crossings_created(), 1);
  });
  for (std::thread& t : enrollers) t.join();
  enrolling = false;
  for (std::thread& t : recognizers) t.join();

  // Recognitions: only OK, or the documented overload answer.
  for (const auto& [code, count] : recognize_codes) {
    EXPECT_TRUE(code == grpc::StatusCode::OK || code == grpc::StatusCode::RESOURCE_EXHAUSTED)
        << count << " recognitions failed with code " << code;
  }
  EXPECT_GT(recognize_codes[grpc::StatusCode::OK], 0);
  EXPECT_GT(recognized, 0);

  // Every view enrolled exactly once, in its own crossing.
  const Snapshot after = Stats();
  EXPECT_EQ(after.views, kCrossings * kViewsPerCrossing);
  ASSERT_EQ(after.views_per_crossing.size(), static_cast<size_t>(kCrossings));
  for (int c = 0; c < kCrossings; ++c) {
    EXPECT_EQ(after.views_per_crossing.at(CrossingName(c)), kViewsPerCrossing) << c;
  }
  EXPECT_EQ(enrolled_views.size(), static_cast<size_t>((1 + kUnaryEnrollers) * kViewsPerCrossing));
  int members = 0;
  for (const auto& [centre, count] : after.clusters) members += count;
  EXPECT_EQ(members, after.views) << "every view belongs to exactly one cluster";
  for (int64_t cluster : enrolled_clusters) EXPECT_EQ(after.cluster_ids.count(cluster), 1u);

  // No torn reads: whatever a recognition named existed completely (its crossing by the same
  // name and id, its cluster), and a view id belongs to the crossing it was enrolled in.
  std::map<int64_t, std::string> crossing_names;
  for (const auto& [name, id] : after.crossing_ids) crossing_names[id] = name;
  const int64_t bulk_crossing_id = after.crossing_ids.at(CrossingName(kBulkCrossing));
  ASSERT_FALSE(references.empty());
  for (const Reference& ref : references) {
    ASSERT_EQ(crossing_names.count(ref.crossing_id), 1u) << "unknown crossing " << ref.crossing_id;
    EXPECT_EQ(ref.crossing, crossing_names.at(ref.crossing_id)) << "view " << ref.view_id;
    if (ref.cluster_id != kUnchecked) {
      EXPECT_EQ(after.cluster_ids.count(ref.cluster_id), 1u)
          << "view " << ref.view_id << " named with cluster " << ref.cluster_id;
    }
    auto unary = enrolled_views.find(ref.view_id);
    if (unary != enrolled_views.end()) {
      EXPECT_EQ(ref.crossing_id, unary->second) << "view " << ref.view_id;
    } else {
      EXPECT_EQ(ref.crossing_id, bulk_crossing_id)
          << "view " << ref.view_id << " was never enrolled";
    }
  }

  // Clusters are consistent: the incremental clustering of the interleaved enrollments is what a
  // sequential rebuild over the same views gives.
  v1::RebuildClustersRequest rebuild;
  rebuild.set_database(kDatabase);
  v1::RebuildClustersResponse rebuilt;
  ASSERT_TRUE((*client_)->RebuildClusters(Ctx().get(), rebuild, &rebuilt).ok());
  EXPECT_EQ(rebuilt.views(), after.views);
  const Snapshot after_rebuild = Stats();
  EXPECT_EQ(after_rebuild.clusters, after.clusters);

  // Every acknowledged write is on disk: a server killed without warning comes back with the same.
  EXPECT_EQ(server_->Stop(SIGKILL), 128 + SIGKILL);
  StartServer();
  ExpectSame(Stats(), after_rebuild);
  v1::RecognizeResponse response;
  ASSERT_TRUE((*client_)->RecognizeCrossing(Ctx().get(), queries.back(), &response).ok());
  EXPECT_TRUE(response.recognized()) << response.reason();
  EXPECT_EQ(response.crossing(), CrossingName(kBulkCrossing));
}

// Issue 15: several clients enroll the same images at once (unary, BulkEnroll and StreamEnroll):
// each image is stored once, every other enrollment of it is answered DUPLICATE, and the clusters
// are what a rebuild gives.
TEST_F(ConcurrentEnrollTest, ConcurrentEnrollmentsOfTheSameImagesStoreEachOnce) {
  v1::CreateDatabaseRequest create;
  create.set_name(kDatabase);
  v1::CrossingDatabase created;
  ASSERT_TRUE((*client_)->CreateDatabase(Ctx().get(), create, &created).ok());
  std::vector<v1::EnrollViewRequest> views;
  for (int k = 0; k < kViewsPerCrossing; ++k) {
    views.push_back(EnrollRequest(kDatabase, 0, Heading(k), panoramas_[0]));
  }

  std::mutex mutex;
  int stored = 0;
  int duplicates = 0;
  std::set<int64_t> stored_ids;
  auto count = [&](const v1::EnrollViewResponse& answer) {
    std::lock_guard<std::mutex> lock(mutex);
    if (answer.outcome() == v1::ENROLL_OUTCOME_STORED) {
      ++stored;
      EXPECT_TRUE(stored_ids.insert(answer.view_id()).second);
    } else {
      EXPECT_EQ(answer.outcome(), v1::ENROLL_OUTCOME_DUPLICATE);
      ++duplicates;
    }
  };
  std::vector<std::thread> clients;
  for (int streamer = 0; streamer < 2; ++streamer) {
    clients.emplace_back([&] {
      auto ctx = Ctx(300);
      auto stream = (*client_)->StreamEnroll(ctx.get());
      for (const v1::EnrollViewRequest& view : views) ASSERT_TRUE(stream->Write(view));
      stream->WritesDone();
      for (v1::EnrollViewResponse answer; stream->Read(&answer);) count(answer);
      const grpc::Status status = stream->Finish();
      ASSERT_TRUE(status.ok()) << status.error_message();
    });
  }
  clients.emplace_back([&] {
    for (const v1::EnrollViewRequest& view : views) {
      v1::EnrollViewResponse answer;
      const grpc::Status status = (*client_)->EnrollView(Ctx().get(), view, &answer);
      ASSERT_TRUE(status.ok()) << status.error_message();
      count(answer);
    }
  });
  v1::BulkEnrollResponse summary;
  clients.emplace_back([&] {
    auto ctx = Ctx(300);
    auto writer = (*client_)->BulkEnroll(ctx.get(), &summary);
    for (const v1::EnrollViewRequest& view : views) ASSERT_TRUE(writer->Write(view));
    writer->WritesDone();
    const grpc::Status status = writer->Finish();
    ASSERT_TRUE(status.ok()) << status.error_message();
  });
  for (std::thread& t : clients) t.join();

  EXPECT_EQ(stored + summary.views(), kViewsPerCrossing);
  EXPECT_EQ(duplicates + summary.duplicates(), 3 * kViewsPerCrossing);
  const Snapshot after = Stats();
  EXPECT_EQ(after.views, kViewsPerCrossing);
  EXPECT_EQ(after.views_per_crossing.at(CrossingName(0)), kViewsPerCrossing);
  v1::RebuildClustersRequest rebuild;
  rebuild.set_database(kDatabase);
  v1::RebuildClustersResponse rebuilt;
  ASSERT_TRUE((*client_)->RebuildClusters(Ctx().get(), rebuild, &rebuilt).ok());
  EXPECT_EQ(Stats().clusters, after.clusters);
}

}  // namespace
}  // namespace waymark
