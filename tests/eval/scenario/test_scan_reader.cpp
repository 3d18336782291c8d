// eval::readScan: a scan written by the scan stage's writer reads back bit for bit, and every
// refusal is one line naming the file and the key or the cause.
#include <gtest/gtest.h>

#include <opencv2/imgcodecs.hpp>

#include <bit>
#include <cstring>
#include <filesystem>
#include <limits>
#include <numbers>
#include <string>

#include "eval/scenario/io.hpp"
#include "eval/scenario/scan_reader.hpp"
#include "perception/sensor_geometry.hpp"
#include "test_support.hpp"

namespace ambler::eval {
namespace {

namespace fs = std::filesystem;
constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();

// A 4 x 6 scan as the ERIM's geometry lays it out, with returns, no-returns (NaN) and range 0.
perception::RangeImage smallScan() {
  const int rows = 4, cols = 6;
  perception::RangeImage img;
  img.range = perception::Raster<float>::Constant(rows, cols, kNaN);
  for (int r = 0; r < rows; ++r) img.phi.push_back(perception::rowAngle(r, rows, 30 * std::numbers::pi / 180));
  for (int c = 0; c < cols; ++c) img.theta.push_back(perception::colAngle(c, cols, 80 * std::numbers::pi / 180));
  img.range(0, 0) = 0.0f;
  img.range(1, 2) = 5.25f;
  img.range(2, 3) = 19.4f;
  img.range(3, 5) = 7.62f;
  return img;
}

ViewSpec smallView() {
  ViewSpec v;
  v.xyz_m = {0.5, -6, 3};
  v.rpy_rad = {0.01, -30 * std::numbers::pi / 180, 0.7};
  return v;
}

std::string messageOf(const fs::path& stem) {
  try {
    readScan(stem);
  } catch (const ScanError& e) {
    return e.what();
  }
  return "(no error)";
}

std::string metaMessage(const std::string& json) {
  try {
    parseScanMeta(json, "m.json");
  } catch (const ScanError& e) {
    return e.what();
  }
  return "(no error)";
}

const std::string kPose = R"("pose": {"xyz_m": [1, 2, 3], "rpy_deg": [0, -30, 90]})";

TEST(ScanReader, RoundTripIsBitIdentical) {
  test::TempDir d;
  const auto img = smallScan();
  const auto view = smallView();
  writeScan(d.path() / "view_0", img, view);
  const ScanFile back = readScan(d.path() / "view_0");
  ASSERT_EQ(back.image.rows(), 4);
  ASSERT_EQ(back.image.cols(), 6);
  EXPECT_EQ(std::memcmp(back.image.range.data(), img.range.data(), sizeof(float) * 24), 0);  // NaN bits too
  EXPECT_EQ(back.image.validCount(), 4);
  ASSERT_EQ(back.image.phi.size(), img.phi.size());
  for (std::size_t i = 0; i < img.phi.size(); ++i)
    EXPECT_EQ(std::bit_cast<std::uint64_t>(back.image.phi[i]), std::bit_cast<std::uint64_t>(img.phi[i]));
  for (std::size_t i = 0; i < img.theta.size(); ++i)
    EXPECT_EQ(std::bit_cast<std::uint64_t>(back.image.theta[i]), std::bit_cast<std::uint64_t>(img.theta[i]));
  EXPECT_EQ(back.view.xyz_m, view.xyz_m);
  // Through degrees: at most an ulp or two.
  for (int i = 0; i < 3; ++i) EXPECT_NEAR(back.view.rpy_rad[i], view.rpy_rad[i], 1e-15);
  const Eigen::Isometry3d T = perception::sensorPose(view.xyz_m, view.rpy_rad);
  EXPECT_TRUE(back.image.T_WS.isApprox(T, 1e-14));
  // And the meta text is the writer's: written again, the same bytes.
  writeScan(d.path() / "view_1", back.image, back.view);
  EXPECT_EQ(test::slurp(d.path() / "view_1_range.tiff"), test::slurp(d.path() / "view_0_range.tiff"));
}

TEST(ScanReader, MissingFiles) {
  test::TempDir d;
  const fs::path stem = d.path() / "view_0";
  EXPECT_EQ(messageOf(stem), stem.string() + "_meta.json: cannot open file (no such file)");
  writeJson(stem.string() + "_meta.json", scanMeta(smallScan(), smallView()));
  EXPECT_EQ(messageOf(stem), stem.string() + "_range.tiff: cannot open file (no such file)");
}

TEST(ScanReader, RefusesWhatIsNotAFloatTiff) {
  test::TempDir d;
  const fs::path stem = d.path() / "view_0";
  const std::string tiff = stem.string() + "_range.tiff";
  writeJson(stem.string() + "_meta.json", scanMeta(smallScan(), smallView()));

  cv::imwrite((d.path() / "x.png").string(), cv::Mat(4, 6, CV_8UC1, cv::Scalar(3)));
  fs::rename(d.path() / "x.png", tiff);
  EXPECT_EQ(messageOf(stem), tiff + ": not a TIFF file (no II*/MM* signature)");

  writeText(tiff, std::string("II*\0garbage", 11));
  EXPECT_EQ(messageOf(stem), tiff + ": cannot decode TIFF");

  cv::imwrite(tiff, cv::Mat(4, 6, CV_16UC1, cv::Scalar(7)));
  EXPECT_EQ(messageOf(stem), tiff + ": expected a single-channel float32 TIFF, got 1 channel(s) of OpenCV depth 2");

  cv::imwrite(tiff, cv::Mat(4, 6, CV_32FC3, cv::Scalar(1, 2, 3)));
  EXPECT_EQ(messageOf(stem), tiff + ": expected a single-channel float32 TIFF, got 3 channel(s) of OpenCV depth 5");
}

TEST(ScanReader, RefusesASizeOtherThanTheMetas) {
  test::TempDir d;
  const fs::path stem = d.path() / "view_0";
  writeJson(stem.string() + "_meta.json", scanMeta(smallScan(), smallView()));
  writeTiff(stem.string() + "_range.tiff", perception::Raster<float>::Constant(6, 4, 1.0f));
  EXPECT_EQ(messageOf(stem), stem.string() + "_range.tiff: 6 x 4 pixels, but " + stem.string() +
                                 "_meta.json has 4 rows (phi_rad) and 6 columns (theta_rad)");
}

TEST(ScanReader, RangesAreNonNegativeOrNaN) {
  auto tiffBytes = [](float v) {
    std::vector<uchar> buf;
    cv::imencode(".tiff", cv::Mat(2, 3, CV_32FC1, cv::Scalar(v)), buf);
    return std::string(buf.begin(), buf.end());
  };
  auto message = [&](float v) {
    try {
      decodeRangeTiff(tiffBytes(v), "r.tiff");
    } catch (const ScanError& e) {
      return std::string(e.what());
    }
    return std::string("(no error)");
  };
  EXPECT_EQ(message(-1.0f), "r.tiff: row 0, column 0: expected a range >= 0 m or NaN (no return), got -1");
  EXPECT_EQ(message(-0.25f), "r.tiff: row 0, column 0: expected a range >= 0 m or NaN (no return), got -0.25");
  EXPECT_EQ(message(std::numeric_limits<float>::infinity()),
            "r.tiff: row 0, column 0: expected a range >= 0 m or NaN (no return), got inf");
  EXPECT_EQ(message(0.0f), "(no error)");
  EXPECT_EQ(message(kNaN), "(no error)");
  const auto nan = decodeRangeTiff(tiffBytes(kNaN), "r.tiff");
  EXPECT_TRUE(std::isnan(nan(1, 2)));
  EXPECT_EQ(decodeRangeTiff(tiffBytes(12.5f), "r.tiff")(1, 2), 12.5f);
}

TEST(ScanReader, MetaKeysAndTypes) {
  EXPECT_EQ(metaMessage("{"), "m.json: not JSON: [json.exception.parse_error.101] parse error at line 1, "
                              "column 2: syntax error while parsing object key - unexpected end of input; "
                              "expected string literal");
  EXPECT_EQ(metaMessage("[]"), "m.json: expected an object, got array");
  EXPECT_EQ(metaMessage(R"({"theta_rad": [0], )" + kPose + "}"), "m.json: phi_rad: missing key");
  EXPECT_EQ(metaMessage(R"({"phi_rad": [0], "theta_rad": [0], "rows": 1, )" + kPose + "}"),
            "m.json: rows: unknown key (allowed: phi_rad, theta_rad, pose)");
  EXPECT_EQ(metaMessage(R"({"phi_rad": [0], "phi_rad": [0], "theta_rad": [0], )" + kPose + "}"),
            "m.json: phi_rad: duplicate key");
  EXPECT_EQ(metaMessage(R"({"phi_rad": [0, "1"], "theta_rad": [0], )" + kPose + "}"),
            "m.json: phi_rad[1]: expected a number, got string");
  EXPECT_EQ(metaMessage(R"({"phi_rad": 0, "theta_rad": [0], )" + kPose + "}"),
            "m.json: phi_rad: expected a list of numbers, got number");
  EXPECT_EQ(metaMessage(R"({"phi_rad": [], "theta_rad": [0], )" + kPose + "}"),
            "m.json: phi_rad: expected at least one angle, got none");
  EXPECT_EQ(metaMessage(R"({"phi_rad": [0.1, 0.2], "theta_rad": [0], )" + kPose + "}"),
            "m.json: phi_rad[1]: expected strictly falling angles, got 0.1 then 0.2");
  EXPECT_EQ(metaMessage(R"({"phi_rad": [0], "theta_rad": [0, 0], )" + kPose + "}"),
            "m.json: theta_rad[1]: expected strictly rising angles, got 0 then 0");
  EXPECT_EQ(metaMessage(R"({"phi_rad": [0], "theta_rad": [2], )" + kPose + "}"),
            "m.json: theta_rad[0]: expected an angle in (-pi/2, pi/2), got 2");
  EXPECT_EQ(metaMessage(R"({"phi_rad": [0], "theta_rad": [0], "pose": {"xyz_m": [1, 2]}})"),
            "m.json: pose.rpy_deg: missing key");
  EXPECT_EQ(metaMessage(R"({"phi_rad": [0], "theta_rad": [0], "pose": {"xyz_m": [1, 2], "rpy_deg": [0, 0, 0]}})"),
            "m.json: pose.xyz_m: expected 3 numbers, got 2");
  // nlohmann's parser refuses a number beyond a double itself (JSON has no NaN or infinity).
  EXPECT_EQ(metaMessage(R"({"phi_rad": [0], "theta_rad": [0], "pose": {"xyz_m": [1, 2, 1e999], "rpy_deg": [0, 0, 0]}})"),
            "m.json: not JSON: [json.exception.out_of_range.406] number overflow parsing '1e999'");
  EXPECT_EQ(metaMessage(R"({"phi_rad": [0], "theta_rad": [0], "pose": {"xyz_m": [1, 2, 3], "rpy_deg": null}})"),
            "m.json: pose.rpy_deg: expected a list of numbers, got null");
  // A key with a line break is escaped: the message stays one line.
  EXPECT_EQ(metaMessage(R"({"a\nb": 1})"), "m.json: a\\nb: unknown key (allowed: phi_rad, theta_rad, pose)");
  const ScanMeta ok = parseScanMeta(R"({"phi_rad": [0.25], "theta_rad": [-0.5, 0.5], )" + kPose + "}", "m.json");
  EXPECT_EQ(ok.phi, std::vector<double>{0.25});
  EXPECT_EQ(ok.theta, (std::vector<double>{-0.5, 0.5}));
  EXPECT_EQ(ok.view.xyz_m, Eigen::Vector3d(1, 2, 3));
  EXPECT_DOUBLE_EQ(ok.view.rpy_rad.y(), -std::numbers::pi / 6);
  EXPECT_DOUBLE_EQ(ok.view.rpy_rad.z(), std::numbers::pi / 2);
}

}  // namespace
}  // namespace ambler::eval
