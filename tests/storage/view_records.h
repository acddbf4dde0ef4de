#ifndef WAYMARK_TESTS_STORAGE_VIEW_RECORDS_H_
#define WAYMARK_TESTS_STORAGE_VIEW_RECORDS_H_

// Crossing views for the store tests: made-up features whose values depend on a seed.

#include <cstdint>
#include <string>

#include "storage/crossing_store.h"

namespace waymark::storage::testing {

// A view with `keypoints` features whose values depend on `seed`, so views differ. No content
// hash (an "unknown" image, as views enrolled before schema version 5).
inline ViewRecord MakeView(int64_t crossing_id, int keypoints, int seed,
                           double heading_deg = 90.0) {
  ViewRecord view;
  view.crossing_id = crossing_id;
  view.heading_deg = heading_deg;
  view.width = 640;
  view.height = 480;
  view.keypoint_count = keypoints;
  for (int i = 0; i < keypoints * kKeypointFloats; ++i) {
    view.keypoints.push_back(static_cast<float>(seed) + 0.1f * static_cast<float>(i));
  }
  for (int i = 0; i < keypoints * kDescriptorBytes; ++i) {
    view.descriptors.push_back(static_cast<uint8_t>((i * 7 + seed) & 0xff));
  }
  view.hue_hist = {0.25f, 0.5f, 0.125f, 0.125f + static_cast<float>(seed) * 1e-3f};
  return view;
}

// A 32-byte stand-in for the SHA-256 of image number `image`.
inline std::string FakeDigest(int image) {
  std::string digest(32, '\0');
  digest[0] = static_cast<char>(image & 0xff);
  digest[1] = static_cast<char>((image >> 8) & 0xff);
  digest[31] = 'h';
  return digest;
}

// MakeView with the content hash of image number `image`.
inline ViewRecord MakeHashedView(int64_t crossing_id, int image, double heading_deg = 90.0) {
  ViewRecord view = MakeView(crossing_id, 2, image, heading_deg);
  view.content_sha256 = FakeDigest(image);
  return view;
}

}  // namespace waymark::storage::testing

#endif  // WAYMARK_TESTS_STORAGE_VIEW_RECORDS_H_
