#include "bench/common/bench_images.h"

#include <algorithm>
#include <filesystem>

#include <opencv2/imgproc.hpp>

namespace waymark::bench {
namespace {

namespace fs = std::filesystem;

std::vector<std::string> ImagesIn(const fs::path& dir, bool recursive) {
  std::vector<std::string> files;
  if (!fs::is_directory(dir)) return files;
  auto add = [&](const fs::path& p) {
    const std::string ext = p.extension().string();
    if (ext == ".jpg" || ext == ".png" || ext == ".jpeg") files.push_back(p.string());
  };
  if (recursive) {
    for (const auto& e : fs::recursive_directory_iterator(dir)) add(e.path());
  } else {
    for (const auto& e : fs::directory_iterator(dir)) add(e.path());
  }
  std::sort(files.begin(), files.end());
  return files;
}

}  // namespace

std::vector<std::string> DatabaseSourceImages(const std::string& shared_dir) {
  const fs::path data = fs::path(shared_dir) / "data";
  std::vector<std::string> all = ImagesIn(data / "vpr/corridor_vprbench/ref", false);
  for (const fs::path& dir :
       {data / "vpr/gardenspoint_sfu_triplets_sample", data / "vslam/kitti_odom06_frames000-050/image_0",
        data / "vslam/bonn_rgbd_crowd_frames270-409/rgb"}) {
    const auto more = ImagesIn(dir, true);
    all.insert(all.end(), more.begin(), more.end());
  }
  return all;
}

std::vector<std::string> QueryImages(const std::string& shared_dir) {
  return ImagesIn(fs::path(shared_dir) / "data/vpr/corridor_vprbench/query", false);
}

cv::Mat Revisit(const cv::Mat& image) {
  const cv::Rect crop(image.cols * 4 / 100, image.rows * 4 / 100, image.cols * 92 / 100,
                      image.rows * 92 / 100);
  cv::Mat out;
  cv::resize(image(crop), out, cv::Size(320, 240), 0, 0, cv::INTER_AREA);
  out.convertTo(out, -1, 0.9, 0);
  cv::GaussianBlur(out, out, cv::Size(0, 0), 0.8);
  return out;
}

cv::Mat Augment(const cv::Mat& image, int k) {
  cv::Mat base;
  cv::resize(image, base, cv::Size(320, 240), 0, 0, cv::INTER_AREA);
  if (k == 0) return base;
  const cv::Size size = base.size();
  cv::Mat out;
  switch (k) {
    case 1:
      cv::flip(base, out, 1);
      return out;
    case 2:
    case 3:
    case 4:
    case 5: {  // 75 % crops from each corner, scaled back up
      const int w = size.width * 3 / 4, h = size.height * 3 / 4;
      const int x = (k % 2) ? 0 : size.width - w, y = (k < 4) ? 0 : size.height - h;
      cv::resize(base(cv::Rect(x, y, w, h)), out, size);
      return out;
    }
    case 6:
    case 7: {  // +-8 degree rotations
      const cv::Mat r = cv::getRotationMatrix2D(cv::Point2f(size.width / 2.f, size.height / 2.f),
                                                k == 6 ? 8 : -8, 1.1);
      cv::warpAffine(base, out, r, size, cv::INTER_LINEAR, cv::BORDER_REFLECT);
      return out;
    }
    case 8: {  // flipped crop
      cv::Mat flipped;
      cv::flip(base, flipped, 1);
      cv::resize(flipped(cv::Rect(size.width / 8, size.height / 8, size.width * 3 / 4,
                                  size.height * 3 / 4)),
                 out, size);
      return out;
    }
    case 10: {  // centre 60 % crop
      cv::resize(base(cv::Rect(size.width / 5, size.height / 5, size.width * 3 / 5,
                               size.height * 3 / 5)),
                 out, size);
      return out;
    }
    case 11: {  // flipped and rotated
      cv::Mat flipped;
      cv::flip(base, flipped, 1);
      const cv::Mat r =
          cv::getRotationMatrix2D(cv::Point2f(size.width / 2.f, size.height / 2.f), 12, 1.15);
      cv::warpAffine(flipped, out, r, size, cv::INTER_LINEAR, cv::BORDER_REFLECT);
      return out;
    }
    default: {  // vertical flip with gamma: distinct gradients everywhere
      cv::Mat flipped;
      cv::flip(base, flipped, 0);
      flipped.convertTo(out, -1, 1.2, -20);
      return out;
    }
  }
}

}  // namespace waymark::bench
