#ifndef WAYMARK_CLIENT_SIM_SIM_SCENE_H_
#define WAYMARK_CLIENT_SIM_SIM_SCENE_H_

// A simulated camera's world: a 360-degree strip of random coloured shapes stands for what a robot
// sees turning on the spot at one crossing; a view at heading h is the crop centred on h. Different
// seeds give different "crossings". Deterministic, so tests can assert exact outcomes, and the
// project's own (no third-party images): `waymark bench load` and the tests enroll and query these.

#include <cstdint>
#include <opencv2/core.hpp>
#include <string>

namespace waymark::adapters {

// A panorama covering 360 degrees horizontally: `width` pixels, `height` rows.
cv::Mat MakePanorama(uint32_t seed, int width = 3840, int height = 240);

// The 320x240 (by default) crop of `panorama` centred on `heading_deg` (wrapping around), with a
// horizontal field of view of `fov_deg`, resized to `out_width` x `out_height`.
cv::Mat CropView(const cv::Mat& panorama, double heading_deg, double fov_deg = 60,
                 int out_width = 320, int out_height = 240);

// Encodes as JPEG (quality 90) or PNG bytes.
std::string EncodeJpeg(const cv::Mat& image);
std::string EncodePng(const cv::Mat& image);

}  // namespace waymark::adapters

#endif  // WAYMARK_CLIENT_SIM_SIM_SCENE_H_
