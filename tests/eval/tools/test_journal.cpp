// The resume journal (eval/tools/journal.hpp) and the progress bar (eval/tools/progress.hpp). The kill-and-
// resume test of whole sweeps and basins is kill_resume.sh.
#include <gtest/gtest.h>

#include <sys/resource.h>

#include <cmath>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <string>
#include <vector>

#include "eval/tools/journal.hpp"
#include "eval/tools/progress.hpp"
#include "test_support.hpp"

namespace ambler::eval {
namespace {

namespace fs = std::filesystem;
using test::slurp;

std::string errorOf(const std::function<void()>& f) {
  try {
    f();
  } catch (const JournalError& e) {
    return e.what();
  }
  return "";
}

TEST(Journal, Crc32IsTheStandardOne) {
  // The check value of CRC-32/ISO-HDLC (zlib's crc32) for "123456789".
  EXPECT_EQ(crc32("123456789"), 0xCBF43926U);
  EXPECT_EQ(crc32(""), 0U);
}

// A journal with items 3, 0, 7 recorded, and the byte offset where each record's line ends.
struct Written {
  std::string text;
  std::vector<std::size_t> ends;  // after the header, then after each record
  std::vector<std::pair<std::size_t, std::string>> records{{3, R"([["a","1"]])"}, {0, "[]"}, {7, R"(["x y"])"}};
};

Written writeThree(const fs::path& file) {
  Written w;
  {
    JournalWriter j(file, "id1", false, 0);
    w.ends.push_back(fs::file_size(file));
    for (const auto& [item, payload] : w.records) {
      j.append(item, payload);
      w.ends.push_back(fs::file_size(file));
    }
  }
  w.text = slurp(file);
  return w;
}

TEST(Journal, RecordsReadBackAsWritten) {
  test::TempDir tmp;
  const Written w = writeThree(tmp.path() / "j");
  EXPECT_EQ(w.text.substr(0, w.ends[0]), "ambler-journal 1 id1\n");
  const JournalContents c = parseJournal(w.text, "j", "id1", 8);
  EXPECT_FALSE(c.torn_tail);
  EXPECT_EQ(c.valid_bytes, w.text.size());
  ASSERT_EQ(c.records.size(), 3U);
  for (const auto& [item, payload] : w.records) EXPECT_EQ(c.records.at(item), payload);
}

// A kill can leave any prefix of the file: every prefix reads as exactly the records whose whole
// line it holds, a partial last line is reported torn and dropped, and nothing throws.
TEST(Journal, EveryPrefixReadsAsItsWholeRecords) {
  test::TempDir tmp;
  const Written w = writeThree(tmp.path() / "j");
  for (std::size_t cut = 0; cut <= w.text.size(); ++cut) {
    SCOPED_TRACE("cut at byte " + std::to_string(cut));
    JournalContents c;
    ASSERT_NO_THROW(c = parseJournal(std::string_view(w.text).substr(0, cut), "j", "id1", 8));
    std::size_t whole = 0;
    while (whole < w.records.size() && w.ends[whole + 1] <= cut) ++whole;
    EXPECT_EQ(c.records.size(), whole);
    for (std::size_t r = 0; r < whole; ++r) EXPECT_EQ(c.records.at(w.records[r].first), w.records[r].second);
    const bool at_boundary = cut < w.ends[0] ? cut == 0 : cut == w.ends[whole];
    EXPECT_EQ(c.torn_tail, cut > w.ends[0] && !at_boundary);
    EXPECT_EQ(c.valid_bytes, cut < w.ends[0] ? 0U : w.ends[whole]);
  }
}

TEST(Journal, DamageBeforeTheLastRecordIsRefused) {
  test::TempDir tmp;
  const Written w = writeThree(tmp.path() / "j");
  std::string middle = w.text;
  middle[w.ends[1] + 11] ^= 0x01;  // record 2's payload: "0 <8 hex> []"
  EXPECT_NE(errorOf([&] { parseJournal(middle, "dir/j", "id1", 8); })
                .find("dir/j: line 3: damaged record (checksum mismatch) followed by others"),
            std::string::npos);
  // The same damage in the last record reads as a record cut short: dropped, run again.
  std::string last = w.text;
  last[w.text.size() - 3] ^= 0x01;
  const JournalContents c = parseJournal(last, "j", "id1", 8);
  EXPECT_TRUE(c.torn_tail);
  EXPECT_EQ(c.records.size(), 2U);
  EXPECT_EQ(c.valid_bytes, w.ends[2]);
}

TEST(Journal, AJournalOfAnotherSweepOrNoneAtAllIsRefused) {
  test::TempDir tmp;
  const Written w = writeThree(tmp.path() / "j");
  EXPECT_NE(errorOf([&] { parseJournal(w.text, "dir/j", "id2", 8); })
                .find("dir/j: recorded for another sweep or basin, or with other options (its identity differs)"),
            std::string::npos);
  EXPECT_NE(errorOf([&] { parseJournal("run,seed\n0,1\n", "dir/j", "id1", 8); }).find("dir/j: not an ambler journal"),
            std::string::npos);
  EXPECT_NE(errorOf([&] { parseJournal("results", "dir/j", "id1", 8); }).find("not an ambler journal"),
            std::string::npos);
  EXPECT_NE(errorOf([&] { parseJournal(w.text, "dir/j", "id1", 7); })
                .find("dir/j: line 4: item 7 is out of range (there are 7)"),
            std::string::npos);
  const std::string twice = w.text + w.text.substr(w.ends[0], w.ends[1] - w.ends[0]) + w.text.substr(w.ends[0]);
  EXPECT_NE(errorOf([&] { parseJournal(twice, "dir/j", "id1", 8); }).find("dir/j: line 5: item 3 is recorded twice"),
            std::string::npos);
}

TEST(Journal, AResumeDropsTheTornTailAndAppendsAfterTheWholeRecords) {
  test::TempDir tmp;
  const fs::path file = tmp.path() / "j";
  const Written w = writeThree(file);
  std::ofstream(file, std::ios::binary) << w.text.substr(0, w.ends[2] + 4);  // record 3 cut after 4 bytes
  {
    Journal j = openJournal(file, "id1", 8, true);
    EXPECT_TRUE(j.done.torn_tail);
    EXPECT_EQ(j.done.records.size(), 2U);
    j.writer->append(7, "[1]");
  }
  const JournalContents c = parseJournal(slurp(file), "j", "id1", 8);
  EXPECT_FALSE(c.torn_tail);
  ASSERT_EQ(c.records.size(), 3U);
  EXPECT_EQ(c.records.at(7), "[1]");
  // Without resume the journal starts over.
  { Journal fresh = openJournal(file, "id1", 8, false); }
  EXPECT_EQ(slurp(file), "ambler-journal 1 id1\n");
}

// A full disk as the program meets it: write() fails (here EFBIG under a file-size limit, with
// SIGXFSZ ignored). The append throws one line naming the file and the cause, and the records
// before it stay whole.
TEST(Journal, AFailedAppendLeavesTheRecordsBeforeItWhole) {
  test::TempDir tmp;
  const fs::path file = tmp.path() / "j";
  JournalWriter j(file, "id1", false, 0);
  j.append(0, "[0]");
  const std::string before = slurp(file);
  const auto old_handler = std::signal(SIGXFSZ, SIG_IGN);
  rlimit old{};
  ASSERT_EQ(getrlimit(RLIMIT_FSIZE, &old), 0);
  rlimit small = old;
  small.rlim_cur = before.size() + 10;  // room for part of the next record only
  ASSERT_EQ(setrlimit(RLIMIT_FSIZE, &small), 0);
  const std::string e = errorOf([&] { j.append(1, std::string(100, 'x')); });
  setrlimit(RLIMIT_FSIZE, &old);
  std::signal(SIGXFSZ, old_handler);
  EXPECT_EQ(e, file.string() + ": cannot record a finished item: File too large");
  EXPECT_EQ(slurp(file), before);
  j.append(1, "[1]");  // and the journal goes on where the whole records end
  EXPECT_EQ(parseJournal(slurp(file), "j", "id1", 2).records.size(), 2U);
}

TEST(Progress, ClockText) {
  EXPECT_EQ(clockText(0), "0:00");
  EXPECT_EQ(clockText(59.4), "0:59");
  EXPECT_EQ(clockText(61), "1:01");
  EXPECT_EQ(clockText(3725), "1:02:05");
  EXPECT_EQ(clockText(NAN), "--:--");
}

TEST(Progress, BarShowsCountRateAndTimeLeft) {
  // 12 of 36 in 15 s: 0.8 per second, 24 left: 30 s. 12/36 of 20 columns: 6 filled.
  EXPECT_EQ(progressBar("sweep", 12, 36, 0, 15.0, "run 11", 200),
            "sweep [======>             ] 12/36  33%  0.80/s  ETA 0:30  run 11");
  // A resume: 10 were recorded before, 2 finished in 4 s: 0.5 per second, 24 left: 48 s.
  EXPECT_EQ(progressBar("sweep", 12, 36, 10, 4.0, "", 200), "sweep [======>             ] 12/36  33%  0.50/s  ETA 0:48");
  // Nothing finished yet: no rate, no estimate.
  EXPECT_EQ(progressBar("basin", 0, 5, 0, 1.0, "", 200), "basin [                    ] 0/5   0%  -/s  ETA --:--");
  EXPECT_EQ(progressBar("basin", 5, 5, 0, 2.0, "x", 200), "basin [====================] 5/5 100%  2.5/s  ETA 0:00  x");
  EXPECT_EQ(progressBar("sweep", 12, 36, 0, 15.0, "run 11: a long detail", 40).size(), 40U);
}

TEST(Progress, PlainLinesWhenNotATerminal) {
  test::TempDir tmp;
  const fs::path file = tmp.path() / "log";
  std::FILE* f = std::fopen(file.c_str(), "w");
  ASSERT_NE(f, nullptr);
  {
    Progress p("sweep s", 3, 1, Progress::Mode::Lines, std::chrono::milliseconds(0), f);
    p.step("run 1");
    p.note("a note");
    p.step("run 2");
  }
  {
    // With a line interval, only the first and the last of a quick burst are printed.
    Progress p("basin b", 4, 0, Progress::Mode::Lines, std::chrono::hours(1), f);
    p.setLinePrefix("basin ");
    for (int k = 0; k < 4; ++k) p.step("draw " + std::to_string(k));
  }
  { Progress off("x", 2, 0, Progress::Mode::Off, std::chrono::milliseconds(0), f); off.step("y"); off.note("z"); }
  std::fclose(f);
  EXPECT_EQ(slurp(file), "ambler: [2/3] run 1\nambler: a note\nambler: [3/3] run 2\n"
                         "ambler: basin [1/4] draw 0\nambler: basin [4/4] draw 3\n");
}

}  // namespace
}  // namespace ambler::eval
