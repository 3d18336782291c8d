// `ambler report` (docs/report.md) against ground truth. Runs: every PNG of the run is embedded
// exactly once and decodes to the file's bytes, nothing points outside the file, a section appears
// iff its stage ran, the tables show metrics.json's values, the goals rows pass or fail as the
// values say, and the same run directory gives the same bytes. Hand-made sweep and basin
// directories: plots, goal counts, worst runs and links, success rates. Base64 against RFC 4648's
// test vectors.
#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "eval/scenario/io.hpp"
#include "eval/tools/report/report.hpp"
#include "eval/run/runner.hpp"
#include "eval/scenario/scenario.hpp"
#include "test_support.hpp"
#include "two_view_mars.hpp"

namespace ambler::eval {
namespace {

namespace fs = std::filesystem;
using test::slurp;

// RFC 4648 §4 decoding, written apart from the encoder; throws on a character outside the alphabet.
std::string base64Decode(const std::string& text) {
  static const std::string alphabet = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  unsigned buffer = 0;
  int bits = 0;
  for (const char c : text) {
    if (c == '=') break;
    const size_t v = alphabet.find(c);
    if (v == std::string::npos) throw std::runtime_error("not base64");
    buffer = (buffer << 6) | unsigned(v);
    bits += 6;
    if (bits >= 8) {
      bits -= 8;
      out += char((buffer >> bits) & 0xFF);
    }
  }
  return out;
}

std::size_t count(const std::string& haystack, const std::string& needle) {
  std::size_t n = 0;
  for (std::size_t at = haystack.find(needle); at != std::string::npos; at = haystack.find(needle, at + 1)) ++n;
  return n;
}

std::string g4(double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.4g", v);
  return buf;
}

// The cells (plain <td>) of the table row `metric` of the table captioned `caption`.
std::vector<std::string> row(const std::string& html, const std::string& caption, const std::string& metric) {
  const size_t table = html.find("<caption>" + caption + "</caption>");
  if (table == std::string::npos) return {};
  const size_t end = html.find("</table>", table);
  const size_t at = html.find("<tr><th>" + metric + "</th>", table);
  if (at == std::string::npos || at > end) return {};
  const size_t row_end = html.find("</tr>", at);
  const std::string r = html.substr(at, row_end - at);
  std::vector<std::string> cells;
  for (size_t td = r.find("<td>"); td != std::string::npos; td = r.find("<td>", td + 1))
    cells.push_back(r.substr(td + 4, r.find("</td>", td) - td - 4));
  return cells;
}

// The small two-view Mars scene, mapped, with fewer rocks and the kind's craters; `extra` adds
// stages.
std::string scenario(const std::string& name, const std::string& extra) {
  test::TwoViewMars scene = test::TwoViewMars::small();
  scene.name = name;
  scene.seed = 3;
  scene.rocks = "{abundance_k: 0.05, min_diameter_m: 0.15, max_diameter_m: 0.6}";
  scene.craters = "";
  scene.view1 = "{xyz_m: [0.3, -3.3, 2.0], rpy_deg: [0, -30, 4]}";
  scene.map_region = "{x_m: [-2, 2], y_m: [-2, 3]}";
  scene.map_baseline = "";
  return scene.yaml() + extra;
}

// Every PNG under `dir`, as paths relative to it.
std::vector<fs::path> pngs(const fs::path& dir) {
  std::vector<fs::path> out;
  for (const auto& e : fs::recursive_directory_iterator(dir))
    if (e.is_regular_file() && e.path().extension() == ".png") out.push_back(fs::relative(e.path(), dir));
  return out;
}

void checkEmbedsEveryPictureOnceAndNothingOutside(const fs::path& run, const std::string& html) {
  const auto files = pngs(run);
  ASSERT_FALSE(files.empty());
  // Every data URI, decoded; each PNG's bytes appear exactly once among them.
  std::vector<std::string> decoded;
  const std::string prefix = "src=\"data:image/png;base64,";  // (std::regex recurses per character)
  for (size_t at = html.find(prefix); at != std::string::npos; at = html.find(prefix, at + 1)) {
    const size_t begin = at + prefix.size(), end = html.find('"', begin);
    ASSERT_NE(end, std::string::npos);
    decoded.push_back(base64Decode(html.substr(begin, end - begin)));
  }
  EXPECT_EQ(decoded.size(), files.size());
  for (const fs::path& f : files) {
    const std::string bytes = slurp(run / f);
    EXPECT_EQ(std::count(decoded.begin(), decoded.end(), bytes), 1) << f;
    EXPECT_EQ(count(html, "<figcaption>" + f.generic_string() + "</figcaption>"), 1u) << f;
  }
  // Nothing from the network or another file.
  EXPECT_EQ(html.find("http://"), std::string::npos);
  EXPECT_EQ(html.find("https://"), std::string::npos);
  EXPECT_EQ(count(html, "src=\""), count(html, "src=\"data:"));
  EXPECT_EQ(html.find("<script"), std::string::npos);
  EXPECT_EQ(html.find("<link"), std::string::npos);
  EXPECT_EQ(html.find("url("), std::string::npos);
}

bool hasSection(const std::string& html, const std::string& id) {
  return html.find("<h2 id=\"" + id + "\">") != std::string::npos;
}

TEST(Report, Base64MatchesRfc4648TestVectors) {
  const std::map<std::string, std::string> vectors = {{"", ""},         {"f", "Zg=="},         {"fo", "Zm8="},
                                                      {"foo", "Zm9v"},  {"foob", "Zm9vYg=="},   {"fooba", "Zm9vYmE="},
                                                      {"foobar", "Zm9vYmFy"}};
  for (const auto& [in, out] : vectors) EXPECT_EQ(base64Encode(in), out) << '"' << in << '"';
  // Every byte value survives.
  std::string all;
  for (int b = 0; b < 256; ++b) all += char(b);
  EXPECT_EQ(base64Decode(base64Encode(all)), all);
}

TEST(Report, HtmlEscapeEscapesMarkup) {
  EXPECT_EQ(htmlEscape("a<b>&\"c'"), "a&lt;b&gt;&amp;&quot;c&#39;");
}

// A run with map only: World, Scans and Maps, no Matching, Footfalls or Leg; every picture once;
// the values of metrics.json; the scenario escaped in a <pre>; the same bytes twice.
TEST(Report, MapRunHasItsStagesOnlyAndEveryPicture) {
  test::TempDir tmp;
  const fs::path run = tmp.dir / "run";
  const auto metrics = runScenario(parseScenario(scenario("report_map", ""), "inline.yaml"), {run, false});
  const fs::path out = writeRunReport(run, tmp.dir / "a.html");
  EXPECT_EQ(out, tmp.dir / "a.html");
  const std::string html = slurp(out);
  checkEmbedsEveryPictureOnceAndNothingOutside(run, html);

  for (const char* id : {"scenario", "run", "world", "scans", "maps"}) EXPECT_TRUE(hasSection(html, id)) << id;
  for (const char* id : {"matching", "footfalls", "leg", "other"}) EXPECT_FALSE(hasSection(html, id)) << id;

  // The scenario as written, escaped.
  EXPECT_NE(html.find("<pre>" + htmlEscape(slurp(run / "scenario.resolved.yaml")) + "</pre>"), std::string::npos);

  // Tables: one column per view, metrics.json's values to 4 significant digits.
  ASSERT_EQ(metrics["map"].size(), 2u);
  std::vector<std::string> coverage, rms;
  for (const auto& m : metrics["map"]) {
    coverage.push_back(g4(m["coverage"].get<double>()));
    rms.push_back(m["rms_error_m"].is_null() ? "\xE2\x80\x94" : g4(m["rms_error_m"].get<double>()));
  }
  EXPECT_EQ(row(html, "map", "coverage"), coverage);
  EXPECT_EQ(row(html, "map", "rms_error_m"), rms);
  EXPECT_EQ(row(html, "scan", "valid_fraction"),
            (std::vector<std::string>{g4(metrics["scan"][0]["valid_fraction"].get<double>()),
                                      g4(metrics["scan"][1]["valid_fraction"].get<double>())}));
  EXPECT_NE(html.find("<th>view 0</th><th>view 1</th>"), std::string::npos);

  // Deterministic: a second write is the same bytes, and the default name is not among the inputs.
  writeRunReport(run, tmp.dir / "b.html");
  EXPECT_EQ(slurp(tmp.dir / "b.html"), html);
  writeRunReport(run, run / "report.html");
  EXPECT_EQ(slurp(run / "report.html"), html);
  EXPECT_EQ(runReportHtml(run), html);
}

// A run's goals: every registration against the scenario's matching.success, every footfall
// method's leg tilt and slip, pass or fail as the values say.
void expectGoalRow(const std::string& html, const std::string& metric, const std::string& entry,
                   const std::string& value, const std::string& goal, bool pass) {
  const std::string want = "<tr><th>" + metric + "</th><td>" + entry + "</td><td>" + value + "</td><td>" + goal +
                           "</td><td class=\"" + (pass ? "pass\">pass" : "fail\">fail") + "</td>";
  EXPECT_NE(html.find(want), std::string::npos) << want;
}

// With matching, footfalls and the leg: their sections appear, with the registration values.
TEST(Report, MatchingFootfallAndLegRunHasThoseSections) {
  test::TempDir tmp;
  const fs::path run = tmp.dir / "run";
  const auto metrics = runScenario(
      parseScenario(scenario("report_all", R"(matching:
  methods: [iconic_lm]
  initial_error: {xyz_m: [0.1, -0.1, 0.0], rpy_deg: [0, 0, 2]}
footfall: {map: view_0, region: {x_m: [-0.5, 0.5], y_m: [0.5, 1.5]}, methods: [max_min, equilibrium]}
leg: {soil: rock}
)"),
                    "inline.yaml"),
      {run, false});
  const std::string html = slurp(writeRunReport(run, tmp.dir / "r.html"));
  checkEmbedsEveryPictureOnceAndNothingOutside(run, html);
  for (const char* id : {"scenario", "world", "scans", "maps", "matching", "footfalls", "leg"})
    EXPECT_TRUE(hasSection(html, id)) << id;
  const auto& reg = metrics["registration"][0];
  EXPECT_EQ(row(html, "registration", "translation_error_m"),
            std::vector<std::string>{g4(reg["translation_error_m"].get<double>())});
  EXPECT_EQ(row(html, "registration", "success"),
            std::vector<std::string>{reg["success"].get<bool>() ? "true" : "false"});
  EXPECT_NE(html.find("<th>pair 0\xE2\x80\x93" "1 iconic_lm</th>"), std::string::npos);
  ASSERT_EQ(metrics["footfall"].size(), 2u);
  EXPECT_EQ(row(html, "footfall", "score"),
            (std::vector<std::string>{g4(metrics["footfall"][0]["score"].get<double>()),
                                      g4(metrics["footfall"][1]["score"].get<double>())}));
  EXPECT_EQ(row(html, "leg", "tilt_deg"),
            (std::vector<std::string>{g4(metrics["footfall"][0]["leg"]["tilt_deg"].get<double>()),
                                      g4(metrics["footfall"][1]["leg"]["tilt_deg"].get<double>())}));
  EXPECT_EQ(slurp(writeRunReport(run, tmp.dir / "r2.html")), html);

  EXPECT_TRUE(hasSection(html, "goals"));
  expectGoalRow(html, "registration.success", "pair 0\xE2\x80\x93" "1 iconic_lm",
                g4(reg["translation_error_m"].get<double>()) + " m, " + g4(reg["rotation_error_deg"].get<double>()) +
                    "\xC2\xB0",
                "\xE2\x89\xA4 0.05 m and \xE2\x89\xA4 0.5\xC2\xB0", reg["success"].get<bool>());
  for (const auto& f : metrics["footfall"]) {
    const double tilt = f["leg"]["tilt_deg"].get<double>(), slip = f["leg"]["slip_m"].get<double>();
    expectGoalRow(html, "footfall.leg.tilt_deg", f["method"].get<std::string>(), g4(tilt), "\xE2\x89\xA4 5\xC2\xB0",
                  tilt <= 5);
    expectGoalRow(html, "footfall.leg.slip_m", f["method"].get<std::string>(), g4(slip),
                  "\xE2\x89\xA4 0.01 m (1 cm)", slip <= 0.01);
  }
}

TEST(Report, NotARunDirectoryIsRefusedAndNothingIsWritten) {
  test::TempDir tmp;
  for (const fs::path& dir : {tmp.dir / "missing", tmp.dir / "empty"}) {
    if (dir.filename() == "empty") fs::create_directories(dir);
    try {
      writeReport(dir, tmp.dir / "out" / "report.html");
      ADD_FAILURE() << "no error for " << dir;
    } catch (const std::runtime_error& e) {
      EXPECT_EQ(std::string(e.what()),
                dir.string() + ": not a run, sweep or basin directory (no metrics.json, results.csv or basin.csv)");
    }
    try {
      writeRunReport(dir, tmp.dir / "out" / "report.html");
      ADD_FAILURE() << "no error for " << dir;
    } catch (const std::runtime_error& e) {
      EXPECT_EQ(std::string(e.what()), dir.string() + ": not a run directory (no metrics.json)");
    }
    EXPECT_FALSE(fs::exists(tmp.dir / "out"));
  }
}

void write(const fs::path& path, const std::string& text) {
  fs::create_directories(path.parent_path());
  std::ofstream(path, std::ios::binary) << text;
}

// A hand-made sweep directory: 2 noise levels x 2 seeds; runs 2 and 3 kept, run 2 with a report.
fs::path sweepDir(const fs::path& root) {
  const fs::path dir = root / "sweep";
  write(dir / "results.csv",
        "run,sensor.noise_k,seed,map.0.rms_error_m,composite.rms_error_m,registration.0.success,map.0.cells\n"
        "0,0,1,0.01,0.02,true,100\n"
        "1,0,2,0.012,0.025,true,100\n"
        "2,0.001,1,0.03,0.04,false,100\n"
        "3,0.001,2,0.02,0.035,true,100\n");
  write(dir / "sweep.resolved.yaml",
        "name: noise\nbase: \"plane.yaml\"\naxes:\n  sensor.noise_k: [0, 0.001]\n  seed: [1, 2]\n");
  write(dir / "runs" / "2" / "report.html", "<!DOCTYPE html>\n");
  write(dir / "runs" / "3" / "metrics.json", "{}\n");
  return dir;
}

// A sweep: its spec, goal counts, a plot of every varying metric against every axis, the worst
// runs largest first with relative links only to the runs kept, the same bytes twice.
TEST(Report, SweepHasPlotsGoalsAndTheWorstRunsWithLinks) {
  test::TempDir tmp;
  const fs::path dir = sweepDir(tmp.dir);
  EXPECT_EQ(reportKind(dir), ReportKind::Sweep);
  const std::string html = slurp(writeReport(dir, dir / "report.html"));
  EXPECT_NE(html.find("<pre>" + htmlEscape(slurp(dir / "sweep.resolved.yaml")) + "</pre>"), std::string::npos);
  for (const char* id : {"sweep", "goals", "metrics", "plots", "worst"}) EXPECT_TRUE(hasSection(html, id)) << id;
  // 3 metrics vary (map.0.cells does not), 2 axes, but the seed replicates the other: 3 plots,
  // each a PNG data URI, against sensor.noise_k only.
  EXPECT_EQ(count(html, "<img "), 3u);
  EXPECT_EQ(count(html, "src=\"data:image/png;base64,iVBORw0KGgo"), 3u);
  for (const char* m : {"map.0.rms_error_m", "composite.rms_error_m", "registration.0.success"}) {
    EXPECT_EQ(count(html, std::string("<figcaption>") + m +
                              " against sensor.noise_k: median, least and greatest over the runs at each value"
                              "</figcaption>"),
              1u)
        << m;
    EXPECT_EQ(count(html, std::string(m) + " against seed"), 0u) << m;
  }
  EXPECT_EQ(html.find("map.0.cells against"), std::string::npos);
  EXPECT_EQ(row(html, "each numeric metric over the runs", "map.0.cells"),
            (std::vector<std::string>{"100", "100", "100", "4"}));
  EXPECT_EQ(row(html, "each numeric metric over the runs", "map.0.rms_error_m"),
            (std::vector<std::string>{"0.01", "0.016", "0.03", "4"}));
  // Goals: composite RMS <= 3 cm in runs 0 and 1; registration success in 3 of 4.
  EXPECT_EQ(row(html, "runs meeting the goals the docs state", "composite.rms_error_m").at(0), "2 of 4");
  EXPECT_EQ(row(html, "runs meeting the goals the docs state", "registration.0.success").at(0), "3 of 4");
  // The worst runs by map.0.rms_error_m: 2, 3, 1, 0; links to the kept runs 2 and 3 only.
  const size_t worst = html.find("<h2 id=\"worst\">");
  ASSERT_NE(worst, std::string::npos);
  const std::string w = html.substr(worst);
  const size_t r2 = w.find("<tr><th><a href=\"runs/2/\">2</a></th>"), r3 = w.find("<tr><th><a href=\"runs/3/\">3</a></th>"),
               r1 = w.find("<tr><th>1</th>"), r0 = w.find("<tr><th>0</th>");
  ASSERT_NE(r2, std::string::npos);
  ASSERT_NE(r3, std::string::npos);
  ASSERT_NE(r1, std::string::npos);
  ASSERT_NE(r0, std::string::npos);
  EXPECT_LT(r2, r3);
  EXPECT_LT(r3, r1);
  EXPECT_LT(r1, r0);
  EXPECT_EQ(count(html, "<a href=\"runs/2/report.html\">report.html</a>"), 1u);
  EXPECT_EQ(count(html, "href="), 5u + 3u);  // the nav's five, the two runs' directories, run 2's report
  EXPECT_EQ(count(html, "href=\"runs/"), 3u);
  // Nothing from elsewhere.
  EXPECT_EQ(html.find("http"), std::string::npos);
  EXPECT_EQ(html.find("<script"), std::string::npos);
  // Written elsewhere, the links are relative to the report's directory.
  const std::string other = slurp(writeReport(dir, tmp.dir / "elsewhere" / "r.html"));
  EXPECT_NE(other.find("<a href=\"../sweep/runs/2/\">2</a>"), std::string::npos);
  EXPECT_EQ(slurp(writeReport(dir, dir / "again.html")), html);
}

// A hand-made basin: 2 methods, 1 translation x 2 rotations, 2 trials; basin.md; two heatmaps and
// a pair picture.
TEST(Report, BasinHasSuccessRatesItsFiguresAndThePair) {
  test::TempDir tmp;
  const fs::path dir = tmp.dir / "basin";
  write(dir / "basin.csv",
        "method,translation_m,rotation_deg,trial,translation_error_m,rotation_error_deg,success,iterations,time_s\n"
        "features,0,0,0,0.01,0.1,true,0,\nfeatures,0,0,1,0.01,0.1,true,0,\n"
        "features,0,5,0,0.3,2,false,0,\nfeatures,0,5,1,0.01,0.1,true,0,\n"
        "iconic_lm,0,0,0,0.001,0.01,true,7,\niconic_lm,0,0,1,0.001,0.01,true,7,\n"
        "iconic_lm,0,5,0,0.001,0.01,true,9,\niconic_lm,0,5,1,0.001,0.01,true,9,\n");
  write(dir / "basin.md", "<!-- written by `ambler basin` -->\n\nGrid: 0 m x 0, 5 deg.\n\n"
                          "| method | successes |\n|---|---|\n| features | 3/4 |\n| iconic_lm | 4/4 |\n");
  write(dir / "pair" / "scenario.resolved.yaml", "name: b\nmatching:\n  success: {translation_m: 0.05}\n");
  fs::create_directories(dir / "pair" / "maps");
  writePng(dir / "basin_features.png", cv::Mat(20, 30, CV_8UC3, cv::Scalar(10, 20, 30)));
  writePng(dir / "basin_boundary.png", cv::Mat(20, 30, CV_8UC3, cv::Scalar(30, 20, 10)));
  writePng(dir / "pair" / "maps" / "view_0.png", cv::Mat(20, 30, CV_8UC3, cv::Scalar(1, 2, 3)));
  EXPECT_EQ(reportKind(dir), ReportKind::Basin);
  const std::string html = slurp(writeReport(dir, dir / "report.html"));
  checkEmbedsEveryPictureOnceAndNothingOutside(dir, html);
  for (const char* id : {"scenario", "success", "summary", "figures", "pair"}) EXPECT_TRUE(hasSection(html, id)) << id;
  EXPECT_EQ(row(html, "features", "0"), (std::vector<std::string>{"2/2", "1/2"}));
  EXPECT_EQ(row(html, "iconic_lm", "0"), (std::vector<std::string>{"2/2", "2/2"}));
  EXPECT_NE(html.find("<tr><th>features</th><td>1 of 2</td><td>3 of 4</td><td class=\"fail\">fail</td></tr>"),
            std::string::npos);
  EXPECT_NE(html.find("<tr><th>iconic_lm</th><td>2 of 2</td><td>4 of 4</td><td class=\"pass\">pass</td></tr>"),
            std::string::npos);
  EXPECT_NE(html.find("<tr><td>features</td><td>3/4</td></tr>"), std::string::npos);  // basin.md's table
  EXPECT_EQ(html.find("written by"), std::string::npos);                               // its comment is not shown
  EXPECT_LT(html.find("<figcaption>basin_boundary.png"), html.find("<figcaption>basin_features.png"));
  EXPECT_EQ(slurp(writeReport(dir, dir / "again.html")), html);
}


// A metrics.json that is not JSON: one line naming the file, nothing written.
TEST(Report, MetricsThatAreNotJsonAreRefusedNamingTheFile) {
  test::TempDir tmp;
  std::ofstream(tmp.dir / "metrics.json") << "{\"name\": ";
  try {
    writeRunReport(tmp.dir, tmp.dir / "report.html");
    ADD_FAILURE() << "no error";
  } catch (const std::runtime_error& e) {
    const std::string what = e.what();
    EXPECT_EQ(what.rfind((tmp.dir / "metrics.json").string() + ": not JSON (", 0), 0u) << what;
    EXPECT_EQ(what.find('\n'), std::string::npos) << what;
  }
  EXPECT_FALSE(fs::exists(tmp.dir / "report.html"));
}

}  // namespace
}  // namespace ambler::eval
