#ifndef WAYMARK_SERVER_CROSSING_GLOBAL_INDEX_H_
#define WAYMARK_SERVER_CROSSING_GLOBAL_INDEX_H_

// The retrieval stage's index: one global descriptor per view (vlad.h), quantised to 8 bits, and
// an exact inner-product scan over all of them.
//
// Why a scan and not an approximate index (HNSW, IVF): at the sizes one server holds (10^3-10^4
// views) the scan over 8-bit codes takes milliseconds, returns the exact ranking the
// float vectors would give up to quantisation (tested against the float scan), needs no training
// or rebuild as views come and go, and costs 1 byte per dimension where an HNSW graph over the
// float vectors would cost 4 plus its links.

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include <opencv2/core.hpp>

#include "absl/status/statusor.h"

namespace waymark::crossing {

// A vector v stored as round(v * 127 / max |v_i|) in 8 bits.
struct GlobalCode {
  std::vector<int8_t> values;
  float scale = 0;  // 1 / |values|; 0: no code (an all-zero vector)
};

// `unit` is 1 x D CV_32F (any norm; the similarity of quantised codes is the cosine).
GlobalCode QuantizeGlobal(const cv::Mat& unit);

// A code as stored with its view: the fingerprint of the vocabulary it was computed under
// (VladVocabulary::Fingerprint), so that a code of an older vocabulary is known to be stale.
struct StoredGlobalCode {
  uint64_t vocabulary = 0;
  GlobalCode code;
};
std::string SerializeGlobalCode(const StoredGlobalCode& stored);
// INVALID_ARGUMENT for bytes SerializeGlobalCode did not write.
absl::StatusOr<StoredGlobalCode> DeserializeGlobalCode(const std::string& bytes);

class GlobalIndex {
 public:
  // Drops every code; the index then takes codes of `dims` values.
  void Reset(int dims);
  int dims() const { return dims_; }
  // Sets the code of `slot` (growing the index; slots never set score 0). A code of another
  // length is ignored (the slot scores 0).
  void Set(uint32_t slot, const GlobalCode& code);
  // The code of `slot` (empty values when it has none).
  GlobalCode Get(uint32_t slot) const;
  size_t size() const { return scales_.size(); }
  size_t coded() const;  // slots with a code
  bool empty() const { return dims_ == 0; }

  // Cosine similarity of `query` with every slot, in slot order.
  std::vector<float> Similarities(const GlobalCode& query) const;
  size_t memory_bytes() const { return codes_.size() + scales_.size() * sizeof(float); }

 private:
  int dims_ = 0;
  std::vector<int8_t> codes_;   // slot-major, dims_ per slot
  std::vector<float> scales_;   // 0 = no code
};

// The `k` highest similarities (value, slot), highest first; ties by lower slot.
std::vector<std::pair<float, uint32_t>> TopSimilar(const std::vector<float>& similarities, int k);

}  // namespace waymark::crossing

#endif  // WAYMARK_SERVER_CROSSING_GLOBAL_INDEX_H_
