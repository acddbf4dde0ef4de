#include "client/ros/bag_images.h"

#include <fmt/format.h>

#include <fstream>
#include <map>
#include <opencv2/imgcodecs.hpp>
#include <set>

#include "absl/strings/ascii.h"
#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "client/ros/ros_images.h"
#include "client/ros/ros_messages.h"

namespace waymark::ros {
namespace {

std::string_view Bare(std::string_view topic) { return FrameName(topic); }

// "/cam" for "/cam/image_raw" and "/cam/image/compressed".
std::string Namespace(const std::string& topic) {
  std::string ns = topic;
  if (absl::EndsWith(ns, "/compressed")) ns.resize(ns.size() - 11);
  const size_t slash = ns.rfind('/');
  return slash == std::string::npos ? "" : ns.substr(0, slash);
}

WireFormat FormatOf(const bags::BagConnection& c) {
  return c.encoding == bags::MessageEncoding::kRos1 ? WireFormat::kRos1 : WireFormat::kCdr;
}

absl::Status WriteBytes(const std::filesystem::path& path, const std::string& bytes) {
  std::ofstream out(path, std::ios::binary);
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  if (!out) return absl::DataLossError(absl::StrCat("cannot write '", path.string(), "'"));
  return absl::OkStatus();
}

}  // namespace

absl::StatusOr<BagImages> ExtractBagImages(std::unique_ptr<bags::BagReader> reader,
                                           const std::string& image_topic, int max_frames,
                                           const std::filesystem::path& dir) {
  const std::vector<bags::BagConnection>& connections = reader->connections();
  std::vector<std::string> image_topics;
  std::vector<std::string> info_topics;
  std::set<std::string> seen;
  for (const bags::BagConnection& c : connections) {
    const RosType type = RosTypeOf(c.type);
    if ((type == RosType::kImage || type == RosType::kCompressedImage) && seen.insert(c.topic).second) {
      image_topics.push_back(c.topic);
    }
    if (type == RosType::kCameraInfo && seen.insert(c.topic).second) info_topics.push_back(c.topic);
  }
  BagImages result;
  if (!image_topic.empty()) {
    const bags::BagConnection* named = nullptr;
    for (const bags::BagConnection& c : connections) {
      if (Bare(c.topic) == Bare(image_topic)) named = &c;
    }
    if (named == nullptr) {
      return absl::NotFoundError(absl::StrCat(
          "--image-topic ", image_topic, ": the bag has no such topic; its image topics: ",
          image_topics.empty() ? "none" : absl::StrJoin(image_topics, ", ")));
    }
    const RosType type = RosTypeOf(named->type);
    if (type != RosType::kImage && type != RosType::kCompressedImage) {
      return absl::InvalidArgumentError(absl::StrCat(
          "--image-topic ", image_topic, ": topic ", named->topic, " is ", named->type,
          ", not sensor_msgs/Image or sensor_msgs/CompressedImage"));
    }
    result.image_topic = named->topic;
  } else if (image_topics.empty()) {
    return absl::NotFoundError(
        "the bag has no sensor_msgs/Image or sensor_msgs/CompressedImage topic");
  } else if (image_topics.size() > 1) {
    return absl::InvalidArgumentError(absl::StrCat(
        "the bag has ", image_topics.size(), " image topics: ", absl::StrJoin(image_topics, ", "),
        "; choose one with --image-topic"));
  } else {
    result.image_topic = image_topics.front();
  }
  for (const std::string& topic : info_topics) {
    if (Namespace(topic) == Namespace(result.image_topic)) result.camera_info_topic = topic;
  }
  if (result.camera_info_topic.empty() && info_topics.size() == 1) {
    result.camera_info_topic = info_topics.front();
  }

  std::map<int, const bags::BagConnection*> image_ids, info_ids;
  std::vector<int> wanted;
  for (const bags::BagConnection& c : connections) {
    if (c.topic == result.image_topic || c.topic == result.camera_info_topic) {
      if (c.encoding == bags::MessageEncoding::kOther) {
        return absl::InvalidArgumentError(absl::StrCat("topic ", c.topic, " is encoded as '",
                                                       c.encoding_name,
                                                       "'; only ROS 1 and CDR are decoded"));
      }
      (c.topic == result.image_topic ? image_ids : info_ids)[c.id] = &c;
      wanted.push_back(c.id);
    }
  }
  reader->Select(wanted);

  std::error_code ec;
  std::filesystem::create_directories(dir / "rgb", ec);
  if (ec) {
    return absl::PermissionDeniedError(
        absl::StrCat("cannot create '", (dir / "rgb").string(), "': ", ec.message()));
  }
  result.sequence.dir = dir;
  result.sequence.layout = cli::SequenceLayout::kTum;
  std::ofstream list(dir / "rgb.txt");
  list << "# frames of " << result.image_topic << " (header stamps)\n";
  bool have_info = false;
  bool have_last = false;
  int64_t last_ns = 0;
  bags::BagMessage message;
  while (max_frames <= 0 || static_cast<int>(result.sequence.frames.size()) < max_frames) {
    absl::StatusOr<bool> more = reader->Next(&message);
    if (!more.ok()) return more.status();
    if (!*more) break;
    if (auto it = info_ids.find(message.connection_id); it != info_ids.end()) {
      if (have_info) continue;
      const MessageOrigin origin{it->second->topic, it->second->type};
      absl::StatusOr<CameraInfoMsg> info = DecodeCameraInfo(FormatOf(*it->second), message.data,
                                                            origin);
      if (!info.ok()) return info.status();
      have_info = true;
      if (info->k[0] <= 0 || info->k[4] <= 0) {
        result.warnings.push_back(absl::StrCat(origin.topic, ": K has no focal length"));
        continue;
      }
      const std::string model = absl::AsciiStrToLower(info->distortion_model);
      cli::CameraIntrinsics camera;
      camera.fx = info->k[0];
      camera.fy = info->k[4];
      camera.cx = info->k[2];
      camera.cy = info->k[5];
      if (model == "plumb_bob" || model == "rational_polynomial" || info->d.empty()) {
        for (size_t i = 0; i < 5 && i < info->d.size(); ++i) camera.distortion[i] = info->d[i];
        result.sequence.intrinsics = camera;
      } else {
        result.warnings.push_back(absl::StrCat(
            origin.topic, ": distortion model '", info->distortion_model,
            "' is not OpenCV's radial-tangential: its intrinsics are not used"));
      }
      continue;
    }
    auto it = image_ids.find(message.connection_id);
    if (it == image_ids.end()) continue;
    const MessageOrigin origin{it->second->topic, it->second->type};
    const int index = static_cast<int>(result.sequence.frames.size());
    std::filesystem::path path;
    int64_t stamp_ns = 0;
    if (RosTypeOf(it->second->type) == RosType::kCompressedImage) {
      absl::StatusOr<CompressedImageMsg> image =
          DecodeCompressedImage(FormatOf(*it->second), message.data, origin);
      if (!image.ok()) return image.status();
      // Decoded once to refuse what the runner could not read; the bytes are kept as they are.
      if (absl::StatusOr<cv::Mat> mat = CompressedImageToMat(*image, origin); !mat.ok()) {
        return mat.status();
      }
      stamp_ns = image->header.stamp_ns;
      if (have_last && stamp_ns <= last_ns) {
        ++result.skipped_stamps;
        continue;
      }
      const bool png = absl::StrContains(absl::AsciiStrToLower(image->format), "png");
      path = dir / "rgb" / fmt::format("{:06d}.{}", index, png ? "png" : "jpg");
      if (absl::Status s = WriteBytes(path, image->data); !s.ok()) return s;
    } else {
      absl::StatusOr<ImageMsg> image = DecodeImage(FormatOf(*it->second), message.data, origin);
      if (!image.ok()) return image.status();
      stamp_ns = image->header.stamp_ns;
      if (have_last && stamp_ns <= last_ns) {
        ++result.skipped_stamps;
        continue;
      }
      absl::StatusOr<cv::Mat> mat = ImageToMat(*image, origin);
      if (!mat.ok()) return mat.status();
      if (mat->depth() == CV_32F) {
        return absl::InvalidArgumentError(absl::StrCat(
            "topic ", origin.topic, ": ", image->encoding,
            " frames (depth in metres) are not camera images visual odometry can track"));
      }
      path = dir / "rgb" / fmt::format("{:06d}.png", index);
      if (!cv::imwrite(path.string(), *mat)) {
        return absl::DataLossError(absl::StrCat("cannot write '", path.string(), "'"));
      }
    }
    have_last = true;
    last_ns = stamp_ns;
    const double stamp = static_cast<double>(stamp_ns) / 1e9;
    list << fmt::format("{:.9f} rgb/{}\n", stamp, path.filename().string());
    result.sequence.frames.push_back({stamp, path, std::nullopt});
  }
  if (!list) return absl::DataLossError(absl::StrCat("cannot write '", (dir / "rgb.txt").string(), "'"));
  if (result.skipped_stamps > 0) {
    result.warnings.push_back(absl::StrCat("skipped ", result.skipped_stamps, " frame(s) on ",
                                           result.image_topic,
                                           " whose header stamp did not increase"));
  }
  if (!result.camera_info_topic.empty() && !have_info) {
    result.warnings.push_back(absl::StrCat(result.camera_info_topic,
                                           " holds no CameraInfo message"));
  }
  for (const std::string& w : reader->warnings()) result.warnings.push_back("bag: " + w);
  return result;
}

}  // namespace waymark::ros
