#ifndef WAYMARK_SERVER_LASER_SLAM_MAPPING_GLOBAL_LOCALIZATION_H_
#define WAYMARK_SERVER_LASER_SLAM_MAPPING_GLOBAL_LOCALIZATION_H_

// The localizer's search for the robot over the whole map (localizer.h, docs/laser-slam.md
// "Localization on a map"): the best pose of a query over every position and heading of a coarse
// grid, refined on the fine grid, then the best rival place, the best pose far from it. A match
// with a rival that scores nearly as well could be either place (two look-alike rooms, a corridor
// that slides along itself) and must not become a fix.
//
// A search over a whole map costs 100-300 M cell reads (0.1-0.6 s here) even at the localizer's
// coarse settings, and took 0.6 s (MIT CSAIL's map) to 1.9 s (its exported grid) inside one
// scan before, so it is resumable under a budget of cell reads: GlobalSearchRunner spends a
// budget per scan on it, inside AddScan (threads = 0: deterministic, for tests and evaluations)
// or on its own thread (threads = 1: the server's setting, so that no answer waits on it).

#include <condition_variable>
#include <cstdint>
#include <memory>
#include <mutex>
#include <optional>
#include <thread>

#include "server/laser_slam/mapping/correlative_matcher.h"
#include "server/laser_slam/mapping/likelihood_grid.h"
#include "server/laser_slam/mapping/point_cloud.h"
#include "server/laser_slam/types.h"

namespace waymark::laser_slam {

struct GlobalSearchSettings {
  double min_score = 0.65;  // a match below it is no match (fine grid, refined)
  // A rival is a pose farther than rival_xy metres or rival_theta radians from the match; it is
  // searched for down to rival_floor times the match's lattice score (weaker ones are none).
  double rival_xy = 1.0;
  double rival_theta = 0.5;
  double rival_floor = 0.8;
  // The searches score the query thinned to one point per query_cell (m; 0 = the coarse grid's
  // cells): their cost is in proportion to the points.
  double query_cell = 0.0;
};

struct GlobalSearchOutcome {
  // The best pose over the whole map, refined on the fine grid (its score compares with the
  // tracking matches'), or nullopt when nothing reaches min_score.
  std::optional<GridMatch> match;
  double lattice_score = 0.0;  // the match's on the coarse lattice, before any refinement
  // The best rival place, found on the coarse lattice (down to rival_floor of lattice_score) and
  // refined on the fine grid as the match is (its score compares with match->score), or nullopt.
  // The coarse grid's wider field scores look-alike poses closer to the match than the fine one
  // does (MIT CSAIL: lattice scores of 0.94-0.99 for right matches, rivals at 0.8-0.99 of them).
  std::optional<GridMatch> rival;
  std::int64_t reads = 0;  // cell reads the search spent (its cost)
};

// One search: built with the query (the newest nodes' points in the newest node's frame) and the
// node it belongs to; Resume until done, then read outcome().
class GlobalSearch {
 public:
  // `coarse` (the search) and `fine` (the refinement) must outlive the search.
  GlobalSearch(const SearchPyramid& coarse, const SearchPyramid& fine,
               const GlobalSearchSettings& settings, std::uint64_t scan, double stamp,
               const Pose2& local, const PointCloud& query);
  // Spends about `budget` more cell reads; true once the search is over.
  bool Resume(std::int64_t budget);
  bool done() const { return phase_ == Phase::kDone; }
  const GlobalSearchOutcome& outcome() const { return outcome_; }
  // The node searched for: its scan, stamp and EKF pose.
  std::uint64_t scan() const { return scan_; }
  double stamp() const { return stamp_; }
  const Pose2& local() const { return local_; }

 private:
  enum class Phase { kBest, kRival, kDone };
  void StartRivalSearch();

  const SearchPyramid& coarse_;
  const SearchPyramid& fine_;
  const GlobalSearchSettings settings_;
  const std::uint64_t scan_;
  const double stamp_;
  const Pose2 local_;
  const PointCloud query_;         // fine (refinement)
  const PointCloud coarse_query_;  // thinned to the coarse grid's cells (the searches)
  const Pose2 centre_;             // of the coarse grid, heading 0
  const SearchWindow whole_;       // the coarse grid and every heading
  Phase phase_ = Phase::kBest;
  std::optional<BranchAndBoundSearch> search_;
  std::int64_t spent_before_ = 0;  // by searches finished before search_
  GlobalSearchOutcome outcome_;
};

// Runs one GlobalSearch at a time under a budget granted per scan. threads = 0: Advance runs it
// there and then, for at most the budget. threads = 1: Advance grants the budget to the runner's
// thread and returns at once, unless the thread is already more than `max_lag` reads behind: then
// it first waits until the thread is back within it. At a robot's pace that never happens (a
// budget of 4 M reads takes 5-10 ms, a scan period 25-200 ms); in a replay faster than real time
// it keeps the search at the pace, in scans, that it has inline, instead of falling hundreds of
// scans behind (Intel's first 3000 scans replayed at 0.1 ms a scan: first fix at scan 2047
// without the wait, 175 inline).
class GlobalSearchRunner {
 public:
  GlobalSearchRunner(int threads, std::int64_t max_lag);
  ~GlobalSearchRunner();  // stops the thread (a search under way is dropped)
  GlobalSearchRunner(const GlobalSearchRunner&) = delete;
  GlobalSearchRunner& operator=(const GlobalSearchRunner&) = delete;

  // A new search; any search not yet taken is dropped.
  void Start(std::unique_ptr<GlobalSearch> search);
  bool busy() const;  // a search is started and not yet taken
  void Advance(std::int64_t budget);
  // The search once it is over (then the runner is idle), else nullptr.
  std::unique_ptr<GlobalSearch> TakeFinished();
  void Cancel();  // drops the search under way (waits for the thread to let go of it)

 private:
  void WorkerLoop();

  const int threads_;
  const std::int64_t max_lag_;
  mutable std::mutex mu_;
  std::condition_variable work_cv_;
  std::condition_variable idle_cv_;
  std::unique_ptr<GlobalSearch> search_;  // guarded by mu_ except while running_
  bool running_ = false;                  // the thread works on search_ outside the lock
  std::int64_t banked_ = 0;               // reads granted that the thread has not spent yet
  bool stopping_ = false;
  std::thread worker_;
};

}  // namespace waymark::laser_slam

#endif  // WAYMARK_SERVER_LASER_SLAM_MAPPING_GLOBAL_LOCALIZATION_H_
