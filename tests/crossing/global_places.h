#ifndef WAYMARK_TESTS_CROSSING_GLOBAL_PLACES_H_
#define WAYMARK_TESTS_CROSSING_GLOBAL_PLACES_H_

// A small database for the retrieval mode's global path: six synthetic places of four views
// each, enrolled with their global codes, and a vocabulary learnt from them.

#include <gtest/gtest.h>

#include <vector>

#include "server/crossing/enrollment.h"
#include "server/crossing/features.h"
#include "server/crossing/view_database.h"
#include "tests/support/synthetic_scene.h"

namespace waymark::crossing::testing_places {

// The features (the global descriptor's dense ones included) of the view of the panorama seeded
// `seed` at `heading` degrees.
inline ImageFeatures GlobalView(int seed, double heading) {
  FeatureOptions features;
  features.global_descriptor = true;
  auto f = ExtractFeatures(
      testing::EncodePng(testing::CropView(testing::MakePanorama(seed), heading)), features);
  EXPECT_TRUE(f.ok()) << f.status();
  return f.ok() ? *f : ImageFeatures{};
}

// Place p (crossing id p + 1) is the panorama seeded first_seed + p; its view at 90 k degrees has
// id 1 + 4 p + k. A vocabulary of 32 words is learnt from all 24 views.
inline void EnrollSixPlaces(int first_seed, ViewDatabase* db) {
  std::vector<cv::Mat> dense;
  for (int place = 0; place < 6; ++place) {
    for (int k = 0; k < 4; ++k) {
      const ImageFeatures f = GlobalView(first_seed + place, 90.0 * k);
      EnrollView(db, 1 + place * 4 + k, place + 1, 90.0 * k, f);
      dense.push_back(f.dense);
    }
  }
  db->TrainGlobal(dense, 32);
}

}  // namespace waymark::crossing::testing_places

#endif  // WAYMARK_TESTS_CROSSING_GLOBAL_PLACES_H_
