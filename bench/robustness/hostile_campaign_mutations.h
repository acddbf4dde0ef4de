#ifndef WAYMARK_BENCH_ROBUSTNESS_HOSTILE_CAMPAIGN_MUTATIONS_H_
#define WAYMARK_BENCH_ROBUSTNESS_HOSTILE_CAMPAIGN_MUTATIONS_H_

// waymark-hostile-campaign: malformed variants of a valid request. Two families of operators:
// on the serialized bytes (bit flips, truncation, random bytes, inserted or duplicated runs, huge
// length prefixes, wrong wire types, nesting deeper than any parser allows) and on the message
// through reflection (numbers no robot measures, oversized strings and repeated fields, unknown
// fields, fields cleared, hostile images in place of a bytes field). Operators are stacked (one
// to three per message), structural ones first, so a byte-level corruption can land on top of an
// extreme value.

#include <google/protobuf/message.h>

#include <cstdint>
#include <functional>
#include <memory>
#include <random>
#include <string>
#include <vector>

namespace waymark::bench::hostile {

using Rng = std::mt19937_64;

struct Mutation {
  std::string bytes;
  std::string kind;  // the operators applied, "+"-joined, in order
};

// Images a robot could send by mistake or on purpose: other formats, odd pixel types, truncated
// data, and headers claiming sizes that would take gigabytes to decode. Made once with OpenCV.
class HostileImages {
 public:
  HostileImages();
  const std::string& Pick(Rng& rng) const;
  size_t size() const { return images_.size(); }

 private:
  std::vector<std::string> images_;
};

class Mutator {
 public:
  // `images` (kept, may be null: no image swaps) replace bytes fields now and then.
  explicit Mutator(const HostileImages* images);
  Mutator(const Mutator&) = delete;  // its operators hold `this`
  Mutator& operator=(const Mutator&) = delete;

  // A malformed variant of `valid` (which is not changed).
  Mutation Mutate(const google::protobuf::Message& valid, Rng& rng) const;

  // The operators' names, for the report.
  static std::vector<std::string> OperatorNames();

 private:
  using MessageOperator = std::function<bool(google::protobuf::Message&, Rng&)>;
  using BytesOperator = std::function<bool(std::string&, const google::protobuf::Descriptor*, Rng&)>;
  struct Operator {
    std::string name;
    MessageOperator on_message;  // one of the two is set
    BytesOperator on_bytes;
    int weight = 1;
  };
  const Operator& Pick(Rng& rng) const;
  bool ImageSwap(google::protobuf::Message& m, Rng& rng) const;

  const HostileImages* images_;
  std::vector<Operator> ops_;
};

// True when `bytes` parse as a message of `type` (as the server's gRPC layer would parse them:
// the same protobuf library, strict UTF-8 for proto3 strings).
bool Parses(const google::protobuf::Descriptor* type, const std::string& bytes);

}  // namespace waymark::bench::hostile

#endif  // WAYMARK_BENCH_ROBUSTNESS_HOSTILE_CAMPAIGN_MUTATIONS_H_
