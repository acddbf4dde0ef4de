#include "client/sim/sim_scene.h"

#include <cmath>
#include <string>
#include <vector>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

namespace waymark::adapters {

cv::Mat MakePanorama(uint32_t seed, int width, int height) {
  cv::RNG rng(seed);
  cv::Mat pano(height, width, CV_8UC3);
  // A coloured gradient background, so hue histograms differ between scenes.
  const cv::Scalar base(rng.uniform(40, 200), rng.uniform(40, 200), rng.uniform(40, 200));
  pano.setTo(base);
  const int shapes = width * height / 900;
  for (int i = 0; i < shapes; ++i) {
    const cv::Point c(rng.uniform(0, width), rng.uniform(0, height));
    const cv::Scalar colour(rng.uniform(0, 256), rng.uniform(0, 256), rng.uniform(0, 256));
    switch (rng.uniform(0, 4)) {
      case 0:
        cv::circle(pano, c, rng.uniform(3, 18), colour, cv::FILLED, cv::LINE_AA);
        break;
      case 1:
        cv::rectangle(pano, c, c + cv::Point(rng.uniform(4, 30), rng.uniform(4, 30)), colour,
                      cv::FILLED);
        break;
      case 2:
        cv::line(pano, c, c + cv::Point(rng.uniform(-40, 40), rng.uniform(-40, 40)), colour,
                 rng.uniform(1, 4), cv::LINE_AA);
        break;
      default:
        cv::ellipse(pano, c, cv::Size(rng.uniform(4, 20), rng.uniform(2, 10)),
                    rng.uniform(0, 180), 0, 360, colour, cv::FILLED, cv::LINE_AA);
    }
  }
  cv::GaussianBlur(pano, pano, cv::Size(3, 3), 0.8);
  return pano;
}

cv::Mat CropView(const cv::Mat& panorama, double heading_deg, double fov_deg, int out_width,
                 int out_height) {
  const int w = panorama.cols;
  const int crop_w = static_cast<int>(std::round(w * fov_deg / 360.0));
  const int centre = static_cast<int>(std::round(w * heading_deg / 360.0));
  // Tile the panorama three times so any crop is one rectangle.
  cv::Mat tiled;
  cv::hconcat(std::vector<cv::Mat>{panorama, panorama, panorama}, tiled);
  const int x0 = w + centre - crop_w / 2;
  cv::Mat crop = tiled(cv::Rect(x0, 0, crop_w, panorama.rows)).clone();
  cv::Mat out;
  cv::resize(crop, out, cv::Size(out_width, out_height), 0, 0, cv::INTER_AREA);
  return out;
}

std::string EncodeJpeg(const cv::Mat& image) {
  std::vector<uchar> bytes;
  cv::imencode(".jpg", image, bytes, {cv::IMWRITE_JPEG_QUALITY, 90});
  return std::string(bytes.begin(), bytes.end());
}

std::string EncodePng(const cv::Mat& image) {
  std::vector<uchar> bytes;
  cv::imencode(".png", image, bytes);
  return std::string(bytes.begin(), bytes.end());
}

}  // namespace waymark::adapters
