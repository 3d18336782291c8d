// The `traverse:` section (docs/scenario.md, "traverse"), read as strictly as the rest of the
// scenario (scenario.cpp): the path and its stops, the sensor's mount, the simulated odometry, how
// each stop is registered; and the sections a traverse replaces or does not support.
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "eval/scenario/scenario.hpp"
#include "eval/scenario/scenario_reader.hpp"

namespace ambler::eval {

const char* traverseRegisterName(TraverseRegister r) {
  switch (r) {
    case TraverseRegister::Composite: return "composite";
    case TraverseRegister::Previous: return "previous";
    case TraverseRegister::None: return "none";
  }
  return "?";
}

namespace scenario_detail {
namespace {

using terrains::TerrainKind;

// Bounds the stops so a typo in a spacing cannot exhaust memory (as checkGridSize bounds grids).
constexpr double kMaxStops = 100000;

const char* const kPathForms = "start_xy_m, heading_deg and length_m, or waypoints_xy_m";

// The unit vector at `deg` degrees from world x, counter-clockwise: exact at multiples of 90°, so
// that heading_deg: 90 keeps x and ends on the line the user drew.
Eigen::Vector2d headingVector(double deg) {
  if (std::remainder(deg, 90.0) == 0.0) {
    const long quarter = std::lround(deg / 90.0) % 4;
    switch (quarter < 0 ? quarter + 4 : quarter) {
      case 0: return {1.0, 0.0};
      case 1: return {0.0, 1.0};
      case 2: return {-1.0, 0.0};
      default: return {0.0, -1.0};
    }
  }
  const double rad = degToRad(deg);
  return {std::cos(rad), std::sin(rad)};
}

std::string pointText(const Eigen::Vector2d& p) {
  std::string text(1, '[');  // not "[" + ...: GCC 12 warns falsely on it (-Wrestrict, PR 105651)
  return text + shortest(p.x()) + ", " + shortest(p.y()) + "]";
}

// path: {start_xy_m, heading_deg, length_m}: the two ends of the segment.
std::vector<Eigen::Vector2d> readLine(const Reader& reader, const Fields& f) {
  for (const char* key : {"start_xy_m", "heading_deg", "length_m"})
    if (!f.get(key)) reader.fail(f.pathOf(key), "missing required key (start_xy_m, heading_deg and length_m go together)");
  const auto start = reader.numbers<2>(*f.get("start_xy_m"), f.pathOf("start_xy_m"), kAny);
  const double heading_deg = f.number("heading_deg", {-360.0, 360.0, false, false}, 0.0);
  const double length_m = f.number("length_m", kPositive, 0.0);
  const Eigen::Vector2d from{start[0], start[1]};
  return {from, from + length_m * headingVector(heading_deg)};
}

// path: {waypoints_xy_m: [[x, y], ...]}: at least two, each different from the one before.
std::vector<Eigen::Vector2d> readWaypoints(const Reader& reader, const Fields& f) {
  const YAML::Node list = f.required("waypoints_xy_m");
  const std::string path = f.pathOf("waypoints_xy_m");
  if (!list.IsSequence() || list.size() < 2)
    reader.fail(path, "expected a list of at least 2 points [x, y], got " + shown(list));
  std::vector<Eigen::Vector2d> points;
  for (std::size_t i = 0; i < list.size(); ++i) {
    const std::string where = path + "[" + std::to_string(i) + "]";
    const auto xy = reader.numbers<2>(list[i], where, kAny);
    const Eigen::Vector2d p{xy[0], xy[1]};
    if (!points.empty() && p == points.back())
      reader.fail(where, "expected a point other than the one before (a path has no zero-length segment), got " +
                             pointText(p) + " twice");
    points.push_back(p);
  }
  return points;
}

// The path's points, and whether they came from the start/heading/length form.
struct PathPoints {
  std::vector<Eigen::Vector2d> points;
  bool line = false;
};

PathPoints readPath(const Reader& reader, const YAML::Node& node) {
  const Fields f(reader, node, "traverse.path", {"start_xy_m", "heading_deg", "length_m", "waypoints_xy_m"});
  const bool line = f.get("start_xy_m") || f.get("heading_deg") || f.get("length_m");
  const bool waypoints = f.get("waypoints_xy_m").has_value();
  if (line && waypoints) reader.fail("traverse.path", std::string("expected ") + kPathForms + ", got both forms");
  if (!line && !waypoints) reader.fail("traverse.path", std::string("expected ") + kPathForms + ", got neither");
  return {line ? readLine(reader, f) : readWaypoints(reader, f), line};
}

double pathLength(const std::vector<Eigen::Vector2d>& points) {
  double length = 0.0;
  for (std::size_t i = 1; i < points.size(); ++i) length += (points[i] - points[i - 1]).norm();
  return length;
}

// Every point of the path at least `radius` inside a generated terrain (the extent of its
// heightfield, as readViews takes it), so the body's footprint at every stop lies on the terrain.
// The terrain and the shrunk rectangle are convex: the waypoints inside means the path inside.
void checkPathOverTerrain(const Reader& reader, const PathPoints& path, double radius, const terrains::TerrainSpec& t) {
  if (t.kind == TerrainKind::Mjcf)
    reader.fail("terrain.kind", "a traverse stands its body on a generated terrain or a DEM, not on an MJCF world");
  const double hx = std::round(t.size_m.x() / t.cell_m) * t.cell_m / 2.0 - radius;
  const double hy = std::round(t.size_m.y() / t.cell_m) * t.cell_m / 2.0 - radius;
  const auto m = [](double v) { return shortest(std::round(v * 1e6) / 1e6); };  // 10, not 10.000000000000002
  if (hx < 0 || hy < 0)
    reader.fail("traverse.footprint_radius_m", "expected at most half the terrain's smaller side (" +
                                                   m(std::min(hx, hy) + radius) + "), got " + shortest(radius));
  const std::string box = " within the terrain less the footprint radius " + shortest(radius) + " (x in [" + m(-hx) +
                          ", " + m(hx) + "], y in [" + m(-hy) + ", " + m(hy) + "]), got ";
  for (std::size_t i = 0; i < path.points.size(); ++i) {
    const Eigen::Vector2d& p = path.points[i];
    if (std::abs(p.x()) <= hx && std::abs(p.y()) <= hy) continue;
    if (!path.line)
      reader.fail("traverse.path.waypoints_xy_m[" + std::to_string(i) + "]", "expected a point" + box + pointText(p));
    if (i == 0) reader.fail("traverse.path.start_xy_m", "expected the start" + box + pointText(p));
    reader.fail("traverse.path.length_m", "expected the path's end" + box + "the end at " + pointText(p));
  }
}

void readOdometry(const Reader& reader, const YAML::Node& node, TraverseOdometry& o) {
  const Fields f(reader, node, "traverse.odometry",
                 {"translation_sigma_per_m", "heading_sigma_deg_per_m", "translation_bias", "heading_bias_deg_per_m"});
  o.translation_sigma_per_m = f.number("translation_sigma_per_m", kNonNegative, o.translation_sigma_per_m);
  o.heading_sigma_deg_per_m = f.number("heading_sigma_deg_per_m", kNonNegative, o.heading_sigma_deg_per_m);
  o.translation_bias = f.number("translation_bias", {-1.0, 1.0, true, true}, o.translation_bias);
  o.heading_bias_deg_per_m = f.number("heading_bias_deg_per_m", kAny, o.heading_bias_deg_per_m);
}

void readDrift(const Reader& reader, const YAML::Node& node, perception::LocalisationDrift& d) {
  const Fields f(reader, node, "traverse.drift",
                 {"translation_sigma_per_m", "vertical_sigma_per_m", "heading_sigma_deg_per_sqrt_m", "shared"});
  d.translation_sigma_per_m = f.number("translation_sigma_per_m", kNonNegative, d.translation_sigma_per_m);
  d.vertical_sigma_per_m = f.number("vertical_sigma_per_m", kNonNegative, d.vertical_sigma_per_m);
  d.heading_sigma_deg_per_sqrt_m = f.number("heading_sigma_deg_per_sqrt_m", kNonNegative, d.heading_sigma_deg_per_sqrt_m);
  d.shared = f.boolean("shared", d.shared);
}

}  // namespace

TraverseSpec readTraverse(const Reader& reader, const YAML::Node& node, const terrains::TerrainSpec& terrain) {
  const Fields f(reader, node, "traverse",
                 {"path", "stop_spacing_m", "footprint_radius_m", "mount", "odometry", "drift", "register", "method"});
  TraverseSpec t;
  const PathPoints path = readPath(reader, f.required("path"));
  t.waypoints_xy_m = path.points;
  t.footprint_radius_m = f.number("footprint_radius_m", kPositive, t.footprint_radius_m);
  checkPathOverTerrain(reader, path, t.footprint_radius_m, terrain);
  const double length_m = pathLength(path.points);
  t.stop_spacing_m = f.number("stop_spacing_m", kPositive, t.stop_spacing_m);
  const std::string given = f.get("stop_spacing_m") ? "" : " (the default)";
  if (t.stop_spacing_m > length_m)
    reader.fail(f.pathOf("stop_spacing_m"), "expected at most the path's length (" + shortest(length_m) + "), got " +
                                                shortest(t.stop_spacing_m) + given);
  if (length_m / t.stop_spacing_m > kMaxStops)
    reader.fail(f.pathOf("stop_spacing_m"), "expected at most " + shortest(kMaxStops) + " stops (length / spacing), got " +
                                                shortest(length_m) + " / " + shortest(t.stop_spacing_m) + given);
  if (const auto m = f.get("mount")) {
    const Fields fm(reader, *m, f.pathOf("mount"), {"height_m", "pitch_deg"});
    t.mount.height_m = fm.number("height_m", kPositive, t.mount.height_m);
    if (fm.get("pitch_deg")) t.mount.pitch_rad = degToRad(fm.number("pitch_deg", {-90.0, 90.0, true, true}, 0.0));
  }
  if (const auto o = f.get("odometry")) readOdometry(reader, *o, t.odometry);
  if (const auto d = f.get("drift")) readDrift(reader, *d, t.drift);
  const std::string reg = f.choice("register", {"composite", "previous", "none"}, traverseRegisterName(t.reg));
  t.reg = reg == "composite" ? TraverseRegister::Composite
                             : (reg == "previous" ? TraverseRegister::Previous : TraverseRegister::None);
  if (const auto method = f.get("method")) {
    t.method = readMatchMethod(reader, *method, f.pathOf("method"));
    if (!paperMethod(t.method))
      reader.fail(f.pathOf("method"), std::string("the Open3D peers do not register a traverse yet (they match two scans' "
                                                  "returns, not a view against the composite); got ") +
                                          matchMethodName(t.method));
  }
  return t;
}

void refuseBesideTraverse(const Reader& reader, const Fields& top) {
  if (top.get("views")) reader.fail("views", "a traverse generates its views, one per stop; remove views");
  if (top.get("merge"))
    reader.fail("merge", "a traverse merges every stop into its running composite; remove merge");
  for (const char* key : {"footfall", "leg"})
    if (top.get(key)) reader.fail(key, "not yet supported in a traverse");
}

void refuseMatchingKeysInTraverse(const Reader& reader, const Fields& matching) {
  const auto refuse = [&](const char* key, const std::string& why) {
    if (matching.get(key)) reader.fail(matching.pathOf(key), why + "; remove " + key);
  };
  refuse("pairs", "a traverse registers each stop as traverse.register says");
  refuse("methods", "a traverse registers by traverse.method");
  refuse("initial_error", "a traverse's dead-reckoning error comes from traverse.odometry");
  refuse("draw_initial_error", "a traverse's dead-reckoning error comes from traverse.odometry");
  for (const char* key : {"prior", "gate"})
    if (matching.get(key))
      reader.fail(matching.pathOf(key),
                  "not yet supported in a traverse (a traverse takes success and odometry from matching)");
}

}  // namespace scenario_detail
}  // namespace ambler::eval
