#include "server/laser_slam/mapping/global_localization.h"

#include <algorithm>
#include <cmath>
#include <utility>

namespace waymark::laser_slam {
namespace {

Pose2 GridCentre(const LikelihoodGrid& grid) {
  return Pose2{grid.origin.x() + 0.5 * grid.width * grid.resolution,
               grid.origin.y() + 0.5 * grid.height * grid.resolution, 0.0};
}

SearchWindow WholeGrid(const LikelihoodGrid& grid) {
  return SearchWindow{0.5 * std::max(grid.width, grid.height) * grid.resolution, M_PI};
}

}  // namespace

GlobalSearch::GlobalSearch(const SearchPyramid& coarse, const SearchPyramid& fine,
                           const GlobalSearchSettings& settings, std::uint64_t scan,
                           double stamp, const Pose2& local, const PointCloud& query)
    : coarse_(coarse),
      fine_(fine),
      settings_(settings),
      scan_(scan),
      stamp_(stamp),
      local_(local),
      query_(query),
      coarse_query_(ThinPoints(query, settings.query_cell > 0 ? settings.query_cell
                                                              : coarse.base().resolution)),
      centre_(GridCentre(coarse.base())),
      whole_(WholeGrid(coarse.base())) {
  search_.emplace(coarse_, coarse_query_, centre_, whole_, settings_.min_score);
}

bool GlobalSearch::Resume(std::int64_t budget) {
  while (phase_ != Phase::kDone) {
    const std::int64_t before = search_->reads();
    const bool over = search_->Resume(budget);
    budget -= search_->reads() - before;
    outcome_.reads = spent_before_ + search_->reads();
    if (!over) return false;
    spent_before_ += search_->reads();
    if (phase_ == Phase::kBest) {
      const std::optional<GridMatch> coarse_match = search_->result();
      search_.reset();
      if (!coarse_match) {
        phase_ = Phase::kDone;
        break;
      }
      // Refined on the fine grid, where the score is comparable with the tracking one (a window
      // of two coarse cells: a small search, counted in the cost but not held to the budget).
      const SearchWindow refine{2.0 * coarse_.base().resolution, 0.05};
      std::optional<GridMatch> match =
          MatchInWindow(fine_, query_, coarse_match->pose, refine, settings_.min_score);
      if (match) {
        spent_before_ += match->candidates * static_cast<std::int64_t>(query_.size());
        outcome_.reads = spent_before_;
      }
      if (!match || match->score < settings_.min_score) {
        phase_ = Phase::kDone;
        break;
      }
      outcome_.match = match;
      outcome_.lattice_score = coarse_match->lattice_score;
      StartRivalSearch();
    } else {
      const std::optional<GridMatch> coarse_rival = search_->result();
      search_.reset();
      phase_ = Phase::kDone;
      if (coarse_rival) {
        const SearchWindow refine{2.0 * coarse_.base().resolution, 0.05};
        outcome_.rival = MatchInWindow(fine_, query_, coarse_rival->pose, refine, 0.0);
        if (outcome_.rival) {
          spent_before_ += outcome_.rival->candidates * static_cast<std::int64_t>(query_.size());
          outcome_.reads = spent_before_;
        }
      }
    }
    if (budget <= 0 && phase_ != Phase::kDone) return false;
  }
  return true;
}

void GlobalSearch::StartRivalSearch() {
  phase_ = Phase::kRival;
  const Pose2 best = outcome_.match->pose;
  const double far_xy = settings_.rival_xy, far_theta = settings_.rival_theta;
  const auto far = [best, far_xy, far_theta](const Pose2& q) {
    return std::hypot(q.x - best.x, q.y - best.y) > far_xy ||
           std::abs(std::remainder(q.theta - best.theta, 2 * M_PI)) > far_theta;
  };
  search_.emplace(coarse_, coarse_query_, centre_, whole_,
                  settings_.rival_floor * outcome_.lattice_score, /*first_only=*/false, far);
}

GlobalSearchRunner::GlobalSearchRunner(int threads, std::int64_t max_lag)
    : threads_(threads), max_lag_(max_lag) {
  if (threads_ > 0) worker_ = std::thread([this] { WorkerLoop(); });
}

GlobalSearchRunner::~GlobalSearchRunner() {
  {
    std::lock_guard<std::mutex> lock(mu_);
    stopping_ = true;
  }
  work_cv_.notify_all();
  if (worker_.joinable()) worker_.join();
}

void GlobalSearchRunner::Start(std::unique_ptr<GlobalSearch> search) {
  Cancel();
  std::lock_guard<std::mutex> lock(mu_);
  search_ = std::move(search);
  banked_ = 0;
}

bool GlobalSearchRunner::busy() const {
  std::lock_guard<std::mutex> lock(mu_);
  return search_ != nullptr || running_;
}

void GlobalSearchRunner::Advance(std::int64_t budget) {
  if (threads_ == 0) {
    // Only this thread touches the search.
    if (search_ && !search_->done()) search_->Resume(budget);
    return;
  }
  {
    std::unique_lock<std::mutex> lock(mu_);
    const auto searching = [this] { return running_ || (search_ && !search_->done()); };
    if (!searching()) return;
    idle_cv_.wait(lock, [&] { return stopping_ || !searching() || banked_ <= max_lag_; });
    banked_ += budget;
  }
  work_cv_.notify_one();
}

std::unique_ptr<GlobalSearch> GlobalSearchRunner::TakeFinished() {
  std::lock_guard<std::mutex> lock(mu_);
  if (running_ || !search_ || !search_->done()) return nullptr;
  banked_ = 0;
  return std::move(search_);
}

void GlobalSearchRunner::Cancel() {
  std::unique_lock<std::mutex> lock(mu_);
  idle_cv_.wait(lock, [this] { return !running_; });
  search_.reset();
  banked_ = 0;
}

void GlobalSearchRunner::WorkerLoop() {
  // The budget is spent in slices so that a cancel or a stop waits for one slice at most.
  constexpr std::int64_t kSlice = 2'000'000;
  std::unique_lock<std::mutex> lock(mu_);
  while (true) {
    work_cv_.wait(lock, [this] {
      return stopping_ || (search_ && !search_->done() && banked_ > 0);
    });
    if (stopping_) return;
    std::unique_ptr<GlobalSearch> search = std::move(search_);
    const std::int64_t slice = std::min(banked_, kSlice);
    running_ = true;
    lock.unlock();
    const std::int64_t before = search->outcome().reads;
    search->Resume(slice);
    const std::int64_t spent = search->outcome().reads - before;
    lock.lock();
    running_ = false;
    banked_ = std::max<std::int64_t>(0, banked_ - spent);
    search_ = std::move(search);
    idle_cv_.notify_all();
  }
}

}  // namespace waymark::laser_slam
