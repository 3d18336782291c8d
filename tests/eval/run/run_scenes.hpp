#pragma once
// The scenes and picture checks the stage tests of `ambler run` share (tests/eval/run/).
#include <gtest/gtest.h>

#include <filesystem>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <string>

#include "two_view_mars.hpp"

namespace ambler::eval::run_test {

// The small two-view Mars scene with 0.4 m of relief, more rocks and two craters; no map.
inline test::TwoViewMars smallScene() {
  test::TwoViewMars scene = test::TwoViewMars::small();
  scene.name = "run_test";
  scene.seed = 11;
  scene.relief_m = "0.4";
  scene.rocks = "{abundance_k: 0.1, min_diameter_m: 0.15, max_diameter_m: 0.8}";
  scene.craters = "{count: 2, min_diameter_m: 1.0, max_diameter_m: 2.0}";
  scene.view1 = "{xyz_m: [0.5, -3.0, 2.0], rpy_deg: [0, -35, 10]}";
  scene.map_region = "";
  return scene;
}
inline const std::string kScenario = smallScene().yaml();

// The picture at `p` (a test failure when it cannot be read).
inline cv::Mat readPicture(const std::filesystem::path& p) {
  cv::Mat img = cv::imread(p.string(), cv::IMREAD_COLOR);
  EXPECT_FALSE(img.empty()) << p;
  return img;
}

// The largest difference of any channel of any pixel (the sizes must agree).
inline double maxDifference(const cv::Mat& a, const cv::Mat& b) {
  if (a.size() != b.size() || a.type() != b.type()) return 1e9;
  return cv::norm(a, b, cv::NORM_INF);
}

// The two-view Mars scene on a 16 m square, mapped on 8 × 9 m, view 1 at the pose `view1`
// ("[x, y, z], rpy_deg: [...]").
inline std::string twoViews(const std::string& name, const std::string& view1) {
  test::TwoViewMars scene;
  scene.name = name;
  scene.size_m = "[16, 16]";
  scene.view1 = "{xyz_m: " + view1 + "}";
  scene.map_region = "{x_m: [-4, 4], y_m: [-3, 6]}";
  return scene.yaml();
}

}  // namespace ambler::eval::run_test
