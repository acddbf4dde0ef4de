#ifndef WAYMARK_TESTS_FUZZ_FUZZ_TARGETS_H_
#define WAYMARK_TESTS_FUZZ_FUZZ_TARGETS_H_

// Parsers and decoders that read robot or file input, as fuzz targets: each takes any bytes and
// must neither crash, hang nor read out of bounds, whatever it answers. Seeds are made by each
// target from valid inputs (so none of ../shared is copied into the repository), plus the small
// files in corpus/<name>/ (the bag and message targets' only seeds: files written by ROS's own
// writers, write_bag_seeds.py).

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace waymark::fuzz {

struct FuzzTarget {
  const char* name;
  void (*run)(const uint8_t* data, size_t size);
  std::vector<std::string> (*seeds)();
};

const std::vector<FuzzTarget>& Targets();

// The targets of the RPCs' requests, each in a file of its own (service_calls.h says what they
// share): CrossingService, SlamService and TokenService with the authorization metadata.
FuzzTarget CrossingRequestsTarget();
FuzzTarget SlamRequestsTarget();
FuzzTarget TokenRequestsTarget();

// Recorded robot messages (bag_targets.cc): whole bag files through OpenBag (ROS 1, MCAP, rosbag2
// .db3 and metadata.yaml) and single ROS messages through their decoders (ROS 1 and CDR).
FuzzTarget BagFilesTarget();
FuzzTarget RosMessagesTarget();

}  // namespace waymark::fuzz

#endif  // WAYMARK_TESTS_FUZZ_FUZZ_TARGETS_H_
