// Whether the weighted iconic matcher's covariance is what its errors are (docs/matching.md,
// "Calibration"). The normalized estimation error squared NEES = eᵀ·P⁻¹·e (e = ν̂ − ν, six
// parameters) is χ² with 6 degrees of freedom if P is right. P describes the error across
// terrains: each terrain carries a bias of its own that its noise draws share (docs/matching.md),
// so the band [4.5, 7.5] on the mean is asserted across terrains (300 trials: 6 ± 0.2, σ of the
// mean √(12/300)), and one terrain's 50 draws are held only to its upper side. An overconfident P
// (the naive (JᵀWJ)⁻¹, which takes lines that share pixels for independent ones) fails both. The
// unweighted LM's σ²·(JᵀJ)⁻¹ is measured alongside, for comparison (not asserted).
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <string>
#include <numbers>
#include <optional>
#include <vector>

#include "base/random.hpp"
#include "eval/geo/dem.hpp"
#include "eval/scenario/scenario.hpp"
#include "perception/iconic.hpp"
#include "perception/range_edges.hpp"
#include "perception/registration.hpp"
#include "perception/scan_to_map.hpp"
#include "perception/sensor_geometry.hpp"
#include "sim/erim_scanner.hpp"
#include "sim/fixtures.hpp"
#include "terrains/terrain.hpp"

namespace ambler::perception {
namespace {

constexpr double kDeg = std::numbers::pi / 180.0;

terrains::TerrainSpec marsGround() {
  terrains::TerrainSpec spec;
  spec.kind = terrains::TerrainKind::Mars;
  spec.size_m = {20.0, 20.0};
  spec.cell_m = 0.05;
  spec.rocks = terrains::RockSpec{0.08, 0.1, 1.0};
  spec.craters = terrains::CraterSpec{3, 1.0, 4.0, 2.0};
  return spec;
}

double nees(const PoseVector& e, const Matrix6d& P) { return e.dot(P.ldlt().solve(e)); }

// One trial of the weighted method as registration runs it: views I and J scanned with the given
// keys, map I (its σ_z with the footprint's term, as eval::PairRegistration maps it) and its
// mapper, image J at the believed pose (unwrapped, its edges), the weighted LM from there, and
// the NEES of its covariance and of the naive (JᵀWJ)⁻¹ at its estimate. Not movable: the mappers
// keep references to the images held here.
struct WeightedTrial {
  ScanMap map_i;
  LocusConfig locus;
  std::optional<LocusMapper> source;  // map I's mapper (the covariance counts its pixels)
  RangeImage image_j;
  Raster<std::uint8_t> edges_j;
  std::optional<LocusMapper> mapper;  // image J at the believed pose
  PoseVector truth;                   // the ν that corrects the believed pose
  IconicResult res;
  PoseVector e;                       // res.nu − truth
  double nees = 0, naive = 0;
  // With `restarts`: the squared distance, in res.covariance's metric, from res.nu to where the
  // method ends started at the truth on the same images, with its polish (restart) and without it
  // (restart_unpolished, both ends unpolished). 0 if the end does not depend on the start.
  double restart = 0, restart_unpolished = 0;

  WeightedTrial(const sim::ErimScanner& scanner, const SensorModel& sensor, const Eigen::Isometry3d& T_I,
                const Eigen::Isometry3d& T_J, const Eigen::Isometry3d& believed, const MapGrid& grid,
                ScanToMapConfig map_config, std::uint64_t key_i, std::uint64_t key_j, bool restarts = false) {
    map_config.locus.footprint_sigma = true;
    locus = map_config.locus;
    map_i = scanToMap(scanner.scan(T_I, key_i).image, sensor, T_I, grid, map_config);
    source.emplace(map_i.image, sensor, &*map_i.edges, locus);
    image_j = scanner.scan(T_J, key_j).image;
    image_j.T_WS = believed;
    unwrapRanges(image_j, sensor);
    edges_j = detectRangeEdges(image_j, sensor, map_config.gnc);
    mapper.emplace(image_j, sensor, &edges_j, locus);
    truth = vectorFromPose(believed * T_J.inverse());
    IconicOptions options;
    options.map1_source = &*source;
    res = iconicWeighted(map_i.map, *mapper, PoseVector::Zero(), options);
    if (res.degenerate) return;
    if (restarts) {
      const auto distance2 = [&](const PoseVector& a, const PoseVector& b) {
        return ambler::perception::nees(a - b, res.covariance);
      };
      restart = distance2(iconicWeighted(map_i.map, *mapper, truth, options).nu, res.nu);
      IconicOptions plain = options;
      plain.polish_iterations = 0;
      restart_unpolished = distance2(iconicWeighted(map_i.map, *mapper, truth, plain).nu,
                                     iconicWeighted(map_i.map, *mapper, PoseVector::Zero(), plain).nu);
    }
    e = res.nu - truth;
    nees = ambler::perception::nees(e, res.covariance);
    const IconicError at = iconicError(map_i.map, *mapper, res.nu, true, 0.0, nullptr, 1, true);
    naive = ambler::perception::nees(e, at.JtJ.ldlt().solve(Matrix6d::Identity()));
  }
  WeightedTrial(const WeightedTrial&) = delete;
  WeightedTrial& operator=(const WeightedTrial&) = delete;
};

TEST(MatchingCalibration, WeightedCovarianceMatchesTheErrors) {
  const auto t0 = std::chrono::steady_clock::now();
  const test::TerrainWorld world(marsGround(), 3);
  const SensorModel sensor;  // the ERIM: noise, 7.6 cm counts, mixed pixels
  const sim::ErimScanner scanner(*world.scene, sensor);
  const Eigen::Isometry3d T_I = sensorPose({0, -6, 3}, {0, -30 * kDeg, 0});
  const Eigen::Isometry3d T_J = sensorPose({0.6, -5.2, 3}, {0, -30 * kDeg, 10 * kDeg});
  const MapGrid grid = MapGrid::covering(-5, 5, -3, 8, 0.1);
  // The weighted method's σ_z has the footprint's term (WeightedTrial); the unweighted LM measured
  // alongside runs on the same maps.
  constexpr int kTrials = 50;
  double sum_weighted = 0, sum_naive = 0, sum_alike = 0, sum_lm = 0, sum_t = 0, sum_r = 0, sum_t_lm = 0, sum_r_lm = 0;
  int lm_trials = 0;
  for (int k = 0; k < kTrials; ++k) {
    // The believed pose of J: 0.2 m across, 0.2 m along, 0.1 m up and 3° of yaw off, each sign drawn.
    base::Rng rng(base::streamKey(2024, k, 2));
    const auto sign = [&] { return rng.uniform() < 0.5 ? -1.0 : 1.0; };
    PoseVector off;
    off << 0, 0, sign() * 3 * kDeg, sign() * 0.2, sign() * 0.2, sign() * 0.1;
    const Eigen::Isometry3d believed = T_J * poseFromVector(off);
    const WeightedTrial t(scanner, sensor, T_I, T_J, believed, grid, ScanToMapConfig{}, base::streamKey(2024, k, 0),
                          base::streamKey(2024, k, 1));
    const IconicResult& res = t.res;
    const ScanMap& map_i = t.map_i;
    const LocusMapper& mapper = *t.mapper;
    const PoseVector& truth = t.truth;
    ASSERT_FALSE(res.degenerate) << "trial " << k;
    const PoseVector& e = t.e;
    const double n = t.nees;
    sum_weighted += n;
    // Scored as sensor J's pose: its error e_S = log(T̂⁻¹·T) in J's frame (T̂ the estimate, T the
    // truth) and its covariance A·P·Aᵀ (sensorPoseCovariance). NEES is invariant to first order
    // under that linear map: the two agree to 1 %.
    const Eigen::Isometry3d T_hat = poseFromVector(res.nu).inverse() * believed;
    const PoseVector e_pose = vectorFromPose(T_hat.inverse() * T_J);
    const double n_pose = nees(e_pose, sensorPoseCovariance(res.nu, res.covariance, believed));
    EXPECT_NEAR(n_pose, n, 0.01 * n + 1e-9) << "trial " << k;
    const PoseError err = poseError(believed * T_J.inverse(), poseFromVector(res.nu));
    sum_t += err.translation_m, sum_r += err.rotation_deg;
    // The naive (JᵀWJ)⁻¹ at the same estimate: every line taken for an independent observation.
    const double naive = t.naive;
    sum_naive += naive;
    // Without map 1's image: its lines taken to share pixels as their crossings with image 2 do.
    const double c = IconicOptions{}.robust_sigmas;  // the loss's final scale, 3 σ
    const double alike = nees(e, weightedCovariance(map_i.map, mapper, res.nu, c, referenceNormals(map_i.map), nullptr));
    sum_alike += alike;
    if (k % 5 == 0) {  // the unweighted LM on every fifth pair, for docs/matching.md
      const IconicResult lm = iconicLevenbergMarquardt(map_i.map, mapper, PoseVector::Zero());
      const PoseError err_lm = poseError(believed * T_J.inverse(), poseFromVector(lm.nu));
      sum_lm += nees(lm.nu - truth, lm.covariance);
      sum_t_lm += err_lm.translation_m, sum_r_lm += err_lm.rotation_deg;
      ++lm_trials;
    }
    std::printf("trial %2d: NEES %6.2f (without image 1: %6.2f; naive %7.1f), error %.4f m %.4f deg, %d iterations, "
                "%ld lines\n", k, n, alike, naive, err.translation_m, err.rotation_deg, res.iterations, res.overlap);
  }
  const double mean = sum_weighted / kTrials;
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::printf("weighted: mean NEES %.2f (without image 1: %.2f; naive (JtWJ)^-1: %.1f), mean error %.4f m %.4f deg "
              "over %d pairs\n", mean, sum_alike / kTrials, sum_naive / kTrials, sum_t / kTrials, sum_r / kTrials, kTrials);
  std::printf("unweighted LM: mean NEES %.2f, mean error %.4f m %.4f deg over %d pairs; %.1f s\n", sum_lm / lm_trials,
              sum_t_lm / lm_trials, sum_r_lm / lm_trials, lm_trials, seconds);
  // One terrain: its draws' errors scatter about the terrain's own bias, so their mean NEES is the
  // scatter's share of P plus that bias's, below 6 where the bias is small (5.0 on mars across
  // terrains); only its upper side is this test's, χ²₆'s mean over 50 draws plus three of its σ's.
  EXPECT_LE(mean, 6 + 3 * std::sqrt(12.0 / kTrials));
  EXPECT_GT(sum_naive / kTrials, 7.5);  // what the correction is for: without it the test fails
}


// Mean NEES of the weighted method across terrains (docs/matching.md, "Calibration"): three kinds
// (the acceptance experiment's Mars-like ground, fractal ground with rocks and craters, the sample
// DEM with rocks), 20 terrains each (seeds 1–20), 5 noise draws on each, each from a believed pose
// drawn from the odometry prior (matching.draw_initial_error); registrations that lose the pair
// (beyond 5 cm) are not the covariance's to explain and are counted out. Also the naive (JᵀWJ)⁻¹'s.
// The DEM kind's 20 terrains are 20 windows of the sample DTM, their centres on a 5 × 4 lattice
// 35 m apart about its centre (the seed changes the window and its rocks).
struct NeesAcross {
  double mean = 0, naive = 0;
  double restart = 0, restart_unpolished = 0;  // WeightedTrial's, their means (when asked)
  std::vector<double> per_kind;
  int n = 0;
};

// noise_scale multiplies the ERIM's noise coefficient k (the sensor grid of docs/matching.md).
NeesAcross neesAcrossTerrains(bool quantise, bool restarts = false, double noise_scale = 1.0) {
  const auto t0 = std::chrono::steady_clock::now();
  const std::filesystem::path dir = std::filesystem::path(AMBLER_SOURCE_DIR) / "scenarios" / "experiments";
  NeesAcross out;
  double all = 0, all_naive = 0;
  for (const char* kind : {"mars", "fractal", "dem"}) {
    double sum = 0, sum_naive = 0, worst = 0;
    PoseVector per_parameter = PoseVector::Zero();  // Σ e_j²/P_jj: 1 a trial each if P is right
    int n = 0;
    for (int seed = 1; seed <= 20; ++seed) {
      eval::Scenario sc = eval::loadScenario(dir / (std::string("acceptance_") + kind + ".yaml"));
      sc.seed = std::uint64_t(seed);
      if (sc.terrain.kind == terrains::TerrainKind::Dem) {
        const int i = seed - 1;
        const eval::SampleDemModel dtm;  // the model scenarios/dem/sample_dtm.tif was made from
        sc.terrain.dem_centre_m = Eigen::Vector2d(dtm.centre_e_m - 70 + 35 * (i % 5), dtm.centre_n_m - 52.5 + 35 * (i / 5));
      }
      if (!quantise) sc.sensor.quantization_m = 0;
      sc.sensor.noise_k *= noise_scale;
      const test::TerrainWorld world(eval::scenarioTerrain(sc));
      const sim::ErimScanner scanner(*world.scene, sc.sensor);
      const Eigen::Isometry3d T_I = sensorPose(sc.views[0].xyz_m, sc.views[0].rpy_rad);
      const Eigen::Isometry3d T_J = sensorPose(sc.views[1].xyz_m, sc.views[1].rpy_rad);
      const MapGrid grid = sc.map->grid();
      ScanToMapConfig map_config = sc.map->scanToMapConfig();
      map_config.locus.trust_edge_samples = true;  // as registration maps (eval::registrationConfig)
      for (int k = 0; k < 5; ++k) {
        const Eigen::Isometry3d T_IJ = T_I.inverse() * T_J;
        const Eigen::Isometry3d believed = T_I * sc.matching->initialEstimate(T_IJ, std::uint64_t(seed * 10 + k), 0, 1);
        const WeightedTrial t(scanner, sc.sensor, T_I, T_J, believed, grid, map_config,
                              base::streamKey(3030, std::uint64_t(seed), std::uint64_t(2 * k)),
                              base::streamKey(3030, std::uint64_t(seed), std::uint64_t(2 * k + 1)), restarts);
        const IconicResult& res = t.res;
        if (res.degenerate) continue;
        if (poseError(poseFromVector(t.truth), poseFromVector(res.nu)).translation_m > 0.05) continue;  // lost
        const double v = t.nees;
        sum += v, sum_naive += t.naive;
        out.restart += t.restart, out.restart_unpolished += t.restart_unpolished;
        per_parameter += t.e.cwiseProduct(t.e).cwiseQuotient(res.covariance.diagonal());
        worst = std::max(worst, v);
        ++n;
      }
    }
    per_parameter /= n;
    std::printf("%s (quantisation %s, noise %.2g k): mean NEES %.2f over %d trials (naive %.1f), largest %.1f; per parameter "
                "e^2/P (rx ry rz tx ty tz) %.2f %.2f %.2f %.2f %.2f %.2f\n", kind, quantise ? "on" : "off", noise_scale, sum / n, n,
                sum_naive / n, worst, per_parameter(0), per_parameter(1), per_parameter(2), per_parameter(3),
                per_parameter(4), per_parameter(5));
    EXPECT_GE(n, 95) << kind;
    out.per_kind.push_back(sum / n);
    all += sum, all_naive += sum_naive, out.n += n;
  }
  out.mean = all / out.n, out.naive = all_naive / out.n;
  out.restart /= out.n, out.restart_unpolished /= out.n;
  if (restarts)
    std::printf("started at the truth instead, the end moves by %.2f (squared, in P's metric; without the polish "
                "%.2f)\n", out.restart, out.restart_unpolished);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::printf("all: mean NEES %.2f over %d trials (naive %.1f); %.1f s\n", out.mean, out.n, out.naive, seconds);
  return out;
}

// With the ERIM's noise, 7.6 cm counts and mixed pixels the covariance holds across the three
// kinds: over 300 trials the mean of χ²₆ is 6 ± 0.2 (σ of the mean, √(12/300)), and [4.5, 7.5]
// holds it with seven of those σ's to spare; the naive (JᵀWJ)⁻¹ fails it (the negative control).
// What eval::covarianceCalibrated says for such sensors. Three things make it hold
// (docs/matching.md, "Calibration"): the sandwich's A through image 2's own slopes, its bread with
// the Cauchy influence's derivative ψ′, and the Gauss–Newton polish that ends at the estimating
// equation's root instead of the staircase's nearest local minimum.
TEST(MatchingCalibration, WeightedCovarianceHoldsAcrossTerrainsWithTheErimsQuantisation) {
  const NeesAcross r = neesAcrossTerrains(true, true);
  EXPECT_GE(r.mean, 4.5);
  EXPECT_LE(r.mean, 7.5);
  EXPECT_GT(r.naive, 7.5);
  // The polish ends at the estimating equation's root, wherever LM started: the end moves by less
  // than a sixth of χ²₆'s mean when started at the truth instead; LM alone stops in the staircase's
  // nearest minimum, and its end moves by more than that mean's sixth.
  EXPECT_LT(r.restart, 1.0);
  EXPECT_GT(r.restart_unpolished, 1.0);
  const auto calibrated = [](const perception::SensorModel& sensor) {
    return eval::covarianceCalibrated(eval::MatchMethod::IconicWeighted, sensor);
  };
  const perception::SensorModel erim;
  EXPECT_TRUE(calibrated(erim));
  EXPECT_FALSE(eval::covarianceCalibrated(eval::MatchMethod::IconicLm, erim));
  // The line of the sensor grid measured inside the band (docs/matching.md): the ERIM's counts
  // with half its noise to its own.
  perception::SensorModel s = erim;
  s.noise_k /= 2;
  EXPECT_TRUE(calibrated(s));
  // What was not measured, or measured outside the band, is not claimed: without mixed pixels,
  // finer or coarser counts, more noise, a quarter of it (4.48), another pixel grid, dropouts.
  s = erim, s.mixed_pixels = false;
  EXPECT_FALSE(calibrated(s));
  s = erim, s.quantization_m = 0.02;
  EXPECT_FALSE(calibrated(s));
  s = erim, s.quantization_m = 0.1;
  EXPECT_FALSE(calibrated(s));
  s = erim, s.noise_k *= 1.5;
  EXPECT_FALSE(calibrated(s));
  s = erim, s.noise_k /= 4;
  EXPECT_FALSE(calibrated(s));
  s = erim, s.rows *= 2;
  EXPECT_FALSE(calibrated(s));
  s = erim, s.dropout = 0.01;
  EXPECT_FALSE(calibrated(s));
}

// Where the flag stops, measured on one side: without the counts the covariance is conservative
// (mean NEES 3.99 over the 300 trials; docs/matching.md, the sensor grid), its σ_z's footprint
// and mixed-pixel terms too large for the errors that are left, so such a sensor is not called
// calibrated.
TEST(MatchingCalibration, WeightedCovarianceIsConservativeWithoutTheCounts) {
  const NeesAcross r = neesAcrossTerrains(false);
  EXPECT_LT(r.mean, 4.5);
  EXPECT_GT(r.naive, 7.5);
  perception::SensorModel ideal_counts;
  ideal_counts.quantization_m = 0;
  EXPECT_FALSE(eval::covarianceCalibrated(eval::MatchMethod::IconicWeighted, ideal_counts));
}

// And on the other: at twice the ERIM's noise, with its counts, the covariance is overconfident
// (mean NEES 12.3 over the 300 trials; docs/matching.md, the sensor grid). The end depends on the
// start there: the noise roughens the cost faster than the polish's contraction test admits its
// steps.
TEST(MatchingCalibration, WeightedCovarianceIsOverconfidentAtTwiceTheErimsNoise) {
  const NeesAcross r = neesAcrossTerrains(true, false, 2.0);
  EXPECT_GT(r.mean, 7.5);
  perception::SensorModel noisier;
  noisier.noise_k *= 2;
  EXPECT_FALSE(eval::covarianceCalibrated(eval::MatchMethod::IconicWeighted, noisier));
}

}  // namespace
}  // namespace ambler::perception
