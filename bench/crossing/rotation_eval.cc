// waymark-rotation-eval: the paper's rotation claim (METHODS.md section 1: recognition 12 and 26
// degrees off the stored headings) on views cut from real 360-degree photos
// (bench/crossing/rotation_set.h).
//
// Every panorama is one crossing, enrolled as 12 views at 0, 30, ..., 330 degrees with the paper's
// clustering. Queries look at 30k + offset degrees (clockwise) for every sector k and each offset;
// both recognition modes answer every query. Writes DIR/rotation_results.md, .json and
// DIR/rotation_views.png (the 12 enrolled views of one place).
//
//   waymark-rotation-eval --out DIR [--root /] [--fov 60,90] [--offsets 0,5,12,15,20,26]
//                         [--sheet blender/courtyard] [--retrieval-features]

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_join.h"
#include "absl/strings/str_split.h"
#include "bench/crossing/rotation_set.h"
#include "server/crossing/enrollment.h"
#include "server/crossing/features.h"
#include "server/crossing/hue_histogram.h"
#include "server/crossing/recognizer.h"
#include "server/crossing/view_database.h"

namespace waymark::bench {
namespace {

namespace wc = waymark::crossing;
using Clock = std::chrono::steady_clock;

constexpr int kViewsPerCrossing = 12;
constexpr double kStepDeg = 30;

struct Args {
  std::string out = "rotation-results";
  std::string root = "/";
  std::vector<double> fovs = {60, 90};
  std::vector<double> offsets = {0, 5, 12, 15, 20, 26};
  std::string sheet;  // panorama shown in the contact sheet; default: the first
  // The retrieval mode on its own features and database (RootSIFT, aspect kept, dense RootSIFT
  // with a vocabulary learnt from the enrolled views), as a retrieval database is created; the
  // paper and verified modes keep the paper's features.
  bool retrieval_features = false;
};

void Usage() {
  std::cerr << "usage: waymark-rotation-eval --out DIR [--root /] [--fov 60,90]\n"
               "                             [--offsets 0,5,12,15,20,26] [--sheet NAME]\n"
               "                             [--retrieval-features]\n";
}

bool ParseList(const std::string& text, std::vector<double>* out) {
  out->clear();
  for (absl::string_view part : absl::StrSplit(text, ',', absl::SkipEmpty())) {
    try {
      out->push_back(std::stod(std::string(part)));
    } catch (...) {
      return false;
    }
  }
  return !out->empty();
}

bool ParseArgs(int argc, char** argv, Args* args) {
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto value = [&](std::string* v) {
      if (i + 1 >= argc) return false;
      *v = argv[++i];
      return true;
    };
    std::string v;
    if (a == "--out") {
      if (!value(&args->out)) return false;
    } else if (a == "--root") {
      if (!value(&args->root)) return false;
    } else if (a == "--sheet") {
      if (!value(&args->sheet)) return false;
    } else if (a == "--fov") {
      if (!value(&v) || !ParseList(v, &args->fovs)) return false;
    } else if (a == "--offsets") {
      if (!value(&v) || !ParseList(v, &args->offsets)) return false;
    } else if (a == "--retrieval-features") {
      args->retrieval_features = true;
    } else {
      return false;
    }
  }
  return true;
}

double HeadingError(double a, double b) {
  double d = std::fmod(std::fabs(a - b), 360.0);
  return d > 180 ? 360 - d : d;
}

double Median(std::vector<double> v) {
  if (v.empty()) return std::nan("");
  std::sort(v.begin(), v.end());
  const size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

wc::ImageFeatures Extract(const cv::Mat& view, const wc::FeatureOptions& options = {}) {
  std::vector<uchar> png;
  cv::imencode(".png", view, png);
  absl::StatusOr<wc::ImageFeatures> f =
      wc::ExtractFeatures(std::string(png.begin(), png.end()), options);
  if (!f.ok()) {
    std::cerr << "feature extraction failed: " << f.status() << "\n";
    std::exit(1);
  }
  return *std::move(f);
}

wc::FeatureOptions RetrievalFeatures() {
  wc::FeatureOptions options;
  options.root_sift = true;
  options.keep_aspect = true;
  options.global_descriptor = true;
  return options;
}

cv::Mat Render(const Panorama& p, double heading, double fov) {
  ViewOptions options;
  options.hfov_deg = fov;
  absl::StatusOr<cv::Mat> view = RenderView(p, heading, options);
  if (!view.ok()) {
    std::cerr << p.name << ": " << view.status() << "\n";
    std::exit(1);
  }
  return *std::move(view);
}

struct Outcome {
  bool recognized = false;
  bool correct = false;  // recognized and the crossing is right
  double heading_error = 0;
  int best_matches = 0;
};

struct Cell {  // one (fov, mode, offset)
  int queries = 0;
  int correct = 0;
  int wrong = 0;
  int none = 0;
  int nearest_heading = 0;      // correct crossing and heading error <= 15
  std::vector<double> errors;   // heading errors of correct-crossing answers
  std::vector<double> matches;  // best view's match count (correct answers)
  std::map<std::string, std::pair<int, int>> per_panorama;  // name -> (correct, queries)
};

const char* ModeName(wc::RecognitionMode m) {
  switch (m) {
    case wc::RecognitionMode::kVerified: return "verified";
    case wc::RecognitionMode::kRetrieval: return "retrieval";
    case wc::RecognitionMode::kPaper: break;
  }
  return "paper";
}

cv::Mat ContactSheet(const std::vector<cv::Mat>& views, const std::string& title) {
  const int cols = 6;
  const int rows = (static_cast<int>(views.size()) + cols - 1) / cols;
  const int w = views.front().cols, h = views.front().rows;
  const int header = 28;
  cv::Mat sheet(header + rows * h, cols * w, CV_8UC3, cv::Scalar(255, 255, 255));
  cv::putText(sheet, title, cv::Point(8, 20), cv::FONT_HERSHEY_SIMPLEX, 0.6, cv::Scalar(0, 0, 0), 1,
              cv::LINE_AA);
  for (size_t i = 0; i < views.size(); ++i) {
    const int r = static_cast<int>(i) / cols, c = static_cast<int>(i) % cols;
    cv::Mat roi = sheet(cv::Rect(c * w, header + r * h, w, h));
    views[i].copyTo(roi);
    const std::string label = absl::StrCat(static_cast<int>(i * kStepDeg), " deg");
    cv::putText(roi, label, cv::Point(7, 23), cv::FONT_HERSHEY_SIMPLEX, 0.6, cv::Scalar(0, 0, 0), 3,
                cv::LINE_AA);
    cv::putText(roi, label, cv::Point(7, 23), cv::FONT_HERSHEY_SIMPLEX, 0.6,
                cv::Scalar(255, 255, 255), 1, cv::LINE_AA);
    cv::rectangle(roi, cv::Rect(0, 0, w, h), cv::Scalar(255, 255, 255), 1);
  }
  return sheet;
}

std::string Pct(int a, int b) { return b ? absl::StrFormat("%.1f %%", 100.0 * a / b) : "-"; }

int Run(const Args& args) {
  const auto start = Clock::now();
  const std::vector<PanoramaSource> sources = FindPanoramas(args.root);
  if (sources.empty()) {
    std::cerr << "no panoramas found under " << args.root << ": install the Debian package "
              << kPanoramaPackage << " (scripts/install-deps.sh)\n";
    return 2;
  }
  std::vector<Panorama> panoramas;
  std::vector<std::string> descriptions;
  std::vector<std::string> packages;
  for (const PanoramaSource& s : sources) {
    absl::StatusOr<Panorama> p = LoadPanorama(s);
    if (!p.ok()) {
      std::cerr << "skipping " << s.name << ": " << p.status() << "\n";
      continue;
    }
    std::cerr << "loaded " << s.name << " (" << p->bgr.cols << "x" << p->bgr.rows << ")\n";
    panoramas.push_back(*std::move(p));
    descriptions.push_back(s.description);
    if (std::find(packages.begin(), packages.end(), s.package) == packages.end()) {
      packages.push_back(s.package);
    }
  }
  if (panoramas.empty()) return 2;
  std::string sheet_name = args.sheet.empty() ? panoramas.front().name : args.sheet;

  std::error_code ec;
  std::filesystem::create_directories(args.out, ec);
  const wc::RecognitionMode modes[] = {wc::RecognitionMode::kPaper, wc::RecognitionMode::kVerified,
                                       wc::RecognitionMode::kRetrieval};
  constexpr int kModes = 3;

  nlohmann::json json;
  json["packages"] = packages;
  json["views_per_crossing"] = kViewsPerCrossing;
  json["offsets_deg"] = args.offsets;
  for (size_t i = 0; i < panoramas.size(); ++i) {
    json["panoramas"].push_back({{"crossing_id", i + 1},
                                 {"name", panoramas[i].name},
                                 {"description", descriptions[i]},
                                 {"width", panoramas[i].bgr.cols},
                                 {"height", panoramas[i].bgr.rows}});
  }
  std::ostringstream md;
  md << "# Rotation robustness of crossing recognition\n\n"
     << "Generated by `waymark-rotation-eval`. Each panorama is one crossing: 12 pinhole views "
        "(320x240, pitch 0) at 0, 30, ..., 330 degrees are enrolled with the paper's clustering "
        "(threshold 5 matches at lambda = 0.32). Each query looks at 30k + offset degrees "
        "(clockwise) for all 12 sectors k. *Correct* = the right crossing; *heading error* = "
        "returned best view's heading vs the true query heading (median over correct answers); "
        "*nearest heading* = share of all queries answered with the right crossing and a view "
        "within 15 degrees (the nearest stored heading; at offset 15 both neighbours count). "
        "Offset 26 is 4 degrees short of the next stored heading.\n\n"
     << "Panoramas (real photos from the Debian package(s) " << absl::StrJoin(packages, ", ")
     << ", found under `" << args.root << "`):\n\n"
     << "| crossing | panorama | pixels | geometry | what it shows |\n|---|---|---|---|---|\n";
  for (size_t i = 0; i < panoramas.size(); ++i) {
    const Panorama& p = panoramas[i];
    md << "| " << i + 1 << " | " << p.name << " | " << p.bgr.cols << "x" << p.bgr.rows << " | "
       << (p.projection == VerticalProjection::kCylindrical ? "cylindrical" : "equirectangular")
       << ", 360 x " << p.top_deg << ".." << p.bottom_deg << " deg | " << descriptions[i] << " |\n";
  }
  md << "\n";
  if (args.retrieval_features) {
    md << "The retrieval mode runs on its own database of the same views with RootSIFT, "
          "aspect-kept frames and the global stage (dense RootSIFT VLAD, vocabulary learnt from "
          "the enrolled views); paper and verified on the paper's features.\n\n";
  }

  for (double fov : args.fovs) {
    std::cerr << "== field of view " << fov << " degrees\n";
    wc::ViewDatabase db;
    wc::ViewDatabase retrieval_db;  // with --retrieval-features
    std::vector<cv::Mat> retrieval_dense;
    int64_t next_view_id = 1;
    std::vector<double> keypoints;
    std::vector<cv::Mat> sheet_views;
    for (size_t i = 0; i < panoramas.size(); ++i) {
      for (int k = 0; k < kViewsPerCrossing; ++k) {
        const double heading = k * kStepDeg;
        const cv::Mat view = Render(panoramas[i], heading, fov);
        const wc::ImageFeatures f = Extract(view);
        keypoints.push_back(f.keypoints.size());
        if (args.retrieval_features) {
          const wc::ImageFeatures rf = Extract(view, RetrievalFeatures());
          wc::EnrollView(&retrieval_db, next_view_id, static_cast<int64_t>(i + 1), heading, rf);
          retrieval_dense.push_back(rf.dense);
        }
        wc::EnrollView(&db, next_view_id++, static_cast<int64_t>(i + 1), heading, f);
        if (panoramas[i].name == sheet_name && fov == args.fovs.front())
          sheet_views.push_back(view);
      }
      std::cerr << "enrolled " << panoramas[i].name << " (" << db.clusters().size()
                << " clusters so far)\n";
    }
    // Clusters: total, and how many hold views of more than one crossing.
    int mixed = 0;
    for (const wc::ClusterEntry& c : db.clusters()) {
      int64_t first = db.views()[c.center].crossing_id;
      for (uint32_t m : c.members) {
        if (db.views()[m].crossing_id != first) {
          ++mixed;
          break;
        }
      }
    }
    const int clusters = static_cast<int>(db.clusters().size());
    if (args.retrieval_features) retrieval_db.TrainGlobal(retrieval_dense);

    std::map<std::pair<int, double>, Cell> cells;  // (mode index, offset)
    for (double offset : args.offsets) {
      for (size_t i = 0; i < panoramas.size(); ++i) {
        for (int k = 0; k < kViewsPerCrossing; ++k) {
          const double truth = k * kStepDeg + offset;
          const cv::Mat query = Render(panoramas[i], truth, fov);
          const wc::ImageFeatures f = Extract(query);
          const wc::ImageFeatures rf =
              args.retrieval_features ? Extract(query, RetrievalFeatures()) : wc::ImageFeatures();
          for (int m = 0; m < kModes; ++m) {
            wc::RecognitionOptions options;
            options.mode = modes[m];
            const bool own = args.retrieval_features && modes[m] == wc::RecognitionMode::kRetrieval;
            const wc::ViewDatabase& mode_db = own ? retrieval_db : db;
            absl::StatusOr<wc::Recognition> r = wc::Recognize(mode_db, own ? rf : f, options);
            if (!r.ok()) {
              std::cerr << "recognition failed: " << r.status() << "\n";
              return 1;
            }
            Cell& cell = cells[{m, offset}];
            ++cell.queries;
            auto& pp = cell.per_panorama[panoramas[i].name];
            ++pp.second;
            if (!r->recognized) {
              ++cell.none;
              continue;
            }
            const wc::ViewEntry& best = mode_db.views()[r->best_slot];
            if (best.crossing_id != static_cast<int64_t>(i + 1)) {
              ++cell.wrong;
              continue;
            }
            ++cell.correct;
            ++pp.first;
            const double err = HeadingError(best.heading_deg, truth);
            cell.errors.push_back(err);
            if (err <= 15 + 1e-9) ++cell.nearest_heading;
            for (const wc::Candidate& c : r->candidates) {
              if (c.slot == r->best_slot) cell.matches.push_back(c.matches);
            }
          }
        }
      }
      const Cell& paper = cells[{0, offset}];
      const Cell& verified = cells[{1, offset}];
      const Cell& retrieval = cells[{2, offset}];
      std::cerr << absl::StrFormat(
          "fov %g offset %g: paper %d/%d correct, verified %d/%d, retrieval %d/%d (%d wrong) "
          "(%.0f s)\n",
          fov, offset, paper.correct, paper.queries, verified.correct, verified.queries,
          retrieval.correct, retrieval.queries, retrieval.wrong,
          std::chrono::duration<double>(Clock::now() - start).count());
    }

    // Report.
    md << "## Field of view " << fov << " degrees\n\n"
       << db.views().size() << " views of " << panoramas.size() << " crossings, " << clusters
       << " clusters made (" << mixed << " mixing crossings); SIFT keypoints per enrolled view: "
       << "median " << Median(keypoints) << ", min "
       << *std::min_element(keypoints.begin(), keypoints.end()) << ".\n\n"
       << "| offset | mode | queries | correct | wrong crossing | no decision | recognition rate "
          "| median heading error | nearest heading | median matches of best view |\n"
       << "|---|---|---|---|---|---|---|---|---|---|\n";
    nlohmann::json jfov;
    jfov["hfov_deg"] = fov;
    jfov["views"] = db.views().size();
    jfov["clusters"] = clusters;
    jfov["clusters_mixing_crossings"] = mixed;
    jfov["median_keypoints_per_view"] = Median(keypoints);
    for (double offset : args.offsets) {
      for (int m = 0; m < kModes; ++m) {
        const Cell& c = cells[{m, offset}];
        const double med = Median(c.errors);
        const double med_matches = Median(c.matches);
        md << "| " << offset << " | " << ModeName(modes[m]) << " | " << c.queries << " | "
           << c.correct << " | " << c.wrong << " | " << c.none << " | " << Pct(c.correct, c.queries)
           << " | " << (std::isnan(med) ? std::string("-") : absl::StrFormat("%.0f deg", med))
           << " | " << Pct(c.nearest_heading, c.queries) << " | "
           << (std::isnan(med_matches) ? std::string("-") : absl::StrFormat("%.0f", med_matches))
           << " |\n";
        nlohmann::json row = {
            {"offset_deg", offset},
            {"mode", ModeName(modes[m])},
            {"queries", c.queries},
            {"correct", c.correct},
            {"wrong_crossing", c.wrong},
            {"no_decision", c.none},
            {"recognition_rate", c.queries ? double(c.correct) / c.queries : 0},
            {"nearest_heading_rate", c.queries ? double(c.nearest_heading) / c.queries : 0}};
        row["median_heading_error_deg"] =
            std::isnan(med) ? nlohmann::json(nullptr) : nlohmann::json(med);
        row["median_best_matches"] =
            std::isnan(med_matches) ? nlohmann::json(nullptr) : nlohmann::json(med_matches);
        for (const auto& [name, counts] : c.per_panorama) {
          row["per_panorama"][name] = {{"correct", counts.first}, {"queries", counts.second}};
        }
        jfov["rows"].push_back(row);
      }
    }
    // Per panorama: correct answers per offset (paper / verified / retrieval).
    md << "\nCorrect crossing per panorama, out of 12 (paper / verified / retrieval):\n\n"
          "| panorama |";
    for (double offset : args.offsets) md << " " << offset << " deg |";
    md << "\n|---|";
    for (size_t j = 0; j < args.offsets.size(); ++j) md << "---|";
    md << "\n";
    for (const Panorama& p : panoramas) {
      md << "| " << p.name << " |";
      for (double offset : args.offsets) {
        md << " " << cells[{0, offset}].per_panorama[p.name].first << " / "
           << cells[{1, offset}].per_panorama[p.name].first << " / "
           << cells[{2, offset}].per_panorama[p.name].first << " |";
      }
      md << "\n";
    }
    md << "\n";
    json["fields_of_view"].push_back(jfov);

    if (!sheet_views.empty()) {
      const std::string png = (std::filesystem::path(args.out) / "rotation_views.png").string();
      cv::imwrite(
          png, ContactSheet(sheet_views, absl::StrCat(sheet_name, ": the 12 enrolled views (", fov,
                                                      " deg field of view)")));
      md << "`rotation_views.png`: the 12 enrolled views of " << sheet_name << " at " << fov
         << " degrees.\n\n";
    }
  }
  const double seconds = std::chrono::duration<double>(Clock::now() - start).count();
  json["seconds"] = seconds;
  md << absl::StrFormat("Run time: %.0f s.\n", seconds);

  const std::filesystem::path out(args.out);
  std::ofstream(out / "rotation_results.md") << md.str();
  std::ofstream(out / "rotation_results.json") << json.dump(2) << "\n";
  std::cerr << "wrote " << (out / "rotation_results.md").string()
            << ", .json and rotation_views.png\n";
  return 0;
}

}  // namespace
}  // namespace waymark::bench

int main(int argc, char** argv) {
  waymark::bench::Args args;
  if (!waymark::bench::ParseArgs(argc, argv, &args)) {
    waymark::bench::Usage();
    return 2;
  }
  return waymark::bench::Run(args);
}
