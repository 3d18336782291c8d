// eval/score/trajectory_score: the path's distances, KITTI's segment end, the absolute and relative
// errors and the final drift against closed forms on hand-made traverses, the JSON entry, and the
// refusal of malformed input. Stops 1 m apart along x have integer distances, which double sums
// exactly, so every segment end is decided without rounding.
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <limits>
#include <numbers>
#include <stdexcept>
#include <string>

#include "eval/score/trajectory_score.hpp"

namespace ambler::eval {
namespace {

using Poses = std::vector<Eigen::Isometry3d>;
constexpr double kDeg = 180.0 / std::numbers::pi;

// A pose at t with R = Rz(yaw)·Ry(roll)·Rx(pitch) (docs/conventions.md).
Eigen::Isometry3d pose(const Eigen::Vector3d& t, double yaw = 0, double pitch = 0, double roll = 0) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = (Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()) * Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitY()) *
                Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitX()))
                   .toRotationMatrix();
  T.translation() = t;
  return T;
}

// Stops at x = xs[k] on the x axis, the sensor turning and nodding from stop to stop (the relative
// errors must not depend on the orientations the estimate shares with the truth).
Poses alongX(const std::vector<double>& xs) {
  Poses p;
  for (std::size_t k = 0; k < xs.size(); ++k) p.push_back(pose({xs[k], 0, 0}, 0.3 * double(k), -0.1 * double(k % 3)));
  return p;
}

Poses metreStops(int n) {
  std::vector<double> xs;
  for (int k = 0; k < n; ++k) xs.push_back(k);
  return alongX(xs);
}

// The estimate of a traverse whose positions are stretched by (1 + s) about the known start, with
// the true orientations.
Poses scaled(const Poses& truth, double s) {
  Poses est = truth;
  for (Eigen::Isometry3d& T : est)
    T.translation() = truth[0].translation() + (1 + s) * (T.translation() - truth[0].translation());
  return est;
}

void expectRelative(double actual, double expected, double rel = 1e-12) {
  EXPECT_NEAR(actual, expected, rel * std::abs(expected)) << "expected " << expected;
}

void expectInvalid(const std::function<void()>& call, const std::string& part) {
  try {
    call();
    ADD_FAILURE() << "no std::invalid_argument; expected one saying \"" << part << "\"";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find(part), std::string::npos) << e.what();
  }
}

TEST(TrajectoryScore, PathDistancesSumTheStepLengths) {
  const Poses p{pose({0, 0, 0}), pose({3, 4, 0}, 1.0), pose({3, 4, 12}, -2.0), pose({3, 4, 12})};
  EXPECT_EQ(pathDistances(p), (std::vector<double>{0, 5, 17, 17}));
  EXPECT_EQ(pathDistances({pose({1, 2, 3})}), std::vector<double>{0});
  EXPECT_TRUE(pathDistances({}).empty());
}

TEST(TrajectoryScore, ASegmentEndsAtTheFirstStopBeyondItsLength) {
  const std::vector<double> dist = pathDistances(alongX({0, 0.75, 1.5, 3.0, 3.25, 6.0}));
  ASSERT_EQ(dist, (std::vector<double>{0, 0.75, 1.5, 3.0, 3.25, 6.0}));
  EXPECT_EQ(segmentEnd(dist, 0, 3.0), 4u);  // the stop at exactly 3 m is not beyond 3 m (KITTI's >)
  EXPECT_EQ(segmentEnd(dist, 0, 2.9), 3u);
  EXPECT_EQ(segmentEnd(dist, 1, 1.5), 3u);  // beyond 2.25 m
  EXPECT_EQ(segmentEnd(dist, 2, 1.5), 4u);  // beyond 3 m
  EXPECT_EQ(segmentEnd(dist, 4, 0.5), 5u);
  EXPECT_EQ(segmentEnd(dist, 0, 6.0), std::nullopt);  // the path ends at 6 m
  EXPECT_EQ(segmentEnd(dist, 5, 0.1), std::nullopt);
}

TEST(TrajectoryScore, IdenticalTrajectoriesScoreZero) {
  Poses truth;
  for (int k = 0; k < 30; ++k)
    truth.push_back(
        pose({2.0 * std::sin(0.2 * k), 1.1 * k, 0.3 * std::cos(0.5 * k)}, 0.2 * k, -0.4 + 0.01 * k, 0.05 * k));
  const TrajectoryErrors e = trajectoryErrors(truth, truth, {{5, 10, 20}, 1});
  EXPECT_EQ(e.ate_rms_m, 0.0);
  EXPECT_EQ(e.ate_max_m, 0.0);
  EXPECT_EQ(e.final_drift_pct, 0.0);
  ASSERT_EQ(e.relative.size(), 3u);
  for (const SegmentErrors& s : e.relative) {
    EXPECT_GT(s.segments, 0) << s.length_m;
    // T⁻¹·T is the identity up to rounding of coordinates of tens of metres (~1e-14 m).
    EXPECT_NEAR(s.translation_pct, 0, 1e-12) << s.length_m;
    EXPECT_NEAR(s.rotation_deg_per_m, 0, 1e-12) << s.length_m;
  }
}

TEST(TrajectoryScore, AConstantOffsetIsAbsoluteErrorAlone) {
  const Poses truth = metreStops(10);  // 9 m
  const Eigen::Vector3d offset(0.3, -0.4, 1.2);  // 1.3 m
  Poses est = truth;
  for (Eigen::Isometry3d& T : est) T.pretranslate(offset);
  const TrajectoryErrors e = trajectoryErrors(truth, est, {{5}, 1});
  expectRelative(e.ate_rms_m, 1.3);
  expectRelative(e.ate_max_m, 1.3);
  expectRelative(e.final_drift_pct, 100 * 1.3 / 9);
  ASSERT_EQ(e.relative.size(), 1u);
  EXPECT_EQ(e.relative[0].segments, 4);  // first stops 0..3, each ending 6 m on
  EXPECT_NEAR(e.relative[0].translation_pct, 0, 1e-12);
  EXPECT_NEAR(e.relative[0].rotation_deg_per_m, 0, 1e-12);
}

// The estimate turns by δ more than the truth at every stop: the truth goes straight along x, the
// estimate steps 1 m forward and turns by δ, so n steps put it on an arc with heading nδ at
// p_n = Σ_{m<n} (cos mδ, sin mδ) = A·(cos φ, sin φ), A = sin(nδ/2)/sin(δ/2), φ = (n − 1)δ/2. A
// segment of n steps has E = (Rz(−nδ), Rz(−nδ)·(n·e_x − p_n)): angle nδ, translation
// ‖n·e_x − p_n‖. On 1 m stops a segment of L metres spans n = L + 1 steps.
TEST(TrajectoryScore, AHeadingErrorPerStepGivesTheArcsClosedForm) {
  const int stops = 60;  // 59 m
  const double delta = 0.002;
  Poses truth, est;
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  const Eigen::Isometry3d step = pose({1, 0, 0}, delta);
  for (int k = 0; k < stops; ++k) {
    truth.push_back(pose({double(k), 0, 0}));
    est.push_back(T);
    T = T * step;
  }
  const std::vector<SegmentErrors> rel = relativeErrors(truth, est, {{5, 10, 20, 50}, 1});
  ASSERT_EQ(rel.size(), 4u);
  for (const SegmentErrors& s : rel) {
    const double L = s.length_m, n = L + 1;
    const double A = std::sin(n * delta / 2) / std::sin(delta / 2), phi = (n - 1) * delta / 2;
    EXPECT_EQ(s.segments, stops - int(n)) << L;  // first stops 0 .. 59 − n
    expectRelative(s.rotation_deg_per_m, n * delta / L * kDeg);
    expectRelative(s.translation_pct, 100 * std::hypot(n - A * std::cos(phi), A * std::sin(phi)) / L);
  }
}

// Stretched by (1 + s), a segment's E is a pure translation of s·‖t_j − t_i‖; KITTI divides it by
// the nominal L, and the segment runs to the first stop beyond L, so on 1 m stops the figure is
// 100·s·(L + 1)/L.
TEST(TrajectoryScore, AScaledEstimateErrsByTheScaleTimesTheSegment) {
  const double s = 0.03;
  const Poses truth = metreStops(60);
  const TrajectoryErrors e = trajectoryErrors(truth, scaled(truth, s), {{5, 10, 20, 50}, 1});
  for (const SegmentErrors& seg : e.relative) {
    EXPECT_EQ(seg.segments, 59 - int(seg.length_m)) << seg.length_m;
    expectRelative(seg.translation_pct, 100 * s * (seg.length_m + 1) / seg.length_m);
    EXPECT_NEAR(seg.rotation_deg_per_m, 0, 1e-12);
  }
  // Stop k is s·k metres off: RMS s·√(Σk²/60) with Σ_{k<60} k² = 70210, max and last 59·s.
  expectRelative(e.ate_rms_m, s * std::sqrt(70210.0 / 60));
  expectRelative(e.ate_max_m, 59 * s);
  expectRelative(e.final_drift_pct, 100 * s);
}

// Uneven stops at 0, 0.75, 1.5, 3, 3.25, 6 m; a stretched estimate errs by s times each segment's
// true length, so the mean over the segments shows which stops ended them.
TEST(TrajectoryScore, UnevenStopsAverageTheSegmentsTheEndRuleChose) {
  const double s = 0.03;
  const Poses truth = alongX({0, 0.75, 1.5, 3.0, 3.25, 6.0});
  const Poses est = scaled(truth, s);
  // L = 1.5: (0,3) 3 m, (1,3) 2.25, (2,4) 1.75, (3,5) 3, (4,5) 2.75; mean 2.55 m.
  // L = 3:   (0,4) 3.25 m, (1,5) 5.25, (2,5) 4.5; mean 13/3 m. Stops 3.. have nothing 3 m on.
  std::vector<SegmentErrors> rel = relativeErrors(truth, est, {{1.5, 3}, 1});
  EXPECT_EQ(rel[0].segments, 5);
  expectRelative(rel[0].translation_pct, 100 * s * 2.55 / 1.5);
  EXPECT_EQ(rel[1].segments, 3);
  expectRelative(rel[1].translation_pct, 100 * s * (13.0 / 3) / 3);
  // Every second first stop: (0,3) 3 m, (2,4) 1.75, (4,5) 2.75; mean 2.5 m.
  rel = relativeErrors(truth, est, {{1.5}, 2});
  EXPECT_EQ(rel[0].segments, 3);
  expectRelative(rel[0].translation_pct, 100 * s * 2.5 / 1.5);
}

TEST(TrajectoryScore, KittisStepOfTenStartsASegmentEveryTenthStop) {
  const Poses truth = metreStops(25);  // 24 m
  const Poses est = scaled(truth, 0.01);
  EXPECT_EQ(relativeErrors(truth, est, {{5}, 10})[0].segments, 2);  // from stops 0 and 10; 20 has no 6 m left
  EXPECT_EQ(relativeErrors(truth, est, {{5}, 1})[0].segments, 19);  // from stops 0..18
}

TEST(TrajectoryScore, ASegmentLongerThanThePathHasNoFigures) {
  const Poses truth = metreStops(10);  // 9 m
  const TrajectoryErrors e = trajectoryErrors(truth, scaled(truth, 0.02), {{5, 9, 10, 50}, 1});
  EXPECT_EQ(e.relative[0].segments, 4);
  for (std::size_t l = 1; l < 4; ++l) {  // 9 m: no stop lies beyond the path's 9 m
    EXPECT_EQ(e.relative[l].segments, 0) << e.relative[l].length_m;
    EXPECT_TRUE(std::isnan(e.relative[l].translation_pct));
    EXPECT_TRUE(std::isnan(e.relative[l].rotation_deg_per_m));
  }
  const nlohmann::ordered_json j = toJson(e);
  EXPECT_TRUE(j["rte_pct"]["50"].is_null());
  EXPECT_TRUE(j["rotation_deg_per_m"]["10"].is_null());
  EXPECT_EQ(j["segments"]["9"], 0);
  EXPECT_EQ(j["segments"]["5"], 4);
}

TEST(TrajectoryScore, JsonHoldsTheFiguresKeyedByLength) {
  TrajectoryErrors e;
  e.ate_rms_m = 0.25, e.ate_max_m = 0.5, e.final_drift_pct = std::numeric_limits<double>::quiet_NaN();
  e.relative = {{5, 12, 1.5, 0.125}, {2.5, 3, 2.0, 0.25}, {50, 0, std::nan(""), std::nan("")}};
  const nlohmann::ordered_json j = toJson(e);
  std::vector<std::string> keys;
  for (const auto& [k, v] : j.items()) keys.push_back(k);
  EXPECT_EQ(keys, (std::vector<std::string>{"ate_rms_m", "ate_max_m", "final_drift_pct", "rte_pct",
                                            "rotation_deg_per_m", "segments"}));
  EXPECT_EQ(j["ate_rms_m"], 0.25);
  EXPECT_EQ(j["ate_max_m"], 0.5);
  EXPECT_TRUE(j["final_drift_pct"].is_null());
  EXPECT_EQ(j["rte_pct"].dump(), R"({"5":1.5,"2.5":2.0,"50":null})");
  EXPECT_EQ(j["rotation_deg_per_m"].dump(), R"({"5":0.125,"2.5":0.25,"50":null})");
  EXPECT_EQ(j["segments"].dump(), R"({"5":12,"2.5":3,"50":0})");
}

TEST(TrajectoryScore, APathOfZeroLengthHasNoFinalDrift) {
  const Poses truth{pose({1, 1, 0}), pose({1, 1, 0}, 0.5)};
  Poses est = truth;
  est[1].pretranslate(Eigen::Vector3d(0, 0.1, 0));
  const TrajectoryErrors e = trajectoryErrors(truth, est, {{5}, 1});
  EXPECT_TRUE(std::isnan(e.final_drift_pct));
  expectRelative(e.ate_max_m, 0.1);
  EXPECT_EQ(e.relative[0].segments, 0);
}

TEST(TrajectoryScore, ANanPositionMakesTheFiguresItEntersNan) {
  const Poses truth = metreStops(10);
  Poses est = truth;
  est[8].translation().x() = std::numeric_limits<double>::quiet_NaN();
  const TrajectoryErrors e = trajectoryErrors(truth, est, {{5}, 1});
  EXPECT_TRUE(std::isnan(e.ate_rms_m));
  EXPECT_TRUE(std::isnan(e.ate_max_m));
  EXPECT_EQ(e.final_drift_pct, 0.0);  // the last stop is exact
  EXPECT_TRUE(std::isnan(e.relative[0].translation_pct));  // the segment (2, 8)
}

TEST(TrajectoryScore, MalformedInputIsRefused) {
  const Poses three = metreStops(3), two = metreStops(2), one = metreStops(1);
  expectInvalid([&] { trajectoryErrors(three, two); }, "the truth has 3 poses and the estimate 2");
  expectInvalid([&] { relativeErrors(two, three); }, "the truth has 2 poses and the estimate 3");
  expectInvalid([&] { trajectoryErrors(one, one); }, "at least 2 poses, got 1");
  expectInvalid([&] { trajectoryErrors({}, {}); }, "at least 2 poses, got 0");
  expectInvalid([&] { relativeErrors(one, one); }, "at least 2 poses, got 1");
  expectInvalid([&] { trajectoryErrors(two, two, {{5}, 0}); }, "step between first stops must be at least 1");
  expectInvalid([&] { trajectoryErrors(two, two, {{5, 0}, 1}); }, "positive and finite");
  expectInvalid([&] { relativeErrors(two, two, {{-1.5}, 1}); }, "positive and finite, got -1.5 m");
  expectInvalid([&] { relativeErrors(two, two, {{std::nan("")}, 1}); }, "positive and finite, got nan m");
}

}  // namespace
}  // namespace ambler::eval
