// `ambler sweep`: the product of the axes in order, rows that match each run's metrics.json, and
// results.csv byte-identical whether produced in one process, with several jobs, or from shards.
#include <gtest/gtest.h>
#include <unistd.h>

#include <charconv>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "eval/scenario/scenario.hpp"
#include "eval/tools/sweep/sweep.hpp"
#include "test_support.hpp"

namespace ambler::eval {
namespace {

namespace fs = std::filesystem;
using test::slurp;

// Small enough that a run takes a fraction of a second: 6 x 6 m plane, 16 x 64 scan, 2 x 2 m map.
const char* kBase = R"(# a tiny flat scene for sweep tests
name: tiny
description: "flat: one small view"
terrain:
  kind: plane
  size_m: [6, 6]
  cell_m: 0.1
sensor: {rows: 16, cols: 64}
views:
  - {xyz_m: [0, -2.5, 1.5], rpy_deg: [0, -30, 0]}
map:
  cell_m: 0.1
  region: {x_m: [-1, 1], y_m: [-1, 1]}
)";

const char* kSweep = R"(name: tiny_sweep
base: base.yaml
axes:
  terrain.slope_deg: [[0, 0], [20, 0]]
  sensor.noise_k: [0, 0.0003, 0.001]
)";

void spit(const fs::path& p, const std::string& text) { std::ofstream(p, std::ios::binary) << text; }

std::vector<std::string> split(const std::string& text, char sep) {
  std::vector<std::string> out;
  std::stringstream s(text);
  for (std::string part; std::getline(s, part, sep);) out.push_back(part);
  if (!text.empty() && text.back() == sep && sep == ',') out.emplace_back();
  return out;
}

// Rows of a CSV without quoted cells, each split into cells.
std::vector<std::vector<std::string>> rowsOf(const std::string& csv) {
  std::vector<std::vector<std::string>> rows;
  for (const auto& line : split(csv, '\n')) rows.push_back(split(line, ','));
  return rows;
}

// A sweep directory with the tiny base scenario and a sweep file beside it.
struct SweepDir : test::TempDir {
  fs::path file;
  explicit SweepDir(const std::string& sweep = kSweep) : file(dir / "sweep.yaml") {
    spit(dir / "base.yaml", kBase);
    spit(file, sweep);
  }
  fs::path run(SweepOptions opt, const std::string& out = "out") const {
    opt.out = dir / out;
    opt.progress = false;
    return runSweep(loadSweep(file), opt);
  }
};

// The message of the SweepError that loadSweep throws, or "" when it loads.
std::string loadError(const SweepDir& d) {
  try {
    loadSweep(d.file);
  } catch (const SweepError& e) {
    return e.what();
  }
  return "";
}

TEST(Sweep, RunsTheProductLastAxisFastest) {
  const SweepDir d;
  const Sweep sweep = loadSweep(d.file);
  ASSERT_EQ(sweep.runs.size(), 6u);
  EXPECT_EQ(sweep.base, d.dir / "base.yaml");
  const double noise[] = {0, 0.0003, 0.001};
  for (std::size_t k = 0; k < 6; ++k) {
    EXPECT_EQ(sweep.runs[k].name, "tiny_sweep_" + std::to_string(k));
    EXPECT_EQ(sweep.runs[k].terrain.slope_deg.x(), k < 3 ? 0.0 : 20.0) << k;
    EXPECT_EQ(sweep.runs[k].sensor.noise_k, noise[k % 3]) << k;
    EXPECT_EQ(sweep.runs[k].description, "flat: one small view");  // the base's quoted string survives
    EXPECT_EQ(sweep.combination(k), (std::vector<std::size_t>{k / 3, k % 3}));
  }

  const fs::path csv = d.run({});
  EXPECT_EQ(csv, d.dir / "out" / "results.csv");
  const auto rows = rowsOf(slurp(csv));
  ASSERT_EQ(rows.size(), 7u);  // header and one row per run
  const auto& header = rows[0];
  ASSERT_GE(header.size(), 4u);
  EXPECT_EQ(header[0], "run");
  EXPECT_EQ(header[1], "terrain.slope_deg");
  EXPECT_EQ(header[2], "sensor.noise_k");
  const char* slope[] = {"0;0", "0;0", "0;0", "20;0", "20;0", "20;0"};
  const char* noise_cell[] = {"0", "0.0003", "0.001", "0", "0.0003", "0.001"};
  for (std::size_t k = 0; k < 6; ++k) {
    ASSERT_EQ(rows[k + 1].size(), header.size()) << k;
    EXPECT_EQ(rows[k + 1][0], std::to_string(k));
    EXPECT_EQ(rows[k + 1][1], slope[k]);
    EXPECT_EQ(rows[k + 1][2], noise_cell[k]);
  }
  for (const auto& column : header) EXPECT_FALSE(column.starts_with("timing_s")) << column;
  // --keep metrics: the run directories hold the two small files only.
  for (int k = 0; k < 6; ++k) {
    std::vector<std::string> names;
    for (const auto& e : fs::directory_iterator(d.dir / "out" / "runs" / std::to_string(k)))
      names.push_back(e.path().filename().string());
    std::sort(names.begin(), names.end());
    EXPECT_EQ(names, (std::vector<std::string>{"metrics.json", "scenario.resolved.yaml"})) << k;
  }
}

TEST(Sweep, MetricCellsAreTheRunsMetricsJson) {
  const SweepDir d;
  const auto rows = rowsOf(slurp(d.run({})));
  const auto& header = rows[0];
  int checked = 0;
  for (std::size_t k = 0; k < 6; ++k) {
    const fs::path run = d.dir / "out" / "runs" / std::to_string(k);
    const auto metrics = nlohmann::json::parse(slurp(run / "metrics.json"));
    EXPECT_EQ(metrics["name"], "tiny_sweep_" + std::to_string(k));
    EXPECT_NE(slurp(run / "scenario.resolved.yaml").find("name: \"tiny_sweep_" + std::to_string(k) + "\""),
              std::string::npos);
    for (const char* column : {"map.0.rms_error_m", "map_cartesian.0.rms_error_m", "scan.0.valid_fraction",
                               "scan.0.range_error_rms_m", "map.0.coverage"}) {
      const auto at = std::find(header.begin(), header.end(), column) - header.begin();
      ASSERT_LT(std::size_t(at), header.size()) << column;
      const auto parts = split(column, '.');
      const auto& value = metrics[parts[0]][std::stoi(parts[1])][parts[2]];
      const std::string& cell = rows[k + 1][at];
      ASSERT_TRUE(value.is_number()) << column;
      double parsed = 0;
      ASSERT_EQ(std::from_chars(cell.data(), cell.data() + cell.size(), parsed).ec, std::errc()) << cell;
      EXPECT_EQ(parsed, value.get<double>()) << column << " of run " << k;  // the same double, bit for bit
      ++checked;
    }
  }
  EXPECT_EQ(checked, 30);
  // Noise raises the range error on the same geometry.
  const auto at = std::find(header.begin(), header.end(), "scan.0.range_error_rms_m") - header.begin();
  EXPECT_LT(std::stod(rows[1][at]), std::stod(rows[3][at]));
}

TEST(Sweep, ShardsMergeIntoTheSameBytes) {
  const SweepDir d;
  const std::string whole = slurp(d.run({}));
  for (int n : {2, 3}) {
    const std::string out = "sharded" + std::to_string(n);
    for (int k = 1; k <= n; ++k) {
      const fs::path shard = d.run({.shard = Shard{k, n}}, out);
      EXPECT_EQ(shard.filename(), "results.shard-" + std::to_string(k) + "-of-" + std::to_string(n) + ".csv");
      const auto rows = rowsOf(slurp(shard));
      ASSERT_EQ(rows.size(), 1u + 6 / n);
      for (std::size_t r = 1; r < rows.size(); ++r) EXPECT_EQ(std::stoi(rows[r][0]) % n, k - 1);
    }
    EXPECT_FALSE(fs::exists(d.dir / out / "results.csv"));
    const fs::path merged = mergeSweep(loadSweep(d.file), d.dir / out, false);
    EXPECT_EQ(slurp(merged), whole) << n << " shards";
  }
}

TEST(Sweep, JobsGiveTheSameBytes) {
  const SweepDir d;
  EXPECT_EQ(slurp(d.run({.jobs = 2}, "two_jobs")), slurp(d.run({}, "one_job")));
  // --timing adds the timing columns; --keep none leaves no run directories.
  const auto rows = rowsOf(slurp(d.run({.keep = Keep::None, .timing = true}, "timed")));
  EXPECT_NE(std::find(rows[0].begin(), rows[0].end(), "timing_s.total"), rows[0].end());
  EXPECT_FALSE(fs::exists(d.dir / "timed" / "runs"));
}

TEST(Sweep, MetricsListPicksTheColumns) {
  const SweepDir d(R"(name: picked
base: base.yaml
axes:
  seed: [1, 2]
metrics: [map.0.rms_error_m, map_cartesian.0.rms_error_m, map.9.rms_error_m]
)");
  const auto rows = rowsOf(slurp(d.run({})));
  ASSERT_EQ(rows.size(), 3u);
  EXPECT_EQ(rows[0], (std::vector<std::string>{"run", "seed", "map.0.rms_error_m",
                                               "map_cartesian.0.rms_error_m", "map.9.rms_error_m"}));
  EXPECT_EQ(rows[2][1], "2");
  EXPECT_FALSE(rows[2][2].empty());
  EXPECT_TRUE(rows[2][4].empty());  // a metric the run does not write is an empty cell
}

TEST(Sweep, QuotedAndListCellsRoundTripThroughShards) {
  const SweepDir d(R"(name: cells
base: base.yaml
axes:
  description: [plain, "with, a comma and \"quotes\""]
  views.0.xyz_m: [[0, -2.5, 1.5], [0.5, -2.5, 1.5]]
metrics: [scan.0.valid_fraction]
)");
  const std::string whole = slurp(d.run({}));
  EXPECT_NE(whole.find("\n1,plain,0.5;-2.5;1.5,"), std::string::npos) << whole;
  EXPECT_NE(whole.find("\n2,\"with, a comma and \"\"quotes\"\"\",0;-2.5;1.5,"), std::string::npos) << whole;
  d.run({.shard = Shard{1, 2}}, "sharded");
  d.run({.shard = Shard{2, 2}}, "sharded");
  EXPECT_EQ(slurp(mergeSweep(loadSweep(d.file), d.dir / "sharded", false)), whole);
}

TEST(Sweep, BadValueFailsBeforeAnyRun) {
  // The bad value is in the last run: every combination is checked before the first runs.
  const SweepDir d(R"(name: bad
base: base.yaml
axes:
  terrain.slope_deg: [[0, 0], [75, 0]]
  seed: [1, 2]
)");
  const fs::path out = d.dir / "out";
  try {
    runSweep(loadSweep(d.file), SweepOptions{.out = out, .progress = false});
    FAIL() << "expected a SweepError";
  } catch (const SweepError& e) {
    EXPECT_EQ(std::string(e.what()),
              d.file.string() + ": axes.terrain.slope_deg = [75, 0]: " + (d.dir / "base.yaml").string() +
                  ": terrain.slope_deg[0]: expected a number in (-60, 60), got 75");
  }
  EXPECT_FALSE(fs::exists(out));
}

TEST(Sweep, BadKeyPathNamesTheAxis) {
  const std::string base = "name: k\nbase: base.yaml\naxes:\n";
  const auto error = [&](const std::string& axes) { return loadError(SweepDir(base + axes)); };
  EXPECT_NE(error("  sensor.noise: [0.001]\n").find("sweep.yaml: axes.sensor.noise = 0.001: "),
            std::string::npos);
  EXPECT_NE(error("  sensor.noise: [0.001]\n").find("sensor.noise: unknown key (did you mean noise_k?)"),
            std::string::npos);
  EXPECT_NE(error("  views.2.xyz_m: [[0, 0, 1]]\n").find("axes.views.2.xyz_m: views has 1 entry: no index 2"),
            std::string::npos);
  EXPECT_NE(error("  terrain.kind.x: [1]\n").find("axes.terrain.kind.x: terrain.kind is a value (plane)"),
            std::string::npos);
  // A quoted number stays a string, as in a scenario file.
  EXPECT_NE(error("  sensor.max_range_m: [\"40\"]\n").find("axes.sensor.max_range_m = \"40\": "),
            std::string::npos);
  // Intermediate sections are created: terrain.rocks did not exist in the base.
  EXPECT_EQ(error("  terrain.rocks.abundance_k: [0.05]\n"), "");
  EXPECT_NE(error("  terrain.rocks.abundance_k: [0.9]\n")
                .find("terrain.rocks.abundance_k: expected a number in (0, 0.5]"),
            std::string::npos);
}

// Traverse keys are axes like any other: a dotted path into the section, creating what the base
// leaves out (here traverse.odometry), each value checked by the scenario reader.
TEST(Sweep, TraverseKeysAreAxes) {
  const std::string base = "name: walk\nterrain: {kind: plane, size_m: [70, 24], cell_m: 0.1}\nmap: {}\n"
                           "traverse: {path: {start_xy_m: [-25, 0], heading_deg: 0, length_m: 50}}\n";
  const auto sweepOver = [&](const std::string& axes) {
    test::TempDir t;
    spit(t.dir / "base.yaml", base);
    spit(t.dir / "sweep.yaml", "name: walks\nbase: base.yaml\naxes:\n" + axes);
    return loadSweep(t.dir / "sweep.yaml");
  };
  const Sweep sweep = sweepOver("  traverse.odometry.translation_sigma_per_m: [0, 0.02, 0.05]\n"
                                "  traverse.path.length_m: [20, 50]\n");
  ASSERT_EQ(sweep.runs.size(), 6u);
  const double sigma[] = {0, 0.02, 0.05};
  for (std::size_t k = 0; k < 6; ++k) {
    ASSERT_TRUE(sweep.runs[k].traverse.has_value()) << k;
    const TraverseSpec& t = *sweep.runs[k].traverse;
    EXPECT_EQ(t.odometry.translation_sigma_per_m, sigma[k / 2]) << k;
    EXPECT_EQ(t.odometry.heading_sigma_deg_per_m, 0.5) << k;  // the rest of the section: its defaults
    EXPECT_EQ(t.waypoints_xy_m.back(), Eigen::Vector2d(k % 2 ? 25 : -5, 0)) << k;
  }
  try {
    sweepOver("  traverse.odometry.translation_sigma_per_m: [0.02, -0.1]\n");
    FAIL() << "expected a SweepError";
  } catch (const SweepError& e) {
    const std::string message = e.what();
    EXPECT_NE(message.find("sweep.yaml: axes.traverse.odometry.translation_sigma_per_m = -0.1: "), std::string::npos)
        << message;
    EXPECT_NE(message.find("base.yaml: traverse.odometry.translation_sigma_per_m: expected a number >= 0, got -0.1"),
              std::string::npos)
        << message;
  }
  // The other path form beside the base's: refused as in a scenario file.
  try {
    sweepOver("  traverse.path.waypoints_xy_m: [[[0, 0], [1, 0]]]\n");
    FAIL() << "expected a SweepError";
  } catch (const SweepError& e) {
    const std::string message = e.what();
    EXPECT_NE(message.find("traverse.path: expected start_xy_m, heading_deg and length_m, or waypoints_xy_m, got both"),
              std::string::npos)
        << message;
  }
}

TEST(Sweep, SweepFileErrorsNameFileAndKey) {
  const auto error = [](const std::string& text) { return loadError(SweepDir(text)); };
  EXPECT_NE(error("name: x\nbase: base.yaml\naxes: {seed: [1]}\ncolour: red\n")
                .find("sweep.yaml: colour: unknown key"),
            std::string::npos);
  EXPECT_NE(error("name: x\naxes: {seed: [1]}\n").find("sweep.yaml: base: missing required key"),
            std::string::npos);
  EXPECT_NE(error("name: x\nbase: base.yaml\n").find("sweep.yaml: axes: missing required key"),
            std::string::npos);
  EXPECT_NE(error("name: x\nbase: base.yaml\naxes: {seed: []}\n")
                .find("sweep.yaml: axes.seed: expected a non-empty list"),
            std::string::npos);
  EXPECT_NE(error("name: x\nbase: nope.yaml\naxes: {seed: [1]}\n")
                .find("sweep.yaml: base: cannot find the scenario file"),
            std::string::npos);
  EXPECT_NE(
      error("name: X\nbase: base.yaml\naxes: {seed: [1]}\n").find("sweep.yaml: name: expected lowercase"),
      std::string::npos);
  EXPECT_NE(
      error("name: x\nbase: base.yaml\naxes: {seed: [1]}\nmetrics: [seed]\n").find("sweep.yaml: metrics[0]"),
      std::string::npos);
  EXPECT_NE(
      error("name: x\nbase: base.yaml\naxes: {views.0: [{xyz_m: [0, 0, 1]}], views.0.xyz_m: [[0, 0, 2]]}\n")
          .find("overlaps axis views.0"),
      std::string::npos);
  for (const char* bad : {"0/2", "3/2", "1", "1/x", "a/b", "1/2/3", "-1/2", ""}) {
    try {
      parseShard(bad);
      ADD_FAILURE() << bad;
    } catch (const ShardError& e) {
      EXPECT_TRUE(std::string(e.what()).starts_with("--shard: expected K/N")) << e.what();
    }
  }
  EXPECT_EQ(parseShard("2/3").index, 2);
  EXPECT_EQ(parseShard("2/3").count, 3);
  EXPECT_THROW(parseKeep("some"), SweepError);
}

TEST(Sweep, MergeRefusesMissingDuplicatedOrMismatchedShards) {
  const SweepDir d(R"(name: m
base: base.yaml
axes:
  seed: [1, 2, 3, 4]
metrics: [scan.0.valid_fraction]
)");
  const Sweep sweep = loadSweep(d.file);
  const fs::path out = d.dir / "out";
  const auto merge_error = [&] {
    try {
      mergeSweep(sweep, out, false);
    } catch (const SweepError& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  d.run({.shard = Shard{1, 2}});
  EXPECT_NE(merge_error().find("results.shard-2-of-2.csv: missing"), std::string::npos);
  d.run({.shard = Shard{2, 2}});
  EXPECT_EQ(merge_error(), "");
  fs::remove(out / "results.csv");
  const fs::path second = out / "results.shard-2-of-2.csv";
  const std::string good = slurp(second);
  // Run 3 removed: missing.
  spit(second, good.substr(0, good.rfind("\n3,") + 1));
  EXPECT_NE(merge_error().find("run 3 is missing"), std::string::npos) << merge_error();
  // Run 1 twice: duplicated.
  spit(second, good + good.substr(good.find("\n1,") + 1, good.find("\n3,") - good.find("\n1,")));
  EXPECT_NE(merge_error().find("run 1 is duplicated"), std::string::npos) << merge_error();
  // Another header.
  spit(second, "run,seed,scan.0.rays" + good.substr(good.find('\n')));
  EXPECT_NE(merge_error().find("header differs"), std::string::npos) << merge_error();
  // A run in the wrong shard.
  spit(second, good + "2,3,1\n");
  EXPECT_NE(merge_error().find("run 2 belongs to shard 1 of 2"), std::string::npos) << merge_error();
  // Stale shards of another split.
  spit(second, good);
  spit(out / "results.shard-1-of-3.csv", good);
  EXPECT_NE(merge_error().find("shards of different splits"), std::string::npos) << merge_error();
  EXPECT_FALSE(fs::exists(out / "results.csv"));  // nothing written by a failed merge
}

// Every example scenario survives the YAML round trip a sweep makes (set a key, write, read).
TEST(Sweep, ExampleScenariosRoundTrip) {
  const fs::path scenarios = fs::path(AMBLER_SOURCE_DIR) / "scenarios";
  int checked = 0;
  for (const auto& entry : fs::directory_iterator(scenarios)) {
    if (entry.path().extension() != ".yaml") continue;
    const std::string text = slurp(entry.path());
    if (text.find("\nterrain:") == std::string::npos && !text.starts_with("terrain:"))
      continue;  // a sweep file
    const test::TempDir t;
    spit(t.dir / "sweep.yaml", "name: rt\nbase: " + entry.path().string() + "\naxes: {seed: [5]}\n");
    const Sweep sweep = loadSweep(t.dir / "sweep.yaml");
    Scenario expected = loadScenario(entry.path());
    expected.name = "rt_0";
    expected.seed = 5;
    EXPECT_EQ(resolvedYaml(sweep.runs.at(0)), resolvedYaml(expected)) << entry.path();
    ++checked;
  }
  EXPECT_GE(checked, 4);
}

}  // namespace
}  // namespace ambler::eval
