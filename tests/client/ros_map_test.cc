// ROS map_server map files (datasets/ros_map.h, pgm_image.h, ros_map_yaml.h): grids written and
// read back, files written by hand the way map_server users write them, every bad-file error, and
// the occupancy.png picture (render/occupancy_picture.h).
#include "client/datasets/ros_map.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <fstream>
#include <opencv2/core.hpp>

#include "absl/strings/match.h"
#include "absl/strings/str_split.h"
#include "client/datasets/pgm_image.h"
#include "client/datasets/ros_map_yaml.h"
#include "client/render/occupancy_picture.h"
#include "tests/client/test_util.h"

namespace waymark::cli {
namespace {

using ::testing::HasSubstr;
using waymark::testing::ReadAll;
using waymark::testing::ScopedTempDir;

// A width x height grid whose cell (x, y) is cell(x, y).
template <typename CellFn>
v1::OccupancyGrid MakeGrid(int width, int height, double resolution, double origin_x,
                           double origin_y, CellFn cell) {
  v1::OccupancyGrid grid;
  grid.set_width(width);
  grid.set_height(height);
  grid.set_resolution(resolution);
  grid.mutable_origin()->set_x(origin_x);
  grid.mutable_origin()->set_y(origin_y);
  std::string cells;
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) cells.push_back(static_cast<char>(cell(x, y)));
  }
  grid.set_cells(cells);
  return grid;
}

int8_t CellAt(const v1::OccupancyGrid& grid, int x, int y) {
  return static_cast<int8_t>(grid.cells()[static_cast<size_t>(y) * grid.width() + x]);
}

// -1, 0 and 100 in a pattern that differs between rows and columns (a flip or a transpose shows).
int8_t Trinary(int x, int y) {
  const int k = (3 * x + 7 * y + x * y) % 3;
  return k == 0 ? -1 : k == 1 ? 0 : 100;
}

void ExpectSameGrid(const v1::OccupancyGrid& actual, const v1::OccupancyGrid& expected) {
  EXPECT_EQ(actual.width(), expected.width());
  EXPECT_EQ(actual.height(), expected.height());
  EXPECT_DOUBLE_EQ(actual.resolution(), expected.resolution());
  EXPECT_DOUBLE_EQ(actual.origin().x(), expected.origin().x());
  EXPECT_DOUBLE_EQ(actual.origin().y(), expected.origin().y());
  EXPECT_DOUBLE_EQ(actual.origin().theta(), 0);
  EXPECT_EQ(actual.cells(), expected.cells());
}

void WriteText(const std::filesystem::path& path, const std::string& text) {
  std::ofstream(path, std::ios::binary) << text;
}

// map_server's YAML with the given image line and extra lines, the rest as map_saver writes it.
std::string Yaml(const std::string& image, const std::string& negate = "0",
                 const std::string& extra = "") {
  return "image: " + image + "\nresolution: 0.1\norigin: [-1.0, 2.0, 0.0]\nnegate: " + negate +
         "\noccupied_thresh: 0.65\nfree_thresh: 0.196\n" + extra;
}

// ---- Write then read ---------------------------------------------------------------------------

TEST(RosMapTest, WrittenGridsReadBackUnchangedAtAnySize) {
  ScopedTempDir dir;
  const std::pair<int, int> sizes[] = {{1, 1}, {5, 3}, {3, 7}, {64, 1}, {1, 9}, {37, 23}};
  for (auto [width, height] : sizes) {
    SCOPED_TRACE(::testing::Message() << width << " x " << height);
    const v1::OccupancyGrid grid = MakeGrid(width, height, 0.05, -12.35, 4.2, Trinary);
    const auto folder = dir.path() / (std::to_string(width) + "x" + std::to_string(height));
    auto files = WriteRosMap(grid, folder);
    ASSERT_TRUE(files.ok()) << files.status();
    EXPECT_EQ(*files,
              (std::vector<std::filesystem::path>{folder / "map.pgm", folder / "map.yaml"}));
    auto read = ReadRosMap(folder / "map.yaml");
    ASSERT_TRUE(read.ok()) << read.status();
    ExpectSameGrid(*read, grid);
  }
}

TEST(RosMapTest, TheTopRowOfTheGridIsTheFirstRowOfThePgm) {
  ScopedTempDir dir;
  // 3 x 2: one occupied cell at the top left (x 0, y 1: the highest y), one free at the bottom
  // right (x 2, y 0), the rest unknown.
  const v1::OccupancyGrid grid = MakeGrid(3, 2, 0.05, 0, 0, [](int x, int y) -> int8_t {
    if (x == 0 && y == 1) return 100;
    if (x == 2 && y == 0) return 0;
    return -1;
  });
  ASSERT_TRUE(WriteRosMap(grid, dir.path()).ok());
  const std::string bytes = ReadAll(dir.path() / "map.pgm");
  EXPECT_EQ(bytes.substr(0, 3), "P5\n");
  auto image = ParsePgm(bytes, "map.pgm");
  ASSERT_TRUE(image.ok()) << image.status();
  ASSERT_EQ(image->width, 3);
  ASSERT_EQ(image->height, 2);
  EXPECT_EQ(image->pixels, (std::vector<uint8_t>{0, 205, 205,  // PGM row 0 = grid row 1
                                                 205, 205, 254}));
}

TEST(RosMapTest, TheYamlIsTheOneMapSaverWrites) {
  ScopedTempDir dir;
  ASSERT_TRUE(WriteRosMap(MakeGrid(2, 2, 0.05, -1.5, 2.25, Trinary), dir.path()).ok());
  const std::string yaml = ReadAll(dir.path() / "map.yaml");
  EXPECT_THAT(yaml, HasSubstr("image: map.pgm\n"));
  EXPECT_THAT(yaml, HasSubstr("resolution: 0.05\n"));
  EXPECT_THAT(yaml, HasSubstr("origin: [-1.5, 2.25, 0.0]\n"));
  EXPECT_THAT(yaml, HasSubstr("negate: 0\n"));
  EXPECT_THAT(yaml, HasSubstr("occupied_thresh: 0.65\n"));
  EXPECT_THAT(yaml, HasSubstr("free_thresh: 0.196\n"));
  EXPECT_THAT(yaml, HasSubstr("mode: trinary\n"));
}

TEST(RosMapTest, CellsAreWrittenInMapSaversTrinaryShadesAndQuantisedOnReading) {
  EXPECT_EQ(PixelOfCell(100), 0);
  EXPECT_EQ(PixelOfCell(65), 0);
  EXPECT_EQ(PixelOfCell(64), 205);
  EXPECT_EQ(PixelOfCell(20), 205);
  EXPECT_EQ(PixelOfCell(19), 254);
  EXPECT_EQ(PixelOfCell(0), 254);
  EXPECT_EQ(PixelOfCell(-1), 205);
  EXPECT_EQ(PixelOfCell(-7), 205);

  ScopedTempDir dir;
  const int8_t values[] = {0, 19, 20, 40, 64, 65, 100, -1};
  const v1::OccupancyGrid grid = MakeGrid(8, 1, 0.05, 0, 0, [&](int x, int) { return values[x]; });
  ASSERT_TRUE(WriteRosMap(grid, dir.path()).ok());
  auto read = ReadRosMap(dir.path() / "map.yaml");
  ASSERT_TRUE(read.ok()) << read.status();
  const int8_t expected[] = {0, 0, -1, -1, -1, 100, 100, -1};
  for (int x = 0; x < 8; ++x)
    EXPECT_EQ(CellAt(*read, x, 0), expected[x]) << "cell " << int{values[x]};
}

TEST(RosMapTest, GridsThatDoNotAddUpAreNotWritten) {
  ScopedTempDir dir;
  v1::OccupancyGrid short_cells = MakeGrid(4, 4, 0.05, 0, 0, Trinary);
  short_cells.mutable_cells()->resize(15);
  auto written = WriteRosMap(short_cells, dir.path());
  EXPECT_EQ(written.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(std::string(written.status().message()), HasSubstr("15 cells, not 4 x 4 = 16"));
  EXPECT_THAT(std::string(WriteRosMap(v1::OccupancyGrid(), dir.path()).status().message()),
              HasSubstr("no cells"));
  v1::OccupancyGrid flat = MakeGrid(2, 2, 0, 0, 0, Trinary);
  EXPECT_THAT(std::string(WriteRosMap(flat, dir.path()).status().message()),
              HasSubstr("resolution 0 m is not positive"));
  EXPECT_FALSE(std::filesystem::exists(dir.path() / "map.pgm"));
}

// ---- Files written by hand ---------------------------------------------------------------------

// Top row 0 254 205, bottom row 255 100 10 (PGM order).
constexpr char kPlainPgm[] =
    "P2\n"
    "# a map written by hand\n"
    "3 2\n"
    "# maxval next\n"
    "255\n"
    "0 254 205\n"
    "255 100 10\n";

TEST(RosMapTest, ReadsAPlainPgmWithComments) {
  ScopedTempDir dir;
  WriteText(dir.path() / "hand.pgm", kPlainPgm);
  WriteText(dir.path() / "hand.yaml",
            "# map_server map\nimage: hand.pgm   # next to this file\nresolution: 0.1\n"
            "origin: [-1.0, 2.0, 0.0]\nnegate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.196\n");
  auto grid = ReadRosMap(dir.path() / "hand.yaml");
  ASSERT_TRUE(grid.ok()) << grid.status();
  EXPECT_EQ(grid->width(), 3u);
  EXPECT_EQ(grid->height(), 2u);
  EXPECT_DOUBLE_EQ(grid->resolution(), 0.1);
  EXPECT_DOUBLE_EQ(grid->origin().x(), -1.0);
  EXPECT_DOUBLE_EQ(grid->origin().y(), 2.0);
  // Grid row 1 (top) = PGM row 0: 0 black -> 100, 254 white -> 0, 205 grey -> -1.
  EXPECT_EQ(CellAt(*grid, 0, 1), 100);
  EXPECT_EQ(CellAt(*grid, 1, 1), 0);
  EXPECT_EQ(CellAt(*grid, 2, 1), -1);
  // Grid row 0 = PGM row 1: 255 -> p 0 free, 100 -> p 0.61 unknown, 10 -> p 0.96 occupied.
  EXPECT_EQ(CellAt(*grid, 0, 0), 0);
  EXPECT_EQ(CellAt(*grid, 1, 0), -1);
  EXPECT_EQ(CellAt(*grid, 2, 0), 100);
}

TEST(RosMapTest, ReadsABinaryPgmWithACommentInASubfolderAndQuotedName) {
  ScopedTempDir dir;
  const std::string raster = {static_cast<char>(0), static_cast<char>(254), static_cast<char>(205),
                              static_cast<char>(255)};
  WriteText(dir.Make("images/room.pgm"),
            "P5\n# CREATOR: map_saver.cpp 0.100 m/pix\n2 2\n255\n" + raster);
  WriteText(dir.path() / "room.yaml", Yaml("\"images/room.pgm\""));
  auto grid = ReadRosMap(dir.path() / "room.yaml");
  ASSERT_TRUE(grid.ok()) << grid.status();
  EXPECT_EQ(CellAt(*grid, 0, 1), 100);
  EXPECT_EQ(CellAt(*grid, 1, 1), 0);
  EXPECT_EQ(CellAt(*grid, 0, 0), -1);
  EXPECT_EQ(CellAt(*grid, 1, 0), 0);
}

TEST(RosMapTest, AnAbsoluteImagePathIsTakenAsItIs) {
  ScopedTempDir dir;
  WriteText(dir.Make("elsewhere/hand.pgm"), kPlainPgm);
  WriteText(dir.Make("maps/hand.yaml"), Yaml((dir.path() / "elsewhere" / "hand.pgm").string()));
  auto grid = ReadRosMap(dir.path() / "maps" / "hand.yaml");
  ASSERT_TRUE(grid.ok()) << grid.status();
  EXPECT_EQ(grid->width(), 3u);
}

TEST(RosMapTest, NegateMakesWhiteOccupied) {
  ScopedTempDir dir;
  WriteText(dir.path() / "hand.pgm", kPlainPgm);
  WriteText(dir.path() / "hand.yaml", Yaml("hand.pgm", "1"));
  auto grid = ReadRosMap(dir.path() / "hand.yaml");
  ASSERT_TRUE(grid.ok()) << grid.status();
  // p = pixel / 255: 0 free, 254 and 205 occupied; 255 occupied, 100 unknown, 10 free.
  EXPECT_EQ(CellAt(*grid, 0, 1), 0);
  EXPECT_EQ(CellAt(*grid, 1, 1), 100);
  EXPECT_EQ(CellAt(*grid, 2, 1), 100);
  EXPECT_EQ(CellAt(*grid, 0, 0), 100);
  EXPECT_EQ(CellAt(*grid, 1, 0), -1);
  EXPECT_EQ(CellAt(*grid, 2, 0), 0);
}

TEST(RosMapTest, ScaleAndRawModes) {
  ScopedTempDir dir;
  WriteText(dir.path() / "hand.pgm", kPlainPgm);
  WriteText(dir.path() / "scale.yaml", Yaml("hand.pgm", "0", "mode: scale\n"));
  auto scale = ReadRosMap(dir.path() / "scale.yaml");
  ASSERT_TRUE(scale.ok()) << scale.status();
  // 100 -> p = 155/255 = 0.608, between the thresholds: (0.608 - 0.196) / (0.65 - 0.196) = 0.907.
  EXPECT_EQ(CellAt(*scale, 1, 0), 91);
  EXPECT_EQ(CellAt(*scale, 0, 1), 100);
  EXPECT_EQ(CellAt(*scale, 1, 1), 0);

  WriteText(dir.path() / "raw.yaml", Yaml("hand.pgm", "0", "mode: raw\n"));
  auto raw = ReadRosMap(dir.path() / "raw.yaml");
  ASSERT_TRUE(raw.ok()) << raw.status();
  EXPECT_EQ(CellAt(*raw, 0, 1), 0);    // pixel 0
  EXPECT_EQ(CellAt(*raw, 1, 1), -1);   // 254: above 100
  EXPECT_EQ(CellAt(*raw, 0, 0), -1);   // 255
  EXPECT_EQ(CellAt(*raw, 1, 0), 100);  // 100
  EXPECT_EQ(CellAt(*raw, 2, 0), 10);   // 10
}

TEST(RosMapYamlTest, ParsesWhatMapServerReadsAndFormatsItBack) {
  auto metadata = ParseRosMapYaml(
      "---\nimage: 'a#b.pgm'\nresolution: 5e-2 # m\norigin: [ -3 , 4.5,0 ]\nnegate: true\n"
      "occupied_thresh: 0.7\nfree_thresh: 0.2\nmode: trinary # the default\n"
      "unknown_key: ignored\r\n",
      "m.yaml");
  ASSERT_TRUE(metadata.ok()) << metadata.status();
  EXPECT_EQ(metadata->image, "a#b.pgm");
  EXPECT_DOUBLE_EQ(metadata->resolution, 0.05);
  EXPECT_DOUBLE_EQ(metadata->origin_x, -3);
  EXPECT_DOUBLE_EQ(metadata->origin_y, 4.5);
  EXPECT_TRUE(metadata->negate);
  EXPECT_DOUBLE_EQ(metadata->occupied_thresh, 0.7);
  EXPECT_DOUBLE_EQ(metadata->free_thresh, 0.2);
  auto again = ParseRosMapYaml(FormatRosMapYaml(*metadata), "again.yaml");
  ASSERT_TRUE(again.ok()) << again.status();
  EXPECT_EQ(again->image, metadata->image);
  EXPECT_DOUBLE_EQ(again->origin_y, 4.5);
  EXPECT_TRUE(again->negate);
  EXPECT_EQ(again->mode, RosMapMode::kTrinary);

  // An apostrophe inside a plain value opens no quote: the comment after it is still one.
  auto apostrophe = ParseRosMapYaml(Yaml("bob's map.pgm   # the picture"), "b.yaml");
  ASSERT_TRUE(apostrophe.ok()) << apostrophe.status();
  EXPECT_EQ(apostrophe->image, "bob's map.pgm");
}

// ---- Bad files ---------------------------------------------------------------------------------

// The error of reading `yaml` (next to a good hand.pgm) as map.yaml.
std::string YamlError(const std::string& yaml) {
  ScopedTempDir dir;
  WriteText(dir.path() / "hand.pgm", kPlainPgm);
  WriteText(dir.path() / "map.yaml", yaml);
  auto grid = ReadRosMap(dir.path() / "map.yaml");
  EXPECT_FALSE(grid.ok());
  EXPECT_EQ(grid.status().code(), absl::StatusCode::kInvalidArgument) << grid.status();
  EXPECT_THAT(std::string(grid.status().message()), HasSubstr("map.yaml: ")) << "names the file";
  return std::string(grid.status().message());
}

TEST(RosMapYamlTest, EachBadYamlSaysWhatIsWrongWhere) {
  const std::string good = Yaml("hand.pgm");
  for (const std::string key :
       {"image", "resolution", "origin", "negate", "occupied_thresh", "free_thresh"}) {
    std::string without;
    for (absl::string_view line : absl::StrSplit(good, '\n', absl::SkipEmpty())) {
      if (!absl::StartsWith(line, key + ":")) without += std::string(line) + "\n";
    }
    EXPECT_THAT(YamlError(without), HasSubstr("missing key '" + key + "'"));
  }
  EXPECT_THAT(YamlError("image: hand.pgm\nresolution: fine\n"),
              HasSubstr("line 2: 'resolution': bad number, got 'fine'"));
  EXPECT_THAT(YamlError(Yaml("hand.pgm") + "resolution: 0.2\n"),
              HasSubstr("line 7: duplicate key 'resolution' (first on line 2)"));
  for (const std::string resolution : {"0", "-0.05"}) {
    std::string yaml = good;
    yaml.replace(yaml.find("0.1"), 3, resolution);
    EXPECT_THAT(YamlError(yaml), HasSubstr("'resolution': must be positive"));
  }
  std::string two_numbers = good;
  two_numbers.replace(two_numbers.find("[-1.0, 2.0, 0.0]"), 16, "[-1.0, 2.0]");
  EXPECT_THAT(YamlError(two_numbers), HasSubstr("'origin': expected [x, y, yaw]"));
  EXPECT_THAT(YamlError(Yaml("hand.pgm", "maybe")), HasSubstr("'negate': expected 0 or 1"));
  EXPECT_THAT(YamlError(Yaml("hand.pgm", "0", "mode: fancy\n")),
              HasSubstr("'mode': expected trinary, scale or raw, got 'fancy'"));
  std::string crossed = good;
  crossed.replace(crossed.find("free_thresh: 0.196"), 18, "free_thresh: 0.7");
  EXPECT_THAT(YamlError(crossed), HasSubstr("free_thresh 0.7 must be below occupied_thresh 0.65"));
  std::string above_one = good;
  above_one.replace(above_one.find("occupied_thresh: 0.65"), 21, "occupied_thresh: 65");
  EXPECT_THAT(YamlError(above_one), HasSubstr("'occupied_thresh': expected a number in [0, 1]"));
  EXPECT_THAT(YamlError("this is not yaml\n"), HasSubstr("line 1: expected 'key: value'"));
  std::string turned = good;
  turned.replace(turned.find("[-1.0, 2.0, 0.0]"), 16, "[-1.0, 2.0, 0.5]");
  EXPECT_THAT(YamlError(turned), HasSubstr("origin yaw 0.5 is not supported"));
}

TEST(RosMapTest, MissingFilesAreNamed) {
  ScopedTempDir dir;
  auto no_yaml = ReadRosMap(dir.path() / "none.yaml");
  EXPECT_EQ(no_yaml.status().code(), absl::StatusCode::kNotFound);
  EXPECT_THAT(std::string(no_yaml.status().message()), HasSubstr("none.yaml"));
  WriteText(dir.path() / "map.yaml", Yaml("gone.pgm"));
  auto no_image = ReadRosMap(dir.path() / "map.yaml");
  EXPECT_EQ(no_image.status().code(), absl::StatusCode::kNotFound);
  EXPECT_THAT(std::string(no_image.status().message()), HasSubstr("gone.pgm"));
  EXPECT_THAT(std::string(no_image.status().message()), HasSubstr("(the image of "));
}

// The error of parsing `bytes` as the PGM "m.pgm".
std::string PgmError(const std::string& bytes) {
  auto image = ParsePgm(bytes, "m.pgm");
  EXPECT_FALSE(image.ok());
  EXPECT_EQ(image.status().code(), absl::StatusCode::kInvalidArgument) << image.status();
  EXPECT_THAT(std::string(image.status().message()), HasSubstr("m.pgm: ")) << "names the file";
  return std::string(image.status().message());
}

TEST(PgmImageTest, EachBadImageSaysWhatIsWrong) {
  EXPECT_THAT(PgmError("P6\n2 2\n255\n"), HasSubstr("not a PGM image: it starts with 'P6'"));
  EXPECT_THAT(PgmError("\x89PNG\r\n"), HasSubstr("it starts with '\\x89P'"));
  EXPECT_THAT(PgmError(""), HasSubstr("not a PGM image"));
  EXPECT_THAT(PgmError("P5\n4 4\n255\n" + std::string(10, '\0')),
              HasSubstr("truncated pixel data: 10 of 16 bytes (4 x 4)"));
  EXPECT_THAT(PgmError("P5\n4 4\n255"), HasSubstr("truncated pixel data: 0 of 16 bytes"));
  EXPECT_THAT(PgmError("P2\n2 2\n255\n1 2 3\n"),
              HasSubstr("truncated pixel data: 3 of 4 pixel values"));
  EXPECT_THAT(
      PgmError("P5\n4 4\n255\n" + std::string(20, '\0')),
      HasSubstr("image size mismatch: the header says 4 x 4 (16 pixels) but more bytes (20)"));
  EXPECT_THAT(PgmError("P2\n2 1\n255\n1 2 3\n"), HasSubstr("image size mismatch"));
  EXPECT_THAT(PgmError("P5\n4 x\n255\n"), HasSubstr("bad height 'x' in the header"));
  EXPECT_THAT(PgmError("P5\n4"), HasSubstr("truncated header: the file ends before the height"));
  EXPECT_THAT(PgmError("P5\n4 4\n65535\n"), HasSubstr("maxval 65535"));
  EXPECT_THAT(PgmError("P5\n0 4\n255\n"), HasSubstr("no pixels (width 0"));
  EXPECT_THAT(PgmError("P2\n2 1\n255\n1 abc\n"), HasSubstr("bad pixel value 'abc' (pixel 1)"));
  EXPECT_THAT(PgmError("P2\n2 1\n255\n1 300\n"), HasSubstr("pixel value 300 above maxval 255"));
}

TEST(PgmImageTest, EncodedImagesParseBack) {
  GrayImage image;
  image.width = 3;
  image.height = 2;
  image.pixels = {0, 10, 35, 32, 255, 205};  // 10 and 32: newline and space bytes in the raster
  auto parsed = ParsePgm(EncodePgm(image, "a comment"), "m.pgm");
  ASSERT_TRUE(parsed.ok()) << parsed.status();
  EXPECT_EQ(parsed->pixels, image.pixels);
  EXPECT_EQ(parsed->width, 3);
}

// ---- The picture -------------------------------------------------------------------------------

TEST(OccupancyPictureTest, SameOrientationAsThePgmWithTheTrajectoryOnIt) {
  // 10 x 5 cells of 0.1 m from (-1, -0.5): free, with the top-left cell occupied and the
  // bottom-right one unknown.
  const v1::OccupancyGrid grid = MakeGrid(10, 5, 0.1, -1, -0.5, [](int x, int y) -> int8_t {
    if (x == 0 && y == 4) return 100;
    if (x == 9 && y == 0) return -1;
    return 0;
  });
  auto plain = OccupancyPicture(grid, {}, {/*min_size_px=*/0});
  ASSERT_TRUE(plain.ok()) << plain.status();
  ASSERT_EQ(plain->cols, 10);
  ASSERT_EQ(plain->rows, 5);
  EXPECT_EQ(plain->at<cv::Vec3b>(0, 0), cv::Vec3b(0, 0, 0));        // occupied: black
  EXPECT_EQ(plain->at<cv::Vec3b>(4, 9), cv::Vec3b(205, 205, 205));  // unknown: grey
  EXPECT_EQ(plain->at<cv::Vec3b>(2, 5), cv::Vec3b(254, 254, 254));  // free: white

  // Scaled up to at least 512 pixels: 52 per cell.
  EXPECT_EQ(OccupancyPictureScale(grid, {}), 52);
  ScenePolyline path;
  path.color = {30, 150, 60};
  path.width_px = 3;
  path.points = {{-0.9, -0.25}, {-0.1, -0.25}};  // through the middle of grid row 2
  auto drawn = OccupancyPicture(grid, {path});
  ASSERT_TRUE(drawn.ok()) << drawn.status();
  ASSERT_EQ(drawn->cols, 520);
  ASSERT_EQ(drawn->rows, 260);
  // The grid spans x -1..0 and y -0.5..0 at 520 pixels per metre: y -0.25 is pixel row 130, x -0.5
  // column 260.
  const cv::Vec3b on_path = drawn->at<cv::Vec3b>(130, 260);
  EXPECT_GT(on_path[1], on_path[0] + 50) << "green, BGR " << on_path;
  EXPECT_EQ(drawn->at<cv::Vec3b>(30, 260), cv::Vec3b(254, 254, 254));  // off the path: free
  EXPECT_EQ(drawn->at<cv::Vec3b>(10, 10), cv::Vec3b(0, 0, 0));
}

}  // namespace
}  // namespace waymark::cli
