#ifndef WAYMARK_SERVER_CROSSING_VLAD_H_
#define WAYMARK_SERVER_CROSSING_VLAD_H_

// VLAD (Jegou et al. 2010; with the intra-normalisation of Arandjelovic & Zisserman 2013): one
// global vector per image from its local descriptors, for retrieval over every view. Each
// descriptor adds its residual to the nearest of `words` centres; the per-word sums are
// square-rooted (signed), normalised per word and then as a whole.

#include <cstdint>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "absl/status/statusor.h"

namespace waymark::crossing {

// Words of a database's vocabulary: 128 measured best of {16, 64, 128, 256} with dense RootSIFT
// on the corridor and the triplets (waymark-vpr-eval, docs/results.md).
inline constexpr int kVladWords = 128;
// Dense descriptors of each view a database's vocabulary learns from (EvenRows): 32 KB per view,
// kept (by the service, until its last retraining) so that a retraining needs no extraction
// before the k-means. Global top-1 with vocabularies learnt from 64 / 256 / 1000 rows per view
// (waymark-vpr-eval --dump-acceptance): corridor 85.6 / 89.2 / 92.8 %, triplets 83.3 / 91.7 /
// 88.3 %.
inline constexpr int kVocabularySampleRows = 256;

// At most `count` rows of `rows`, evenly spread (all of them when there are fewer): the sample of a
// view's dense descriptors a vocabulary is trained on.
cv::Mat EvenRows(const cv::Mat& rows, int count);

// The vocabulary schedule (issue 34): a database learns its vocabulary from exactly the first 16,
// 32, 64, ... `last` views it holds (in enrollment order), whenever the worker gets to it. How many
// views a database of `views` views learns from: the largest of first, 2 first, 4 first, ... up to
// `last` that is at most `views`; 0 below `first`. A vocabulary learnt from the first N views is
// a function of the enrollment sequence alone, not of how far enrollment had gone on meanwhile
// (a worker that learnt from every view present when it looked recorded 44, 95, 228 and 301
// views under a bulk enrollment of 20 views/s).
int VocabularyScheduleSize(int views, int first, int last);

class VladVocabulary {
 public:
  // k-means (k-means++, fixed seed: the same descriptors give the same words) on at most
  // `max_samples` of `descriptors` (N x 128, CV_8U or CV_32F). Fewer descriptors than words:
  // an empty vocabulary.
  static VladVocabulary Train(const cv::Mat& descriptors, int words, int max_samples = 100000);
  // The same over the descriptors of many images, at most max_samples / images rows of each
  // (evenly spread), so every view has its say and nothing big is stacked.
  static VladVocabulary TrainOnImages(const std::vector<cv::Mat>& descriptors, int words,
                                      int max_samples = 50000);
  // TrainOnImages on the first `views` of `descriptors` only (all of them when fewer): the
  // schedule's vocabulary (VocabularyScheduleSize) from the samples of every view held.
  static VladVocabulary TrainOnFirstImages(const std::vector<cv::Mat>& descriptors, int views,
                                           int words, int max_samples = 50000);

  bool empty() const { return centers_.empty(); }
  // A 64-bit hash of the words (FNV-1a over their bytes; 0 for an empty vocabulary): what a stored
  // code names to say which vocabulary it was computed under.
  uint64_t Fingerprint() const;
  int words() const { return centers_.rows; }
  // 1 x (words * 128) CV_32F, unit L2 norm (all zero for no descriptors).
  cv::Mat Encode(const cv::Mat& descriptors) const;

  // Bytes to store with a database: a versioned header, then the words as little-endian floats.
  std::string Serialize() const;
  // INVALID_ARGUMENT for bytes Serialize did not write (wrong magic, version or length).
  static absl::StatusOr<VladVocabulary> Deserialize(const std::string& bytes);

 private:
  cv::Mat centers_;  // words x 128, CV_32F
};

}  // namespace waymark::crossing

#endif  // WAYMARK_SERVER_CROSSING_VLAD_H_
