#include "eval/run/traverse_truth.hpp"

#include <Eigen/QR>
#include <array>
#include <cmath>
#include <numbers>
#include <optional>
#include <stdexcept>
#include <string>

#include "base/random.hpp"
#include "base/text.hpp"

namespace ambler::eval {

namespace {

constexpr double kPi = std::numbers::pi;
constexpr double kDeg = kPi / 180.0;
// Distances along the path closer than this are the same point: a stop on a waypoint takes the
// waypoint and the leaving segment's heading, and a length this close to whole spacings ends on the end.
constexpr double kPathTolerance = 1e-9;
// The odometry's draws: stream (seed, kOdometryStream, stop). Apart from the terrain's (1–3), the
// views' scans (1000 + view, second key 0), the matcher's initial errors (3000 + i) and the basin's (7001).
constexpr std::uint64_t kOdometryStream = 5000;

double wrapAngle(double a) {
  const double r = std::remainder(a, 2.0 * kPi);  // exact: an angle in range comes back bit for bit
  return r <= -kPi ? r + 2.0 * kPi : r;
}

std::string pointText(const Eigen::Vector2d& p) {
  return "(" + base::plainText(p.x()) + ", " + base::plainText(p.y()) + ")";
}

void checkPath(const std::vector<Eigen::Vector2d>& waypoints, double spacing_m) {
  if (waypoints.size() < 2)
    throw std::invalid_argument("traverse path: needs at least 2 waypoints, got " + std::to_string(waypoints.size()));
  for (std::size_t i = 0; i < waypoints.size(); ++i)
    if (!waypoints[i].allFinite())
      throw std::invalid_argument("traverse path: waypoint " + std::to_string(i) + " is not finite");
  for (std::size_t i = 1; i < waypoints.size(); ++i)
    if (!((waypoints[i] - waypoints[i - 1]).norm() > kPathTolerance))
      throw std::invalid_argument("traverse path: segment " + std::to_string(i - 1) + " from waypoint " +
                                  pointText(waypoints[i - 1]) + " to " + pointText(waypoints[i]) +
                                  " has zero length");
  if (!(std::isfinite(spacing_m) && spacing_m > 0))
    throw std::invalid_argument("traverse path: stop spacing must be positive and finite, got " +
                                base::plainText(spacing_m) + " m");
}

void checkOdometry(const TraverseOdometry& o) {
  const auto need = [](bool ok, const char* key, double v, const char* what) {
    if (!ok)
      throw std::invalid_argument(std::string("traverse odometry: ") + key + " must be " + what + ", got " +
                                  base::plainText(v));
  };
  need(std::isfinite(o.translation_sigma_per_m) && o.translation_sigma_per_m >= 0, "translation_sigma_per_m",
       o.translation_sigma_per_m, "finite and >= 0");
  need(std::isfinite(o.heading_sigma_deg_per_m) && o.heading_sigma_deg_per_m >= 0, "heading_sigma_deg_per_m",
       o.heading_sigma_deg_per_m, "finite and >= 0");
  need(std::isfinite(o.translation_bias) && o.translation_bias > -1, "translation_bias", o.translation_bias,
       "finite and > -1 (a positive scale)");
  need(std::isfinite(o.heading_bias_deg_per_m), "heading_bias_deg_per_m", o.heading_bias_deg_per_m, "finite");
}

// value + error, where a zero error leaves the value's bits alone (−0 + 0 would give +0).
double plus(double value, double error) { return error == 0 ? value : value + error; }

}  // namespace

std::vector<PathStop> stopsAlongPath(const std::vector<Eigen::Vector2d>& waypoints, double spacing_m) {
  checkPath(waypoints, spacing_m);
  const std::size_t n_seg = waypoints.size() - 1;
  std::vector<double> start(n_seg + 1, 0.0);  // distance along the path of each waypoint
  for (std::size_t i = 0; i < n_seg; ++i) start[i + 1] = start[i] + (waypoints[i + 1] - waypoints[i]).norm();
  const double length = start[n_seg];
  const auto headingOfSegment = [&](std::size_t i) {
    const Eigen::Vector2d d = waypoints[i + 1] - waypoints[i];
    return std::atan2(d.y(), d.x());
  };
  const auto n_spacings = static_cast<std::size_t>(std::floor((length + kPathTolerance) / spacing_m));
  const bool ends_on_end = std::abs(length - double(n_spacings) * spacing_m) <= kPathTolerance;

  std::vector<PathStop> stops;
  stops.reserve(n_spacings + 1);
  std::size_t seg = 0;
  for (std::size_t k = 0; k <= n_spacings; ++k) {
    if (k == n_spacings && ends_on_end) {
      stops.push_back({waypoints.back(), headingOfSegment(n_seg - 1), length});
      break;
    }
    const double t = double(k) * spacing_m;
    while (seg + 1 < n_seg && t >= start[seg + 1] - kPathTolerance) ++seg;
    PathStop stop;
    stop.distance_m = t;
    stop.heading_rad = headingOfSegment(seg);
    if (std::abs(t - start[seg]) <= kPathTolerance)
      stop.xy = waypoints[seg];
    else
      stop.xy = waypoints[seg] +
                (t - start[seg]) / (start[seg + 1] - start[seg]) * (waypoints[seg + 1] - waypoints[seg]);
    stops.push_back(stop);
  }
  return stops;
}

Eigen::Isometry3d bodyPoseOnTerrain(const terrains::Terrain& terrain, const PathStop& stop, double footprint_radius_m) {
  if (!(std::isfinite(footprint_radius_m) && footprint_radius_m > 0))
    throw std::invalid_argument("traverse: footprint radius must be positive and finite, got " +
                                base::plainText(footprint_radius_m) + " m");
  // The polar grid turns with the heading (the legs are where the body puts them). Coordinates are
  // relative to the stop, so the fitted c is the plane's height under it.
  constexpr std::array<int, 4> kRingPoints = {1, 6, 12, 18};
  constexpr int kSamples = 1 + 6 + 12 + 18;
  Eigen::Matrix<double, kSamples, 3> A;
  Eigen::Matrix<double, kSamples, 1> z;
  int row = 0;
  for (std::size_t ring = 0; ring < kRingPoints.size(); ++ring) {
    const double radius = footprint_radius_m * double(ring) / 3.0;
    for (int k = 0; k < kRingPoints[ring]; ++k) {
      const double angle = stop.heading_rad + 2.0 * kPi * k / kRingPoints[ring];
      const Eigen::Vector2d offset = radius * Eigen::Vector2d(std::cos(angle), std::sin(angle));
      const Eigen::Vector2d at = stop.xy + offset;
      const std::optional<double> height = terrains::surfaceAt(terrain, at.x(), at.y());
      if (!height)
        throw std::invalid_argument("traverse: the body's footprint at stop " + pointText(stop.xy) +
                                    " reaches " + pointText(at) + ", outside the terrain");
      A.row(row) << offset.x(), offset.y(), 1.0;
      z(row++) = *height;
    }
  }
  const Eigen::Vector3d abc = A.colPivHouseholderQr().solve(z);  // z = a·u + b·v + c

  const Eigen::Vector3d normal = Eigen::Vector3d(-abc.x(), -abc.y(), 1.0).normalized();
  const Eigen::Vector3d ahead(std::cos(stop.heading_rad), std::sin(stop.heading_rad), 0.0);
  // Along the vertical onto the plane, so B's x projects back on the horizontal as the path's heading
  // (perception::headingOf gives stop.heading_rad); an orthogonal projection would turn it on a side slope.
  const Eigen::Vector3d x = (ahead - ahead.dot(normal) / normal.z() * Eigen::Vector3d::UnitZ()).normalized();
  Eigen::Isometry3d T_WB = Eigen::Isometry3d::Identity();
  T_WB.linear().col(0) = x;
  T_WB.linear().col(1) = normal.cross(x);
  T_WB.linear().col(2) = normal;
  T_WB.translation() = Eigen::Vector3d(stop.xy.x(), stop.xy.y(), abc.z());
  return T_WB;
}

std::vector<perception::OdometryStep> measuredSteps(const std::vector<Eigen::Isometry3d>& true_WB,
                                                    const TraverseOdometry& odometry, std::uint64_t seed) {
  checkOdometry(odometry);
  std::vector<perception::OdometryStep> steps;
  steps.reserve(true_WB.size());
  if (!true_WB.empty()) steps.emplace_back();
  for (std::size_t k = 1; k < true_WB.size(); ++k) {
    perception::OdometryStep step = perception::stepBetween(true_WB[k - 1], true_WB[k]);
    const double d = std::hypot(step.dx_m, step.dy_m);
    // Four standard normals in a fixed order, drawn whatever the sigmas, so one key always means the same draws.
    base::Rng rng(base::streamKey(seed, kOdometryStream, k));
    const double nx = rng.normal(), ny = rng.normal(), nz = rng.normal(), nh = rng.normal();
    const double scale = 1.0 + odometry.translation_bias;  // a zero bias gives exactly 1, and 1·v is v
    const double sigma_t = odometry.translation_sigma_per_m * d;
    step.dx_m = plus(scale * step.dx_m, sigma_t * nx);
    step.dy_m = plus(scale * step.dy_m, sigma_t * ny);
    step.dz_m = plus(step.dz_m, sigma_t * nz);
    const double turn_error = (odometry.heading_bias_deg_per_m * d + odometry.heading_sigma_deg_per_m * d * nh) * kDeg;
    step.dheading_rad = wrapAngle(plus(step.dheading_rad, turn_error));
    steps.push_back(step);
  }
  return steps;
}

std::vector<Eigen::Isometry3d> deadReckoning(const std::vector<Eigen::Isometry3d>& true_WB,
                                             const std::vector<perception::OdometryStep>& steps) {
  if (steps.size() != true_WB.size())
    throw std::invalid_argument("deadReckoning: " + std::to_string(true_WB.size()) + " true poses but " +
                                std::to_string(steps.size()) +
                                " steps; it needs one step per stop (the first a zero step)");
  std::vector<Eigen::Isometry3d> believed;
  believed.reserve(true_WB.size());
  if (!true_WB.empty()) believed.push_back(true_WB[0]);
  for (std::size_t k = 1; k < true_WB.size(); ++k)
    believed.push_back(perception::integrate(believed.back(), steps[k], perception::tiltOf(true_WB[k].linear())));
  return believed;
}

}  // namespace ambler::eval
