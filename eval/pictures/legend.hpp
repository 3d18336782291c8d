#pragma once
// The legend strip every map picture carries along its bottom (docs/scenario.md, "The run
// directory"): 26 px high, one entry after another, each a 14 px glyph and its label 20 px to the
// right of it, 18 px between entries, then an optional note in grey.
#include <functional>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

namespace ambler::eval {

struct LegendEntry {
  std::string label;
  // Draws the 14 × 14 px glyph whose top-left corner is `at` on `picture`.
  std::function<void(cv::Mat& picture, cv::Point at)> glyph;
};

// `canvas` with the legend strip added below it.
cv::Mat withLegend(const cv::Mat& canvas, const std::vector<LegendEntry>& entries, const std::string& note = "");

}  // namespace ambler::eval
