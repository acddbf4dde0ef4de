#ifndef WAYMARK_CLIENT_SESSIONS_FOLDER_ENROLL_H_
#define WAYMARK_CLIENT_SESSIONS_FOLDER_ENROLL_H_

// `waymark enroll NAME DIR` and `enroll NAME --video FILE`: the views of a scanned folder
// (image_folder.h) or the frames sampled from a video (video_frames.h) into a crossing database
// over StreamEnroll, with the server's answer for every view (stored, duplicate or
// invalid), so progress counts what the server did, not what was sent.
//
// At most `window` views are in flight (sent, not yet answered): enough for the server never to
// wait for the next view, few enough that a stop (Ctrl-C) or an error leaves only a handful of
// answers to wait for. On a stop, no further view is sent, the stream is half-closed and the
// answers of the views already sent are read: each view is stored completely or not at all
// (one transaction per view), and the report says which.

#include <atomic>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "client/datasets/image_folder.h"
#include "client/lib/crossing_client.h"

namespace waymark::cli {

struct FolderEnrollOptions {
  std::string database;
  bool store_images = false;
  bool strict = false;   // an invalid view ends the enrollment instead of being skipped
  bool replace = false;  // EnrollViewRequest.replace
  int window = 4;        // views in flight
};

// What the server did with the views answered so far.
struct EnrollTally {
  int total = 0;  // views in the folder
  int sent = 0;
  int stored = 0;
  int duplicates = 0;  // skipped: the image was already stored
  int invalid = 0;     // skipped: rejected by the server (corrupt, no texture)
  int replaced = 0;    // stored views deleted by `replace`
  int crossings_created = 0;
  int clusters_created = 0;
  int64_t keypoints = 0;

  int answered() const { return stored + duplicates + invalid; }
  int remaining() const { return total - answered(); }
};

// A view that was not stored, with its file.
struct SkippedImage {
  EnrollImage image;
  v1::EnrollViewResponse answer;  // DUPLICATE names the stored view; INVALID says why
};

struct FolderEnrollReport {
  EnrollTally tally;
  std::vector<SkippedImage> duplicates;
  std::vector<SkippedImage> invalid;
  bool stopped = false;  // `stop` was set before every view was sent
  // OK, or what ended the enrollment early (a file that cannot be read, the server's error);
  // views answered before it are in `tally`.
  absl::Status status;
};

// Called after every answer, e.g. to redraw a progress bar.
using EnrollProgress = std::function<void(const EnrollTally&)>;

FolderEnrollReport EnrollFolder(client::CrossingClient& client,
                                const std::vector<EnrollImage>& images,
                                const FolderEnrollOptions& options, const std::atomic<bool>& stop,
                                const EnrollProgress& progress = {});

// "56 stored, 160 skipped as duplicates, 6 skipped as invalid" (with "(4 replacing 5 older
// views)" after "stored" when views were replaced).
std::string DescribeOutcomes(const EnrollTally& tally);

}  // namespace waymark::cli

#endif  // WAYMARK_CLIENT_SESSIONS_FOLDER_ENROLL_H_
