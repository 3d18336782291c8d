// The rover's verdict on a registration (perception/acceptance.hpp): the odometry prior and the
// correction's Mahalanobis distance against their closed forms, the verification cost over the
// lines every hypothesis has, and each reason to reject on a scene built to have it: ground with
// three caps seen twice (the truth accepted, a wrong pose refused by its residuals), a correction
// the prior cannot explain, a plane (degenerate), a covariance that is not positive definite, and a
// descent stopped short of its cost's minimum.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <numbers>
#include <string>
#include <vector>

#include "perception/acceptance.hpp"
#include "perception/locus_mapper.hpp"
#include "perception/range_edges.hpp"
#include "perception/registration.hpp"
#include "perception/scan_to_map.hpp"
#include "perception/sensor_geometry.hpp"
#include "synthetic.hpp"

namespace ambler::perception {
namespace {

constexpr double kDeg = std::numbers::pi / 180.0;
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

bool hasReason(const Assessment& a, const std::string& prefix) {
  for (const std::string& r : a.reject_reasons)
    if (r.rfind(prefix, 0) == 0) return true;
  return false;
}

TEST(Acceptance, OdometryPriorGrowsWithDistanceAboveItsFloor) {
  const OdometryModel m;  // 0.15 m/m (floor 0.05 m), 2°/m (floor 0.5°)
  EXPECT_DOUBLE_EQ(m.at(0).translation_m, 0.05);
  EXPECT_DOUBLE_EQ(m.at(0).rotation_deg, 0.5);
  EXPECT_DOUBLE_EQ(m.at(0.2).translation_m, 0.05);  // 0.03 < floor
  EXPECT_DOUBLE_EQ(m.at(0.2).rotation_deg, 0.5);    // 0.4° < floor
  EXPECT_DOUBLE_EQ(m.at(2.0).translation_m, 0.30);
  EXPECT_DOUBLE_EQ(m.at(2.0).rotation_deg, 4.0);
  EXPECT_DOUBLE_EQ(m.at(-1).translation_m, 0.05);  // a distance is never negative
}

TEST(Acceptance, CorrectionMahalanobisIsItsClosedForm) {
  const PriorSigma prior{0.15, 2.0};
  const Eigen::Isometry3d believed = sensorPose({1, -4, 3}, {0.1, -0.5, 0.7});
  // A translation of 0.3 m in the believed sensor's frame: (0.3/0.15)² = 4.
  Eigen::Isometry3d shift = Eigen::Isometry3d::Identity();
  shift.translation() = Eigen::Vector3d(0.18, -0.24, 0);
  EXPECT_NEAR(correctionMahalanobis2(believed, believed * shift, prior), 4.0, 1e-12);
  // A turn of 4° about any axis: (4/2)² = 4.
  const Eigen::Isometry3d turn(Eigen::AngleAxisd(4 * kDeg, Eigen::Vector3d(1, 2, 3).normalized()));
  EXPECT_NEAR(correctionMahalanobis2(believed, believed * turn, prior), 4.0, 1e-9);
  // Both: the sum (translation of the turn-then-shift's δ is the shift's, rotated).
  EXPECT_NEAR(correctionMahalanobis2(believed, believed * turn * shift, prior), 8.0, 1e-9);
  EXPECT_NEAR(correctionMahalanobis2(believed, believed, prior), 0.0, 1e-20);
}

TEST(Acceptance, VerificationCostCountsOnlyTheLinesEveryHypothesisHas) {
  // Lines 0 and 3 are common; line 1 is missing from the second, line 2 from the first.
  const std::vector<std::vector<double>> u{{0.0, 30.0, kNaN, 1.0}, {2.0, kNaN, 0.0, 1.0}};
  long common = 0;
  const double c = 3;
  const std::vector<double> cost = commonOverlapCosts(u, c, &common);
  const auto rho = [&](double x) { return c * c * std::log1p(x * x / (c * c)); };
  EXPECT_EQ(common, 2);
  EXPECT_NEAR(cost[0], (rho(0) + rho(1)) / 2, 1e-15);  // line 1's 30σ does not count
  EXPECT_NEAR(cost[1], (rho(2) + rho(1)) / 2, 1e-15);
  // No common line: no hypothesis can be preferred (infinite costs).
  const std::vector<double> none = commonOverlapCosts({{1.0, kNaN}, {kNaN, 1.0}}, c, &common);
  EXPECT_EQ(common, 0);
  EXPECT_TRUE(std::isinf(none[0]) && std::isinf(none[1]));
}

// The caps of test_iconic (ground with three sphere caps: every parameter constrained): map 1
// from a noise-free scan at T1, image 2 noise-free from T_WS, 0.56 m away and turned 4°, with its
// range edges; σ from the ERIM's sensor model (the images are exact, the σ the model's).
struct CapsScene {
  test::Caps caps;
  Eigen::Isometry3d T1 = sensorPose({0, -3, 3}, {0, -30 * kDeg, 0});
  Eigen::Isometry3d T_WS = sensorPose({0.3, -2.5, 3}, {0, -32 * kDeg, -4 * kDeg});
  SensorModel erim;
  ElevationMap map1 = scanToMap(test::capsImage(caps, T1), erim, T1, MapGrid::covering(-3, 3, 1.5, 8, 0.1)).map;
  RangeImage image = test::capsImage(caps, T_WS);
  Raster<std::uint8_t> edges = detectRangeEdges(image, SensorModel{});
  LocusConfig config;
  // Image 2 at the believed pose `believed` (rendered at the truth T_WS; the mapper keeps a
  // reference to the image, which lives as long as the scene).
  LocusMapper mapper(const Eigen::Isometry3d& believed) {
    image.T_WS = believed;
    return LocusMapper(image, erim, &edges, config);
  }
  // ν that corrects the believed pose to the truth: T_WS = exp(ν)⁻¹·believed.
  PoseVector correction(const Eigen::Isometry3d& believed) const { return vectorFromPose(believed * T_WS.inverse()); }
};

AcceptanceConfig wide() {
  AcceptanceConfig a;
  a.prior = {10.0, 90.0};
  return a;
}

TEST(Acceptance, TheTruthIsAccepted) {
  CapsScene s;
  const LocusMapper m = s.mapper(s.T_WS);
  const Assessment a = assessRegistration(s.map1, m, PoseVector::Zero(), s.T_WS, nullptr, nullptr, wide());
  // The residuals are the two interpolations' error (≤ 2 mm a line, test_iconic), far inside 3σ
  // of the ERIM's model (σ_z of centimetres at these ranges).
  EXPECT_TRUE(a.accepted) << (a.reject_reasons.empty() ? "" : a.reject_reasons.front());
  EXPECT_GT(a.inlier_fraction, 0.99);
  EXPECT_GT(a.overlap, 500);
  EXPECT_EQ(a.correction_m, 0.0);
  EXPECT_FALSE(a.degenerate);
}

TEST(Acceptance, AWrongPoseIsRefusedByItsResiduals) {
  CapsScene s;
  // The estimate 0.3 m too high and tilted 2°: on the level ground the lines miss by 0.2–0.4 m,
  // ten σ and more.
  const LocusMapper m = s.mapper(s.T_WS);
  PoseVector nu;
  nu << 2 * kDeg, 0, 0, 0, 0, 0.3;
  const Assessment a = assessRegistration(s.map1, m, nu, s.T_WS, nullptr, nullptr, wide());
  EXPECT_FALSE(a.accepted);
  EXPECT_TRUE(hasReason(a, "residuals:")) << (a.reject_reasons.empty() ? "" : a.reject_reasons.front());
  EXPECT_LT(a.inlier_fraction, AcceptanceConfig{}.min_inlier_fraction);
  EXPECT_FALSE(hasReason(a, "prior:"));  // the wide prior explains it
}

TEST(Acceptance, ACorrectionThePriorCannotExplainIsRefused) {
  CapsScene s;
  // Believed 0.3 m off along the sensor's x; ν corrects it exactly, so the lines agree.
  Eigen::Isometry3d E = Eigen::Isometry3d::Identity();
  E.translation() = Eigen::Vector3d(0.3, 0, 0);
  const Eigen::Isometry3d believed = s.T_WS * E;
  const LocusMapper m = s.mapper(believed);
  const PoseVector nu = s.correction(believed);
  AcceptanceConfig loose = wide();
  const Assessment ok = assessRegistration(s.map1, m, nu, believed, nullptr, nullptr, loose);
  EXPECT_TRUE(ok.accepted) << (ok.reject_reasons.empty() ? "" : ok.reject_reasons.front());
  EXPECT_NEAR(ok.correction_m, 0.3, 1e-9);
  // σ_t 5 cm: (0.3/0.05)² = 36 > 22.46.
  AcceptanceConfig tight = wide();
  tight.prior = {0.05, 90.0};
  const Assessment no = assessRegistration(s.map1, m, nu, believed, nullptr, nullptr, tight);
  EXPECT_FALSE(no.accepted);
  EXPECT_NEAR(no.mahalanobis2, 36.0 + std::pow(no.correction_deg / 90.0, 2), 1e-6);
  ASSERT_EQ(no.reject_reasons.size(), 1u);
  EXPECT_TRUE(hasReason(no, "prior:"));
}

TEST(Acceptance, APlaneIsDegenerate) {
  const test::Plane plane{0.0, 0.0, 0.0};
  const Eigen::Isometry3d T = sensorPose({0, -3, 2}, {0, -30 * kDeg, 0});
  ElevationMap map1(MapGrid::covering(-2, 2, 0, 4, 0.1));
  for (int r = 0; r < map1.grid().rows; ++r)
    for (int c = 0; c < map1.grid().cols; ++c) map1.setKnown(r, c, 0.f, 1e-3f);
  const RangeImage image = test::planeImage(plane, T);
  const LocusMapper m(image, SensorModel{}, nullptr);
  const Assessment a = assessRegistration(map1, m, PoseVector::Zero(), T, nullptr, nullptr, wide());
  EXPECT_FALSE(a.accepted);
  EXPECT_TRUE(a.degenerate);
  ASSERT_TRUE(hasReason(a, "degenerate:"));
  // A level plane leaves tx, ty and rz free.
  EXPECT_EQ(a.free_directions, (std::vector<std::string>{"rz", "tx", "ty"}));
}

TEST(Acceptance, ACovarianceThatIsNotPositiveDefiniteIsRefused) {
  CapsScene s;
  const LocusMapper m = s.mapper(s.T_WS);
  Matrix6d P = Matrix6d::Identity() * 1e-6;
  const Assessment good = assessRegistration(s.map1, m, PoseVector::Zero(), s.T_WS, &P, nullptr, wide());
  EXPECT_TRUE(good.accepted);
  P(2, 2) = -1e-9;
  const Assessment bad = assessRegistration(s.map1, m, PoseVector::Zero(), s.T_WS, &P, nullptr, wide());
  EXPECT_FALSE(bad.accepted);
  EXPECT_TRUE(hasReason(bad, "covariance:"));
  P = Matrix6d::Constant(kNaN);
  EXPECT_TRUE(hasReason(assessRegistration(s.map1, m, PoseVector::Zero(), s.T_WS, &P, nullptr, wide()), "covariance:"));
}

TEST(Acceptance, TooLittleOverlapIsRefused) {
  CapsScene s;
  // The estimate 12 m to the side: the lines leave the image.
  const LocusMapper m = s.mapper(s.T_WS);
  PoseVector nu = PoseVector::Zero();
  nu(3) = 12.0;
  const Assessment a = assessRegistration(s.map1, m, nu, s.T_WS, nullptr, nullptr, wide());
  EXPECT_FALSE(a.accepted);
  EXPECT_TRUE(hasReason(a, "overlap:"));
}

// One Gauss–Newton step's statistic, δᵀHδ/σ² = Σ_k (v_k·g/2)²/λ_k/σ², on a diagonal H: a direction
// H does not constrain (λ = 0) adds nothing, and with 6 lines or fewer there is none.
TEST(Acceptance, TheStepStatisticIsItsClosedForm) {
  IconicError e;
  e.overlap = 100;
  e.JtJ = PoseVector(1, 4, 9, 16, 25, 0).asDiagonal();
  e.gradient << 2, 2, 6, 0, 10, 7;  // g/2 = (1, 1, 3, 0, 5, 3.5)
  const double sigma2 = 0.5;
  EXPECT_NEAR(stepMahalanobis2(e, sigma2), (1.0 / 1 + 1.0 / 4 + 9.0 / 9 + 0 + 25.0 / 25) / sigma2, 1e-12);
  e.overlap = 6;
  EXPECT_TRUE(std::isnan(stepMahalanobis2(e, sigma2)));
}

// The statistic is the decrease of E/σ² one Gauss–Newton step predicts: on the caps 2 cm and 0.2°
// from the truth (plain squares, image 2's normals: the exact gradient), taking the step lowers E
// by T·σ² to within 10 % (the residuals' second-order terms over a 2 cm step), and T at the truth
// is what the noise-free images' interpolation leaves, far below the statistic of the offset.
TEST(Acceptance, TheStepStatisticIsTheDecreaseOneStepPredicts) {
  CapsScene s;
  const LocusMapper m = s.mapper(s.T_WS);
  PoseVector nu;
  nu << 0, 0, 0.2 * kDeg, 0.02, -0.01, 0.01;
  const IconicError e = iconicError(s.map1, m, nu, true);
  const double sigma2 = 1e-6;  // (1 mm)²: T in units of it
  const double T = stepMahalanobis2(e, sigma2);
  const PoseVector delta = e.JtJ.ldlt().solve(-0.5 * e.gradient);
  const IconicError after = iconicError(s.map1, m, nu + delta, false);
  EXPECT_NEAR((e.E - after.E) / sigma2, T, 0.1 * T);
  EXPECT_LT(stepMahalanobis2(iconicError(s.map1, m, PoseVector::Zero(), true), sigma2), 0.01 * T);
}

// A descent stopped short of its cost's minimum is refused ("not converged"), and the same start
// refined to the minimum by LM is accepted: the caps believed 0.1 m and 1° off.
TEST(Acceptance, AStallShortOfTheMinimumIsRefused) {
  CapsScene s;
  const Eigen::Isometry3d believed = s.T_WS * (Eigen::Translation3d(0.08, -0.05, 0.03) * Eigen::AngleAxisd(1 * kDeg, Eigen::Vector3d::UnitZ()));
  const LocusMapper m = s.mapper(believed);
  IconicOptions stall;
  stall.max_iterations = 2;
  const IconicResult stalled = iconicGradientDescent(s.map1, m, PoseVector::Zero(), stall);
  const IconicResult lm = iconicLevenbergMarquardt(s.map1, m, PoseVector::Zero());
  const AcceptanceConfig config = wide();
  const Assessment a = assessRegistration(s.map1, m, stalled.nu, believed, nullptr, nullptr, config, nullptr,
                                          stalled.step_mahalanobis2);
  EXPECT_FALSE(a.accepted);
  EXPECT_TRUE(hasReason(a, "not converged:")) << (a.reject_reasons.empty() ? "" : a.reject_reasons.front());
  const Assessment b = assessRegistration(s.map1, m, lm.nu, believed, nullptr, nullptr, config, nullptr, lm.step_mahalanobis2);
  EXPECT_TRUE(b.accepted) << (b.reject_reasons.empty() ? "" : b.reject_reasons.front());
  EXPECT_LT(lm.step_mahalanobis2, config.max_step_mahalanobis2);
  // Unknown (NaN): no reason.
  EXPECT_FALSE(hasReason(assessRegistration(s.map1, m, lm.nu, believed, nullptr, nullptr, config), "not converged:"));
}

// features+iconic_weighted: its iconic stage reads the weighted map I (σ_z with the footprint's
// term), its feature stage the plain one, and map J made with the plain locus settings: the
// features are those of the plain maps. A weighted method against a view without its weighted
// map is refused.
TEST(Verification, TheWeightedTwoStageMethodsFeaturesComeFromThePlainMaps) {
  using test::sameBits;
  CapsScene s;
  const Eigen::Isometry3d believed = s.T_WS * Eigen::Translation3d(0.05, -0.03, 0.02);
  ScanMap scan_i;
  scan_i.image = test::capsImage(s.caps, s.T1);
  scan_i.edges = detectRangeEdges(scan_i.image, s.erim);
  scan_i.sensor = s.erim;
  const MapGrid grid = s.map1.grid();
  RegistrationConfig config;
  config.acceptance = wide();
  const ReferenceView view_i = referenceView(scan_i, grid, config, true);
  LocusConfig with_footprint = config.locus;
  with_footprint.footprint_sigma = true;
  const ElevationMap plain = LocusMapper(scan_i.image, s.erim, &*scan_i.edges, config.locus).map(grid);
  const ElevationMap weighted = LocusMapper(scan_i.image, s.erim, &*scan_i.edges, with_footprint).map(grid);
  ASSERT_TRUE(view_i.weighted.has_value());
  EXPECT_TRUE(sameBits(view_i.map, plain));
  EXPECT_TRUE(sameBits(*view_i.weighted, weighted));
  ScanMap scan_j;
  scan_j.image = s.image;
  scan_j.edges = s.edges;
  scan_j.sensor = s.erim;
  const RegistrationResult r =
      registerViews(view_i, scan_j, believed, RegistrationMethod::FeaturesIconicWeighted, config);
  const std::vector<Feature> expected = extractFeatures(plain, config.features);
  ASSERT_EQ(r.features_i.size(), expected.size());
  for (std::size_t k = 0; k < expected.size(); ++k) EXPECT_EQ(r.features_i[k].position, expected[k].position);
  RangeImage image2 = s.image;
  image2.T_WS = believed;
  const MapGrid grid_j = believedGrid(grid, s.T1, believed);
  const LocusMapper mapper_j(image2, s.erim, &s.edges, config.locus, grid_j.T_WM);
  ASSERT_TRUE(r.map_j.has_value());
  EXPECT_TRUE(sameBits(*r.map_j, mapper_j.map(grid_j)));
  // The weighted refinement finds the truth (the caps' 5 mm of test_iconic) and is believed.
  const PoseError e = poseError(poseFromVector(s.correction(believed)), poseFromVector(r.nu));
  EXPECT_LT(e.translation_m, 5e-3);
  EXPECT_TRUE(r.assessment.accepted) << (r.assessment.reject_reasons.empty() ? "" : r.assessment.reject_reasons.front());
  // The corrected pose of sensor J is ν's one conversion, exp(ν)⁻¹·believed, bit for bit.
  EXPECT_TRUE(r.correction.matrix() == poseFromVector(r.nu).inverse().matrix());
  EXPECT_TRUE(r.corrected_WS.matrix() == (poseFromVector(r.nu).inverse() * believed).matrix());
  const ReferenceView plain_only = referenceView(scan_i, grid, config, false);
  EXPECT_THROW(registerViews(plain_only, scan_j, believed, RegistrationMethod::FeaturesIconicWeighted, config),
               std::invalid_argument);
  EXPECT_NO_THROW(registerViews(plain_only, scan_j, believed, RegistrationMethod::Features, config));
}

// Verification on the caps with a planted wrong pairing: feature matching's T_F put 0.8 m, 0.6 m
// and 20° off the truth, the rover believing it is E off. Returns the verification by LM, its
// error against the truth and the verdict on what it kept.
struct PlantedRun {
  Verification v;
  PoseError error;
  Assessment verdict;
};

PlantedRun plantedWrongPairing(CapsScene& s, const Eigen::Isometry3d& E) {
  const Eigen::Isometry3d believed = s.T_WS * E;
  const LocusMapper m = s.mapper(believed);
  const PoseVector truth = s.correction(believed);
  PoseVector wrong = truth;
  wrong(2) += 20 * kDeg, wrong(3) += 0.8, wrong(4) -= 0.6;
  RegistrationConfig config;
  config.acceptance = wide();
  const Refiner lm = [&](const PoseVector& start, const IconicOptions& o) { return iconicLevenbergMarquardt(s.map1, m, start, o); };
  PlantedRun run;
  run.v = verifyHypotheses(s.map1, m, {{"T_F", "screen", wrong, {}, 1.0, 0, 0}}, 2.0, lm, config);
  run.error = poseError(poseFromVector(truth), poseFromVector(run.v.result.nu));
  run.verdict = assessRegistration(s.map1, m, run.v.result.nu, believed, &run.v.result.covariance, nullptr, config.acceptance);
  return run;
}

// T_0 within LM's reach (0.14 m, 1.5°): the screen finds the pairing's cost high, and the kept
// result is T_0's refinement at the truth (to test_iconic's 5 mm and 0.05°); it is accepted.
TEST(Verification, APlantedWrongPairingIsNotKept) {
  CapsScene s;
  const PlantedRun r = plantedWrongPairing(s, Eigen::Translation3d(0.1, -0.08, 0.05) * Eigen::AngleAxisd(1.5 * kDeg, Eigen::Vector3d::UnitZ()));
  const Verification& v = r.v;
  ASSERT_EQ(v.hypotheses.size(), 3u);  // the screen, then the pairing and T_0 refined
  EXPECT_EQ(v.hypotheses[std::size_t(v.chosen)].start, "T_0");
  EXPECT_LT(r.error.translation_m, 5e-3);
  EXPECT_LT(r.error.rotation_deg, 0.05);
  // Never worse than refining T_0 by its own cost: the kept one is the lower of the two.
  EXPECT_LE(v.hypotheses[std::size_t(v.chosen)].cost, v.hypotheses[2].cost);
  EXPECT_GT(v.hypotheses[1].cost, v.hypotheses[2].cost);
  EXPECT_TRUE(r.verdict.accepted) << (r.verdict.reject_reasons.empty() ? "" : r.verdict.reject_reasons.front());
}

// The same wrong pairing, and T_0 out of LM's reach (1.5 m and 25° off): neither refinement finds
// the truth, and the rover says so (accepted false), whichever it keeps.
TEST(Verification, WhenEveryStartIsWrongTheRoverSaysSo) {
  CapsScene s;
  const PlantedRun r = plantedWrongPairing(s, Eigen::Translation3d(1.2, -0.9, 0.1) * Eigen::AngleAxisd(25 * kDeg, Eigen::Vector3d::UnitZ()));
  ASSERT_GT(r.error.translation_m, 0.05) << "the premise: no start reaches the truth";
  EXPECT_FALSE(r.verdict.accepted) << r.error.translation_m << " m, " << r.error.rotation_deg << " deg";
}

}  // namespace
}  // namespace ambler::perception
