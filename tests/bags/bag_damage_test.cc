// Damaged input: truncated copies of real bags give what they hold plus a warning; files that
// are not bags, lying length fields, unknown compressions and bad CRCs get precise errors or
// warnings, never a crash or an allocation of what a header claims.
#include <gtest/gtest.h>

#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>

#include "client/bags/bag_reader.h"
#include "tests/bags/bag_test_util.h"

namespace waymark::bags {
namespace {

std::filesystem::path BagsDir() { return std::filesystem::path(WAYMARK_SHARED_DIR) / "data" / "bags"; }

std::string Slurp(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

std::string Write(const TempDir& dir, const std::string& name, const std::string& bytes) {
  const std::string path = dir.path() + "/" + name;
  std::ofstream(path, std::ios::binary) << bytes;
  return path;
}

bool AnyWarningHas(const BagReader& reader, const std::string& text) {
  for (const std::string& warning : reader.warnings()) {
    if (warning.find(text) != std::string::npos) return true;
  }
  return false;
}

class TruncatedTest : public testing::TestWithParam<std::string> {};

// A real bag cut at several points: every message read is one of the whole file's messages, in
// order and unchanged; a cut before the end reads fewer and warns.
TEST_P(TruncatedTest, GivesWhatItHoldsAndWarns) {
  const std::filesystem::path source = BagsDir() / GetParam();
  if (!std::filesystem::exists(source)) GTEST_SKIP() << source << " is absent";
  absl::StatusOr<std::unique_ptr<BagReader>> whole = OpenBag(source.string());
  ASSERT_TRUE(whole.ok()) << whole.status();
  const std::vector<ReadMessage> all = ReadAll(**whole);
  ASSERT_GT(all.size(), 100u);
  const std::string bytes = Slurp(source);
  TempDir dir;
  int64_t previous = -1;
  for (double fraction : {0.3, 0.6, 0.9, 0.995}) {
    SCOPED_TRACE(fraction);
    const std::string path =
        Write(dir, "cut" + std::filesystem::path(GetParam()).extension().string(),
              bytes.substr(0, static_cast<size_t>(bytes.size() * fraction)));
    absl::StatusOr<std::unique_ptr<BagReader>> cut = OpenBag(path);
    ASSERT_TRUE(cut.ok()) << cut.status();
    const std::vector<ReadMessage> held = ReadAll(**cut);
    // A cut in the index at the end loses no message; one in the first third loses some.
    EXPECT_LE(held.size(), all.size());
    if (fraction < 0.5) EXPECT_LT(held.size(), all.size());
    EXPECT_GE(static_cast<int64_t>(held.size()), previous) << "a longer prefix held fewer messages";
    previous = static_cast<int64_t>(held.size());
    EXPECT_FALSE((*cut)->warnings().empty());
    // The messages of a cut file are a time-ordered subset of the whole file's.
    size_t j = 0;
    for (const ReadMessage& message : held) {
      while (j < all.size() && !(all[j].time_ns == message.time_ns && all[j].data == message.data)) ++j;
      ASSERT_LT(j, all.size()) << "a message of the cut file is not in the whole one";
      EXPECT_EQ(all[j].topic, message.topic);
      ++j;
    }
    absl::StatusOr<BagSummary> summary = (*cut)->Summary();
    ASSERT_TRUE(summary.ok()) << summary.status();
    EXPECT_EQ(summary->messages, static_cast<int64_t>(held.size()));
  }
  EXPECT_GT(previous, static_cast<int64_t>(all.size() / 2)) << "99.5% of the file held under half";
}

INSTANTIATE_TEST_SUITE_P(RealBags, TruncatedTest,
                         testing::Values("zaki_urg_feb13_subset/subset.bag",
                                         "embag_stage_sim/test_stage_lz4.bag",
                                         "rosbagjs_fixtures/example-bz2.bag"),
                         [](const testing::TestParamInfo<std::string>& info) {
                           return std::string(info.index == 0 ? "plain" : info.index == 1 ? "lz4" : "bz2");
                         });

TEST(BadBags, CutMcapWithoutFooterIsReadByScanning) {
  const std::filesystem::path source = BagsDir() / "rosbag2_fixtures/rosbag2_py/test/resources/mcap/"
                                                   "reindex_test_bags/multiple_files/multiple_files_0.mcap";
  if (!std::filesystem::exists(source)) GTEST_SKIP() << source << " is absent";
  const std::string bytes = Slurp(source);
  // Its one zstd chunk spans bytes 45 to 10438 of 32605, its message index the rest. Cut in the
  // message index, all 1324 messages are there; cut in the chunk (a zstd frame of one block,
  // which cannot be expanded in part), none is, and both say why.
  TempDir dir;
  absl::StatusOr<std::unique_ptr<BagReader>> bag = OpenBag(Write(dir, "index.mcap", bytes.substr(0, 20000)));
  ASSERT_TRUE(bag.ok()) << bag.status();
  EXPECT_EQ(ReadAll(**bag).size(), 1324u);
  EXPECT_TRUE(AnyWarningHas(**bag, "no footer"));
  bag = OpenBag(Write(dir, "chunk.mcap", bytes.substr(0, 6000)));
  ASSERT_TRUE(bag.ok()) << bag.status();
  EXPECT_TRUE(ReadAll(**bag).empty());
  EXPECT_TRUE(AnyWarningHas(**bag, "claims 10384 bytes but the file ends sooner"));
}

TEST(BadBags, NotABagSaysWhatItStartsWith) {
  TempDir dir;
  absl::StatusOr<std::unique_ptr<BagReader>> bag =
      OpenBag(Write(dir, "notes.bag", "hello, this is a text file\n"));
  ASSERT_FALSE(bag.ok());
  EXPECT_EQ(bag.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(bag.status().message().find("not a bag"), std::string::npos) << bag.status();
  EXPECT_NE(bag.status().message().find("hello, this is a"), std::string::npos) << bag.status();

  bag = OpenBag(dir.path() + "/missing.bag");
  EXPECT_EQ(bag.status().code(), absl::StatusCode::kNotFound);
  bag = OpenBag(dir.path());  // a folder with no bag in it
  ASSERT_FALSE(bag.ok());
  EXPECT_NE(bag.status().message().find("not a bag folder"), std::string::npos) << bag.status();
}

TEST(BadBags, FirstLineCutShortIsDataLoss) {
  TempDir dir;
  absl::StatusOr<std::unique_ptr<BagReader>> bag = OpenBag(Write(dir, "short.bag", "#ROSB"));
  ASSERT_FALSE(bag.ok());
  EXPECT_EQ(bag.status().code(), absl::StatusCode::kDataLoss) << bag.status();
  bag = OpenBag(Write(dir, "header_only.bag", "#ROSBAG V2.0\n"));
  ASSERT_FALSE(bag.ok());
  EXPECT_EQ(bag.status().code(), absl::StatusCode::kDataLoss) << bag.status();
}

TEST(BadBags, HugeDeclaredLengthsAreRefusedNotAllocated) {
  TempDir dir;
  // A bag header record claiming a 4 GiB header.
  std::string ros1 = "#ROSBAG V2.0\n";
  ros1 += std::string("\xff\xff\xff\xff", 4) + std::string(100, '\0');
  absl::StatusOr<std::unique_ptr<BagReader>> bag = OpenBag(Write(dir, "huge.bag", ros1));
  ASSERT_FALSE(bag.ok());
  EXPECT_EQ(bag.status().code(), absl::StatusCode::kDataLoss) << bag.status();

  // An MCAP whose header record claims 2^63 bytes, then nothing: no footer, nothing to read.
  std::string mcap("\x89MCAP0\r\n", 8);
  mcap += '\x01';
  mcap += std::string("\0\0\0\0\0\0\0\x80", 8);
  mcap += std::string(64, 'x');
  bag = OpenBag(Write(dir, "huge.mcap", mcap));
  ASSERT_TRUE(bag.ok()) << bag.status();
  EXPECT_TRUE(ReadAll(**bag).empty());
  EXPECT_TRUE(AnyWarningHas(**bag, "claims")) << ((*bag)->warnings().empty() ? "" : (*bag)->warnings()[0]);
}

TEST(BadBags, UnknownChunkCompressionNamesIt) {
  const std::filesystem::path source = BagsDir() / "embag_stage_sim/test_stage_lz4.bag";
  if (!std::filesystem::exists(source)) GTEST_SKIP() << source << " is absent";
  std::string bytes = Slurp(source);
  // Every chunk's "compression=lz4" becomes "compression=xz9": same length, a codec nobody has.
  size_t renamed = 0;
  for (size_t at = bytes.find("compression=lz4"); at != std::string::npos;
       at = bytes.find("compression=lz4", at + 1)) {
    bytes.replace(at, 15, "compression=xz9");
    ++renamed;
  }
  ASSERT_GT(renamed, 0u);
  TempDir dir;
  absl::StatusOr<std::unique_ptr<BagReader>> bag = OpenBag(Write(dir, "xz9.bag", bytes));
  ASSERT_TRUE(bag.ok()) << bag.status();
  EXPECT_TRUE(ReadAll(**bag).empty());
  EXPECT_TRUE(AnyWarningHas(**bag, "compression \"xz9\"")) << (*bag)->warnings().size();
}

TEST(BadBags, McapChunkWithABadCrcIsSkippedWithAWarning) {
  const std::filesystem::path source =
      BagsDir() / "rosbag2_fixtures/rosbag2_tests/resources/mcap/cdr_test/cdr_test_0.mcap";
  if (!std::filesystem::exists(source)) GTEST_SKIP() << source << " is absent";
  std::string bytes = Slurp(source);
  // Its one chunk (opcode 0x06 right after the 34-byte header record) has no CRC (0: not
  // computed); give it a wrong one. Start and end time, uncompressed size, then the CRC.
  ASSERT_EQ(bytes[42], '\x06');
  const size_t crc_at = 42 + 9 + 8 + 8 + 8;
  ASSERT_EQ(bytes.substr(crc_at, 4), std::string(4, '\0'));
  bytes[crc_at] = 1;
  // Drop the footer, so the reader scans (the summary would still list the channels).
  bytes.resize(bytes.size() - 8 - 29);
  TempDir dir;
  absl::StatusOr<std::unique_ptr<BagReader>> bag = OpenBag(Write(dir, "crc.mcap", bytes));
  ASSERT_TRUE(bag.ok()) << bag.status();
  EXPECT_TRUE(ReadAll(**bag).empty());
  EXPECT_TRUE(AnyWarningHas(**bag, "CRC")) << ((*bag)->warnings().empty() ? "" : (*bag)->warnings().back());
}

TEST(BadBags, DamagedSqliteIsAPreciseError) {
  const std::filesystem::path source =
      BagsDir() / "rosbag2_fixtures/rosbag2_py/test/resources/sqlite3/talker/talker.db3";
  if (!std::filesystem::exists(source)) GTEST_SKIP() << source << " is absent";
  TempDir dir;
  absl::StatusOr<std::unique_ptr<BagReader>> bag =
      OpenBag(Write(dir, "cut.db3", Slurp(source).substr(0, 5000)));
  ASSERT_FALSE(bag.ok());
  EXPECT_NE(bag.status().message().find("malformed"), std::string::npos) << bag.status();
}

}  // namespace
}  // namespace waymark::bags
