#ifndef WAYMARK_SERVER_CROSSING_GLOBAL_INDEX_H_
#define WAYMARK_SERVER_CROSSING_GLOBAL_INDEX_H_

// The retrieval stage's index: one global descriptor per view (vlad.h), and an inner-product scan
// over all of them. A view's code arrives quantised to 8 bits (QuantizeGlobal: what is stored
// with the view) and is held in 4 bits (issue 34): 15 levels, a step of 0.34 x the RMS of the
// code's nonzero values (the uniform quantiser of least squared error for a Gaussian; the words
// a view's descriptors never reached stay 0), two dimensions per byte. The
// query stays in 8 bits. At 12,000 views that halves both the memory (98 instead of 196 MB) and
// the bytes each query reads; the scan's similarities stay within about 0.002 of the 8-bit
// ones (the quantisation error is 1 % of the values' variance, tested against the float scan).
//
// Why a scan and not an approximate index (HNSW, IVF): at the sizes one server holds (10^3-10^4
// views) the scan takes milliseconds, returns the similarity of every view (the acceptance
// compares the best with all of them), needs no training or rebuild as views come and go, and
// costs half a byte per dimension where an HNSW graph over the float vectors would cost 4 plus
// its links.

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
  // length is ignored (the slot scores 0). A code whose values all lie in [-7, 7] (what Get
  // returns) is held exactly, with its scale; any other is quantised to 4 bits.
  void Set(uint32_t slot, const GlobalCode& code);
  // The code of `slot` as held: values in [-7, 7] (empty values when it has none).
  GlobalCode Get(uint32_t slot) const;
  size_t size() const { return scales_.size(); }
  size_t coded() const;  // slots with a code
  bool empty() const { return dims_ == 0; }

  // Cosine similarity of `query` (8 bits) with every slot, in slot order.
  std::vector<float> Similarities(const GlobalCode& query) const;
  size_t memory_bytes() const { return codes_.size() + scales_.size() * sizeof(float); }

  // Dimensions per block of the packed layout: byte j of a block holds dimension j in its low
  // nibble and j + 32 in its high one, each as its value + 8 (a code's tail is padded with 0).
  static constexpr int kBlockDims = 64;

 private:
  size_t packed_bytes() const { return static_cast<size_t>(blocks_) * (kBlockDims / 2); }

  int dims_ = 0;
  int blocks_ = 0;              // ceil(dims_ / kBlockDims)
  std::vector<uint8_t> codes_;  // slot-major, packed_bytes() per slot
  std::vector<float> scales_;   // 1 / |values| of the held code; 0 = no code
};

// The `k` highest similarities (value, slot), highest first; ties by lower slot.
std::vector<std::pair<float, uint32_t>> TopSimilar(const std::vector<float>& similarities, int k);

}  // namespace waymark::crossing

#endif  // WAYMARK_SERVER_CROSSING_GLOBAL_INDEX_H_
