#include "server/service/slam/visual_session_engine.h"

#include <utility>

#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "server/service/slam/visual_frame_decoder.h"
#include "server/visual_slam/detectors/detector_factory.h"

namespace waymark::service {

namespace vs = visual_slam;

namespace {

// Checkpoint bytes. v1 (older builds): only this marker; the session resumes at its last stored
// pose with an empty map. v2: this marker, then the engine's map (VisualOdometry::SerializeState):
// the session resumes tracking against the keyframes it had.
constexpr char kStateV1[] = "waymark visual odometry checkpoint v1";
constexpr absl::string_view kStateV2 = "waymark visual odometry checkpoint v2\n";

struct FrameInput final : EngineInput {
  DecodedFrame frame;
};

storage::TrajectoryPoseRecord ToRecord(int64_t seq, const vs::TimedPose& pose) {
  const v1::Pose3D p = ToProtoPose3D(pose.pose);
  storage::TrajectoryPoseRecord record;
  record.seq = seq;
  record.stamp = pose.stamp;
  record.x = p.x();
  record.y = p.y();
  record.pose3 = storage::Pose3Extra{p.z(), p.qx(), p.qy(), p.qz(), p.qw()};
  return record;
}

}  // namespace

absl::Status NoSegmentMapError() {
  return absl::FailedPreconditionError("visual sessions have no segment map; use GetTrajectory");
}

VisualSessionEngine::VisualSessionEngine(v1::VisualSlamConfig config, VisualSessionOptions options,
                                         std::unique_ptr<vs::VisualOdometry> odometry)
    : config_(std::move(config)), options_(std::move(options)), odometry_(std::move(odometry)) {}

absl::StatusOr<std::unique_ptr<VisualSessionEngine>> VisualSessionEngine::Create(
    const v1::VisualSlamConfig& config) {
  absl::StatusOr<VisualSessionOptions> options = ToVisualSessionOptions(config);
  if (!options.ok()) return options.status();
  absl::StatusOr<std::unique_ptr<vs::ObjectDetector>> detector =
      vs::MakeDetector(options->detector);
  if (!detector.ok()) {
    return absl::Status(detector.status().code(),
                        absl::StrCat("detector: ", detector.status().message()));
  }
  absl::StatusOr<std::unique_ptr<vs::VisualOdometry>> odometry =
      vs::VisualOdometry::Create(options->odometry, options->camera, *std::move(detector));
  if (!odometry.ok()) return odometry.status();
  return std::unique_ptr<VisualSessionEngine>(
      new VisualSessionEngine(config, *std::move(options), *std::move(odometry)));
}

absl::StatusOr<std::unique_ptr<VisualSessionEngine>> VisualSessionEngine::Resume(
    const v1::VisualSlamConfig& config, const std::string& state,
    std::vector<storage::TrajectoryPoseRecord> stored) {
  const bool with_map = absl::StartsWith(state, kStateV2);
  if (state != kStateV1 && !with_map) {
    return absl::DataLossError(absl::StrCat("the visual checkpoint (", state.size(),
                                            " bytes) is not one this build reads"));
  }
  for (const storage::TrajectoryPoseRecord& pose : stored) {
    if (!pose.pose3.has_value()) {
      return absl::DataLossError(
          absl::StrCat("trajectory pose ", pose.seq, " has no 3-D pose (a laser row?)"));
    }
  }
  absl::StatusOr<std::unique_ptr<VisualSessionEngine>> engine = Create(config);
  if (!engine.ok()) return engine.status();
  if (with_map) {
    if (absl::Status s = (*engine)->odometry_->RestoreState(state.substr(kStateV2.size()));
        !s.ok()) {
      return absl::DataLossError(absl::StrCat("the visual checkpoint's map: ", s.message()));
    }
  } else if (!stored.empty()) {
    const storage::TrajectoryPoseRecord& last = stored.back();
    v1::Pose3D pose;
    pose.set_x(last.x);
    pose.set_y(last.y);
    pose.set_z(last.pose3->z);
    pose.set_qx(last.pose3->qx);
    pose.set_qy(last.pose3->qy);
    pose.set_qz(last.pose3->qz);
    pose.set_qw(last.pose3->qw);
    (*engine)->odometry_->ResetAt(vs::TimedPose{last.stamp, FromProtoPose3D(pose)});
  }
  (*engine)->resumed_ = std::move(stored);
  return engine;
}

absl::StatusOr<AdmittedMessage> VisualSessionEngine::Admit(const v1::SensorData& data) const {
  if (data.payload_case() != v1::SensorData::kFrame) {
    return absl::InvalidArgumentError(
        data.payload_case() == v1::SensorData::PAYLOAD_NOT_SET
            ? "SensorData has no payload: set frame"
            : "this is a visual session: it takes image frames, not odometry or scans");
  }
  absl::StatusOr<DecodedFrame> decoded =
      DecodeFrame(data.frame(), data.sequence(), options_.camera);
  if (!decoded.ok()) return decoded.status();
  AdmittedMessage admitted;
  admitted.answered = true;
  admitted.sensor = "frame";
  admitted.stamp = decoded->input.stamp;
  admitted.bytes = decoded->bytes;
  auto input = std::make_unique<FrameInput>();
  input->frame = *std::move(decoded);
  admitted.input = std::move(input);
  return admitted;
}

absl::StatusOr<std::optional<v1::SlamUpdate>> VisualSessionEngine::Process(EngineInput& base,
                                                                           double queue_ms) {
  DecodedFrame& frame = static_cast<FrameInput&>(base).frame;
  absl::StatusOr<vs::FrameResult> result = odometry_->ProcessFrame(frame.input);
  if (!result.ok()) return result.status();
  v1::SlamUpdate update;
  FillVisualUpdate(*result, frame.want_features, frame.decode_ms, queue_ms, &update);
  // The pixels are not needed once processed; free them before the answer is sent.
  frame.input = vs::FrameInput();
  return std::optional<v1::SlamUpdate>(std::move(update));
}

std::string VisualSessionEngine::SerializeState() const {
  return absl::StrCat(kStateV2, odometry_->SerializeState());
}

int64_t VisualSessionEngine::trajectory_size() const {
  return static_cast<int64_t>(resumed_.size() + odometry_->trajectory().size());
}

storage::TrajectoryPoseRecord VisualSessionEngine::PoseRecord(int64_t seq) const {
  const size_t index = static_cast<size_t>(seq);
  if (index < resumed_.size()) return resumed_[index];
  return ToRecord(seq, odometry_->trajectory()[index - resumed_.size()]);
}

void VisualSessionEngine::AppendTrajectory(v1::Trajectory* out) const {
  for (const storage::TrajectoryPoseRecord& pose : resumed_) {
    *out->add_poses() = TrajectoryPoseFromRecord(pose);
  }
  const int64_t first = static_cast<int64_t>(resumed_.size());
  const std::vector<vs::TimedPose>& poses = odometry_->trajectory();
  for (size_t i = 0; i < poses.size(); ++i) {
    *out->add_poses() =
        TrajectoryPoseFromRecord(ToRecord(first + static_cast<int64_t>(i), poses[i]));
  }
}

absl::Status VisualSessionEngine::FillMap(v1::SegmentMap* map) const { return NoSegmentMapError(); }

void VisualSessionEngine::DescribeConfig(v1::Session* out) const {
  *out->mutable_visual() = EchoVisualConfig(config_);
  out->set_kind("visual");
}

}  // namespace waymark::service
