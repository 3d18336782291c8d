// `ambler experiment locus-vs-cartesian --quick` end to end: the first and last value of every
// axis of scenarios/experiments/*.yaml with one seed, run twice into temporary directories.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <charconv>
#include <filesystem>
#include <fstream>
#include <limits>
#include <opencv2/imgcodecs.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "eval/experiment.hpp"
#include "eval/sweep.hpp"

namespace ambler::eval {
namespace {

namespace fs = std::filesystem;

std::string slurp(const fs::path& file) {
  std::ifstream in(file, std::ios::binary);
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

// The lines of the markdown section that starts with `heading`, up to the next heading.
std::vector<std::string> section(const std::string& md, const std::string& heading) {
  std::vector<std::string> out;
  std::istringstream in(md);
  bool inside = false;
  for (std::string line; std::getline(in, line);) {
    if (line.starts_with("### ")) inside = line == heading;
    else if (inside && line.starts_with("| ")) out.push_back(line);
  }
  return out;
}

struct TempDir {
  fs::path dir;
  explicit TempDir(const std::string& tag)
      : dir(fs::temp_directory_path() / ("ambler-experiment-" + tag + "-" + std::to_string(::getpid()))) {
    fs::remove_all(dir);
  }
  ~TempDir() {
    std::error_code ec;
    fs::remove_all(dir, ec);
  }
};

TEST(Experiment, QuickRunWritesTablesPlotsAndCsvsDeterministically) {
  const fs::path sweeps = fs::path(AMBLER_SOURCE_DIR) / "scenarios" / "experiments";
  TempDir a("a"), b("b");
  ExperimentOptions opt;
  opt.sweeps = sweeps;
  opt.quick = true;
  opt.progress = false;
  opt.out = a.dir;
  const std::string md = runLocusVsCartesian(opt);
  EXPECT_EQ(md, slurp(a.dir / "table.md"));

  // A row per tilt × noise combination of the quick sweep: level and 45° sideways (the first and
  // last orientation), noise-free unquantised and k = 0.001 (the first and last noise entry).
  const auto rows = section(md, "### Tilted planes: whole map (0.10 m cells)");
  ASSERT_EQ(rows.size(), 5u) << md;  // the header and four runs
  const std::vector<std::string> labels{"| level | none, unquantised |", "| level | k = 0.001 |",
                                        "| 45° sideways | none, unquantised |", "| 45° sideways | k = 0.001 |"};
  for (std::size_t i = 0; i < labels.size(); ++i) EXPECT_TRUE(rows[i + 1].starts_with(labels[i])) << rows[i + 1];
  for (const char* heading : {"### Tilted planes: RMS error by range band, mm (L / C)",
                              "### Tilted planes: coverage by range band, % (L / C)"})
    EXPECT_EQ(section(md, heading).size(), 5u) << heading;
  const auto res_rows = section(md, "### Fractal terrain: whole map by map cell");
  ASSERT_EQ(res_rows.size(), 3u);
  EXPECT_TRUE(res_rows[1].starts_with("| 2 cm |"));
  EXPECT_TRUE(res_rows[2].starts_with("| 20 cm |"));

  for (const char* png : {"tilt_noise.png", "resolution.png", "range_bands.png"}) {
    const cv::Mat img = cv::imread((a.dir / png).string());
    ASSERT_FALSE(img.empty()) << png;
    EXPECT_GE(img.cols, 1200) << png;  // two panels side by side
    EXPECT_LT(fs::file_size(a.dir / png), 300u * 1024) << png;
  }

  // The sweeps' own rows: on the noise-free, unquantised level plane both maps are exact to well
  // under the 2 mm the locus mapper's plane tests allow; k = 0.001 (σ_ρ ≈ 0.1 m at 10 m) is far above.
  const auto csv = parseResultsCsv(slurp(a.dir / "tilt_noise" / "results.csv"));
  ASSERT_TRUE(csv);
  ASSERT_EQ(csv->size(), 5u);
  const auto& header = csv->front();
  const auto value = [&](std::size_t row, const std::string& column) {
    const auto it = std::find(header.begin(), header.end(), column);
    EXPECT_NE(it, header.end()) << column;
    const std::string& text = (*csv)[row][std::size_t(it - header.begin())];
    double v = std::numeric_limits<double>::quiet_NaN();
    std::from_chars(text.data(), text.data() + text.size(), v);
    return v;
  };
  EXPECT_LT(value(1, "map.0.rms_error_m"), 2e-3);
  EXPECT_LT(value(1, "map_cartesian.0.rms_error_m"), 2e-3);
  EXPECT_GT(value(2, "map.0.rms_error_m"), 5e-3);
  EXPECT_GT(value(1, "map.0.by_range.0.visible"), 0);
  EXPECT_EQ(parseResultsCsv(slurp(a.dir / "resolution" / "results.csv"))->size(), 3u);

  // Same sweeps, same bytes.
  opt.out = b.dir;
  EXPECT_EQ(runLocusVsCartesian(opt), md);
  for (const char* file : {"table.md", "tilt_noise.png", "resolution.png", "range_bands.png",
                           "tilt_noise/results.csv", "resolution/results.csv"})
    EXPECT_EQ(slurp(a.dir / file), slurp(b.dir / file)) << file;
}

TEST(Experiment, MissingSweepFileIsAnError) {
  TempDir out("missing");
  ExperimentOptions opt;
  opt.sweeps = out.dir / "nowhere";
  opt.out = out.dir;
  opt.progress = false;
  EXPECT_THROW(runLocusVsCartesian(opt), SweepError);
  EXPECT_FALSE(fs::exists(out.dir / "table.md"));
}

}  // namespace
}  // namespace ambler::eval
