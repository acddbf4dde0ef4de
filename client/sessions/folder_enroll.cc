#include "client/sessions/folder_enroll.h"

#include <fmt/format.h>

#include <memory>
#include <utility>

#include "client/common/read_file.h"

namespace waymark::cli {
namespace {

v1::EnrollViewRequest MakeRequest(const FolderEnrollOptions& options, const EnrollImage& image,
                                  std::string bytes) {
  v1::EnrollViewRequest request;
  request.set_database(options.database);
  request.set_crossing(image.crossing);
  // A heading that is not a number: the view's heading is not known (enroll_manifest.h).
  if (image.heading_deg == image.heading_deg) {
    request.set_heading_deg(image.heading_deg);
  } else {
    request.set_heading_unknown(true);
  }
  request.set_position(image.position);
  request.mutable_image()->set_data(std::move(bytes));
  request.set_create_crossing(true);
  request.set_store_image(options.store_images);
  request.set_skip_invalid(!options.strict);
  request.set_replace(options.replace);
  return request;
}

// The image's bytes: its file, or the frame it holds (EnrollImage::encoded).
absl::StatusOr<std::string> ImageBytes(const EnrollImage& image) {
  if (!image.encoded.empty()) return image.encoded;
  return ReadFileBytes(image.path);
}

void Record(const v1::EnrollViewResponse& answer, const EnrollImage& image,
            FolderEnrollReport* report) {
  EnrollTally& tally = report->tally;
  if (answer.crossing_created()) ++tally.crossings_created;
  switch (answer.outcome()) {
    case v1::ENROLL_OUTCOME_DUPLICATE:
      ++tally.duplicates;
      report->duplicates.push_back({image, answer});
      break;
    case v1::ENROLL_OUTCOME_INVALID:
      ++tally.invalid;
      report->invalid.push_back({image, answer});
      break;
    default:
      ++tally.stored;
      tally.replaced += answer.replaced_view_ids_size();
      tally.clusters_created += answer.new_cluster() ? 1 : 0;
      tally.keypoints += answer.keypoints();
      break;
  }
}

}  // namespace

FolderEnrollReport EnrollFolder(client::CrossingClient& client,
                                const std::vector<EnrollImage>& images,
                                const FolderEnrollOptions& options, const std::atomic<bool>& stop,
                                const EnrollProgress& progress) {
  FolderEnrollReport report;
  report.tally.total = static_cast<int>(images.size());
  std::unique_ptr<client::EnrollStream> stream = client.StreamEnroll();
  absl::Status read_error;
  size_t next = 0;
  int in_flight = 0;
  bool writing = true;
  auto stop_writing = [&] {
    stream->WritesDone();
    writing = false;
  };
  while (true) {
    while (writing && in_flight < options.window) {
      if (next == images.size()) {
        stop_writing();
      } else if (stop.load()) {
        report.stopped = true;
        stop_writing();
      } else if (absl::StatusOr<std::string> bytes = ImageBytes(images[next]);
                 !bytes.ok()) {
        read_error = bytes.status();
        stop_writing();
      } else if (!stream->Send(MakeRequest(options, images[next], *std::move(bytes)))) {
        writing = false;  // the stream is broken: Read() and Finish() say why
      } else {
        ++next;
        ++in_flight;
        ++report.tally.sent;
      }
    }
    if (in_flight == 0) break;
    v1::EnrollViewResponse answer;
    if (!stream->Read(&answer)) break;  // the server ended the stream; Finish() says why
    --in_flight;
    const size_t index = static_cast<size_t>(answer.index());
    if (index < images.size()) Record(answer, images[index], &report);
    if (progress) progress(report.tally);
  }
  if (writing) stream->WritesDone();
  // When the server ended the stream early, it stopped at the view it names in its error: the
  // views sent after that one were never looked at, so nothing of them is stored.
  report.status = stream->Finish();
  if (report.status.ok()) report.status = read_error;
  return report;
}

std::string DescribeOutcomes(const EnrollTally& tally) {
  const std::string replaced =
      tally.replaced > 0 ? fmt::format(" (replacing {} older views)", tally.replaced) : "";
  return fmt::format("{} stored{}, {} skipped as duplicates, {} skipped as invalid", tally.stored,
                     replaced, tally.duplicates, tally.invalid);
}

}  // namespace waymark::cli
