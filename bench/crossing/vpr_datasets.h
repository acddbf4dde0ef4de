#ifndef WAYMARK_BENCH_CROSSING_VPR_DATASETS_H_
#define WAYMARK_BENCH_CROSSING_VPR_DATASETS_H_

// Loaders for the real image sets in ../shared/data (read in place, never copied): the VPR-Bench
// corridor, the Gardens Point / SFU matching triplets, and two posed frame sequences (KITTI
// odometry 06 frames 0-50, Bonn RGB-D crowd frames 270-409). They return file paths and ground
// truth only; images are decoded later, once, by the experiment's feature cache.

#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "absl/status/statusor.h"

namespace waymark::vpr {

// Where each set lives below the shared folder (the project's ../shared).
struct DataPaths {
  std::string corridor;  // data/vpr/corridor_vprbench
  std::string triplets;  // data/vpr/gardenspoint_sfu_triplets_sample
  std::string kitti;     // data/vslam/kitti_odom06_frames000-050
  std::string bonn;      // data/vslam/bonn_rgbd_crowd_frames270-409
};
DataPaths DefaultDataPaths(const std::string& shared_dir);

// VPR-Bench corridor: 111 reference and 111 query images (laterally offset traversals).
struct CorridorSet {
  std::vector<std::string> refs;               // ref/0000000.jpg ... in index order
  std::vector<std::string> queries;            // query/0000000.jpg ...
  std::vector<std::vector<int>> ground_truth;  // per query: the matching ref indices (+-2 frames)
};
// NOT_FOUND if the folder or a listed file is missing, INVALID_ARGUMENT for a malformed
// ground_truth.csv.
absl::StatusOr<CorridorSet> LoadCorridor(const std::string& dir);

// Matching triplets: `images[place][slot]`, 10 places x 3 images, from manifest.csv
// (place "pN" -> N, slot "iK" -> K).
struct TripletSet {
  std::vector<std::vector<std::string>> images;
  int places() const { return static_cast<int>(images.size()); }
};
absl::StatusOr<TripletSet> LoadTriplets(const std::string& dir);

// A frame of a sequence with its ground-truth camera pose (camera-to-world).
struct PosedFrame {
  std::string path;
  int index = 0;         // position in the sequence (0-based within the copied window)
  double timestamp = 0;  // seconds (KITTI: index / 10 Hz)
  cv::Vec3d position;    // metres, world frame
  cv::Matx33d rotation = cv::Matx33d::eye();
};
struct FrameSequence {
  std::string name;
  std::vector<PosedFrame> frames;
};

// KITTI odometry format: image_0/NNNNNN.png (grayscale) and poses.txt (3x4 row-major per line).
absl::StatusOr<FrameSequence> LoadKittiFrames(const std::string& dir);

// TUM format: rgb.txt lists the frames, groundtruth.txt (timestamp tx ty tz qx qy qz qw) covers
// the whole sequence. A frame's position is interpolated linearly between the two ground-truth
// poses around its timestamp; its rotation is the nearest one's (poses are ~30 Hz apart).
absl::StatusOr<FrameSequence> LoadBonnFrames(const std::string& dir);

// Angle in degrees of the relative rotation between two camera orientations.
double RotationAngleDeg(const cv::Matx33d& a, const cv::Matx33d& b);

}  // namespace waymark::vpr

#endif  // WAYMARK_BENCH_CROSSING_VPR_DATASETS_H_
