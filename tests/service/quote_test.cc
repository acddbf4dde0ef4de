// server/common/quote.h (issue 35): client text in answers and messages is valid UTF-8, escaped
// where it is not printable, cut at a character boundary, and bounded.
#include "server/common/quote.h"

#include <gtest/gtest.h>

#include <string>

namespace waymark {
namespace {

TEST(QuoteClientTextTest, PlainTextIsQuotedUnchanged) {
  EXPECT_EQ(QuoteClientText("north-kerb"), "\"north-kerb\"");
  EXPECT_EQ(QuoteClientText(""), "\"\"");
  EXPECT_EQ(QuoteClientText("Main St / 5th Ave"), "\"Main St / 5th Ave\"");
  EXPECT_EQ(QuoteClientText("Straße \u00e9 \u6771\u4eac \U0001F6A6"),
            "\"Straße \u00e9 \u6771\u4eac \U0001F6A6\"");
}

TEST(QuoteClientTextTest, EscapesControlCharactersQuotesAndBackslashes) {
  EXPECT_EQ(QuoteClientText(std::string("a\nb\tc\rd\x01" "e\x7f", 10)),
            "\"a\\nb\\tc\\rd\\x01e\\x7f\"");
  EXPECT_EQ(QuoteClientText("say \"hi\" \\o/"), "\"say \\\"hi\\\" \\\\o/\"");
  EXPECT_EQ(QuoteClientText(std::string("nul\0here", 8)), "\"nul\\x00here\"");
}

TEST(QuoteClientTextTest, BytesThatAreNotUtf8AreEscaped) {
  // A lone continuation byte, a cut two-byte character, an overlong '/', a surrogate, a byte
  // never in UTF-8, and a character beyond U+10FFFF.
  EXPECT_EQ(QuoteClientText("a\x80" "b"), "\"a\\x80b\"");
  EXPECT_EQ(QuoteClientText("caf\xc3"), "\"caf\\xc3\"");
  EXPECT_EQ(QuoteClientText("\xc0\xaf"), "\"\\xc0\\xaf\"");
  EXPECT_EQ(QuoteClientText("\xed\xa0\x80"), "\"\\xed\\xa0\\x80\"");
  EXPECT_EQ(QuoteClientText("\xff"), "\"\\xff\"");
  EXPECT_EQ(QuoteClientText("\xf4\x90\x80\x80"), "\"\\xf4\\x90\\x80\\x80\"");
  for (const char* bad : {"a\x80" "b", "caf\xc3", "\xc0\xaf", "\xed\xa0\x80", "\xff"}) {
    EXPECT_FALSE(IsValidUtf8(bad)) << bad;
    EXPECT_TRUE(IsValidUtf8(QuoteClientText(bad))) << bad;
    EXPECT_TRUE(IsValidUtf8(BoundClientText(bad))) << bad;
  }
}

// The campaign's case: a position of "a" and 40 two-byte characters, cut at 64 bytes, ended in
// the middle of a character.
TEST(QuoteClientTextTest, CutsAtCharactersNeverInsideOne) {
  std::string position = "a";
  for (int i = 0; i < 40; ++i) position += "\u00e9";
  ASSERT_FALSE(IsValidUtf8(position.substr(0, 64)));  // what a byte cut did
  const std::string quoted = QuoteClientText(position, 10);
  EXPECT_EQ(quoted, "\"a\u00e9\u00e9\u00e9\u00e9\u00e9\u00e9\u00e9\u00e9\u00e9...\"");
  EXPECT_TRUE(IsValidUtf8(quoted));
  EXPECT_EQ(QuoteClientText(position), "\"" + position + "\"");  // 41 characters: whole
  // Exactly max_chars characters: whole, no "...".
  EXPECT_EQ(QuoteClientText("abc", 3), "\"abc\"");
  EXPECT_EQ(QuoteClientText("abcd", 3), "\"abc...\"");
  // Four-byte characters are one character each.
  EXPECT_EQ(QuoteClientText("\U0001F6A6\U0001F6A6\U0001F6A6", 2), "\"\U0001F6A6\U0001F6A6...\"");
}

TEST(QuoteClientTextTest, AMegabyteIsQuotedInAFewHundredBytes) {
  const std::string huge(1 << 20, 'p');
  const std::string quoted = QuoteClientText(huge);
  EXPECT_EQ(quoted, "\"" + std::string(kMaxQuotedChars, 'p') + "...\"");
  // The worst case: every character escaped or four bytes long.
  EXPECT_LE(QuoteClientText(std::string(1 << 20, '\x01')).size(), 4 * kMaxQuotedChars + 5);
  std::string emoji;
  for (int i = 0; i < 1000; ++i) emoji += "\U0001F6A6";
  EXPECT_LE(QuoteClientText(emoji).size(), 4 * kMaxQuotedChars + 5);
  EXPECT_LE(BoundClientText(emoji, 128).size(), 4 * 128 + 3u);
}

TEST(BoundClientTextTest, EchoesValidValuesUnchangedAndBoundsTheRest) {
  EXPECT_EQ(BoundClientText("north-kerb"), "north-kerb");
  EXPECT_EQ(BoundClientText("say \"hi\"\n"), "say \"hi\"\n");  // printable or not: the value
  EXPECT_EQ(BoundClientText(std::string(128, 'x'), 128), std::string(128, 'x'));
  EXPECT_EQ(BoundClientText(std::string(1 << 20, 'x'), 128), std::string(128, 'x') + "...");
  EXPECT_EQ(BoundClientText("caf\xc3"), "caf\\xc3");
}

// Every string of up to three bytes from an alphabet of edge bytes: the output is valid UTF-8,
// and valid input of at most max_chars characters comes back whole.
TEST(QuoteClientTextTest, EveryShortByteStringGivesValidUtf8) {
  const unsigned char alphabet[] = {0x00, 0x22, 0x41, 0x5c, 0x7f, 0x80, 0xbf, 0xc2,
                                    0xc3, 0xe0, 0xed, 0xef, 0xf0, 0xf4, 0xf5, 0xff};
  std::string text;
  for (unsigned char a : alphabet) {
    for (unsigned char b : alphabet) {
      for (unsigned char c : alphabet) {
        text = {static_cast<char>(a), static_cast<char>(b), static_cast<char>(c)};
        for (size_t cut : {size_t{1}, size_t{2}, size_t{64}}) {
          ASSERT_TRUE(IsValidUtf8(QuoteClientText(text, cut)));
          ASSERT_TRUE(IsValidUtf8(BoundClientText(text, cut)));
        }
        if (IsValidUtf8(text)) {
          ASSERT_EQ(BoundClientText(text), text);
        }
      }
    }
  }
}

}  // namespace
}  // namespace waymark
