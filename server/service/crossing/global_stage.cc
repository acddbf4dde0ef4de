#include "server/service/crossing/global_stage.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <cstring>
#include <unordered_map>
#include <utility>
#include <vector>

#include <opencv2/imgcodecs.hpp>

#include "absl/strings/str_cat.h"
#include "server/common/stopwatch.h"
#include "server/crossing/dense_sift.h"
#include "server/crossing/vlad.h"
#include "server/service/crossing/crossing_loading.h"

namespace waymark::service {
namespace {

cv::Mat SampleFromBytes(const std::string& bytes) {
  if (bytes.empty() || bytes.size() % crossing::kDescriptorSize != 0) return {};
  cv::Mat sample(static_cast<int>(bytes.size() / crossing::kDescriptorSize),
                 crossing::kDescriptorSize, CV_8U);
  std::memcpy(sample.data, bytes.data(), bytes.size());
  return sample;
}

std::string SampleToBytes(const cv::Mat& sample) {
  if (sample.empty()) return {};
  const cv::Mat rows = sample.isContinuous() ? sample : sample.clone();
  return std::string(reinterpret_cast<const char*>(rows.data), rows.total() * rows.elemSize());
}

// The view's code under `vocabulary`, computed again from its stored working image.
absl::StatusOr<crossing::GlobalCode> CodeFromWorkImage(storage::CrossingStore& store,
                                                       int64_t view_id,
                                                       const crossing::VladVocabulary& vocabulary) {
  absl::StatusOr<std::string> png = store.LoadWorkImage(view_id);
  if (!png.ok()) return png.status();
  const cv::Mat gray = cv::imdecode(cv::Mat(1, static_cast<int>(png->size()), CV_8U, png->data()),
                                    cv::IMREAD_GRAYSCALE);
  if (gray.empty()) {
    return absl::DataLossError(absl::StrCat("view ", view_id, ": stored working image is corrupt"));
  }
  return crossing::QuantizeGlobal(vocabulary.Encode(crossing::DenseRootSift(gray)));
}

}  // namespace

bool KeepsSamples(const ResidentDatabase& db) {
  return db.global.trained_views < kLastVocabularyViews;
}

bool NeedsVocabulary(int views, int trained_views) {
  // The last size of the schedule (16, 32, 64, ... 512) the database has reached; a vocabulary is
  // learnt from exactly that many views, its first ones (vlad.h, VocabularyScheduleSize).
  const int due = crossing::VocabularyScheduleSize(views, kFirstVocabularyViews,
                                                   kLastVocabularyViews);
  return due > 0 && trained_views < due;
}

bool GlobalStageHasWork(const ResidentDatabase& db) {
  if (db.deleted || !db.options.features.global_descriptor) return false;
  return NeedsVocabulary(static_cast<int>(db.views->views().size()), db.global.trained_views) ||
         (db.global.vocabulary != 0 && !db.global.uncoded.empty());
}

absl::StatusOr<PreparedGlobal> PrepareGlobal(const ResidentDatabase& db,
                                             const crossing::ImageFeatures& features) {
  PreparedGlobal prepared;
  std::vector<uchar> png;
  if (features.working_gray.empty() || !cv::imencode(".png", features.working_gray, png)) {
    return absl::InternalError("could not encode the working image for the global descriptor");
  }
  prepared.work_image.assign(png.begin(), png.end());
  prepared.sample = crossing::EvenRows(features.dense, crossing::kVocabularySampleRows);
  crossing::VladVocabulary vocabulary;  // shares the words: a new vocabulary replaces, never edits
  {
    absl::ReaderMutexLock lock(&db.mutex);
    vocabulary = db.views->vocabulary();
    prepared.vocabulary = db.global.vocabulary;
  }
  if (prepared.vocabulary != 0) {
    prepared.code = crossing::QuantizeGlobal(vocabulary.Encode(features.dense));
  }
  return prepared;
}

void FillGlobalRecord(const ResidentDatabase& db, const PreparedGlobal& prepared,
                      storage::ViewRecord* record) {
  record->work_image = prepared.work_image;
  if (KeepsSamples(db)) record->global_sample = SampleToBytes(prepared.sample);
  if (prepared.vocabulary != 0 && prepared.vocabulary == db.global.vocabulary) {
    record->global_code = crossing::SerializeGlobalCode({prepared.vocabulary, prepared.code});
  }
}

void InstallGlobal(ResidentDatabase& db, uint32_t slot, int64_t view_id,
                   const PreparedGlobal& prepared) {
  if (KeepsSamples(db)) db.views->SetGlobalSample(slot, prepared.sample);
  if (db.global.vocabulary == 0) return;
  if (prepared.vocabulary == db.global.vocabulary) {
    db.views->SetGlobalCode(slot, prepared.code);
  } else {
    db.global.uncoded.insert(view_id);  // prepared under a vocabulary that has been replaced
  }
}

void LoadGlobalVocabulary(ResidentDatabase& db,
                          const std::optional<storage::VocabularyRecord>& record) {
  if (!record.has_value()) return;
  absl::StatusOr<crossing::VladVocabulary> vocabulary =
      crossing::VladVocabulary::Deserialize(record->data);
  if (!vocabulary.ok() || vocabulary->empty()) {
    spdlog::warn("database \"{}\": stored vocabulary dropped ({}); it is learnt again",
                 db.record.name, vocabulary.ok() ? "empty" : vocabulary.status().ToString());
    return;
  }
  db.global.vocabulary = vocabulary->Fingerprint();
  db.global.trained_views = record->trained_views;
  db.views->SetVocabulary(*std::move(vocabulary));
}

void LoadGlobalView(ResidentDatabase& db, uint32_t slot, const storage::ViewRecord& view) {
  if (KeepsSamples(db)) db.views->SetGlobalSample(slot, SampleFromBytes(view.global_sample));
  if (db.global.vocabulary == 0 || !db.options.features.global_descriptor) return;
  if (!view.global_code.empty()) {
    absl::StatusOr<crossing::StoredGlobalCode> stored =
        crossing::DeserializeGlobalCode(view.global_code);
    if (stored.ok() && stored->vocabulary == db.global.vocabulary) {
      db.views->SetGlobalCode(slot, stored->code);
      return;
    }
  }
  db.global.uncoded.insert(view.id);  // none, unreadable, or of an older vocabulary
}

GlobalStageWorker::GlobalStageWorker(storage::CrossingStore* store,
                                     const crossing::IndexOptions& index)
    : store_(store), index_(index), thread_([this] { Loop(); }) {}

GlobalStageWorker::~GlobalStageWorker() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stopping_ = true;
  }
  changed_.notify_all();
  thread_.join();
}

void GlobalStageWorker::Schedule(const std::shared_ptr<ResidentDatabase>& db) {
  std::lock_guard<std::mutex> lock(mutex_);
  auto [it, inserted] = pending_.emplace(db.get(), false);
  if (!inserted) {
    it->second = true;  // the running round may have looked before this work arrived
    return;
  }
  queue_.push_back(db);
  changed_.notify_all();
}

void GlobalStageWorker::WaitIdle() {
  std::unique_lock<std::mutex> lock(mutex_);
  changed_.wait(lock, [this] { return pending_.empty() || stopping_; });
}

void GlobalStageWorker::Loop() {
  std::unique_lock<std::mutex> lock(mutex_);
  while (true) {
    changed_.wait(lock, [this] { return stopping_ || !queue_.empty(); });
    if (stopping_) return;
    std::shared_ptr<ResidentDatabase> db = std::move(queue_.front());
    queue_.pop_front();
    while (true) {
      pending_[db.get()] = false;
      lock.unlock();
      while (!stopping_ && Round(*db)) {
      }
      lock.lock();
      if (stopping_) return;
      if (!pending_[db.get()]) break;  // nothing scheduled since the last look
    }
    pending_.erase(db.get());
    changed_.notify_all();
  }
}

bool GlobalStageWorker::Round(ResidentDatabase& db) {
  const auto start = Clock::now();
  // What to do, from one consistent look at the database.
  bool train = false;
  int views = 0;
  int learn_from = 0;  // training: the schedule's size, the first views of the database
  std::vector<int64_t> ids;
  std::vector<cv::Mat> samples;
  crossing::VladVocabulary vocabulary;
  {
    absl::ReaderMutexLock lock(&db.mutex);
    if (!GlobalStageHasWork(db)) return false;
    views = static_cast<int>(db.views->views().size());
    train = NeedsVocabulary(views, db.global.trained_views);
    if (train) {
      // Exactly the first 16, 32, ... views, however many were enrolled before the worker got
      // here (it used to learn from all of them: 44, 95, 228, 301 under a bulk enrollment).
      learn_from =
          crossing::VocabularyScheduleSize(views, kFirstVocabularyViews, kLastVocabularyViews);
      // Slots are in enrollment order (view ids increase with them); a view without a sample
      // (enrolled without a working image) keeps its place as an empty one, so "the first N"
      // counts views, not samples.
      const std::vector<crossing::ViewEntry>& all = db.views->views();
      for (const crossing::ViewEntry& v : all) {
        ids.push_back(v.view_id);
        if (static_cast<int>(samples.size()) < learn_from) samples.push_back(v.global_sample);
      }
    } else {
      ids.assign(db.global.uncoded.begin(), db.global.uncoded.end());
      vocabulary = db.views->vocabulary();
    }
  }
  if (train) {
    vocabulary =
        crossing::VladVocabulary::TrainOnFirstImages(samples, learn_from, crossing::kVladWords);
    if (vocabulary.empty()) {
      spdlog::warn("database \"{}\": {} views hold too few samples to learn a vocabulary",
                   db.record.name, views);
      return false;
    }
  }
  const uint64_t fingerprint = vocabulary.Fingerprint();

  // The codes, from the stored working images, with no lock held.
  std::unordered_map<int64_t, crossing::GlobalCode> codes;
  std::vector<storage::ViewCode> rows;
  for (int64_t id : ids) {
    if (stopping_) return false;
    absl::StatusOr<crossing::GlobalCode> code = CodeFromWorkImage(*store_, id, vocabulary);
    if (!code.ok()) {
      // Deleted since the look, or enrolled without a working image: it stays without a code.
      if (code.status().code() != absl::StatusCode::kNotFound) {
        spdlog::warn("database \"{}\": {}", db.record.name, code.status().ToString());
      }
      continue;
    }
    rows.push_back({id, crossing::SerializeGlobalCode({fingerprint, *code})});
    codes.emplace(id, *std::move(code));
  }

  // Disk first, then memory. Servers sharing the database take turns (crossing_loading.h), and
  // another one may have learnt this vocabulary, or a newer one, meanwhile: then this round's
  // work is dropped rather than saved over theirs.
  absl::StatusOr<WriteScope> writing = WriteScope::Begin(*store_, index_, db);
  if (!writing.ok()) {
    if (writing.status().code() != absl::StatusCode::kNotFound) {
      spdlog::warn("database \"{}\": {}", db.record.name, writing.status().ToString());
    }
    return false;
  }
  {
    absl::ReaderMutexLock lock(&db.mutex);
    const int views_now = static_cast<int>(db.views->views().size());
    if (train ? !NeedsVocabulary(views_now, db.global.trained_views)
              : db.global.vocabulary != fingerprint) {
      return true;  // look again
    }
  }
  const absl::Status saved =
      train ? store_->SaveVocabulary({db.record.id, learn_from, vocabulary.Serialize()}, rows)
            : store_->SaveViewCodes(db.record.id, rows);
  if (!saved.ok()) {
    if (saved.code() != absl::StatusCode::kNotFound) {  // NOT_FOUND: the database was deleted
      spdlog::warn("database \"{}\": saving the global stage failed: {}", db.record.name,
                   saved.ToString());
    }
    return false;
  }
  absl::MutexLock lock(&db.mutex);
  if (db.deleted) return false;
  db.NoteOwnWrite(/*reload=*/true);
  if (train) {
    db.views->SetVocabulary(vocabulary);
    db.global.vocabulary = fingerprint;
    db.global.trained_views = learn_from;
    db.global.uncoded.clear();
    // Views enrolled since the look hold codes of the old vocabulary, or none.
    for (const crossing::ViewEntry& v : db.views->views()) {
      if (!codes.count(v.view_id)) db.global.uncoded.insert(v.view_id);
    }
    for (int64_t id : ids) db.global.uncoded.erase(id);  // those that failed stay without
    if (!KeepsSamples(db)) {  // the last vocabulary: the samples have done their job
      for (uint32_t slot = 0; slot < db.views->views().size(); ++slot) {
        db.views->SetGlobalSample(slot, cv::Mat());
      }
    }
  } else if (db.global.vocabulary != fingerprint) {
    return true;  // replaced meanwhile: the next round codes against the new one
  } else {
    for (int64_t id : ids) db.global.uncoded.erase(id);
  }
  for (const auto& [id, code] : codes) {
    if (const crossing::ViewEntry* v = db.FindView(id)) {
      db.views->SetGlobalCode(static_cast<uint32_t>(v - db.views->views().data()), code);
    }
  }
  spdlog::info("database \"{}\": {} {} views in {:.1f} s", db.record.name,
               train ? absl::StrCat("learnt a vocabulary from the first ", learn_from, " of ",
                                    views, " views and coded")
                     : std::string("coded"),
               codes.size(), MsSince(start) / 1000.0);
  return true;
}

}  // namespace waymark::service
