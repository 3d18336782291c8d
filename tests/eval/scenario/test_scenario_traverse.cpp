// The traverse section (eval/scenario/scenario_traverse.cpp): every key read, the defaults of the
// struct, the resolved YAML read back bit for bit, and each refusal one line that names the file
// and the key.
#include <gtest/gtest.h>
#include <unistd.h>

#include <bit>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <string>

#include "eval/scenario/scenario.hpp"
#include "scenario_errors.hpp"

namespace ambler::eval {
namespace {

namespace fs = std::filesystem;

using scenario_test::kFile;
// A 70 x 24 m plane (x in [-35, 35], y in [-12, 12]) with a map section; the traverse follows.
const std::string kHead = "name: t\nterrain: {kind: plane, size_m: [70, 24], cell_m: 0.1}\nmap: {}\n";
const std::string kLine = "{start_xy_m: [-25, 0], heading_deg: 0, length_m: 50}";

std::string withTraverse(const std::string& traverse) { return kHead + "traverse: " + traverse + "\n"; }
std::string withPath(const std::string& path, const std::string& more = "") {
  return withTraverse("{path: " + path + (more.empty() ? "" : ", " + more) + "}");
}

double deg(double d) { return d * std::numbers::pi / 180.0; }
std::uint64_t bits(double v) { return std::bit_cast<std::uint64_t>(v); }

using scenario_test::errorOf;
using scenario_test::expectError;

// Every field of the two traverses, bit for bit.
void expectSameTraverse(const TraverseSpec& a, const TraverseSpec& b) {
  ASSERT_EQ(a.waypoints_xy_m.size(), b.waypoints_xy_m.size());
  for (std::size_t k = 0; k < a.waypoints_xy_m.size(); ++k) {
    EXPECT_EQ(bits(a.waypoints_xy_m[k].x()), bits(b.waypoints_xy_m[k].x())) << k;
    EXPECT_EQ(bits(a.waypoints_xy_m[k].y()), bits(b.waypoints_xy_m[k].y())) << k;
  }
  EXPECT_EQ(bits(a.stop_spacing_m), bits(b.stop_spacing_m));
  EXPECT_EQ(bits(a.footprint_radius_m), bits(b.footprint_radius_m));
  EXPECT_EQ(bits(a.mount.height_m), bits(b.mount.height_m));
  EXPECT_EQ(bits(a.mount.pitch_rad), bits(b.mount.pitch_rad));
  EXPECT_EQ(bits(a.odometry.translation_sigma_per_m), bits(b.odometry.translation_sigma_per_m));
  EXPECT_EQ(bits(a.odometry.heading_sigma_deg_per_m), bits(b.odometry.heading_sigma_deg_per_m));
  EXPECT_EQ(bits(a.odometry.translation_bias), bits(b.odometry.translation_bias));
  EXPECT_EQ(bits(a.odometry.heading_bias_deg_per_m), bits(b.odometry.heading_bias_deg_per_m));
  EXPECT_EQ(bits(a.drift.translation_sigma_per_m), bits(b.drift.translation_sigma_per_m));
  EXPECT_EQ(bits(a.drift.vertical_sigma_per_m), bits(b.drift.vertical_sigma_per_m));
  EXPECT_EQ(bits(a.drift.heading_sigma_deg_per_sqrt_m), bits(b.drift.heading_sigma_deg_per_sqrt_m));
  EXPECT_EQ(a.drift.shared, b.drift.shared);
  EXPECT_EQ(a.reg, b.reg);
  EXPECT_EQ(a.method, b.method);
}

// parseScenario(resolvedYaml(s)) gives the same traverse, and resolving again the same bytes.
void expectRoundTrip(const Scenario& s) {
  const std::string resolved = resolvedYaml(s);
  SCOPED_TRACE(resolved);
  const Scenario back = parseScenario(resolved, s.file);
  ASSERT_TRUE(back.traverse.has_value());
  expectSameTraverse(*s.traverse, *back.traverse);
  EXPECT_TRUE(back.views.empty());
  EXPECT_EQ(resolvedYaml(back), resolved);
}

TEST(ScenarioTraverse, EveryKeyIsRead) {
  const Scenario s = parseScenario(
      withTraverse("{path: {waypoints_xy_m: [[-20, -5], [0, 0], [20, 5.5]]}, stop_spacing_m: 0.5, footprint_radius_m: 0.8, "
                   "mount: {height_m: 2.5, pitch_deg: -35}, odometry: {translation_sigma_per_m: 0.03, "
                   "heading_sigma_deg_per_m: 0.25, translation_bias: -0.05, heading_bias_deg_per_m: 0.1}, "
                   "drift: {translation_sigma_per_m: 0.004, vertical_sigma_per_m: 0.0007, heading_sigma_deg_per_sqrt_m: 0.09, shared: false}, "
                   "register: previous, method: features+iconic_robust}"),
      kFile);
  ASSERT_TRUE(s.traverse.has_value());
  EXPECT_TRUE(s.views.empty());
  const TraverseSpec& t = *s.traverse;
  ASSERT_EQ(t.waypoints_xy_m.size(), 3u);
  EXPECT_EQ(t.waypoints_xy_m[0], Eigen::Vector2d(-20, -5));
  EXPECT_EQ(t.waypoints_xy_m[1], Eigen::Vector2d(0, 0));
  EXPECT_EQ(t.waypoints_xy_m[2], Eigen::Vector2d(20, 5.5));
  EXPECT_EQ(t.stop_spacing_m, 0.5);
  EXPECT_EQ(t.footprint_radius_m, 0.8);
  EXPECT_EQ(t.mount.height_m, 2.5);
  EXPECT_EQ(bits(t.mount.pitch_rad), bits(deg(-35)));  // degrees in the file, radians in the struct
  EXPECT_EQ(t.odometry.translation_sigma_per_m, 0.03);
  EXPECT_EQ(t.odometry.heading_sigma_deg_per_m, 0.25);  // degrees in both
  EXPECT_EQ(t.odometry.translation_bias, -0.05);
  EXPECT_EQ(t.odometry.heading_bias_deg_per_m, 0.1);
  EXPECT_EQ(t.drift.translation_sigma_per_m, 0.004);
  EXPECT_EQ(t.drift.vertical_sigma_per_m, 0.0007);
  EXPECT_EQ(t.drift.heading_sigma_deg_per_sqrt_m, 0.09);
  EXPECT_FALSE(t.drift.shared);
  EXPECT_EQ(t.reg, TraverseRegister::Previous);
  EXPECT_EQ(t.method, MatchMethod::FeaturesIconicRobust);
  expectRoundTrip(s);
  for (const auto& [word, reg] : {std::pair{"composite", TraverseRegister::Composite},
                                  std::pair{"previous", TraverseRegister::Previous},
                                  std::pair{"none", TraverseRegister::None}}) {
    EXPECT_EQ(parseScenario(withPath(kLine, std::string("register: ") + word), kFile).traverse->reg, reg) << word;
    EXPECT_STREQ(traverseRegisterName(reg), word);
  }
  // Every method of the paper's that matching.methods takes; the peers match two scans' returns,
  // not a view against a composite, and are refused.
  for (const char* name : {"features", "iconic", "features+iconic", "iconic_robust", "features+iconic_robust", "iconic_lm",
                           "features+iconic_lm", "iconic_weighted", "features+iconic_weighted"})
    EXPECT_STREQ(matchMethodName(parseScenario(withPath(kLine, std::string("method: ") + name), kFile).traverse->method),
                 name);
  for (const char* name : {"icp_point_to_plane", "gicp", "fgr"})
    expectError(withPath(kLine, std::string("method: ") + name), "traverse.method",
                std::string("the Open3D peers do not register a traverse yet (they match two scans' returns, not a view "
                            "against the composite); got ") + name);
}

// The start, heading and length form is the two points it makes: heading from world x,
// counter-clockwise, exact at multiples of 90°.
TEST(ScenarioTraverse, StartHeadingAndLengthMakeTwoWaypoints) {
  const auto ends = [](const std::string& path) { return parseScenario(withPath(path), kFile).traverse->waypoints_xy_m; };
  const auto line = ends(kLine);
  ASSERT_EQ(line.size(), 2u);
  EXPECT_EQ(line[0], Eigen::Vector2d(-25, 0));
  EXPECT_EQ(line[1], Eigen::Vector2d(25, 0));
  EXPECT_EQ(ends("{start_xy_m: [3, -10], heading_deg: 90, length_m: 20}")[1], Eigen::Vector2d(3, 10));
  EXPECT_EQ(ends("{start_xy_m: [3, 10], heading_deg: -90, length_m: 20}")[1], Eigen::Vector2d(3, -10));
  EXPECT_EQ(ends("{start_xy_m: [3, 10], heading_deg: 270, length_m: 20}")[1], Eigen::Vector2d(3, -10));
  EXPECT_EQ(ends("{start_xy_m: [20, 1], heading_deg: 180, length_m: 40}")[1], Eigen::Vector2d(-20, 1));
  EXPECT_EQ(ends("{start_xy_m: [-20, 1], heading_deg: -360, length_m: 40}")[1], Eigen::Vector2d(20, 1));
  const Eigen::Vector2d end = ends("{start_xy_m: [-10, -5], heading_deg: 30, length_m: 20}")[1];
  EXPECT_NEAR(end.x(), -10 + 20 * std::sqrt(3.0) / 2, 1e-14);
  EXPECT_NEAR(end.y(), -5 + 20 * 0.5, 1e-14);
  // Written back as waypoints, it reads back bit for bit.
  expectRoundTrip(parseScenario(withPath("{start_xy_m: [-10, -5], heading_deg: 30, length_m: 20}"), kFile));
}

TEST(ScenarioTraverse, DefaultsAreTheStructs) {
  const Scenario s = parseScenario(withPath(kLine), kFile);
  ASSERT_TRUE(s.traverse.has_value());
  const TraverseSpec& t = *s.traverse;
  EXPECT_EQ(t.stop_spacing_m, 1.0);
  EXPECT_EQ(t.footprint_radius_m, 1.0);
  EXPECT_EQ(t.mount.height_m, 3.0);
  EXPECT_EQ(bits(t.mount.pitch_rad), bits(deg(-30)));  // what pitch_deg: -30 reads as
  EXPECT_EQ(t.odometry.translation_sigma_per_m, 0.02);
  EXPECT_EQ(t.odometry.heading_sigma_deg_per_m, 0.5);
  EXPECT_EQ(t.odometry.translation_bias, 0.0);
  EXPECT_EQ(t.odometry.heading_bias_deg_per_m, 0.0);
  EXPECT_EQ(t.reg, TraverseRegister::Composite);
  EXPECT_STREQ(matchMethodName(t.method), "features+iconic_lm");
  expectSameTraverse(t, [] {
    TraverseSpec d;
    d.waypoints_xy_m = {{-25, 0}, {25, 0}};
    return d;
  }());
  EXPECT_FALSE(s.matching.has_value());
  const std::string y = resolvedYaml(s);
  for (const char* line : {"traverse:\n", "  path: {waypoints_xy_m: [[-25, 0], [25, 0]]}\n", "  stop_spacing_m: 1\n",
                           "  footprint_radius_m: 1\n", "  mount: {height_m: 3, pitch_deg: -30}\n",
                           "  odometry: {translation_sigma_per_m: 0.02, heading_sigma_deg_per_m: 0.5, translation_bias: 0, "
                           "heading_bias_deg_per_m: 0}\n",
                           "  drift: {translation_sigma_per_m: 0.0033, vertical_sigma_per_m: 0.0003, "
                           "heading_sigma_deg_per_sqrt_m: 0.067, shared: true}\n",
                           "  register: composite\n", "  method: features+iconic_lm\n"})
    EXPECT_NE(y.find(line), std::string::npos) << line << "\n" << y;
  EXPECT_EQ(y.find("views:"), std::string::npos) << y;
  expectRoundTrip(s);
}

TEST(ScenarioTraverse, RefusesUnknownKeysAndWrongTypes) {
  expectError(withPath(kLine, "stop_spacing: 2"), "traverse.stop_spacing", "unknown key (did you mean stop_spacing_m?)");
  expectError(withPath(kLine, "speed_m_s: 2"), "traverse.speed_m_s",
              "unknown key (allowed: path, stop_spacing_m, footprint_radius_m, mount, odometry, drift, register, method)");
  expectError(withPath(kLine, "drift: {heading_sigma_deg_per_m: 0.1}"), "traverse.drift.heading_sigma_deg_per_m",
              "unknown key (did you mean heading_sigma_deg_per_sqrt_m?)");
  expectError(withPath("{start_xy: [0, 0], heading_deg: 0, length_m: 5}"), "traverse.path.start_xy",
              "unknown key (did you mean start_xy_m?)");
  expectError(withPath(kLine, "mount: {pitch_rad: -0.5}"), "traverse.mount.pitch_rad", "unknown key (did you mean pitch_deg?)");
  expectError(withPath(kLine, "odometry: {translation_sigma_per: 0.01}"), "traverse.odometry.translation_sigma_per",
              "unknown key (did you mean translation_sigma_per_m?)");
  expectError(withPath(kLine, "stop_spacing_m: \"1\""), "traverse.stop_spacing_m", "expected a number > 0, got the string '1'");
  expectError(withPath(kLine, "register: sideways"), "traverse.register",
              "expected one of composite, previous, none, got 'sideways'");
  expectError(withPath(kLine, "register: previus"), "traverse.register", "(did you mean previous?)");
  expectError(withPath(kLine, "method: iconik"), "traverse.method", "(did you mean iconic?)");
  expectError(withPath(kLine, "method: [iconic_lm]"), "traverse.method", "got a list of 1");
  expectError(withTraverse("{path: [[0, 0], [1, 0]]}"), "traverse.path", "expected a mapping, got a list of 2");
  expectError(withPath(kLine, "mount: 3"), "traverse.mount", "expected a mapping, got 3");
  expectError(kHead + "traverse:\n", "traverse", "expected a mapping, got nothing");
  expectError(withTraverse("{stop_spacing_m: 1}"), "traverse.path", "missing required key");
}

TEST(ScenarioTraverse, RefusesValuesOutOfRange) {
  expectError(withPath("{start_xy_m: [0, 0], heading_deg: 0, length_m: 0}"), "traverse.path.length_m",
              "expected a number > 0, got 0");
  expectError(withPath("{start_xy_m: [0, 0], heading_deg: 400, length_m: 5}"), "traverse.path.heading_deg",
              "expected a number in [-360, 360], got 400");
  expectError(withPath(kLine, "stop_spacing_m: 0"), "traverse.stop_spacing_m", "expected a number > 0, got 0");
  expectError(withPath(kLine, "drift: {vertical_sigma_per_m: -0.001}"), "traverse.drift.vertical_sigma_per_m",
              "expected a number >= 0, got -0.001");
  expectError(withPath(kLine, "footprint_radius_m: -1"), "traverse.footprint_radius_m", "expected a number > 0, got -1");
  expectError(withPath(kLine, "mount: {height_m: 0}"), "traverse.mount.height_m", "expected a number > 0, got 0");
  expectError(withPath(kLine, "mount: {pitch_deg: -90}"), "traverse.mount.pitch_deg",
              "expected a number in (-90, 90), got -90");
  expectError(withPath(kLine, "mount: {pitch_deg: 90}"), "traverse.mount.pitch_deg", "expected a number in (-90, 90), got 90");
  expectError(withPath(kLine, "odometry: {translation_sigma_per_m: -0.01}"), "traverse.odometry.translation_sigma_per_m",
              "expected a number >= 0, got -0.01");
  expectError(withPath(kLine, "odometry: {heading_sigma_deg_per_m: -1}"), "traverse.odometry.heading_sigma_deg_per_m",
              "expected a number >= 0, got -1");
  expectError(withPath(kLine, "odometry: {translation_bias: 1}"), "traverse.odometry.translation_bias",
              "expected a number in (-1, 1), got 1");
  expectError(withPath(kLine, "odometry: {translation_bias: -1}"), "traverse.odometry.translation_bias",
              "expected a number in (-1, 1), got -1");
  // Zero errors are allowed: odometry that measures the steps exactly.
  const Scenario exact =
      parseScenario(withPath(kLine, "odometry: {translation_sigma_per_m: 0, heading_sigma_deg_per_m: 0}"), kFile);
  EXPECT_EQ(exact.traverse->odometry.translation_sigma_per_m, 0.0);
  // Not finite.
  expectError(withPath(kLine, "stop_spacing_m: .nan"), "traverse.stop_spacing_m", "expected a finite number > 0, got .nan");
  expectError(withPath(kLine, "odometry: {heading_bias_deg_per_m: .inf}"), "traverse.odometry.heading_bias_deg_per_m",
              "expected a finite number, got .inf");
  expectError(withPath("{start_xy_m: [.nan, 0], heading_deg: 0, length_m: 5}"), "traverse.path.start_xy_m[0]",
              "expected a finite number, got .nan");
  expectError(withPath("{waypoints_xy_m: [[0, 0], [1, nan]]}"), "traverse.path.waypoints_xy_m[1][1]",
              "expected a finite number, got nan");
}

// A path is one form or the other, whole; waypoints are at least two, each different from the one
// before; the stops fit on it.
TEST(ScenarioTraverse, RefusesBadPaths) {
  expectError(withPath("{start_xy_m: [0, 0], heading_deg: 0, length_m: 5, waypoints_xy_m: [[0, 0], [1, 0]]}"), "traverse.path",
              "expected start_xy_m, heading_deg and length_m, or waypoints_xy_m, got both forms");
  expectError(withPath("{}"), "traverse.path", "expected start_xy_m, heading_deg and length_m, or waypoints_xy_m, got neither");
  expectError(withPath("{start_xy_m: [0, 0], length_m: 5}"), "traverse.path.heading_deg",
              "missing required key (start_xy_m, heading_deg and length_m go together)");
  expectError(withPath("{heading_deg: 0}"), "traverse.path.start_xy_m", "missing required key");
  expectError(withPath("{waypoints_xy_m: [[0, 0]]}"), "traverse.path.waypoints_xy_m",
              "expected a list of at least 2 points [x, y], got a list of 1");
  expectError(withPath("{waypoints_xy_m: 3}"), "traverse.path.waypoints_xy_m", "expected a list of at least 2 points");
  expectError(withPath("{waypoints_xy_m: [[0, 0], [1, 0, 0]]}"), "traverse.path.waypoints_xy_m[1]",
              "expected a list of 2 numbers, got a list of 3");
  expectError(withPath("{waypoints_xy_m: [[0, 0], [1, 0], [1, 0]]}"), "traverse.path.waypoints_xy_m[2]",
              "expected a point other than the one before (a path has no zero-length segment), got [1, 0] twice");
  // A point may come back later: only consecutive points must differ.
  EXPECT_EQ(parseScenario(withPath("{waypoints_xy_m: [[0, 0], [1, 0], [0, 0]]}"), kFile).traverse->waypoints_xy_m.size(), 3u);
  expectError(withPath("{start_xy_m: [0, 0], heading_deg: 0, length_m: 0.5}"), "traverse.stop_spacing_m",
              "expected at most the path's length (0.5), got 1 (the default)");
  expectError(withPath("{waypoints_xy_m: [[0, 0], [3, 4], [3, 5]]}", "stop_spacing_m: 7"), "traverse.stop_spacing_m",
              "expected at most the path's length (6), got 7");
  const Scenario whole = parseScenario(withPath("{waypoints_xy_m: [[0, 0], [3, 4], [3, 5]]}", "stop_spacing_m: 6"), kFile);
  EXPECT_EQ(whole.traverse->stop_spacing_m, 6.0);
  expectError(withPath(kLine, "stop_spacing_m: 0.0001"), "traverse.stop_spacing_m",
              "expected at most 100000 stops (length / spacing), got 50 / 0.0001");
}

// The path lies on the terrain with a footprint radius to spare: the 70 x 24 m plane leaves
// x in [-34, 34] and y in [-11, 11] for the default radius of 1 m.
TEST(ScenarioTraverse, PathStaysOnTheTerrain) {
  EXPECT_EQ(errorOf(withPath("{start_xy_m: [-40, 0], heading_deg: 0, length_m: 50}")),
            kFile + ": traverse.path.start_xy_m: expected the start within the terrain less the footprint radius 1 "
                    "(x in [-34, 34], y in [-11, 11]), got [-40, 0]");
  EXPECT_EQ(errorOf(withPath("{start_xy_m: [-25, 0], heading_deg: 0, length_m: 60}")),
            kFile + ": traverse.path.length_m: expected the path's end within the terrain less the footprint radius 1 "
                    "(x in [-34, 34], y in [-11, 11]), got the end at [35, 0]");
  expectError(withPath("{waypoints_xy_m: [[0, 0], [0, 11.5], [5, 0]]}"), "traverse.path.waypoints_xy_m[1]",
              "expected a point within the terrain less the footprint radius 1 (x in [-34, 34], y in [-11, 11]), "
              "got [0, 11.5]");
  // The edges of that box are on it.
  EXPECT_TRUE(parseScenario(withPath("{waypoints_xy_m: [[-34, -11], [34, 11]]}"), kFile).traverse.has_value());
  // A larger footprint shrinks the box.
  expectError(withPath("{waypoints_xy_m: [[-33.5, 0], [0, 0]]}", "footprint_radius_m: 2"), "traverse.path.waypoints_xy_m[0]",
              "(x in [-33, 33], y in [-10, 10]), got [-33.5, 0]");
  expectError(withPath(kLine, "footprint_radius_m: 13"), "traverse.footprint_radius_m",
              "expected at most half the terrain's smaller side (12), got 13");
  // The body stands on the terrain's surface, which an MJCF world does not give: refused.
  const fs::path dir = fs::temp_directory_path() / ("ambler-test-traverse-" + std::to_string(::getpid()));
  fs::create_directories(dir);
  std::ofstream(dir / "w.xml") << "<mujoco/>\n";
  try {
    parseScenario("name: t\nterrain: {kind: mjcf, mjcf: w.xml}\nmap: {}\n"
                  "traverse: {path: {waypoints_xy_m: [[-500, 0], [500, 0]]}}\n",
                  dir / "x.yaml");
    ADD_FAILURE() << "an MJCF world under a traverse was taken";
  } catch (const ScenarioError& e) {
    EXPECT_NE(std::string(e.what()).find("terrain.kind: a traverse stands its body on a generated terrain or a DEM"),
              std::string::npos) << e.what();
  }
  fs::remove_all(dir);
}

// A traverse generates its views and merges its stops itself; footfalls and the leg are not
// supported in one; its matching section gives success bounds and the odometry model alone.
TEST(ScenarioTraverse, SectionsBesideATraverse) {
  const std::string t = "traverse: {path: " + kLine + "}\n";
  EXPECT_EQ(errorOf(kHead + "views: [{xyz_m: [0, 0, 3]}]\n" + t),
            kFile + ": views: a traverse generates its views, one per stop; remove views");
  EXPECT_EQ(errorOf(kHead + t + "merge: {}\n"),
            kFile + ": merge: a traverse merges every stop into its running composite; remove merge");
  expectError(kHead + t + "footfall: {}\n", "footfall", "not yet supported in a traverse");
  expectError(kHead + t + "leg: {}\n", "leg", "not yet supported in a traverse");
  EXPECT_EQ(errorOf(kHead + t + "matching: {pairs: [[0, 1]]}\n"),
            kFile + ": matching.pairs: a traverse registers each stop as traverse.register says; remove pairs");
  expectError(kHead + t + "matching: {methods: [iconic_lm]}\n", "matching.methods", "traverse.method; remove methods");
  expectError(kHead + t + "matching: {initial_error: {xyz_m: [0.1, 0, 0]}}\n", "matching.initial_error",
              "traverse.odometry; remove initial_error");
  expectError(kHead + t + "matching: {draw_initial_error: true}\n", "matching.draw_initial_error", "remove draw_initial_error");
  expectError(kHead + t + "matching: {prior: {translation_m: 1}}\n", "matching.prior", "not yet supported in a traverse");
  expectError(kHead + t + "matching: {gate: prior}\n", "matching.gate", "not yet supported in a traverse");
  expectError(kHead + t + "matching: {succes: {}}\n", "matching.succes", "unknown key (did you mean success?)");
  // Success bounds and the odometry model are taken, and written back alone.
  const std::string matching =
      "matching: {success: {translation_m: 0.1, rotation_deg: 1}, odometry: {translation_per_m: 0.05, "
      "translation_floor_m: 0.02, heading_deg_per_m: 1, heading_floor_deg: 0.2}}\n";
  const Scenario m = parseScenario(kHead + t + matching, kFile);
  ASSERT_TRUE(m.matching.has_value());
  EXPECT_EQ(m.matching->success_translation_m, 0.1);
  EXPECT_EQ(m.matching->success_rotation_deg, 1.0);
  EXPECT_EQ(m.matching->odometry.translation_per_m, 0.05);
  EXPECT_EQ(m.matching->odometry.heading_floor_deg, 0.2);
  EXPECT_TRUE(m.matching->pairs.empty());
  const std::string y = resolvedYaml(m);
  EXPECT_NE(y.find("matching:\n  success: {translation_m: 0.1, rotation_deg: 1}\n  odometry: {translation_per_m: 0.05, "
                   "translation_floor_m: 0.02, heading_deg_per_m: 1, heading_floor_deg: 0.2}\n"),
            std::string::npos)
      << y;
  const Scenario back = parseScenario(y, kFile);
  EXPECT_EQ(back.matching->odometry.translation_floor_m, 0.02);
  EXPECT_EQ(resolvedYaml(back), y);
  // Registration goes through the maps: composite and previous need a map section; none does not.
  const std::string no_map = "name: t\nterrain: {kind: plane, size_m: [70, 24], cell_m: 0.1}\n";
  EXPECT_EQ(errorOf(no_map + t),
            kFile + ": traverse.register: composite needs a map section: each stop is registered through its map "
                    "(or register: none)");
  expectError(no_map + "traverse: {path: " + kLine + ", register: previous}\n", "traverse.register",
              "previous needs a map section");
  EXPECT_FALSE(parseScenario(no_map + "traverse: {path: " + kLine + ", register: none}\n", kFile).map.has_value());
  expectError(no_map + "traverse: {path: " + kLine + ", register: none}\nmatching: {}\n", "matching", "needs a map section");
  // Without a traverse, views are required as ever.
  expectError(no_map, "views", "missing required key");
}

// scenarios/traverse.yaml: the 50 m example of docs/scenario.md.
TEST(ScenarioTraverse, ExampleIsTheDocumentedOne) {
  const Scenario s = loadScenario(fs::path(AMBLER_SOURCE_DIR) / "scenarios" / "traverse.yaml");
  ASSERT_TRUE(s.traverse.has_value());
  EXPECT_TRUE(s.views.empty());
  EXPECT_EQ(s.terrain.kind, terrains::TerrainKind::Mars);
  EXPECT_EQ(s.terrain.size_m, Eigen::Vector2d(70, 24));
  EXPECT_TRUE(s.terrain.rocks && s.terrain.craters && s.terrain.craters->count > 0);
  const perception::SensorModel erim;
  EXPECT_EQ(s.sensor.rows, erim.rows);
  EXPECT_EQ(s.sensor.cols, erim.cols);
  EXPECT_EQ(s.sensor.fov_v_rad, erim.fov_v_rad);
  EXPECT_EQ(s.sensor.quantization_m, erim.quantization_m);
  EXPECT_EQ(s.sensor.ambiguity_m, erim.ambiguity_m);
  ASSERT_TRUE(s.map.has_value());
  EXPECT_EQ(s.map->cell_m, 0.10);
  const TraverseSpec& t = *s.traverse;
  ASSERT_EQ(t.waypoints_xy_m.size(), 2u);
  EXPECT_EQ(t.waypoints_xy_m[0], Eigen::Vector2d(-25, 0));
  EXPECT_EQ(t.waypoints_xy_m[1], Eigen::Vector2d(25, 0));
  EXPECT_EQ(t.stop_spacing_m, 1.0);
  EXPECT_EQ(t.reg, TraverseRegister::Composite);
  EXPECT_EQ(t.method, MatchMethod::FeaturesLm);
  expectRoundTrip(s);
}

}  // namespace
}  // namespace ambler::eval
