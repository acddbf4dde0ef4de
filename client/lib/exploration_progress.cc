#include "client/lib/exploration_progress.h"

#include "absl/strings/ascii.h"

namespace waymark::client {

bool ExplorationEnded(const v1::ExplorationProgress& progress) {
  return progress.state() == v1::ExplorationProgress::DONE ||
         progress.state() == v1::ExplorationProgress::STUCK;
}

std::string ExplorationStateName(const v1::ExplorationProgress& progress) {
  if (progress.state() == v1::ExplorationProgress::STATE_UNSPECIFIED) return "-";
  return absl::AsciiStrToLower(v1::ExplorationProgress::State_Name(progress.state()));
}

}  // namespace waymark::client
