#include "eval/pictures/legend.hpp"

#include <opencv2/imgproc.hpp>

namespace ambler::eval {

cv::Mat withLegend(const cv::Mat& canvas, const std::vector<LegendEntry>& entries, const std::string& note) {
  cv::Mat out;
  cv::copyMakeBorder(canvas, out, 0, 26, 0, 0, cv::BORDER_CONSTANT, cv::Scalar(255, 255, 255));
  int x = 8;
  const int y = canvas.rows + 4;
  for (const LegendEntry& e : entries) {
    e.glyph(out, cv::Point(x, y));
    cv::putText(out, e.label, cv::Point(x + 20, y + 12), cv::FONT_HERSHEY_SIMPLEX, 0.4, cv::Scalar(0, 0, 0), 1,
                cv::LINE_AA);
    int baseline = 0;
    x += 20 + cv::getTextSize(e.label, cv::FONT_HERSHEY_SIMPLEX, 0.4, 1, &baseline).width + 18;
  }
  if (!note.empty())
    cv::putText(out, note, cv::Point(x, y + 12), cv::FONT_HERSHEY_SIMPLEX, 0.4, cv::Scalar(90, 90, 90), 1,
                cv::LINE_AA);
  return out;
}

}  // namespace ambler::eval
