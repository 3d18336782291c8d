// A traverse's ground truth and odometry (eval/run/traverse_truth.hpp): stops on a straight and an
// L-shaped path placed by hand, the body on a tilted plane against the plane's roll and pitch,
// odometry without errors exact, with errors matching the scenario's spec in mean and σ, seeded
// draws, dead reckoning against closed forms, and the refusals.
#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <cstdint>
#include <functional>
#include <numbers>
#include <string>
#include <vector>

#include "eval/run/traverse_truth.hpp"

namespace ambler::eval {
namespace {

using Eigen::Isometry3d;
using Eigen::Matrix3d;
using Eigen::Vector2d;
using Eigen::Vector3d;
using perception::OdometryStep;
constexpr double kPi = std::numbers::pi;
constexpr double kDeg = kPi / 180.0;

void expectInvalid(const std::function<void()>& call, const std::string& part) {
  try {
    call();
    ADD_FAILURE() << "no std::invalid_argument; expected one saying \"" << part << "\"";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find(part), std::string::npos) << e.what();
  }
}

void expectStop(const PathStop& s, const Vector2d& xy, double heading, double distance) {
  EXPECT_LE((s.xy - xy).norm(), 1e-12) << "stop at " << s.xy.transpose() << ", expected " << xy.transpose();
  EXPECT_NEAR(s.heading_rad, heading, 1e-12);
  EXPECT_NEAR(s.distance_m, distance, 1e-12);
}

// z = z0 + a·x + b·y on a square grid of half-width `half` (no rocks): the heightfield's triangles
// all lie in the plane, so the surface is the plane to rounding.
terrains::Terrain planeTerrain(double a, double b, double z0, double half = 10.0, double cell = 0.1) {
  const int n = int(std::lround(2 * half / cell)) + 1;
  terrains::Terrain t{terrains::Heightfield(n, n, cell, {-half, -half}), {}};
  for (int r = 0; r < n; ++r)
    for (int c = 0; c < n; ++c) {
      const Vector2d p = t.ground.position(r, c);
      t.ground.at(r, c) = z0 + a * p.x() + b * p.y();
    }
  return t;
}

Matrix3d ry(double v) { return Eigen::AngleAxisd(v, Vector3d::UnitY()).toRotationMatrix(); }
Matrix3d rx(double v) { return Eigen::AngleAxisd(v, Vector3d::UnitX()).toRotationMatrix(); }

// Level poses every `step_m` along heading psi from the origin.
std::vector<Isometry3d> straightLevelPoses(std::size_t n, double step_m, double psi) {
  std::vector<Isometry3d> poses(n, Isometry3d::Identity());
  for (std::size_t k = 0; k < n; ++k) {
    poses[k].linear() = Eigen::AngleAxisd(psi, Vector3d::UnitZ()).toRotationMatrix();
    poses[k].translation() = double(k) * step_m * Vector3d(std::cos(psi), std::sin(psi), 0);
  }
  return poses;
}

TEST(TraverseTruth, StopsOnAStraightLine) {
  // 3.5 m at heading 0: stops at 0, 1, 2, 3 m; the last whole spacing, not the end.
  const auto short_of_end = stopsAlongPath({{0, 0}, {3.5, 0}}, 1.0);
  ASSERT_EQ(short_of_end.size(), 4u);
  for (int k = 0; k < 4; ++k) expectStop(short_of_end[k], {k, 0}, 0.0, k);
  // 5 m along (3, 4)/5 in spacings of 1.25 m: five stops, the last exactly the end.
  const Vector2d start(-1, -1), end(2, 3);
  const auto whole = stopsAlongPath({start, end}, 1.25);
  ASSERT_EQ(whole.size(), 5u);
  for (int k = 0; k < 5; ++k)
    expectStop(whole[k], start + 1.25 * k * Vector2d(0.6, 0.8), std::atan2(4.0, 3.0), 1.25 * k);
  EXPECT_EQ(whole.back().xy, end);
  EXPECT_EQ(whole.back().distance_m, 5.0);
  // A length within 1e-9 m of whole spacings ends on the end; 1e-8 m beyond does too (the last
  // whole spacing is then 1e-8 m short of it); 1e-8 m short does not reach the last spacing.
  const auto within = stopsAlongPath({{0, 0}, {3 + 5e-10, 0}}, 1.0);
  ASSERT_EQ(within.size(), 4u);
  EXPECT_EQ(within.back().xy, Vector2d(3 + 5e-10, 0));
  EXPECT_EQ(within.back().distance_m, 3 + 5e-10);
  const auto beyond = stopsAlongPath({{0, 0}, {3 + 1e-8, 0}}, 1.0);
  ASSERT_EQ(beyond.size(), 4u);
  expectStop(beyond.back(), {3, 0}, 0.0, 3.0);
  EXPECT_EQ(stopsAlongPath({{0, 0}, {3 - 1e-8, 0}}, 1.0).size(), 3u);
}

TEST(TraverseTruth, StopsOnAnLShapedPath) {
  const std::vector<Vector2d> path{{0, 0}, {2.5, 0}, {2.5, 2}};
  // 0.5 m spacing: six stops along x, the corner (a stop on a waypoint takes the leaving
  // segment's heading), then up y to the end, 4.5 m, nine spacings.
  const auto half = stopsAlongPath(path, 0.5);
  ASSERT_EQ(half.size(), 10u);
  for (int k = 0; k < 5; ++k) expectStop(half[k], {0.5 * k, 0}, 0.0, 0.5 * k);
  expectStop(half[5], {2.5, 0}, kPi / 2, 2.5);
  EXPECT_EQ(half[5].xy, path[1]);
  for (int k = 6; k < 10; ++k) expectStop(half[k], {2.5, 0.5 * (k - 5)}, kPi / 2, 0.5 * k);
  EXPECT_EQ(half.back().xy, path.back());
  // 0.7 m spacing: six spacings make 4.2 m, 0.3 m short of the end; the turn falls between stops.
  const auto odd = stopsAlongPath(path, 0.7);
  ASSERT_EQ(odd.size(), 7u);
  for (int k = 0; k < 4; ++k) expectStop(odd[k], {0.7 * k, 0}, 0.0, 0.7 * k);
  expectStop(odd[4], {2.5, 0.3}, kPi / 2, 2.8);
  expectStop(odd[5], {2.5, 1.0}, kPi / 2, 3.5);
  expectStop(odd[6], {2.5, 1.7}, kPi / 2, 4.2);
}

TEST(TraverseTruth, StopsRefuseBadPaths) {
  expectInvalid([] { stopsAlongPath({{1, 1}}, 1.0); }, "at least 2 waypoints, got 1");
  expectInvalid([] { stopsAlongPath({{0, 0}, {1, 0}, {1, 0}, {2, 0}}, 1.0); },
                "segment 1 from waypoint (1, 0) to (1, 0) has zero length");
  expectInvalid([] { stopsAlongPath({{0, 0}, {std::nan(""), 0}}, 1.0); }, "waypoint 1 is not finite");
  for (const double bad : {0.0, -1.0, std::nan(""), HUGE_VAL})
    expectInvalid([bad] { stopsAlongPath({{0, 0}, {1, 0}}, bad); }, "stop spacing must be positive and finite");
}

// On z = z0 + a·x + b·y the body stands on the plane: origin on it, z its normal, heading the path's,
// and the tilt Ry(θ)·Rx(φ) with θ = −atan(slope along the heading) (nose up: negative pitch, REP 103)
// and sin φ = −(normal's component to the left of the heading).
TEST(TraverseTruth, BodyStandsOnATiltedPlane) {
  const double a = 0.2, b = -0.35, z0 = 0.4;
  const terrains::Terrain terrain = planeTerrain(a, b, z0);
  const Vector3d normal = Vector3d(-a, -b, 1).normalized();
  for (const double psi : {0.0, 0.7, kPi / 2, -2.2, kPi, -kPi + 1e-6})
    for (const Vector2d& xy : {Vector2d(0, 0), Vector2d(3.3, -4.1), Vector2d(-7.95, 6.02)}) {
      const Isometry3d T = bodyPoseOnTerrain(terrain, {xy, psi, 0.0}, 1.5);
      const double slope = a * std::cos(psi) + b * std::sin(psi);
      const double pitch = -std::atan(slope);
      const double roll = std::asin((b * std::cos(psi) - a * std::sin(psi)) / std::sqrt(1 + a * a + b * b));
      EXPECT_NEAR(std::remainder(perception::headingOf(T.linear()) - psi, 2 * kPi), 0.0, 1e-9);
      EXPECT_LE((perception::tiltOf(T.linear()) - ry(pitch) * rx(roll)).cwiseAbs().maxCoeff(), 1e-9);
      EXPECT_LE((T.linear().col(2) - normal).norm(), 1e-9);
      EXPECT_LE((T.linear().transpose() * T.linear() - Matrix3d::Identity()).cwiseAbs().maxCoeff(), 1e-12);
      EXPECT_NEAR(T.linear().determinant(), 1.0, 1e-12);
      EXPECT_EQ(T.translation().head<2>(), xy);
      EXPECT_NEAR(T.translation().z(), z0 + a * xy.x() + b * xy.y(), 1e-9);
    }
}

TEST(TraverseTruth, BodyRefusesAFootprintOffTheTerrain) {
  const terrains::Terrain terrain = planeTerrain(0.1, 0.0, 0.0, 5.0);
  // The first sample off the grid is on the 2r/3 ring, straight ahead.
  expectInvalid([&] { bodyPoseOnTerrain(terrain, {{4.5, 0}, 0.0, 0.0}, 1.0); },
                "footprint at stop (4.5, 0) reaches (5.166666666666667, 0), outside the terrain");
  EXPECT_NO_THROW(bodyPoseOnTerrain(terrain, {{4.0, 0}, 0.0, 0.0}, 1.0));
  expectInvalid([&] { bodyPoseOnTerrain(terrain, {{0, 0}, 0.0, 0.0}, 0.0); }, "footprint radius must be positive");
}

// The true poses of an L-shaped traverse on a tilted plane.
std::vector<Isometry3d> planeTraverse() {
  static const terrains::Terrain terrain = planeTerrain(0.15, -0.1, 1.0);
  std::vector<Isometry3d> poses;
  for (const PathStop& s : stopsAlongPath({{-6, -5}, {4, -5}, {4, 5}, {-3, 2}}, 0.8))
    poses.push_back(bodyPoseOnTerrain(terrain, s, 1.0));
  return poses;
}

TEST(TraverseTruth, WithoutErrorsOdometryIsExactAndDeadReckoningIsTheTruth) {
  const std::vector<Isometry3d> truth = planeTraverse();
  ASSERT_GT(truth.size(), 30u);
  const TraverseOdometry none{0.0, 0.0, 0.0, 0.0};
  const std::vector<OdometryStep> steps = measuredSteps(truth, none, 42);
  ASSERT_EQ(steps.size(), truth.size());
  EXPECT_EQ(steps[0].dx_m, 0.0);
  EXPECT_EQ(steps[0].dy_m, 0.0);
  EXPECT_EQ(steps[0].dz_m, 0.0);
  EXPECT_EQ(steps[0].dheading_rad, 0.0);
  for (std::size_t k = 1; k < truth.size(); ++k) {
    const OdometryStep exact = perception::stepBetween(truth[k - 1], truth[k]);
    EXPECT_EQ(std::bit_cast<std::uint64_t>(steps[k].dx_m), std::bit_cast<std::uint64_t>(exact.dx_m));
    EXPECT_EQ(std::bit_cast<std::uint64_t>(steps[k].dy_m), std::bit_cast<std::uint64_t>(exact.dy_m));
    EXPECT_EQ(std::bit_cast<std::uint64_t>(steps[k].dz_m), std::bit_cast<std::uint64_t>(exact.dz_m));
    EXPECT_EQ(std::bit_cast<std::uint64_t>(steps[k].dheading_rad), std::bit_cast<std::uint64_t>(exact.dheading_rad));
  }
  const std::vector<Isometry3d> believed = deadReckoning(truth, steps);
  ASSERT_EQ(believed.size(), truth.size());
  for (std::size_t k = 0; k < truth.size(); ++k) {
    EXPECT_LE((believed[k].translation() - truth[k].translation()).cwiseAbs().maxCoeff(), 1e-12) << "stop " << k;
    EXPECT_LE((believed[k].linear() - truth[k].linear()).cwiseAbs().maxCoeff(), 1e-12) << "stop " << k;
  }
}

// Biases alone: dx and dy scaled by 1 + bias, the turn grown by bias·d; dz untouched.
TEST(TraverseTruth, BiasesAloneScaleAndTurn) {
  const std::vector<Isometry3d> truth = planeTraverse();
  const TraverseOdometry biased{0.0, 0.0, -0.04, 0.3};
  const std::vector<OdometryStep> steps = measuredSteps(truth, biased, 1);
  for (std::size_t k = 1; k < truth.size(); ++k) {
    const OdometryStep exact = perception::stepBetween(truth[k - 1], truth[k]);
    const double d = std::hypot(exact.dx_m, exact.dy_m);
    EXPECT_EQ(steps[k].dx_m, 0.96 * exact.dx_m);
    EXPECT_EQ(steps[k].dy_m, 0.96 * exact.dy_m);
    EXPECT_EQ(steps[k].dz_m, exact.dz_m);
    EXPECT_NEAR(steps[k].dheading_rad, exact.dheading_rad + 0.3 * kDeg * d, 1e-15);
  }
}

// A heading bias ε per step on a straight level path of n steps of s: the believed path turns by ε
// each step, so stop n is at s·Σⱼ (cos(ψ₀ + jε), sin(ψ₀ + jε)), j < n, which is
// s·sin(nε/2)/sin(ε/2) along ψ₀ + (n − 1)ε/2, and heads ψ₀ + nε.
TEST(TraverseTruth, DeadReckoningWithAHeadingBiasWalksAnArc) {
  const double s = 1.0, psi0 = -0.4, bias_deg_per_m = 0.5, eps = bias_deg_per_m * s * kDeg;
  const std::size_t n = 100;
  const std::vector<Isometry3d> truth = straightLevelPoses(n + 1, s, psi0);
  const std::vector<Isometry3d> believed =
      deadReckoning(truth, measuredSteps(truth, {0.0, 0.0, 0.0, bias_deg_per_m}, 3));
  const double chord = s * std::sin(n * eps / 2) / std::sin(eps / 2), along = psi0 + (n - 1) * eps / 2;
  EXPECT_LE((believed[n].translation() - chord * Vector3d(std::cos(along), std::sin(along), 0)).norm(), 1e-12);
  EXPECT_NEAR(perception::headingOf(believed[n].linear()), psi0 + n * eps, 1e-12);
}

struct Moments {
  double mean = 0, sd = 0;
};

Moments moments(const std::vector<double>& v) {
  double sum = 0;
  for (const double x : v) sum += x;
  const double mean = sum / double(v.size());
  double ss = 0;
  for (const double x : v) ss += (x - mean) * (x - mean);
  return {mean, std::sqrt(ss / double(v.size() - 1))};
}

// 20000 steps of 0.5 m: each error's sample mean and σ match the spec's within 4 standard errors
// (σ/√N for the mean, σ/√(2N) for σ), and the four errors are uncorrelated (|r| < 4/√N).
TEST(TraverseTruth, NoisyStepsMatchTheSpecInMeanAndSigma) {
  const std::size_t n = 20000;
  const double s = 0.5;
  const TraverseOdometry spec{0.02, 0.5, -0.05, 0.3};
  const std::vector<Isometry3d> truth = straightLevelPoses(n + 1, s, 0.3);
  const std::vector<OdometryStep> steps = measuredSteps(truth, spec, 2024);
  std::vector<double> ex, ey, ez, eh;
  for (std::size_t k = 1; k <= n; ++k) {
    const OdometryStep exact = perception::stepBetween(truth[k - 1], truth[k]);
    ex.push_back(steps[k].dx_m - exact.dx_m);
    ey.push_back(steps[k].dy_m - exact.dy_m);
    ez.push_back(steps[k].dz_m - exact.dz_m);
    eh.push_back(steps[k].dheading_rad - exact.dheading_rad);
  }
  const double sigma_t = spec.translation_sigma_per_m * s, sigma_h = spec.heading_sigma_deg_per_m * s * kDeg;
  const struct {
    const char* name;
    const std::vector<double>& e;
    double mean, sigma;
  } cases[] = {{"dx", ex, spec.translation_bias * s, sigma_t},
               {"dy", ey, 0.0, sigma_t},
               {"dz", ez, 0.0, sigma_t},
               {"dheading", eh, spec.heading_bias_deg_per_m * s * kDeg, sigma_h}};
  const double root_n = std::sqrt(double(n));
  for (const auto& c : cases) {
    const Moments m = moments(c.e);
    EXPECT_NEAR(m.mean, c.mean, 4 * c.sigma / root_n) << c.name;
    EXPECT_NEAR(m.sd, c.sigma, 4 * c.sigma / std::sqrt(2.0 * n)) << c.name;
  }
  for (std::size_t i = 0; i < 4; ++i)
    for (std::size_t j = i + 1; j < 4; ++j) {
      const Moments mi = moments(cases[i].e), mj = moments(cases[j].e);
      double cov = 0;
      for (std::size_t k = 0; k < n; ++k) cov += (cases[i].e[k] - mi.mean) * (cases[j].e[k] - mj.mean);
      EXPECT_LT(std::abs(cov / double(n - 1) / (mi.sd * mj.sd)), 4 / root_n)
          << cases[i].name << " vs " << cases[j].name;
    }
}

TEST(TraverseTruth, SameSeedSameStepsOtherSeedOthers) {
  const std::vector<Isometry3d> truth = planeTraverse();
  const TraverseOdometry spec;
  const auto a = measuredSteps(truth, spec, 7), b = measuredSteps(truth, spec, 7), c = measuredSteps(truth, spec, 8);
  for (std::size_t k = 1; k < truth.size(); ++k) {
    EXPECT_EQ(std::bit_cast<std::uint64_t>(a[k].dx_m), std::bit_cast<std::uint64_t>(b[k].dx_m));
    EXPECT_EQ(std::bit_cast<std::uint64_t>(a[k].dy_m), std::bit_cast<std::uint64_t>(b[k].dy_m));
    EXPECT_EQ(std::bit_cast<std::uint64_t>(a[k].dz_m), std::bit_cast<std::uint64_t>(b[k].dz_m));
    EXPECT_EQ(std::bit_cast<std::uint64_t>(a[k].dheading_rad), std::bit_cast<std::uint64_t>(b[k].dheading_rad));
    EXPECT_NE(a[k].dx_m, c[k].dx_m);
    EXPECT_NE(a[k].dheading_rad, c[k].dheading_rad);
  }
}

TEST(TraverseTruth, OdometryRefusesBadInput) {
  const std::vector<Isometry3d> truth = straightLevelPoses(3, 1.0, 0.0);
  expectInvalid([&] { measuredSteps(truth, {-0.01, 0.5, 0.0, 0.0}, 1); },
                "translation_sigma_per_m must be finite and >= 0, got -0.01");
  expectInvalid([&] { measuredSteps(truth, {0.02, std::nan(""), 0.0, 0.0}, 1); },
                "heading_sigma_deg_per_m must be finite and >= 0");
  expectInvalid([&] { measuredSteps(truth, {0.02, 0.5, -1.0, 0.0}, 1); }, "translation_bias must be finite and > -1");
  expectInvalid([&] { measuredSteps(truth, {0.02, 0.5, 0.0, HUGE_VAL}, 1); }, "heading_bias_deg_per_m must be finite");
  expectInvalid([&] { deadReckoning(truth, std::vector<OdometryStep>(2)); }, "3 true poses but 2 steps");
  EXPECT_TRUE(measuredSteps({}, TraverseOdometry{}, 1).empty());
  EXPECT_TRUE(deadReckoning({}, {}).empty());
}

}  // namespace
}  // namespace ambler::eval
