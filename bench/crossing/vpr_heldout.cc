// waymark-vpr-heldout: the retrieval mode's acceptance on places that are NOT in the database
// (issue 34). For each set (corridor, triplets, KITTI, Bonn, the rotation set) it builds the
// usual known-places protocol and an unknown-places variant (bench/crossing/vpr_heldout_sets.h),
// runs every query once through the engine (RootSIFT, kept aspect, the global stage: a retrieval
// database), records the NFA path's answer and the global path's chance model, and scores:
// - today's rule (the legacy lift 0.16 before the NFA), measured in the same run;
// - the chance-model rule for a grid of epsilon (replayed: recognizer.cc's order, NFA first);
// - leave one set out: epsilon calibrated on four sets, reported on the fifth.
//
//   waymark-vpr-heldout --shared ../shared --out DIR [--offsets 0,12,26] [--fov 60]
//
// Writes DIR/heldout_results.md and DIR/heldout_rows.csv; progress on stderr.

#include <CLI/CLI.hpp>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "bench/crossing/rotation_set.h"
#include "bench/crossing/vpr_datasets.h"
#include "bench/crossing/vpr_experiment.h"
#include "bench/crossing/vpr_heldout_score.h"
#include "bench/crossing/vpr_heldout_sets.h"
#include "server/crossing/global_chance.h"
#include "server/crossing/global_index.h"
#include "server/crossing/recognizer.h"

namespace waymark::vpr {
namespace {

using crossing::RecognitionMode;
using crossing::RecognitionOptions;
using Clock = std::chrono::steady_clock;

constexpr double kToday = 0.16;          // the lift limit the retrieval mode had (issue 18)
constexpr double kMaxFalseAccept = 0.03;  // issue 34's ceiling on every left-out set

bool Contains(const std::vector<int64_t>& v, int64_t x) {
  return std::find(v.begin(), v.end(), x) != v.end();
}

std::string Pct(double v) { return absl::StrFormat("%.1f %%", 100 * v); }

struct Part {
  std::string set;
  bool unknown_variant = false;
  std::vector<Protocol> protocols;
};

absl::Status RunPart(const Part& part, FeatureCache* cache, std::vector<HeldOutRow>* rows,
                     int* without_global, std::ostream* sims_out) {
  for (const Protocol& protocol : part.protocols) {
    absl::StatusOr<PreparedProtocol> prepared = Prepare(protocol, cache);
    if (!prepared.ok()) return prepared.status();
    const crossing::ViewDatabase& db = *prepared->db;
    if (db.global_index().empty()) ++*without_global;
    RecognitionOptions today;
    today.mode = RecognitionMode::kRetrieval;
    today.min_global_lift = kToday;
    RecognitionOptions pieces;
    pieces.mode = RecognitionMode::kRetrieval;
    pieces.max_log10_global_efa = -1e4;  // the global path never accepts: replayed below
    for (size_t i = 0; i < protocol.queries.size(); ++i) {
      const Query& q = protocol.queries[i];
      const crossing::ImageFeatures& f = *prepared->query_features[i];
      absl::StatusOr<crossing::Recognition> t = crossing::Recognize(db, f, today);
      absl::StatusOr<crossing::Recognition> r = crossing::Recognize(db, f, pieces);
      if (!t.ok()) return t.status();
      if (!r.ok()) return r.status();
      HeldOutRow row;
      row.set = part.set;
      row.unknown_variant = part.unknown_variant;
      row.known = !q.accepted.empty();
      auto place = [&](uint32_t slot) { return db.views()[slot].crossing_id; };
      row.today_recognized = t->recognized;
      row.today_correct = t->recognized && Contains(q.accepted, place(t->best_slot));
      row.nfa_recognized = r->recognized;
      row.nfa_correct = r->recognized && Contains(q.accepted, place(r->best_slot));
      row.nfa_computed = r->nfa_computed;
      row.log10_nfa = r->log10_nfa;
      row.global_computed = r->global.computed;
      row.global_log10_efa = r->global.log10_efa;
      row.global_similarity = r->global.best_similarity;
      row.global_correct = r->global_stage && Contains(q.accepted, r->global.best_place);
      row.protocol = protocol.name;
      if (r->global_stage) {
        const std::vector<float> sim = db.global_index().Similarities(
            crossing::QuantizeGlobal(db.vocabulary().Encode(f.dense)));
        std::vector<int64_t> places;
        for (const crossing::ViewEntry& v : db.views()) places.push_back(v.crossing_id);
        for (const ModelVariant& m : kModels) {
          crossing::GlobalChanceOptions o;
          o.low_quantile = m.low_quantile;
          o.high_quantile = m.high_quantile;
          o.place_maxima = m.place_maxima;
          const crossing::GlobalChance g = crossing::EstimateGlobalChance(sim, places, o);
          row.efa_by_model.push_back(g.computed ? g.log10_efa : std::nan(""));
        }
        if (sims_out != nullptr) {
          // One line per row with a global stage: the row's index, then (similarity, place) pairs.
          *sims_out << rows->size();
          for (size_t k = 0; k < sim.size(); ++k) *sims_out << " " << sim[k] << " " << places[k];
          *sims_out << "\n";
        }
      }
      rows->push_back(row);
    }
    std::cerr << absl::StrFormat("  %-40s %3d views %4d queries\n", protocol.name,
                                 db.views().size(), protocol.queries.size());
  }
  return absl::OkStatus();
}

std::string ScoreLine(const std::string& label, const SetScore& s) {
  return absl::StrFormat("| %s | %d/%d (%s) | %d | %d | %d/%d (%s) |", label, s.correct, s.known,
                         Pct(s.recall()), s.wrong, s.refused, s.false_accepts, s.unknown,
                         Pct(s.false_accept_rate()));
}

int Main(int argc, char** argv) {
  CLI::App app("held-out places: the retrieval mode's acceptance on places not in the database");
  std::string shared = "../shared";
  std::string out_dir;
  std::vector<double> offsets = {0, 12, 26};
  double fov = 60;
  double kitti_min_m = 10, bonn_min_m = 0.5;
  app.add_option("--shared", shared, "the shared folder holding data/vpr and data/vslam");
  app.add_option("--out", out_dir, "folder for heldout_results.md and heldout_rows.csv")
      ->required();
  app.add_option("--offsets", offsets, "rotation set: query offsets (degrees)")->delimiter(',');
  app.add_option("--fov", fov, "rotation set: field of view (degrees)");
  app.add_option("--kitti-unknown-m", kitti_min_m,
                 "KITTI: a held-out frame is unknown this far from every enrolled one");
  app.add_option("--bonn-unknown-m", bonn_min_m, "Bonn: the same");
  bool dump_similarities = false;
  app.add_flag("--dump-similarities", dump_similarities,
               "also write DIR/heldout_similarities.txt: each row's global similarities and places");
  CLI11_PARSE(app, argc, argv);

  crossing::FeatureOptions features;
  features.root_sift = true;
  features.keep_aspect = true;
  features.global_descriptor = true;
  FeatureCache cache(features);
  const DataPaths paths = DefaultDataPaths(shared);
  std::vector<Part> parts;
  const auto start = Clock::now();
  auto prefetch = [&](const std::vector<Protocol>& ps) {
    std::vector<std::string> all;
    for (const Protocol& p : ps) {
      for (const std::string& s : ImagePaths(p)) {
        if (s.rfind("rotation:", 0) != 0) all.push_back(s);
      }
    }
    return cache.Prefetch(all, 2);
  };
  auto add = [&](const std::string& set, std::vector<Protocol> known,
                 std::vector<Protocol> unknown) -> absl::Status {
    if (absl::Status s = prefetch(known); !s.ok()) return s;
    if (absl::Status s = prefetch(unknown); !s.ok()) return s;
    parts.push_back({set, false, std::move(known)});
    parts.push_back({set, true, std::move(unknown)});
    return absl::OkStatus();
  };
  auto check = [](const absl::Status& s) {
    if (!s.ok()) {
      std::cerr << "error: " << s << "\n";
      std::exit(1);
    }
  };
  if (auto c = LoadCorridor(paths.corridor); c.ok()) {
    check(add("corridor", {CorridorAll(*c)}, CorridorHeldOut(*c)));
  } else {
    std::cerr << "skipping corridor: " << c.status() << "\n";
  }
  if (auto t = LoadTriplets(paths.triplets); t.ok()) {
    check(add("triplets", TripletFolds(*t), TripletHeldOut(*t, 1)));
  } else {
    std::cerr << "skipping triplets: " << t.status() << "\n";
  }
  if (auto k = LoadKittiFrames(paths.kitti); k.ok()) {
    std::vector<Protocol> known;
    for (int stride : {2, 5, 10}) known.push_back(OffPosition(*k, stride));
    check(add("kitti", known, SequenceHeldOut(*k, 2, kitti_min_m)));
  } else {
    std::cerr << "skipping KITTI: " << k.status() << "\n";
  }
  if (auto b = LoadBonnFrames(paths.bonn); b.ok()) {
    std::vector<Protocol> known;
    for (int stride : {5, 10, 20, 40}) known.push_back(OffPosition(*b, stride));
    check(add("bonn", known, SequenceHeldOut(*b, 5, bonn_min_m)));
  } else {
    std::cerr << "skipping Bonn: " << b.status() << "\n";
  }
  // The rotation set: views rendered from the panoramas, extracted into the cache.
  std::vector<std::string> names;
  for (const bench::PanoramaSource& source : bench::FindPanoramas("/")) {
    absl::StatusOr<bench::Panorama> pano = bench::LoadPanorama(source);
    if (!pano.ok()) continue;
    names.push_back(source.name);
    bench::ViewOptions view;
    view.hfov_deg = fov;
    std::vector<double> headings;
    for (int k = 0; k < 12; ++k) {
      headings.push_back(k * 30.0);
      for (double o : offsets) headings.push_back(k * 30.0 + o);
    }
    for (double h : headings) {
      absl::StatusOr<cv::Mat> img = bench::RenderView(*pano, h, view);
      check(img.status());
      check(cache.Put(RotationKey(source.name, h, fov), *img));
    }
  }
  if (names.size() >= 3) {
    parts.push_back({"rotation", false, {RotationKnown(names, offsets, fov)}});
    parts.push_back({"rotation", true, RotationHeldOut(names, offsets, fov)});
  } else {
    std::cerr << "skipping the rotation set: blender-data's panoramas not found\n";
  }
  std::cerr << absl::StrFormat("features of %d images in %.0f s\n", cache.size(),
                               std::chrono::duration<double>(Clock::now() - start).count());

  std::vector<HeldOutRow> rows;
  int without_global = 0;
  std::filesystem::create_directories(out_dir);
  std::ofstream sims_file;
  if (dump_similarities) sims_file.open(out_dir + "/heldout_similarities.txt");
  for (const Part& part : parts) {
    std::cerr << part.set << (part.unknown_variant ? " (unknown places)" : "") << "\n";
    check(RunPart(part, &cache, &rows, &without_global,
                  dump_similarities ? &sims_file : nullptr));
  }
  {
    std::ofstream csv(out_dir + "/heldout_rows.csv");
    csv << "set,unknown_variant,known,today_recognized,today_correct,nfa_recognized,nfa_correct,"
           "nfa_computed,log10_nfa,global_computed,global_correct,global_log10_efa,"
           "global_similarity,protocol";
    for (size_t m = 0; m < std::size(kModels); ++m) csv << ",efa_model" << m;
    csv << "\n";
    for (const HeldOutRow& r : rows) {
      csv << r.set << "," << r.unknown_variant << "," << r.known << "," << r.today_recognized
          << "," << r.today_correct << "," << r.nfa_recognized << "," << r.nfa_correct << ","
          << r.nfa_computed << "," << r.log10_nfa << "," << r.global_computed << ","
          << r.global_correct << "," << r.global_log10_efa << "," << r.global_similarity << ","
          << r.protocol;
      for (double e : r.efa_by_model) csv << "," << e;
      csv << "\n";
    }
  }
  const std::vector<double> grid = {-0.5, -1, -1.5, -2, -2.5, -3, -4, -5, -6, -8};
  std::ostringstream md;
  md << "# Held-out places (waymark-vpr-heldout)\n\n"
     << "Retrieval databases (RootSIFT, kept aspect, global stage). R@1 = correct / known queries "
        "of the set's usual protocol (a refusal counts as wrong); false accepts = accepted "
        "queries of places held out of the database, on the set's unknown-places variant.\n\n";
  if (without_global > 0) {
    md << "Warning: " << without_global << " database(s) ran without a global stage.\n\n";
  }
  md << "| rule, set | R@1 | wrong | refused | false accepts |\n|---|---|---|---|---|\n";
  for (const auto& [set, s] : Score(rows, Today)) md << ScoreLine("today (lift 0.16), " + set, s) << "\n";
  const auto nfa_only = Score(rows, [](const HeldOutRow& r) { return Replay(r, -1e9); });
  for (const auto& [set, s] : nfa_only) md << ScoreLine("NFA only, " + set, s) << "\n";
  for (int model = 0; model < static_cast<int>(std::size(kModels)); ++model) {
    for (double eps : grid) {
      for (const auto& [set, s] :
           Score(rows, [eps, model](const HeldOutRow& r) { return Replay(r, eps, model); }))
        md << ScoreLine(absl::StrFormat("%s, EFA < 10^%.1f, %s", kModels[model].name, eps, set),
                        s)
           << "\n";
    }
  }
  md << "\n## Leave one set out (epsilon chosen on the other four: false accepts <= "
     << Pct(kMaxFalseAccept) << " on each, then the best mean R@1)\n\n"
     << "| left out | chosen model, log10 epsilon | R@1 | wrong | refused | false accepts |\n"
     << "|---|---|---|---|---|---|\n";
  double worst = 0;
  for (const LeaveOneOut& l : LeaveOneSetOut(rows, grid, kMaxFalseAccept)) {
    const SetScore& s = l.held_out;
    worst = std::max(worst, s.false_accept_rate());
    md << absl::StrFormat("| %s | %s, %.1f%s | %d/%d (%s) | %d | %d | %d/%d (%s) |\n", l.left_out,
                          kModels[l.chosen_model].name, l.chosen_log10_efa, l.feasible ? "" : " (none met the ceiling)",
                          s.correct, s.known, Pct(s.recall()), s.wrong, s.refused,
                          s.false_accepts, s.unknown, Pct(s.false_accept_rate()));
  }
  md << "\nWorst left-out false-accept rate: " << Pct(worst) << "\n";
  std::ofstream(out_dir + "/heldout_results.md") << md.str();
  std::cout << md.str();
  return 0;
}

}  // namespace
}  // namespace waymark::vpr

int main(int argc, char** argv) { return waymark::vpr::Main(argc, argv); }
