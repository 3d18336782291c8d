#include "eval/pictures/traverse_figures.hpp"

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>

#include "eval/pictures/figures.hpp"
#include "eval/pictures/legend.hpp"
#include "eval/pictures/plot.hpp"
#include "eval/scenario/io.hpp"

namespace ambler::eval {

namespace {

const cv::Scalar kTrue(0, 0, 0), kBelieved(40, 40, 220), kEstimated(200, 90, 20);  // BGR

}  // namespace

void writePathsPicture(const std::filesystem::path& file, const perception::ElevationMap& truth,
                       const std::vector<Eigen::Isometry3d>& true_WS, const std::vector<Eigen::Isometry3d>& believed_WS,
                       const std::vector<Eigen::Isometry3d>& estimated_WS, const std::string& title) {
  const perception::MapGrid& g = truth.grid();
  const Relief relief = reliefImage(truth.elevation(), g.cell);
  const double f = std::clamp(1400.0 / std::max(g.rows, g.cols), 1.0, 8.0);
  cv::Mat picture;
  cv::resize(relief.image, picture, cv::Size(), f, f, cv::INTER_NEAREST);
  // World (x, y) to the enlarged raster's pixel (north up: row 0 at y_max).
  const auto pixel = [&](const Eigen::Isometry3d& T) {
    const Eigen::Vector3d p = T.translation();
    return cv::Point(int(std::lround((p.x() - g.x_min) / g.cell * f)), int(std::lround((g.y_max - p.y()) / g.cell * f)));
  };
  const auto draw = [&](const std::vector<Eigen::Isometry3d>& poses, const cv::Scalar& colour) {
    std::vector<cv::Point> points;
    for (const Eigen::Isometry3d& T : poses) points.push_back(pixel(T));
    cv::polylines(picture, points, false, colour, 2, cv::LINE_AA);
    for (const cv::Point& p : points) cv::circle(picture, p, 3, colour, cv::FILLED, cv::LINE_AA);
  };
  draw(believed_WS, kBelieved);
  draw(true_WS, kTrue);
  draw(estimated_WS, kEstimated);
  const auto line = [](cv::Scalar colour) {
    return [colour](cv::Mat& m, cv::Point at) { cv::line(m, at + cv::Point(0, 7), at + cv::Point(13, 7), colour, 2, cv::LINE_AA); };
  };
  const cv::Mat framed = framePicture(picture, title, colourRamp(cv::COLORMAP_VIRIDIS), relief.lo, relief.hi, "m");
  writePng(file, withLegend(framed, {{"true", line(kTrue)}, {"dead reckoning", line(kBelieved)}, {"estimate", line(kEstimated)}},
                            "sensor positions at each stop, over the true terrain"));
}

void writeErrorPlot(const std::filesystem::path& file, const std::vector<double>& distance_m,
                    const std::vector<Eigen::Isometry3d>& true_WS, const std::vector<Eigen::Isometry3d>& believed_WS,
                    const std::vector<Eigen::Isometry3d>& estimated_WS, const std::string& title) {
  Series est{"estimate", distance_m, {}, kEstimated, true, true};
  Series dr{"dead reckoning", distance_m, {}, kBelieved, true, true};
  for (std::size_t k = 0; k < true_WS.size(); ++k) {
    est.y.push_back((estimated_WS[k].translation() - true_WS[k].translation()).norm());
    dr.y.push_back((believed_WS[k].translation() - true_WS[k].translation()).norm());
  }
  PlotSpec spec;
  spec.title = title;
  spec.x_label = "distance travelled (m)";
  spec.y_label = "position error (m)";
  spec.series = {dr, est};
  writePng(file, renderPlot(spec));
}

}  // namespace ambler::eval
