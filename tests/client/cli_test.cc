// The `waymark` command line against the in-memory fake service: arguments reach the API, results
// reach stdout (tables or one JSON document), errors reach stderr with code and message.
#include "client/cli/cli.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <csignal>
#include <fstream>
#include <nlohmann/json.hpp>

#include "tests/client/fake_crossing_service.h"
#include "tests/client/test_util.h"

namespace waymark::cli {
namespace {

using ::testing::HasSubstr;
using ::testing::Not;
using waymark::testing::CliResult;
using waymark::testing::FakeServer;
using waymark::testing::ReadAll;
using waymark::testing::RunWaymark;
using waymark::testing::ScopedTempDir;
using waymark::testing::WriteImage;

class CliTest : public ::testing::Test {
 protected:
  CliResult Run(std::vector<std::string> args, const std::string& server = "") {
    return RunWaymark(server.empty() ? server_.address() : server, std::move(args));
  }

  // DIR/A/{000,090}.png and DIR/B/{000,090}.png, all different.
  void MakeViews(const ScopedTempDir& dir) {
    WriteImage(dir.Make("views/A/000.png"), 40, 30, cv::Scalar(255, 0, 0));
    WriteImage(dir.Make("views/A/090.png"), 40, 30, cv::Scalar(0, 255, 0));
    WriteImage(dir.Make("views/B/090.png"), 40, 30, cv::Scalar(0, 0, 255));
    WriteImage(dir.Make("views/B/000.png"), 40, 30, cv::Scalar(9, 9, 9));
  }

  void Copy(const ScopedTempDir& dir, const std::string& from, const std::string& to) {
    std::filesystem::copy_file(dir.path() / from, dir.Make(to));
  }

  FakeServer server_;
};

TEST_F(CliTest, DbCreateSendsOnlyTheGivenParams) {
  CliResult r = Run({"db", "create", "campus", "--hue-bins", "18", "--mode", "verified", "--json"});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(r.Json()["name"], "campus");
  const v1::CreateDatabaseRequest sent = server_.service().last_create();
  EXPECT_EQ(sent.params().hue_bins(), 18);
  EXPECT_EQ(sent.params().recognition().mode(), v1::RECOGNITION_MODE_VERIFIED);
  EXPECT_FALSE(sent.params().has_work_width());
  EXPECT_FALSE(sent.params().has_cluster_threshold());

  r = Run({"db", "create", "lab", "--work-width", "640", "--work-height", "480",
           "--cluster-threshold", "7"});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("created database lab"));
  EXPECT_THAT(r.out, HasSubstr("640x480"));
  EXPECT_EQ(server_.service().last_create().params().cluster_threshold(), 7);
}

// Issue 34: `db create` without options makes the best measured database (retrieval mode,
// RootSIFT, kept aspect; the server adds the global stage to a retrieval database); --mode paper
// keeps the paper's configuration exactly; the features can be set either way.
TEST_F(CliTest, DbCreateDefaultsToTheBestMeasuredConfigurationAndPaperModeIsThePapers) {
  CliResult r = Run({"db", "create", "city"});
  ASSERT_EQ(r.code, 0) << r.err;
  v1::CreateDatabaseRequest sent = server_.service().last_create();
  EXPECT_EQ(sent.params().recognition().mode(), v1::RECOGNITION_MODE_RETRIEVAL);
  EXPECT_TRUE(sent.params().root_sift());
  EXPECT_TRUE(sent.params().keep_aspect());
  EXPECT_FALSE(sent.params().has_global_descriptor());  // the server's: on in retrieval mode
  EXPECT_FALSE(sent.params().has_work_width());          // the paper's 320x240 stays
  EXPECT_FALSE(sent.params().recognition().has_ratio());
  EXPECT_THAT(r.out, HasSubstr("retrieval mode"));
  EXPECT_THAT(r.out, HasSubstr("RootSIFT (root_sift)"));
  EXPECT_THAT(r.out, HasSubstr("keeping their aspect (keep_aspect)"));

  r = Run({"db", "create", "paper", "--mode", "paper"});
  ASSERT_EQ(r.code, 0) << r.err;
  sent = server_.service().last_create();
  EXPECT_EQ(sent.params().recognition().mode(), v1::RECOGNITION_MODE_PAPER);
  EXPECT_TRUE(sent.params().has_root_sift());
  EXPECT_FALSE(sent.params().root_sift());
  EXPECT_FALSE(sent.params().keep_aspect());
  EXPECT_FALSE(sent.params().has_global_descriptor());
  EXPECT_FALSE(sent.params().recognition().has_ratio());  // lambda 0.32, N0/N1/N2: the server's
  EXPECT_THAT(r.out, HasSubstr("paper mode"));
  EXPECT_THAT(r.out, HasSubstr("features     SIFT, images resized to the working size"));

  ASSERT_EQ(Run({"db", "create", "v", "--mode", "verified"}).code, 0);
  EXPECT_FALSE(server_.service().last_create().params().root_sift());
  ASSERT_EQ(Run({"db", "create", "r", "--no-root-sift", "--no-keep-aspect"}).code, 0);
  sent = server_.service().last_create();
  EXPECT_EQ(sent.params().recognition().mode(), v1::RECOGNITION_MODE_RETRIEVAL);
  EXPECT_FALSE(sent.params().root_sift());
  EXPECT_FALSE(sent.params().keep_aspect());
  ASSERT_EQ(Run({"db", "create", "p", "--mode", "paper", "--root-sift"}).code, 0);
  EXPECT_TRUE(server_.service().last_create().params().root_sift());
}

// `db stats` shows RootSIFT, aspect and the global stage with its vocabulary's state.
TEST_F(CliTest, DbStatsShowsTheFeaturesAndTheGlobalStage) {
  ASSERT_EQ(Run({"db", "create", "city", "--global-descriptor"}).code, 0);
  CliResult r = Run({"db", "stats", "city"});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("RootSIFT (root_sift)"));
  EXPECT_THAT(r.out, HasSubstr("(keep_aspect)"));
  EXPECT_THAT(r.out, HasSubstr("global descriptor"));
  EXPECT_THAT(r.out, HasSubstr("no vocabulary yet: learnt at 16 views, the database holds 0"));
  ASSERT_EQ(Run({"db", "create", "paper", "--mode", "paper"}).code, 0);
  r = Run({"db", "stats", "paper"});
  EXPECT_THAT(r.out, HasSubstr("features     SIFT, images resized"));
  EXPECT_THAT(r.out, HasSubstr("global       off"));
  r = Run({"db", "stats", "city", "--json"});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(r.Json()["database"]["params"]["root_sift"], true);
}

// Issue 34: images whose names are not headings, through a manifest, and views with no heading.
TEST_F(CliTest, EnrollAManifestWithViewsOfNoHeading) {
  ScopedTempDir dir;
  WriteImage(dir.Make("photos/p0_i0.JPG"), 40, 30, cv::Scalar(255, 0, 0));
  WriteImage(dir.Make("photos/p0_i1.JPG"), 40, 30, cv::Scalar(0, 255, 0));
  WriteImage(dir.Make("photos/p1_i0.png"), 40, 30, cv::Scalar(0, 0, 255));
  {
    std::ofstream manifest(dir.Make("views.csv"));
    manifest << "file,crossing,heading,position\n"
                "photos/p0_i0.JPG,main-and-1st,30,north-kerb\n"
                "photos/p0_i1.JPG,main-and-1st,,\n"
                "photos/p1_i0.png,station,unknown\n";
  }
  ASSERT_EQ(Run({"db", "create", "campus"}).code, 0);
  // The folder layout refuses such names, and says what to do.
  CliResult refused = Run({"enroll", "campus", (dir.path() / "photos").string()});
  EXPECT_NE(refused.code, 0);
  CliResult r = Run({"enroll", "campus", "--manifest", (dir.path() / "views.csv").string(),
                     "--json"});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(r.Json()["views"], 3);
  EXPECT_EQ(r.Json()["crossings"], 2);
  const auto views = server_.service().views("campus");
  ASSERT_EQ(views.size(), 3u);
  EXPECT_EQ(views[0].crossing, "main-and-1st");
  EXPECT_EQ(views[0].heading_deg, 30);
  EXPECT_FALSE(views[0].heading_unknown);
  EXPECT_EQ(views[0].position, "north-kerb");
  EXPECT_TRUE(views[1].heading_unknown);
  EXPECT_EQ(views[1].heading_deg, 0);
  EXPECT_EQ(views[2].crossing, "station");
  EXPECT_TRUE(views[2].heading_unknown);
  EXPECT_EQ(views[2].bytes, ReadAll(dir.path() / "photos/p1_i0.png"));

  // DIR/<crossing>/<any name> with --no-headings: every view without a heading.
  WriteImage(dir.Make("folders/yard/IMG_0001.JPG"), 40, 30, cv::Scalar(1, 2, 3));
  r = Run({"enroll", "campus", (dir.path() / "folders").string(), "--no-headings"});
  ASSERT_EQ(r.code, 0) << r.err;
  const auto more = server_.service().views("campus");
  ASSERT_EQ(more.size(), 4u);
  EXPECT_EQ(more[3].crossing, "yard");
  EXPECT_TRUE(more[3].heading_unknown);
  // Again: a duplicate at its own place (no heading either way) is a re-run, not listed.
  r = Run({"enroll", "campus", (dir.path() / "folders").string(), "--no-headings"});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_THAT(r.err, Not(HasSubstr("already stored")));
}

TEST_F(CliTest, ErrorsGoToStderrWithCodeNameAndMessage) {
  ASSERT_EQ(Run({"db", "create", "campus"}).code, 0);
  CliResult r = Run({"db", "create", "campus", "--json"});
  EXPECT_NE(r.code, 0);
  EXPECT_EQ(r.out, "");
  EXPECT_THAT(r.err, HasSubstr("ALREADY_EXISTS: database 'campus' already exists"));

  r = Run({"db", "stats", "nowhere"});
  EXPECT_NE(r.code, 0);
  EXPECT_THAT(r.err, HasSubstr("NOT_FOUND: no crossing database named 'nowhere'"));
}

TEST_F(CliTest, UnreachableServerNamesTheAddress) {
  CliResult r = Run({"--timeout", "2", "db", "list"}, "127.0.0.1:1");
  EXPECT_NE(r.code, 0);
  EXPECT_THAT(r.err, HasSubstr("UNAVAILABLE"));
  EXPECT_THAT(r.err, HasSubstr("127.0.0.1:1"));
}

TEST_F(CliTest, UsageErrorsFailWithoutCallingTheServer) {
  EXPECT_NE(Run({"db"}).code, 0);
  EXPECT_NE(Run({"db", "create"}).code, 0);
  EXPECT_NE(Run({"recognize", "campus"}).code, 0);  // neither IMAGE nor --camera
  EXPECT_NE(Run({"recognize", "campus", "--ratio", "2", "x.png"}).code, 0);
  EXPECT_EQ(server_.service().calls("CreateDatabase"), 0);
  EXPECT_EQ(server_.service().calls("RecognizeCrossing"), 0);
}

TEST_F(CliTest, DbListStatsAndDelete) {
  ASSERT_EQ(Run({"db", "create", "campus"}).code, 0);
  ASSERT_EQ(Run({"crossing", "add", "campus", "A", "--label", "Main St / 1st Ave"}).code, 0);

  CliResult list = Run({"db", "list"});
  ASSERT_EQ(list.code, 0) << list.err;
  EXPECT_THAT(list.out, HasSubstr("name"));
  EXPECT_THAT(list.out, HasSubstr("campus"));
  EXPECT_EQ(Run({"db", "list", "--json"}).Json()["databases"][0]["crossings"], 1);

  CliResult stats = Run({"db", "stats", "campus"});
  ASSERT_EQ(stats.code, 0) << stats.err;
  EXPECT_THAT(stats.out, HasSubstr("Main St / 1st Ave"));
  EXPECT_THAT(stats.out, HasSubstr("members"));
  nlohmann::json json = Run({"--json", "db", "stats", "campus"}).Json();
  EXPECT_EQ(json["database"]["name"], "campus");
  EXPECT_TRUE(json.contains("keypoints"));
  EXPECT_TRUE(json.contains("descriptor_bytes"));
  EXPECT_EQ(json["clusters"].size(), 1u);

  EXPECT_EQ(Run({"db", "delete", "campus", "--json"}).Json()["deleted"], "campus");
  EXPECT_TRUE(Run({"db", "list", "--json"}).Json()["databases"].empty());
  EXPECT_THAT(Run({"db", "list"}).out, HasSubstr("no databases"));
}

TEST_F(CliTest, CrossingCommands) {
  ASSERT_EQ(Run({"db", "create", "campus"}).code, 0);
  CliResult add = Run({"crossing", "add", "campus", "A", "--json"});
  ASSERT_EQ(add.code, 0) << add.err;
  EXPECT_EQ(add.Json()["name"], "A");
  EXPECT_THAT(Run({"crossing", "list", "campus"}).out, HasSubstr("A"));
  EXPECT_EQ(Run({"crossing", "delete", "campus", "A", "--json"}).Json()["views_deleted"], 0);
  EXPECT_NE(Run({"crossing", "delete", "campus", "A"}).code, 0);
}

TEST_F(CliTest, EnrollSendsFileBytesInCrossingThenHeadingOrder) {
  ScopedTempDir dir;
  MakeViews(dir);
  ASSERT_EQ(Run({"db", "create", "campus"}).code, 0);
  CliResult r =
      Run({"enroll", "campus", (dir.path() / "views").string(), "--store-images", "--json"});
  ASSERT_EQ(r.code, 0) << r.err;
  nlohmann::json json = r.Json();
  EXPECT_EQ(json["views"], 4);
  EXPECT_EQ(json["crossings"], 2);
  EXPECT_EQ(json["crossings_created"], 2);
  EXPECT_EQ(json["keypoints"], 400);

  const auto views = server_.service().views("campus");
  ASSERT_EQ(views.size(), 4u);
  EXPECT_EQ(views[0].crossing, "A");
  EXPECT_EQ(views[0].heading_deg, 0);
  EXPECT_EQ(views[1].heading_deg, 90);
  EXPECT_EQ(views[2].crossing, "B");
  EXPECT_EQ(views[2].heading_deg, 0);
  EXPECT_EQ(views[2].bytes, ReadAll(dir.path() / "views/B/000.png"));  // sent as they are
  EXPECT_TRUE(views[3].store_image);
}

TEST_F(CliTest, EnrollHumanOutputAndErrors) {
  ScopedTempDir dir;
  MakeViews(dir);
  ASSERT_EQ(Run({"db", "create", "campus"}).code, 0);
  CliResult r = Run({"enroll", "campus", (dir.path() / "views").string()});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("4 views of 2 crossings into campus: 4 stored, 0 skipped"));
  EXPECT_EQ(r.err, "");  // no progress bar when stderr is not a terminal

  CliResult missing_db = Run({"enroll", "nowhere", (dir.path() / "views").string()});
  EXPECT_NE(missing_db.code, 0);
  EXPECT_THAT(missing_db.err, HasSubstr("NOT_FOUND"));

  WriteImage(dir.Make("views/C/left.png"), 8, 8, cv::Scalar(1, 2, 3));
  CliResult bad_name = Run({"enroll", "campus", (dir.path() / "views").string()});
  EXPECT_NE(bad_name.code, 0);
  EXPECT_THAT(bad_name.err, HasSubstr("left.png"));
}

TEST_F(CliTest, EnrollAgainSkipsTheStoredViewsAndTheFinalLineCountsEachOutcome) {
  ScopedTempDir dir;
  MakeViews(dir);
  std::ofstream(dir.Make("views/B/180.png"));  // empty: the fake's invalid view
  ASSERT_EQ(Run({"db", "create", "campus"}).code, 0);
  const std::string views = (dir.path() / "views").string();

  CliResult first = Run({"enroll", "campus", views});
  ASSERT_EQ(first.code, 0) << first.err;
  EXPECT_THAT(first.out, HasSubstr("5 views of 2 crossings into campus: 4 stored, 0 skipped as "
                                   "duplicates, 1 skipped as invalid"));
  // The warning names the file, not only crossing and heading.
  EXPECT_THAT(first.err, HasSubstr("skipped " + (dir.path() / "views/B/180.png").string() +
                                   ": the image is empty"));

  CliResult again = Run({"enroll", "campus", views, "--json"});
  ASSERT_EQ(again.code, 0) << again.err;
  const nlohmann::json json = again.Json();
  EXPECT_EQ(json["views"], 0);
  EXPECT_EQ(json["duplicates"], 4);
  EXPECT_EQ(json["invalid"], 1);
  EXPECT_EQ(json["views_sent"], 5);
  EXPECT_EQ(json["complete"], true);
  EXPECT_EQ(server_.service().views("campus").size(), 4u);
  EXPECT_THAT(Run({"enroll", "campus", views}).out,
              HasSubstr("0 stored, 4 skipped as duplicates, 1 skipped as invalid"));
}

TEST_F(CliTest, EnrollReplaceStoresAChangedImageAndFlagsOneFiledTwice) {
  ScopedTempDir dir;
  MakeViews(dir);
  ASSERT_EQ(Run({"db", "create", "campus"}).code, 0);
  const std::string views = (dir.path() / "views").string();
  ASSERT_EQ(Run({"enroll", "campus", views}).code, 0);

  Copy(dir, "views/B/090.png", "views/C/045.png");  // the same image filed twice
  CliResult plain = Run({"enroll", "campus", views});
  ASSERT_EQ(plain.code, 0) << plain.err;
  EXPECT_THAT(plain.out, HasSubstr("0 stored, 5 skipped as duplicates"));
  EXPECT_THAT(plain.err, HasSubstr("skipped " + (dir.path() / "views/C/045.png").string() +
                                   ": the same image is already stored as view"));
  EXPECT_THAT(plain.err, HasSubstr("(B/90); use --replace"));

  WriteImage(dir.path() / "views/A/000.png", 40, 30, cv::Scalar(7, 7, 7));  // re-shot
  CliResult replace = Run({"enroll", "campus", views, "--replace"});
  ASSERT_EQ(replace.code, 0) << replace.err;
  EXPECT_THAT(replace.out, HasSubstr("2 stored (replacing 2 older views), 3 skipped"));
  std::vector<std::string> places;
  for (const auto& view : server_.service().views("campus")) {
    places.push_back(view.crossing + "/" + std::to_string(static_cast<int>(view.heading_deg)));
  }
  std::sort(places.begin(), places.end());
  EXPECT_EQ(places, (std::vector<std::string>{"A/0", "A/90", "B/0", "C/45"}));
}

TEST_F(CliTest, EnrollInterruptedByCtrlCSaysWhatWasStoredAndExitsNonZero) {
  ScopedTempDir dir;
  // More views than the client keeps in flight, so that some are never sent.
  constexpr int kViews = 12;
  for (int k = 0; k < kViews; ++k) {
    WriteImage(dir.Make("views/A/" + std::to_string(100 + 10 * k) + ".png"), 40, 30,
               cv::Scalar(20 * k, 0, 0));
  }
  ASSERT_EQ(Run({"db", "create", "campus"}).code, 0);
  std::atomic<bool> raised{false};
  // SIGINT while the server works on the second view, as a person pressing Ctrl-C.
  server_.service().set_on_enroll([&](int index) {
    if (index == 1 && !raised.exchange(true)) std::raise(SIGINT);
  });
  CliResult r = Run({"enroll", "campus", (dir.path() / "views").string(), "--json"});
  server_.service().set_on_enroll(nullptr);
  EXPECT_EQ(r.code, 130) << r.err;
  EXPECT_THAT(r.err, HasSubstr("interrupted after"));
  EXPECT_THAT(r.err, HasSubstr("running the same command again enrolls the rest"));
  const nlohmann::json json = r.Json();
  EXPECT_EQ(json["complete"], false);
  const int stored = json["views"];
  EXPECT_EQ(stored + json["duplicates"].get<int>() + json["invalid"].get<int>() +
                json["remaining"].get<int>(),
            kViews);
  EXPECT_GE(stored, 2);  // the view in the server's hands when the signal came is finished
  EXPECT_GT(json["remaining"].get<int>(), 0);
  EXPECT_EQ(static_cast<int>(server_.service().views("campus").size()), stored);
}

TEST_F(CliTest, EnrollErrorSaysWhatWasDoneAndExitsNonZero) {
  ScopedTempDir dir;
  MakeViews(dir);
  std::ofstream(dir.Make("views/A/045.png"));  // empty, second in order
  ASSERT_EQ(Run({"db", "create", "campus"}).code, 0);
  CliResult r = Run({"enroll", "campus", (dir.path() / "views").string(), "--strict"});
  EXPECT_EQ(r.code, 1);
  EXPECT_THAT(r.err, HasSubstr("INVALID_ARGUMENT"));
  EXPECT_THAT(r.err, HasSubstr("stopped after 1 of 5 views: 1 stored, 0 skipped as duplicates, "
                               "0 skipped as invalid, 4 not enrolled"));
  EXPECT_EQ(server_.service().views("campus").size(), 1u);
}

TEST_F(CliTest, EnrollRefusesABadLayoutBeforeSendingAnything) {
  ScopedTempDir dir;
  WriteImage(dir.Make("views/a/b/c/000.png"), 40, 30, cv::Scalar(1, 2, 3));
  ASSERT_EQ(Run({"db", "create", "campus"}).code, 0);
  CliResult r = Run({"enroll", "campus", (dir.path() / "views").string()});
  EXPECT_NE(r.code, 0);
  EXPECT_THAT(r.err, HasSubstr("one level too deep?"));
  EXPECT_EQ(server_.service().calls("StreamEnroll"), 0);
}

TEST_F(CliTest, EnrollSendsThePositionFolderAsTheViewsPosition) {
  ScopedTempDir dir;
  WriteImage(dir.Make("views/A/north-kerb/000.png"), 40, 30, cv::Scalar(255, 0, 0));
  WriteImage(dir.Make("views/A/p2/000.png"), 40, 30, cv::Scalar(0, 255, 0));
  WriteImage(dir.Make("views/B/090.png"), 40, 30, cv::Scalar(0, 0, 255));
  ASSERT_EQ(Run({"db", "create", "campus"}).code, 0);
  const std::string views = (dir.path() / "views").string();
  CliResult r = Run({"enroll", "campus", views});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("3 views of 2 crossings into campus: 3 stored"));
  const auto stored = server_.service().views("campus");
  ASSERT_EQ(stored.size(), 3u);
  EXPECT_EQ(stored[0].position, "north-kerb");
  EXPECT_EQ(stored[1].position, "p2");
  EXPECT_EQ(stored[2].position, "");

  // The place of a duplicate names the position it is stored at.
  Copy(dir, "views/A/north-kerb/000.png", "views/C/045.png");
  EXPECT_THAT(Run({"enroll", "campus", views}).err, HasSubstr("(A/north-kerb/0); use --replace"));

  // Recognition names the best view's position, and the candidate table gets a column for it.
  CliResult recognized =
      Run({"recognize", "campus", (dir.path() / "views/A/north-kerb/000.png").string(), "-v"});
  ASSERT_EQ(recognized.code, 0) << recognized.err;
  EXPECT_THAT(recognized.out, HasSubstr("position north-kerb"));
  EXPECT_THAT(recognized.out, HasSubstr("position"));
}

TEST_F(CliTest, EnrollVideoSendsSampledFramesTaggedWithTheirTimes) {
  ScopedTempDir dir;
  std::vector<cv::Mat> frames;
  for (int i = 0; i < 20; ++i) frames.push_back(waymark::testing::BlockFrame(16 * i));
  const std::string video = dir.Make("drive.avi").string();
  waymark::testing::WriteVideo(video, frames, 10);
  ASSERT_EQ(Run({"db", "create", "campus"}).code, 0);

  CliResult r = Run({"enroll", "campus", "--video", video, "--crossing", "main-and-1st",
                     "--every-s", "0.5", "--json"});
  ASSERT_EQ(r.code, 0) << r.err;
  const nlohmann::json json = r.Json();
  EXPECT_EQ(json["views"], 4);
  EXPECT_EQ(json["video"]["sampled"], 4);
  EXPECT_EQ(json["video"]["kept"], 4);
  EXPECT_EQ(json["video"]["ended_early"], false);
  const auto stored = server_.service().views("campus");
  ASSERT_EQ(stored.size(), 4u);
  EXPECT_EQ(stored[0].crossing, "main-and-1st");
  EXPECT_EQ(stored[0].heading_deg, 0);
  EXPECT_EQ(stored[0].position, "t=0s");
  EXPECT_EQ(stored[3].position, "t=1.5s");

  // Again, with a heading: the same frames are duplicates; the summary says how they were sampled.
  CliResult again =
      Run({"enroll", "campus", "--video", video, "--crossing", "main-and-1st", "--heading", "90"});
  ASSERT_EQ(again.code, 0) << again.err;
  EXPECT_THAT(again.out, HasSubstr(video + ": 4 frames sampled every 0.5 s over 2.0 s: 4 kept"));
  EXPECT_THAT(again.out, HasSubstr("0 stored, 4 skipped as duplicates"));
}

TEST_F(CliTest, EnrollVideoThatCannotBeReadEnrollsNothingAndSaysSo) {
  ScopedTempDir dir;
  const std::string garbage = dir.Make("garbage.avi").string();
  std::ofstream(garbage) << std::string(4096, 'x');
  ASSERT_EQ(Run({"db", "create", "campus"}).code, 0);
  CliResult r = Run({"enroll", "campus", "--video", garbage, "--crossing", "A"});
  EXPECT_EQ(r.code, 1);
  EXPECT_THAT(r.err, HasSubstr(garbage));
  EXPECT_THAT(r.err, HasSubstr("nothing was enrolled"));
  EXPECT_EQ(server_.service().calls("StreamEnroll"), 0);

  EXPECT_THAT(Run({"enroll", "campus"}).err,
              HasSubstr("give one of DIR, --manifest FILE or --video FILE"));
  EXPECT_NE(Run({"enroll", "campus", "--video", garbage}).code, 0);  // --crossing missing
  EXPECT_NE(Run({"enroll", "campus", (dir.path()).string(), "--video", garbage, "--crossing", "A"})
                .code,
            0);
  EXPECT_EQ(server_.service().calls("StreamEnroll"), 0);
}

TEST_F(CliTest, HelpListsTheNewFlags) {
  EXPECT_THAT(Run({"enroll", "--help"}).out, HasSubstr("--replace"));
  EXPECT_THAT(Run({"enroll", "--help"}).out, HasSubstr("--every-s"));
  EXPECT_THAT(Run({"enroll", "--help"}).out, HasSubstr("<position>"));
  EXPECT_THAT(Run({"recognize", "--help"}).out, HasSubstr("folders"));
}

TEST_F(CliTest, RecognizeAFolderRecognizesEachImageInItByName) {
  ScopedTempDir dir;
  MakeViews(dir);
  ASSERT_EQ(Run({"db", "create", "campus"}).code, 0);
  ASSERT_EQ(Run({"enroll", "campus", (dir.path() / "views").string()}).code, 0);
  const std::string folder = (dir.path() / "views/B").string();

  CliResult r = Run({"recognize", "campus", folder, "--json"});
  ASSERT_EQ(r.code, 0) << r.err;
  const nlohmann::json results = r.Json()["results"];
  ASSERT_EQ(results.size(), 2u);
  EXPECT_EQ(results[0]["image"], (dir.path() / "views/B/000.png").string());
  EXPECT_EQ(results[1]["image"], (dir.path() / "views/B/090.png").string());
  EXPECT_EQ(results[1]["crossing"], "B");
  EXPECT_DOUBLE_EQ(results[1]["heading_deg"].get<double>(), 90);

  CliResult human = Run({"recognize", "campus", folder});
  ASSERT_EQ(human.code, 0) << human.err;
  EXPECT_THAT(human.out, HasSubstr((dir.path() / "views/B/000.png").string() + ": recognized B"));
  EXPECT_THAT(human.out, HasSubstr((dir.path() / "views/B/090.png").string() + ": recognized B"));

  // A folder of crossing folders has no images of its own: say where they are.
  CliResult nested = Run({"recognize", "campus", (dir.path() / "views").string()});
  EXPECT_NE(nested.code, 0);
  EXPECT_THAT(nested.err, HasSubstr((dir.path() / "views/A").string() + "/"));
  EXPECT_THAT(nested.err, HasSubstr("waymark eval"));
  EXPECT_THAT(nested.err, Not(HasSubstr("no file")));
}

TEST_F(CliTest, RecognizeImagesWithOverrides) {
  ScopedTempDir dir;
  MakeViews(dir);
  ASSERT_EQ(Run({"db", "create", "campus"}).code, 0);
  ASSERT_EQ(Run({"enroll", "campus", (dir.path() / "views").string()}).code, 0);
  WriteImage(dir.Make("elsewhere.png"), 40, 30, cv::Scalar(1, 1, 1));

  CliResult r = Run({"recognize", "campus", (dir.path() / "views/B/090.png").string(),
                     (dir.path() / "elsewhere.png").string(), "--ratio", "0.5", "--json"});
  ASSERT_EQ(r.code, 0) << r.err;
  nlohmann::json results = r.Json()["results"];
  ASSERT_EQ(results.size(), 2u);
  EXPECT_EQ(results[0]["recognized"], true);
  EXPECT_EQ(results[0]["crossing"], "B");
  EXPECT_DOUBLE_EQ(results[0]["heading_deg"].get<double>(), 90);
  EXPECT_EQ(results[1]["recognized"], false);
  EXPECT_TRUE(results[1].contains("latency_ms"));

  const v1::RecognitionParams params = server_.service().last_params();
  EXPECT_DOUBLE_EQ(params.ratio(), 0.5);
  EXPECT_FALSE(params.has_n0());
  EXPECT_FALSE(params.has_mode());

  CliResult verbose =
      Run({"recognize", "campus", (dir.path() / "views/A/090.png").string(), "--verbose"});
  ASSERT_EQ(verbose.code, 0) << verbose.err;
  EXPECT_THAT(verbose.out, HasSubstr("recognized A, heading 90.0 deg"));
  EXPECT_THAT(verbose.out, HasSubstr("similarity"));  // the candidate table
  EXPECT_THAT(verbose.out, HasSubstr("decision"));
}

TEST_F(CliTest, RecognizeReportsABadFileButKeepsTheOthers) {
  ScopedTempDir dir;
  MakeViews(dir);
  ASSERT_EQ(Run({"db", "create", "campus"}).code, 0);
  ASSERT_EQ(Run({"enroll", "campus", (dir.path() / "views").string()}).code, 0);
  CliResult r = Run({"recognize", "campus", (dir.path() / "missing.png").string(),
                     (dir.path() / "views/A/000.png").string()});
  EXPECT_NE(r.code, 0);
  EXPECT_THAT(r.err, HasSubstr("NOT_FOUND"));
  EXPECT_THAT(r.err, HasSubstr("missing.png"));
  EXPECT_THAT(r.out, HasSubstr("recognized A"));
}

TEST_F(CliTest, RecognizeCameraStreamsFrames) {
  ScopedTempDir dir;
  for (int i = 0; i < 5; ++i) {
    WriteImage(dir.Make(cv::format("cam/%03d.png", i)), 64, 48, cv::Scalar(i * 40, 50, 50));
  }
  ASSERT_EQ(Run({"db", "create", "campus"}).code, 0);
  const std::string pattern = (dir.path() / "cam/%03d.png").string();

  CliResult all = Run({"recognize", "campus", "--camera", pattern, "--json"});
  ASSERT_EQ(all.code, 0) << all.err;
  EXPECT_EQ(all.Json()["frames"].size(), 5u);
  EXPECT_EQ(all.Json()["first_recognized_frame"], 0);
  EXPECT_EQ(server_.service().stream_frame_sizes().front(), std::make_pair(320, 240));

  CliResult limited = Run({"recognize", "campus", "--camera", pattern, "--max-frames", "2"});
  ASSERT_EQ(limited.code, 0) << limited.err;
  EXPECT_THAT(limited.out, HasSubstr("frame 0: recognized A"));
  EXPECT_THAT(limited.out, HasSubstr("frame 1:"));
  EXPECT_THAT(limited.out, Not(HasSubstr("frame 2:")));

  server_.service().set_stream_recognize_from(3);
  CliResult until =
      Run({"recognize", "campus", "--camera", pattern, "--until-recognized", "--json"});
  ASSERT_EQ(until.code, 0) << until.err;
  EXPECT_EQ(until.Json()["frames"].size(), 4u);
  EXPECT_EQ(until.Json()["first_recognized_frame"], 3);
  EXPECT_EQ(until.Json()["end"], "recognized");

  CliResult no_camera = Run({"recognize", "campus", "--camera", (dir.path() / "x.mp4").string()});
  EXPECT_NE(no_camera.code, 0);
  EXPECT_THAT(no_camera.err, HasSubstr("x.mp4"));
}

TEST_F(CliTest, EvalComputesTheProtocolsMetrics) {
  ScopedTempDir dir;
  MakeViews(dir);
  ASSERT_EQ(Run({"db", "create", "campus"}).code, 0);
  ASSERT_EQ(Run({"enroll", "campus", (dir.path() / "views").string()}).code, 0);
  // The fake recognizes a query iff it is byte-identical to a view.
  Copy(dir, "views/A/090.png", "queries/A/090.png");  // correct, heading error 0
  Copy(dir, "views/B/000.png", "queries/A/odd.png");  // wrong crossing
  Copy(dir, "views/B/090.png", "queries/B/080.png");  // correct, heading error 10
  WriteImage(dir.Make("queries/unknown/park.png"), 40, 30, cv::Scalar(7, 7, 7));  // rejected
  Copy(dir, "views/A/000.png", "queries/unknown/fake.png");                       // false accept
  const std::string csv = (dir.path() / "per_query.csv").string();

  CliResult r = Run({"eval", "campus", (dir.path() / "queries").string(), "--per-query", csv,
                     "--n0", "4", "--json"});
  ASSERT_EQ(r.code, 0) << r.err;
  nlohmann::json json = r.Json();
  EXPECT_EQ(json["queries"], 5);
  EXPECT_EQ(json["known_queries"], 3);
  EXPECT_EQ(json["unknown_queries"], 2);
  EXPECT_NEAR(json["top1_accuracy"].get<double>(), 2.0 / 3.0, 1e-12);
  EXPECT_DOUBLE_EQ(json["false_accept_rate"].get<double>(), 0.5);
  EXPECT_DOUBLE_EQ(json["heading_error_deg_median"].get<double>(), 5);
  EXPECT_TRUE(json["latency_ms_p50"].is_number());
  EXPECT_TRUE(json["latency_ms_p99"].is_number());
  EXPECT_EQ(json["confusion"]["A"]["B"], 1);
  EXPECT_EQ(json["confusion"]["unknown"]["(not recognized)"], 1);
  EXPECT_EQ(json["recall"]["per_crossing"]["B"]["correct"], 1);
  EXPECT_EQ(server_.service().last_params().n0(), 4);

  std::istringstream rows(ReadAll(csv));
  int lines = 0;
  for (std::string line; std::getline(rows, line);) ++lines;
  EXPECT_EQ(lines, 1 + 5);

  CliResult human = Run({"eval", "campus", (dir.path() / "queries").string()});
  ASSERT_EQ(human.code, 0) << human.err;
  EXPECT_THAT(human.out, HasSubstr("top-1 accuracy       66.7% (2/3)"));
  EXPECT_THAT(human.out, HasSubstr("A (2): A 1, B 1"));
}

TEST_F(CliTest, EvalWithoutUnknownFolderHasNullFalseAcceptRate) {
  ScopedTempDir dir;
  MakeViews(dir);
  ASSERT_EQ(Run({"db", "create", "campus"}).code, 0);
  ASSERT_EQ(Run({"enroll", "campus", (dir.path() / "views").string()}).code, 0);
  Copy(dir, "views/A/090.png", "queries/A/q.png");
  CliResult r = Run({"--json", "eval", "campus", (dir.path() / "queries").string()});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_TRUE(r.Json()["false_accept_rate"].is_null());
  EXPECT_TRUE(r.Json()["heading_error_deg_median"].is_null());  // stem "q" is no heading
  EXPECT_DOUBLE_EQ(r.Json()["top1_accuracy"].get<double>(), 1.0);

  CliResult missing_db = Run({"eval", "nowhere", (dir.path() / "queries").string()});
  EXPECT_NE(missing_db.code, 0);
  EXPECT_THAT(missing_db.err, HasSubstr("NOT_FOUND"));
}

// Issue 34's tour: one unknown-place query without SIFT keypoints made eval say the database
// "has no vocabulary ... or keeps no global stage" when it had both. The warning names the cause
// each answer gives (RecognizeResponse.global_stage_skipped).
TEST_F(CliTest, EvalNamesWhyQueriesRanWithoutTheGlobalStage) {
  ScopedTempDir dir;
  MakeViews(dir);
  ASSERT_EQ(Run({"db", "create", "campus"}).code, 0);
  ASSERT_EQ(Run({"enroll", "campus", (dir.path() / "views").string()}).code, 0);
  Copy(dir, "views/A/090.png", "queries/A/090.png");
  WriteImage(dir.Make("queries/unknown/sunset-162.png"), 40, 30, cv::Scalar(7, 7, 7));
  const std::string blank = ReadAll(dir.path() / "queries/unknown/sunset-162.png");
  const std::string queries = (dir.path() / "queries").string();
  // Retrieval answers from a database with its vocabulary: the blank query had no keypoints.
  std::string database_cause;  // every answer's cause when set
  server_.service().set_on_recognize(
      [&](const v1::RecognizeRequest& request, v1::RecognizeResponse* answer) {
        answer->set_mode(v1::RECOGNITION_MODE_RETRIEVAL);
        std::string skipped = database_cause;
        if (skipped.empty() && request.image().data() == blank) skipped = "no_keypoints";
        answer->set_global_stage(skipped.empty());
        answer->set_global_stage_skipped(skipped);
      });

  CliResult r = Run({"eval", "campus", queries});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_THAT(r.err, HasSubstr("warning: 1 of 2 retrieval-mode queries ran without the global "
                               "stage: 1 because the query had no SIFT keypoints"));
  EXPECT_THAT(r.err, Not(HasSubstr("vocabulary")));
  EXPECT_THAT(r.err, Not(HasSubstr("keeps no global stage")));
  r = Run({"--json", "eval", "campus", queries});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(r.Json()["without_global_stage"]["queries"], 1);
  EXPECT_EQ(r.Json()["without_global_stage"]["causes"]["no_keypoints"], 1);

  database_cause = "off";
  r = Run({"eval", "campus", queries});
  EXPECT_THAT(r.err, HasSubstr("warning: 2 of 2 retrieval-mode queries ran without the global "
                               "stage: 2 because the database keeps no global stage"));
  EXPECT_THAT(r.err, Not(HasSubstr("keypoints")));
  database_cause = "no_vocabulary";
  r = Run({"eval", "campus", queries});
  EXPECT_THAT(r.err, HasSubstr("2 because the database had no vocabulary yet"));
}

// Issue 15: an unknown command said only "A subcommand is required".
TEST_F(CliTest, AnUnknownCommandIsNamedAndTheCommandsListed) {
  CliResult r = Run({"frobnicate"});
  EXPECT_NE(r.code, 0);
  EXPECT_THAT(r.err, HasSubstr("error: unknown command 'frobnicate'\n"));
  EXPECT_THAT(r.err, HasSubstr("\n  db "));
  EXPECT_THAT(r.err, HasSubstr("\n  slam "));
  EXPECT_THAT(r.err, HasSubstr("\n  vo "));
  EXPECT_THAT(r.err, Not(HasSubstr("A subcommand is required")));

  CliResult in_group = Run({"slam", "frob"});
  EXPECT_NE(in_group.code, 0);
  EXPECT_THAT(in_group.err, HasSubstr("error: unknown command 'frob' for 'waymark slam'\n"));
  EXPECT_THAT(in_group.err, HasSubstr("commands of 'waymark slam':\n"));
  EXPECT_THAT(in_group.err, HasSubstr("\n  replay "));
  EXPECT_THAT(in_group.err, Not(HasSubstr("\n  db ")));

  CliResult none = Run({"slam"});
  EXPECT_NE(none.code, 0);
  EXPECT_THAT(none.err, HasSubstr("error: 'waymark slam' needs a command\n"));
  EXPECT_THAT(none.err, HasSubstr("\n  replay "));
}

TEST_F(CliTest, ArgumentErrorsOfAKnownCommandAreStillCli11s) {
  CliResult r = Run({"db", "create"});  // the name is missing
  EXPECT_NE(r.code, 0);
  EXPECT_THAT(r.err, Not(HasSubstr("unknown command")));
  EXPECT_THAT(r.err, HasSubstr("NAME is required"));
}

// Issue 15: `--server 127.0.0.1` dialled port 0, and an unreachable server printed gRPC's text.
TEST_F(CliTest, AServerWithoutAPortIsDialledOnTheDefaultPort) {
  // Nothing listens on 127.0.0.254 (a loopback address no test binds): the error names the
  // address dialled, with the default port.
  CliResult r = Run({"--timeout", "60", "db", "list"}, "127.0.0.254");
  EXPECT_NE(r.code, 0);
  EXPECT_THAT(r.err, HasSubstr("UNAVAILABLE"));
  EXPECT_THAT(r.err, HasSubstr("is the server running at 127.0.0.254:50051?")) << r.err;
}

TEST_F(CliTest, AServerAddressThatCannotBeDialledIsRefusedBeforeDialling) {
  CliResult r = Run({"db", "list"}, "127.0.0.1:0");
  EXPECT_NE(r.code, 0);
  EXPECT_THAT(r.err, HasSubstr("INVALID_ARGUMENT: server address '127.0.0.1:0': port '0'"));
}

}  // namespace
}  // namespace waymark::cli
