// base/text, base/digest, base/read_file: the shortest round-trip text against hand-written
// doubles, FNV-1a 64's published test vectors, and a file read back byte for byte or refused with
// the cause alone.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <limits>
#include <string>
#include <vector>

#include "base/atomic_file.hpp"
#include "base/digest.hpp"
#include "base/random.hpp"
#include "base/read_file.hpp"
#include "base/text.hpp"
#include "test_support.hpp"

namespace ambler::base {
namespace {

TEST(Text, ShortestTextReadsBackAsTheSameDouble) {
  EXPECT_EQ(shortestText(0.1), "0.1");
  EXPECT_EQ(shortestText(40), "40");
  EXPECT_EQ(shortestText(-2.5), "-2.5");
  EXPECT_EQ(shortestText(1e-5), "1e-05");
  EXPECT_EQ(shortestText(1e21), "1e+21");
  EXPECT_EQ(shortestText(0.1 + 0.2), "0.30000000000000004");  // the double nearest 0.3 is another
  Rng rng(7);
  for (int k = 0; k < 10000; ++k) {
    const double v = std::ldexp(rng.uniform() - 0.5, int(rng.next() % 200) - 100);
    EXPECT_EQ(std::strtod(shortestText(v).c_str(), nullptr), v);
  }
}

TEST(Text, PlainTextIsFixedWherePeopleWriteItSo) {
  EXPECT_EQ(plainText(0.0003), "0.0003");
  EXPECT_EQ(plainText(40), "40");
  EXPECT_EQ(plainText(0), "0");
  EXPECT_EQ(plainText(1e-5), "1e-05");
  EXPECT_EQ(plainText(1e16), "1e+16");
  EXPECT_EQ(plainText(123456789012345.6), "123456789012345.6");
  Rng rng(8);
  for (int k = 0; k < 10000; ++k) {
    const double v = std::ldexp(rng.uniform() - 0.5, int(rng.next() % 120) - 60);
    EXPECT_EQ(std::strtod(plainText(v).c_str(), nullptr), v);
  }
}

TEST(Text, SplitKeepsEmptyPieces) {
  EXPECT_EQ(split("a,b,,c", ','), (std::vector<std::string>{"a", "b", "", "c"}));
  EXPECT_EQ(split("", ','), (std::vector<std::string>{""}));
  EXPECT_EQ(split("2/3", '/'), (std::vector<std::string>{"2", "3"}));
  EXPECT_TRUE(allDigits("0123456789"));
  EXPECT_FALSE(allDigits(""));
  EXPECT_FALSE(allDigits("12a"));
  EXPECT_FALSE(allDigits("-1"));
}

TEST(Digest, IsFnv1a64) {
  // FNV-1a 64's published test vectors.
  EXPECT_EQ(digest(""), "cbf29ce484222325");
  EXPECT_EQ(digest("a"), "af63dc4c8601ec8c");
  EXPECT_EQ(digest("foobar"), "85944171f73967e8");
}

TEST(ReadFile, BytesBackOrTheCauseAlone) {
  const test::TempDir dir;
  const std::string bytes("a\0b\r\n\xff", 6);
  writeFileAtomic(dir.path() / "f", bytes);
  EXPECT_EQ(readFile(dir.path() / "f"), bytes);
  const auto cause = [](const std::filesystem::path& p) {
    try {
      readFile(p);
    } catch (const ReadError& e) {
      return std::string(e.what());
    }
    return std::string("read");
  };
  EXPECT_EQ(cause(dir.path() / "missing"), "cannot open file");
  EXPECT_EQ(cause(dir.path()), "cannot open file");  // a directory
}

TEST(Random, ViewSeedsAreTheScenarioSeedsStreams) {
  EXPECT_EQ(viewSeed(14, 0), streamKey(14, 1000));
  EXPECT_NE(viewSeed(14, 0), viewSeed(14, 1));
  EXPECT_NE(viewSeed(14, 0), viewSeed(15, 0));
}

}  // namespace
}  // namespace ambler::base
