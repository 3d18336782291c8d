// `ambler basin`: the draws' initial errors have the asked magnitudes exactly (horizontal
// translation, rotation about a unit axis); on a noise-free terrain from zero initial error every
// method that starts from T_0 succeeds in every trial; the basin sharded three ways merges into
// the unsharded CSV byte for byte; a user's own method (CustomMethod) is scored as a built-in one;
// bad grids and scenarios are refused in one line before anything is written.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <numbers>
#include <string>
#include <vector>

#include "eval/tools/basin/basin.hpp"
#include "eval/scenario/scenario.hpp"
#include "perception/rigid_transform.hpp"
#include "perception/sensor_geometry.hpp"
#include "test_support.hpp"
#include "two_view_mars.hpp"

namespace ambler::eval {
namespace {

namespace fs = std::filesystem;
using test::slurp;
using test::TempDir;

// The two-view Mars scene as it is (the demo's patch and first view), noise-free.
std::string scenario(const std::string& methods, bool with_matching = true) {
  test::TwoViewMars scene;
  scene.name = "basin_test";
  scene.sensor = test::kNoiseFreeSensor;
  std::string s = scene.yaml();
  if (with_matching) s += "matching:\n  methods: [" + methods + "]\n";
  return s;
}

BasinOptions options(const fs::path& out, std::vector<double> t, std::vector<double> r, int trials) {
  BasinOptions o;
  o.out = out;
  o.grid = {std::move(t), std::move(r), trials};
  o.progress = false;
  return o;
}

TEST(Basin, DrawsHaveTheAskedMagnitudesHorizontalTranslationAndAUnitAxis) {
  const Eigen::Isometry3d T_WS_j = perception::sensorPose({0.3, -5.2, 3.0}, {0, -30 * std::numbers::pi / 180, 0.4});
  for (int trial = 0; trial < 20; ++trial) {
    const Eigen::Isometry3d E = basinError(11, trial, 1.7, 23.0, T_WS_j);
    const perception::PoseError e = perception::poseError(Eigen::Isometry3d::Identity(), E);
    EXPECT_NEAR(e.translation_m, 1.7, 1e-12);
    EXPECT_NEAR(e.rotation_deg, 23.0, 1e-9);
    // Sensor J believed at T_WS_j·E: moved by a horizontal vector in the world.
    const Eigen::Vector3d moved = (T_WS_j * E).translation() - T_WS_j.translation();
    EXPECT_NEAR(moved.z(), 0.0, 1e-12);
    EXPECT_NEAR(moved.norm(), 1.7, 1e-12);
    // The same trial gives the same direction at any magnitude (cells differ in magnitude only).
    const Eigen::Isometry3d half = basinError(11, trial, 0.85, 11.5, T_WS_j);
    EXPECT_NEAR(((T_WS_j * half).translation() - T_WS_j.translation() - 0.5 * moved).norm(), 0.0, 1e-12);
    const Eigen::AngleAxisd a(E.linear()), b(half.linear());
    EXPECT_NEAR(a.axis().dot(b.axis()), 1.0, 1e-9);
  }
  // About the vertical: the believed sensor keeps its gravity direction (a yaw error alone).
  const Eigen::Isometry3d yaw = basinError(11, 3, 1.0, 20.0, T_WS_j, true);
  const Eigen::Vector3d up_true = T_WS_j.linear().transpose() * Eigen::Vector3d::UnitZ();
  const Eigen::Vector3d up_believed = (T_WS_j * yaw).linear().transpose() * Eigen::Vector3d::UnitZ();
  EXPECT_NEAR((up_true - up_believed).norm(), 0.0, 1e-12);
  EXPECT_NEAR(perception::poseError(Eigen::Isometry3d::Identity(), yaw).rotation_deg, 20.0, 1e-9);
  // Different trials draw different directions.
  const Eigen::Vector3d t0 = basinError(11, 0, 1, 0, T_WS_j).translation();
  const Eigen::Vector3d t1 = basinError(11, 1, 1, 0, T_WS_j).translation();
  EXPECT_GT((t0 - t1).norm(), 1e-3);
}

TEST(Basin, ZeroInitialErrorOnNoiseFreeTerrainSucceedsInEveryTrial) {
  TempDir tmp;
  const Scenario sc = parseScenario(scenario("features, features+iconic, iconic, iconic_lm, iconic_weighted"),
                                    tmp.path() / "basin.yaml");
  const fs::path csv = runBasin(sc, options(tmp.path() / "out", {0}, {0}, 3));
  const auto records = parseResultsCsv(slurp(csv));
  ASSERT_TRUE(records);
  ASSERT_EQ(records->size(), 1u + 5u * 3u);
  EXPECT_EQ(records->front(), (std::vector<std::string>{"method", "translation_m", "rotation_deg", "trial",
                                                         "translation_error_m", "rotation_error_deg", "success",
                                                         "iterations", "time_s", "accepted", "false_accept"}));
  // Every method that starts from T_0 (the iconic ones, and features+iconic, whose descent starts
  // from T_F) finds the truth. Feature matching alone does not use T_0 beyond the prior's bounds:
  // it is the same search at any initial error, so its trials agree to the bit; whether it
  // succeeds is the terrain's (eq. 3 may prefer another pairing; docs/basin.md).
  for (std::size_t k = 1; k < records->size(); ++k) {
    const auto& row = (*records)[k];
    EXPECT_EQ(row[8], "") << "time_s is filled only with --timing";
    if (row[0] == "features") {
      EXPECT_EQ(row[4], (*records)[1][4]);
      EXPECT_EQ(row[5], (*records)[1][5]);
      continue;
    }
    EXPECT_EQ(row[6], "true") << row[0] << " trial " << row[3] << ": " << row[4] << " m, " << row[5] << " deg";
    // At the truth, on terrain the sensor model describes, the rover's verdict is to accept.
    EXPECT_EQ(row[9], "true") << row[0] << " trial " << row[3];
  }
  // false_accept is accepted and not a success, row by row.
  for (std::size_t k = 1; k < records->size(); ++k) {
    const auto& row = (*records)[k];
    EXPECT_EQ(row[10], row[9] == "true" && row[6] != "true" ? "true" : "false") << row[0];
  }
  for (const char* png : {"basin_features.png", "basin_features_iconic.png", "basin_iconic.png",
                          "basin_iconic_lm.png", "basin_iconic_weighted.png", "basin_boundary.png", "basin.md"})
    EXPECT_TRUE(fs::exists(tmp.path() / "out" / png)) << png;
}

TEST(Basin, ThreeShardsMergeIntoTheUnshardedBytes) {
  TempDir tmp;
  // Every method that can be reproducible, the Open3D peers included (eval/peers/open3d_peers.hpp).
  const Scenario sc = parseScenario(scenario("features, iconic_lm, icp_point_to_plane, gicp, fgr"), tmp.path() / "basin.yaml");
  const std::vector<double> t{0, 0.4}, r{0, 4};
  const fs::path whole = runBasin(sc, options(tmp.path() / "whole", t, r, 2));
  BasinOptions jobs = options(tmp.path() / "jobs", t, r, 2);
  jobs.jobs = 2;
  const fs::path with_jobs = runBasin(sc, jobs);
  for (int k = 1; k <= 3; ++k) {
    BasinOptions o = options(tmp.path() / "sharded", t, r, 2);
    o.shard = Shard{k, 3};
    runBasin(sc, o);
  }
  const fs::path merged = mergeBasin(sc, options(tmp.path() / "sharded", t, r, 2));
  const std::string bytes = slurp(whole);
  EXPECT_EQ(std::count(bytes.begin(), bytes.end(), '\n'), 1 + 5 * 8);
  EXPECT_EQ(slurp(merged), bytes);
  EXPECT_EQ(slurp(with_jobs), bytes);
  EXPECT_EQ(slurp(tmp.path() / "sharded" / "basin_boundary.png"), slurp(tmp.path() / "whole" / "basin_boundary.png"));
  EXPECT_EQ(slurp(tmp.path() / "sharded" / "basin.md"), slurp(tmp.path() / "whole" / "basin.md"));

  // A shard missing, or a merge with another grid, is refused.
  fs::remove(tmp.path() / "sharded" / "basin.shard-2-of-3.csv");
  EXPECT_THROW(mergeBasin(sc, options(tmp.path() / "sharded", t, r, 2)), std::runtime_error);
  runBasin(sc, [&] {
    BasinOptions o = options(tmp.path() / "sharded", t, r, 2);
    o.shard = Shard{2, 3};
    return o;
  }());
  EXPECT_THROW(mergeBasin(sc, options(tmp.path() / "sharded", {0, 0.5}, r, 2)), BasinError);
  EXPECT_THROW(mergeBasin(sc, options(tmp.path() / "sharded", t, r, 3)), BasinError);
}

template <class F>
std::string errorOf(F&& f) {
  try {
    f();
  } catch (const std::exception& e) {
    return e.what();
  }
  return "(no error)";
}

TEST(Basin, BadGridsAndScenariosAreRefusedBeforeAnythingIsWritten) {
  EXPECT_EQ(errorOf([] { parseBasinAxis("", "--translation-m", 100); }),
            "--translation-m: expected comma-separated numbers, got \"\"");
  EXPECT_EQ(errorOf([] { parseBasinAxis("0,-0.5,1", "--translation-m", 100); }),
            "--translation-m: -0.5 is negative; the axis is a magnitude (>= 0)");
  EXPECT_EQ(errorOf([] { parseBasinAxis("0,5,x", "--rotation-deg", 180); }),
            "--rotation-deg: expected comma-separated numbers, got \"0,5,x\"");
  EXPECT_EQ(errorOf([] { parseBasinAxis("0,10,5", "--rotation-deg", 180); }),
            "--rotation-deg: values must increase, got 5 after 10");
  EXPECT_EQ(errorOf([] { parseBasinAxis("0,200", "--rotation-deg", 180); }), "--rotation-deg: 200 is beyond 180");
  EXPECT_EQ(errorOf([] { parseBasinAxis("nan", "--rotation-deg", 180); }),
            "--rotation-deg: expected comma-separated numbers, got \"nan\"");
  EXPECT_EQ(parseBasinAxis("0, 0.5,1", "--translation-m", 100), (std::vector<double>{0, 0.5, 1}));

  TempDir tmp;
  const Scenario no_matching = parseScenario(scenario("", false), tmp.path() / "plain.yaml");
  const std::string e = errorOf([&] { runBasin(no_matching, options(tmp.path() / "out", {0}, {0}, 1)); });
  EXPECT_NE(e.find("plain.yaml: matching:"), std::string::npos) << e;
  EXPECT_FALSE(fs::exists(tmp.path() / "out"));
  const Scenario sc = parseScenario(scenario("iconic_lm"), tmp.path() / "basin.yaml");
  EXPECT_THROW(runBasin(sc, options(tmp.path() / "out", {}, {0}, 1)), BasinError);
  EXPECT_THROW(runBasin(sc, options(tmp.path() / "out", {0}, {0}, 0)), BasinError);
  BasinOptions too_many = options(tmp.path() / "out", {0}, {0}, 2);
  too_many.shard = Shard{1, 3};
  EXPECT_THROW(runBasin(sc, too_many), BasinError);
  EXPECT_FALSE(fs::exists(tmp.path() / "out"));
}

}  // namespace
}  // namespace ambler::eval

namespace ambler::eval {
namespace {

// A user's own method (CustomMethod; the Python module's `custom`), in C++: one that answers the
// truth is a success with zero error and is accepted on noise-free terrain; one that answers T_0
// keeps the draw's initial error exactly; one that hands back the built-in LM's registration of the
// pair gives LM's rows but the name; a given covariance of the pose is checked against ν's.
TEST(Basin, AUsersOwnMethodIsScoredAsABuiltInOne) {
  TempDir tmp;
  const Scenario sc = parseScenario(scenario("iconic_lm"), tmp.path() / "basin.yaml");
  BasinOptions o = options(tmp.path() / "out", {0, 0.4}, {0, 4}, 2);
  o.custom.push_back({"truth", [](const PairRegistration& pair, const Eigen::Isometry3d&) {
                        return CustomEstimate{pair.trueRelative(), perception::Matrix6d::Identity() * 1e-6, 7, {}};
                      }});
  o.custom.push_back({"stay", [](const PairRegistration&, const Eigen::Isometry3d& T_0) {
                        return CustomEstimate{T_0, std::nullopt, 0, {}};
                      }});
  o.custom.push_back({"lm", [](const PairRegistration& pair, const Eigen::Isometry3d& T_0) {
                        const PairResult r = pair.run(MatchMethod::IconicLm, T_0);
                        return CustomEstimate{r.T_est, std::nullopt, r.reg.iterations, r};
                      }});
  const auto records = parseResultsCsv(slurp(runBasin(sc, o)));
  ASSERT_TRUE(records);
  ASSERT_EQ(records->size(), 1u + 4u * 8u);
  std::vector<std::vector<std::string>> lm, mine;
  for (std::size_t k = 1; k < records->size(); ++k) {
    const auto& row = (*records)[k];
    if (row[0] == "truth") {
      EXPECT_EQ(row[4], "0");
      EXPECT_EQ(row[5], "0");
      EXPECT_EQ(row[6], "true");
      EXPECT_EQ(row[7], "7");
      EXPECT_EQ(row[9], "true") << "at the truth on noise-free terrain the rover accepts";
    } else if (row[0] == "stay") {
      EXPECT_NEAR(std::stod(row[4]), std::stod(row[1]), 1e-9);
      EXPECT_NEAR(std::stod(row[5]), std::stod(row[2]), 1e-9);
      // 0.4 m from the truth: the lines disagree and the rover refuses.
      if (row[1] == "0.4") EXPECT_EQ(row[9], "false");
    }
    if (row[0] == "iconic_lm") lm.emplace_back(row.begin() + 1, row.end());
    if (row[0] == "lm") mine.emplace_back(row.begin() + 1, row.end());
  }
  EXPECT_EQ(mine, lm);
  EXPECT_TRUE(fs::exists(tmp.path() / "out" / "basin_truth.png"));

  // Names that would clash with a built-in method, a file name or each other are refused.
  for (const char* bad : {"iconic_lm", "a/b", ""}) {
    BasinOptions b = options(tmp.path() / "bad", {0}, {0}, 1);
    b.custom.push_back({bad, o.custom[0].fn});
    EXPECT_THROW(runBasin(sc, b), BasinError) << bad;
  }
  EXPECT_FALSE(fs::exists(tmp.path() / "bad"));
}

TEST(Basin, NuCovarianceInvertsTheSensorPoseCovariance) {
  const perception::PoseVector nu = (perception::PoseVector() << 0.01, -0.02, 0.05, 0.3, -0.2, 0.1).finished();
  const Eigen::Isometry3d B = perception::sensorPose({1.0, -4.0, 3.0}, {0.02, -0.5, 0.7});
  perception::Matrix6d L = perception::Matrix6d::Random();
  const perception::Matrix6d C = L * L.transpose() + perception::Matrix6d::Identity() * 1e-3;
  const perception::Matrix6d back =
      perception::sensorPoseCovariance(nu, perception::nuCovariance(nu, C, B), B);
  // Central differences (h = 1e-6) make A to about 1e-9; the round trip keeps that.
  EXPECT_LT((back - C).cwiseAbs().maxCoeff(), 1e-6 * C.cwiseAbs().maxCoeff());
}

}  // namespace
}  // namespace ambler::eval
