// Feature matching (paper §4.1): eq. 3's distance per feature type against its closed form, and
// the predict-and-verify search on feature sets with a known transform — the paper's case of
// about 30° and 2 m from T_0 — recovered exactly without noise and within the fit's σ with it,
// despite dropped and spurious features; the prior's rotation bound is honoured.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <random>
#include <stdexcept>

#include "perception/feature_matching.hpp"
#include "perception/sensor_geometry.hpp"

namespace ambler::perception {
namespace {

constexpr double kDeg = std::numbers::pi / 180.0;

Feature point(double x, double y, double z, double strength) {
  Feature f;
  f.type = FeatureType::Point;
  f.position = {x, y, z};
  f.strength = strength;
  f.extent_m = 0.2;
  return f;
}

Feature line(const Eigen::Vector3d& centre, const Eigen::Vector3d& direction, double length, double strength) {
  Feature f;
  f.type = FeatureType::Line;
  f.position = centre;
  f.direction = direction.normalized();
  f.length_m = length;
  f.extent_m = length / 2;
  f.strength = strength;
  return f;
}

// Map 2: every cell Known over [−12, 12]² (features never fall off it).
ElevationMap knownMap() {
  ElevationMap m(MapGrid::covering(-12, 12, -12, 12, 0.5));
  for (int r = 0; r < m.grid().rows; ++r)
    for (int c = 0; c < m.grid().cols; ++c) m.setKnown(r, c, 0.f, 1e-3f);
  return m;
}

// 14 points and 3 lines over [−5, 5]², strengths in [1, 3] /m, seeded.
std::vector<Feature> scene(std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> xy(-5, 5), z(-0.3, 0.3), s(1, 3), a(0, std::numbers::pi);
  std::vector<Feature> f;
  for (int k = 0; k < 14; ++k) f.push_back(point(xy(rng), xy(rng), z(rng), s(rng)));
  for (int k = 0; k < 3; ++k) {
    const double t = a(rng);
    f.push_back(line({xy(rng), xy(rng), z(rng)}, {std::cos(t), std::sin(t), 0.05}, 1.0 + k, s(rng)));
  }
  return f;
}

// The truth of the paper's case: 30° of yaw, 2 m of translation.
Eigen::Isometry3d paperCase() {
  PoseVector nu;
  nu << 0, 0, 30 * kDeg, 1.6, -1.2, 0.05;
  return poseFromVector(nu);
}

// Map 2's features: map 1's moved by T, with map 1's features 3, 7 and 12 not seen (dropped) and
// four spurious points, each position perturbed by N(0, σ²) per axis.
std::vector<Feature> secondView(const std::vector<Feature>& f1, const Eigen::Isometry3d& T, double sigma,
                                std::vector<std::pair<int, int>>* truth, std::uint32_t seed = 99) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> n(0, sigma);
  std::uniform_real_distribution<double> xy(-6, 6), s(1, 3);
  std::vector<Feature> f2;
  for (int i = 0; i < int(f1.size()); ++i) {
    if (i == 3 || i == 7 || i == 12) continue;
    Feature g = transformed(f1[i], T);
    if (sigma > 0) g.position += Eigen::Vector3d(n(rng), n(rng), n(rng));
    if (truth) truth->emplace_back(i, int(f2.size()));
    f2.push_back(g);
  }
  for (int k = 0; k < 4; ++k) f2.push_back(point(xy(rng), xy(rng), 0, s(rng)));
  return f2;
}

TEST(FeatureMatching, DistancePerTypeIsItsClosedForm) {
  // Points: the distance of the centres.
  EXPECT_DOUBLE_EQ(featureDistance(point(0, 0, 0, 1), point(3, 4, 0, 1)), 5.0);
  // Parallel lines 0.2 m apart, centres level: the perpendicular distance.
  const Feature b = line({0, 0, 0}, {1, 0, 0}, 2.0, 1);
  EXPECT_NEAR(featureDistance(line({0, 0.2, 0}, {1, 0, 0}, 2.0, 1), b), 0.2, 1e-15);
  // Turned by θ about a common centre: half the shorter length's swing, (L/2)·sin θ.
  const double th = 20 * kDeg;
  EXPECT_NEAR(featureDistance(line({0, 0, 0}, {std::cos(th), std::sin(th), 0}, 1.0, 1), b), 0.5 * std::sin(th), 1e-15);
  // A centre 1.5 m along a 2 m line lies 0.5 m beyond its extent.
  EXPECT_NEAR(featureDistance(line({1.5, 0, 0}, {1, 0, 0}, 1.0, 1), b), 0.5, 1e-15);
}

TEST(FeatureMatching, RecoversThePapersCaseExactlyWithoutNoise) {
  const std::vector<Feature> f1 = scene(7);
  const Eigen::Isometry3d T = paperCase();
  std::vector<std::pair<int, int>> truth;
  const std::vector<Feature> f2 = secondView(f1, T, 0.0, &truth);
  const ElevationMap map2 = knownMap();
  const FeatureMatch m = matchFeatures(f1, f2, map2, PoseVector::Zero());
  std::printf("nodes %ld, hypotheses %ld, D %.4f (T_0: %.3f)\n", m.nodes, m.hypotheses, m.D, m.D0);
  ASSERT_TRUE(m.found);
  EXPECT_FALSE(m.exhausted);
  const PoseError e = poseError(T, poseFromVector(m.nu));
  EXPECT_LT(e.translation_m, 1e-9);
  EXPECT_LT(e.rotation_deg, 1e-7);
  EXPECT_EQ(m.pairs, truth);
  // D: the three map-1 features map 2 did not see cost d_max each; the rest 0.
  EXPECT_NEAR(m.D, 3 * FeatureMatchConfig{}.d_max_m, 1e-9);
  // The ranked pairings verification refines: T_F first, then others by D, each distinct (some
  // feature of map 1 lands at least inlier_m apart under any two), all better than T_0.
  const FeatureMatchConfig config;
  ASSERT_FALSE(m.ranked.empty());
  EXPECT_LE(int(m.ranked.size()), config.keep_ranked);
  EXPECT_EQ(m.ranked.front().nu, m.nu);
  EXPECT_EQ(m.ranked.front().D, m.D);
  for (std::size_t a = 0; a < m.ranked.size(); ++a) {
    EXPECT_LT(m.ranked[a].D, m.D0);
    if (a > 0) EXPECT_LE(m.ranked[a - 1].D, m.ranked[a].D);
    for (std::size_t b = a + 1; b < m.ranked.size(); ++b) {
      double apart = 0;
      for (const Feature& f : f1)
        apart = std::max(apart, (poseFromVector(m.ranked[a].nu) * f.position - poseFromVector(m.ranked[b].nu) * f.position).norm());
      EXPECT_GE(apart, config.inlier_m) << a << " and " << b;
    }
  }
}

// keep_ranked bounds the list, 0 keeps none and leaves T_F as it was.
TEST(FeatureMatching, RankedPairingsHonourKeepRanked) {
  const std::vector<Feature> f1 = scene(7);
  const std::vector<Feature> f2 = secondView(f1, paperCase(), 0.03, nullptr);
  FeatureMatchConfig none;
  none.keep_ranked = 0;
  FeatureMatchConfig five;
  five.keep_ranked = 5;
  const FeatureMatch a = matchFeatures(f1, f2, knownMap(), PoseVector::Zero(), none);
  const FeatureMatch b = matchFeatures(f1, f2, knownMap(), PoseVector::Zero(), five);
  EXPECT_TRUE(a.ranked.empty());
  EXPECT_LE(b.ranked.size(), 5u);
  EXPECT_EQ(a.nu, b.nu);
  EXPECT_EQ(a.D, b.D);
  FeatureMatchConfig bad;
  bad.keep_ranked = -1;
  EXPECT_THROW(matchFeatures(f1, f2, knownMap(), PoseVector::Zero(), bad), std::invalid_argument);
}

TEST(FeatureMatching, NoisyPositionsGiveTheFitsAccuracy) {
  // σ = 3 cm per axis on 14 paired features spread over ±5 m: the fit's translation σ is about
  // σ/√14 = 8 mm at the centroid and its yaw σ about σ/(r·√14), r ≈ 3.5 m the RMS spread: 0.14°.
  // Bounds at four of those σ (the translation taken at the origin, 2 m off the centroid, adds
  // about 2 m × the yaw's σ).
  const std::vector<Feature> f1 = scene(11);
  const Eigen::Isometry3d T = paperCase();
  std::vector<std::pair<int, int>> truth;
  const std::vector<Feature> f2 = secondView(f1, T, 0.03, &truth);
  const FeatureMatch m = matchFeatures(f1, f2, knownMap(), PoseVector::Zero());
  ASSERT_TRUE(m.found);
  const PoseError e = poseError(T, poseFromVector(m.nu));
  std::printf("error %.4f m %.3f deg, %zu pairs, nodes %ld\n", e.translation_m, e.rotation_deg, m.pairs.size(), m.nodes);
  EXPECT_LT(e.translation_m, 4 * (0.008 + 2.0 * 0.14 * kDeg));
  EXPECT_LT(e.rotation_deg, 4 * 0.14);
  EXPECT_EQ(m.pairs, truth);
}

// A prior of 20° when the truth is 30° from T_0: the truth is not returned, and what is returned
// is turned from T_0 by at most the prior plus three σ of its own fit's rotation.
TEST(FeatureMatching, HonoursThePriorsRotationBound) {
  const std::vector<Feature> f1 = scene(7);
  const std::vector<Feature> f2 = secondView(f1, paperCase(), 0.0, nullptr);
  FeatureMatchConfig c;
  c.max_rotation_deg = 20;  // the truth is 30° from T_0
  const FeatureMatch m = matchFeatures(f1, f2, knownMap(), PoseVector::Zero(), c);
  if (m.found) {
    EXPECT_LE(poseError(Eigen::Isometry3d::Identity(), poseFromVector(m.nu)).rotation_deg,
              20 + 3 * m.rotation_sigma_deg + 1e-9);
  }
  EXPECT_GT(poseError(paperCase(), poseFromVector(m.nu)).rotation_deg, 5.0);
}

// The truth exactly at the prior's bound (30° from T_0, a 30° prior: the paper's case as the
// scenarios pose it), features with 3 cm of noise: a fit of the true pairing errs by its σ (about
// 0.14°, NoisyPositionsGiveTheFitsAccuracy) and so lies past the bound about half the time. Held to
// the bound exactly, the search then lost the truth; with the fit's 3σ allowed it keeps it on
// every draw of the noise.
TEST(FeatureMatching, TheTruthAtThePriorsBoundIsKept) {
  const std::vector<Feature> f1 = scene(7);
  int past_bound = 0;
  for (std::uint32_t seed = 1; seed <= 20; ++seed) {
    std::vector<std::pair<int, int>> truth;
    const std::vector<Feature> f2 = secondView(f1, paperCase(), 0.03, &truth, seed);
    const FeatureMatch m = matchFeatures(f1, f2, knownMap(), PoseVector::Zero());
    ASSERT_TRUE(m.found) << "noise seed " << seed;
    EXPECT_EQ(m.pairs, truth) << "noise seed " << seed;
    const double turned = poseError(Eigen::Isometry3d::Identity(), poseFromVector(m.nu)).rotation_deg;
    if (turned > 30) ++past_bound;
    EXPECT_LE(turned, 30 + 3 * m.rotation_sigma_deg) << "noise seed " << seed;
  }
  std::printf("fits past the 30° bound: %d of 20\n", past_bound);
  EXPECT_GT(past_bound, 0);  // the case the margin exists for did occur
}

// The scenario's prior bounds each angle of the dead-reckoning error by 30°; a composition of
// three such angles turns by up to acos(9/16) = 55.8° (registrationConfig's prior,
// ScenarioDefaults.RegistrationPriorCoversEveryAllowedError). Truth at that corner, features with
// 3 cm of noise: a search held to 30° of total turn can never keep the true pairing; held to
// 55.8° it finds it.
TEST(FeatureMatching, TruthTurnedByThreeAnglesAtTheirBoundIsFound) {
  const std::vector<Feature> f1 = scene(7);
  const Eigen::Isometry3d T = sensorPose(Eigen::Vector3d(0.5, -0.3, 0.1), Eigen::Vector3d(-30, -30, -30) * kDeg);
  std::vector<std::pair<int, int>> truth;
  const std::vector<Feature> f2 = secondView(f1, T, 0.03, &truth, 3);
  FeatureMatchConfig config;
  config.max_rotation_deg = std::acos(9.0 / 16.0) / kDeg;
  const FeatureMatch m = matchFeatures(f1, f2, knownMap(), PoseVector::Zero(), config);
  ASSERT_TRUE(m.found);
  EXPECT_EQ(m.pairs, truth);
  const PoseError e = poseError(T, poseFromVector(m.nu));
  EXPECT_LT(e.rotation_deg, 3 * m.rotation_sigma_deg + 1e-9);
  config.max_rotation_deg = 30;
  const FeatureMatch held = matchFeatures(f1, f2, knownMap(), PoseVector::Zero(), config);
  EXPECT_TRUE(!held.found || held.pairs != truth);
}

TEST(FeatureMatching, NothingToMatchLeavesTheInitialEstimate) {
  const std::vector<Feature> f1 = {point(0, 0, 0, 2), point(3, 0, 0, 2)};  // two points: no rotation
  PoseVector nu0;
  nu0 << 0, 0, 0.1, 0.5, 0, 0;
  const FeatureMatch m = matchFeatures(f1, {}, knownMap(), nu0);
  EXPECT_FALSE(m.found);
  EXPECT_EQ(m.nu, nu0);
  EXPECT_NEAR(m.D, 2 * FeatureMatchConfig{}.d_max_m, 1e-12);
}

TEST(FeatureMatching, RefusesBadConfig) {
  FeatureMatchConfig c;
  c.pairs_per_hypothesis = 1;
  EXPECT_THROW(matchFeatures({}, {}, knownMap(), PoseVector::Zero(), c), std::invalid_argument);
  c = {};
  c.d_max_m = 0;
  EXPECT_THROW(matchFeatures({}, {}, knownMap(), PoseVector::Zero(), c), std::invalid_argument);
}

}  // namespace
}  // namespace ambler::perception
