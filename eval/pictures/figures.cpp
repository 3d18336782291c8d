#include "eval/pictures/figures.hpp"

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <numbers>

namespace ambler::eval {

namespace {

const cv::Vec3b kNoData(40, 40, 40);

std::string fmt(double v, const char* unit) {
  char buf[48];
  std::snprintf(buf, sizeof buf, "%.2f %s", v, unit);
  return buf;
}

// Scales `img` (nearest neighbour when enlarging, area when shrinking) to about `target` pixels
// wide, with independent x and y factors.
cv::Mat rescale(const cv::Mat& img, double fx, double fy) {
  cv::Mat out;
  const bool enlarge = fx >= 1.0 && fy >= 1.0;
  cv::resize(img, out, cv::Size(), fx, fy, enlarge ? cv::INTER_NEAREST : cv::INTER_AREA);
  return out;
}

// The picture framed by framePicture with the colour scale of an OpenCV colour map.
cv::Mat frame(const cv::Mat& picture, const std::string& title, double lo, double hi, const char* unit,
              int colormap) {
  return framePicture(picture, title, colourRamp(colormap), lo, hi, unit);
}

}  // namespace

cv::Mat colourRamp(int colormap) {
  cv::Mat ramp(1, 256, CV_8UC1), colour;
  for (int i = 0; i < 256; ++i) ramp.at<uchar>(0, i) = uchar(i);
  cv::applyColorMap(ramp, colour, colormap);
  return colour;
}

cv::Mat coolWarmRamp(int levels) {
  const cv::Vec3d blue(192, 76, 59), white(247, 247, 247), red(38, 4, 180);  // BGR
  const double half = (levels - 1) / 2.0;
  cv::Mat ramp(1, levels, CV_8UC3);
  for (int i = 0; i < levels; ++i) {
    const double t = i / half - 1.0;
    const cv::Vec3d c = t < 0 ? white + (-t) * (blue - white) : white + t * (red - white);
    ramp.at<cv::Vec3b>(0, i) =
        cv::Vec3b(uchar(std::lround(c[0])), uchar(std::lround(c[1])), uchar(std::lround(c[2])));
  }
  return ramp;
}

int cellEnlargement(int rows, int cols) {
  int k = std::max(1, (600 + cols - 1) / std::max(cols, 1));
  while (k > 1 && rows * k > 2400) --k;
  return k;
}

cv::Mat framePicture(const cv::Mat& picture, const std::string& title, const cv::Mat& ramp, double lo,
                     double hi, const char* unit) {
  const int pad = 8, head = 28, foot = 46;
  const int width = std::max(picture.cols + 2 * pad, 360);
  cv::Mat canvas(picture.rows + head + foot, width, CV_8UC3, cv::Scalar(255, 255, 255));
  picture.copyTo(canvas(cv::Rect((width - picture.cols) / 2, head, picture.cols, picture.rows)));
  cv::putText(canvas, title, cv::Point(pad, 20), cv::FONT_HERSHEY_SIMPLEX, 0.5, cv::Scalar(0, 0, 0), 1,
              cv::LINE_AA);
  const int bar_w = width - 2 * pad - 160, bar_y = head + picture.rows + 8;
  cv::Mat bar;
  cv::resize(ramp, bar, cv::Size(bar_w, 14), 0, 0, cv::INTER_LINEAR);
  bar.copyTo(canvas(cv::Rect(pad + 80, bar_y, bar_w, 14)));
  cv::putText(canvas, fmt(lo, unit), cv::Point(pad, bar_y + 12), cv::FONT_HERSHEY_SIMPLEX, 0.4,
              cv::Scalar(0, 0, 0), 1, cv::LINE_AA);
  cv::putText(canvas, fmt(hi, unit), cv::Point(pad + 88 + bar_w, bar_y + 12), cv::FONT_HERSHEY_SIMPLEX,
              0.4, cv::Scalar(0, 0, 0), 1, cv::LINE_AA);
  return canvas;
}

Relief reliefImage(const perception::Raster<float>& z, double cell_m) {
  const int rows = int(z.rows()), cols = int(z.cols());
  float lo = std::numeric_limits<float>::max(), hi = std::numeric_limits<float>::lowest();
  for (int i = 0; i < z.size(); ++i)
    if (std::isfinite(z.data()[i])) lo = std::min(lo, z.data()[i]), hi = std::max(hi, z.data()[i]);
  if (lo > hi) lo = hi = 0;
  const double span = std::max(1e-9, double(hi - lo));
  cv::Mat level(rows, cols, CV_8UC1), colour;
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < cols; ++c)
      level.at<uchar>(r, c) = std::isfinite(z(r, c)) ? uchar(std::lround(255.0 * (z(r, c) - lo) / span)) : 0;
  cv::applyColorMap(level, colour, cv::COLORMAP_VIRIDIS);
  // Hillshade: sun at azimuth 315° (north-west), altitude 45°; raster rows run north to south.
  const double zen = std::numbers::pi / 4, az = 315.0 * std::numbers::pi / 180.0;
  auto at = [&](int r, int c) {
    r = std::clamp(r, 0, rows - 1), c = std::clamp(c, 0, cols - 1);
    return z(r, c);
  };
  cv::Mat out(rows, cols, CV_8UC3);
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < cols; ++c) {
      if (!std::isfinite(z(r, c))) {
        out.at<cv::Vec3b>(r, c) = kNoData;
        continue;
      }
      double gx = (at(r, c + 1) - at(r, c - 1)) / (2 * cell_m);  // east
      double gy = (at(r - 1, c) - at(r + 1, c)) / (2 * cell_m);  // north
      if (!std::isfinite(gx)) gx = 0;
      if (!std::isfinite(gy)) gy = 0;
      const double slope = std::atan(std::hypot(gx, gy));
      const double aspect = std::atan2(-gx, -gy);  // downhill direction, clockwise from north
      const double shade = std::max(0.0, std::cos(zen) * std::cos(slope) +
                                             std::sin(zen) * std::sin(slope) * std::cos(az - aspect));
      const double k = 0.3 + 0.7 * shade;
      const cv::Vec3b base = colour.at<cv::Vec3b>(r, c);
      out.at<cv::Vec3b>(r, c) = cv::Vec3b(uchar(base[0] * k), uchar(base[1] * k), uchar(base[2] * k));
    }
  return {out, lo, hi};
}

cv::Mat shadedRelief(const perception::Raster<float>& z, double cell_m, const std::string& title) {
  const Relief relief = reliefImage(z, cell_m);
  const double f = std::clamp(900.0 / std::max(z.rows(), z.cols()), 0.25, 4.0);
  return frame(rescale(relief.image, f, f), title, relief.lo, relief.hi, "m", cv::COLORMAP_VIRIDIS);
}

cv::Mat rangePicture(const perception::RangeImage& image, double max_range_m, const std::string& title) {
  const int rows = image.rows(), cols = image.cols();
  float lo = std::numeric_limits<float>::max(), hi = 0;
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < cols; ++c)
      if (image.valid(r, c)) lo = std::min(lo, image.range(r, c)), hi = std::max(hi, image.range(r, c));
  if (lo > hi) lo = 0, hi = float(max_range_m);
  const double span = std::max(1e-6, double(hi - lo));
  cv::Mat level(rows, cols, CV_8UC1), colour;
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < cols; ++c)
      level.at<uchar>(r, c) = image.valid(r, c) ? uchar(std::lround(255.0 * (image.range(r, c) - lo) / span)) : 0;
  cv::applyColorMap(level, colour, cv::COLORMAP_TURBO);
  // Shade by the surface the returns describe (normals from neighbouring returns, light from the
  // north-west and above): range alone hides rocks and ledges in a smooth colour ramp.
  const Eigen::Vector3d light = Eigen::Vector3d(-1, 1, 2).normalized();
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < cols; ++c) {
      if (!image.valid(r, c)) {
        colour.at<cv::Vec3b>(r, c) = cv::Vec3b(0, 0, 0);
        continue;
      }
      const int r0 = std::max(r - 1, 0), r1 = std::min(r + 1, rows - 1);
      const int c0 = std::max(c - 1, 0), c1 = std::min(c + 1, cols - 1);
      if (!image.valid(r0, c) || !image.valid(r1, c) || !image.valid(r, c0) || !image.valid(r, c1)) continue;
      const Eigen::Vector3d n =
          (image.pointWorld(r, c1) - image.pointWorld(r, c0)).cross(image.pointWorld(r0, c) - image.pointWorld(r1, c));
      if (n.norm() == 0) continue;
      const double shade = 0.45 + 0.55 * std::max(0.0, std::abs(n.normalized().dot(light)));
      cv::Vec3b& px = colour.at<cv::Vec3b>(r, c);
      for (int k = 0; k < 3; ++k) px[k] = uchar(px[k] * shade);
    }
  // Keep the angular aspect: a row spans Δφ, a column Δθ.
  const double dphi = rows > 1 ? std::abs(image.phi[0] - image.phi[1]) : 1.0;
  const double dtheta = cols > 1 ? std::abs(image.theta[1] - image.theta[0]) : 1.0;
  const double fx = std::clamp(1024.0 / cols, 0.25, 8.0);
  const double fy = fx * dphi / dtheta;
  return frame(rescale(colour, fx, fy), title, lo, hi, "m", cv::COLORMAP_TURBO);
}

}  // namespace ambler::eval
