#pragma once
// Pictures of matching (paper §4, fig. 5; docs/matching.md): a map's features over its relief,
// two maps' features and their correspondences, the difference of two maps before and after a
// registration, and each method's residual per iteration. Maps are drawn like the map pictures
// (eval/pictures/map_outputs.hpp): north up, every cell a square of cellEnlargement px, framed by
// framePicture; features are placed by their map-frame x, y on the map's grid (MapGrid), so a map
// in any frame is drawn in its own.
#include <filesystem>
#include <opencv2/core.hpp>
#include <string>
#include <utility>
#include <vector>

#include "perception/elevation_map.hpp"
#include "perception/features.hpp"

namespace ambler::eval {

// The colour (BGR) featuresPicture draws a feature type in.
cv::Scalar featureColour(perception::FeatureType type);
// The colours of correspondencePicture: map I's features, map J's, the lines joining pairs.
extern const cv::Scalar kFeaturesIColour, kFeaturesJColour, kCorrespondenceColour;

// The map's shaded relief (reliefImage, framed with its elevation scale) with `features` drawn at
// their positions: a point as a circle of radius extent_m with a dot at its centre, a line as a
// segment of its length along its direction through its position, a region as a tinted disc of
// radius extent_m with a dot at its centre (circles at least 5 px across); one colour per type
// (featureColour) over a black outline, and a legend of the types with their counts.
cv::Mat featuresPicture(const perception::ElevationMap& map, const std::vector<perception::Feature>& features,
                        const std::string& title);

// Fig. 5: map I's relief with its features in kFeaturesIColour, map J's features (already moved
// into map I's frame by the estimate, by the caller) in kFeaturesJColour, and a line in
// kCorrespondenceColour from the first to the second feature of each pair (indices into
// features_i, features_j), drawn over the features but under their centre dots. Throws
// std::invalid_argument for an index out of range.
cv::Mat correspondencePicture(const perception::ElevationMap& map_i,
                              const std::vector<perception::Feature>& features_i,
                              const std::vector<perception::Feature>& features_j,
                              const std::vector<std::pair<int, int>>& pairs, const std::string& title);

// a − b where both cells are Known, in coolWarmRamp(255) over [−span_m, span_m] (0 exactly its
// white middle, beyond the span its ends); cells not Known in both grey (150, 150, 150). The title
// gains the RMS difference. Throws std::invalid_argument unless the grids are the same and
// span_m > 0.
cv::Mat differencePicture(const perception::ElevationMap& a, const perception::ElevationMap& b, double span_m,
                          const std::string& title);

// Two differences side by side under one colour scale over [−span_m, span_m]: before − reference
// on the left, labelled "before", after − reference on the right, labelled `after_label`, each
// drawn as differencePicture draws it. Throws like differencePicture.
cv::Mat beforeAfterPicture(const perception::ElevationMap& reference, const perception::ElevationMap& before,
                           const perception::ElevationMap& after, double span_m, const std::string& title,
                           const std::string& after_label = "after");

// A span for pictures of a − b: the 99th percentile of |a − b| over the cells Known in both,
// rounded up to 1, 2 or 5 · 10^n metres, at least 1 mm (1 mm too when no cell is). Throws
// std::invalid_argument unless the grids are the same.
double differenceSpan(const perception::ElevationMap& a, const perception::ElevationMap& b);

// One method's residual per iteration (values[k] at iteration k).
struct ConvergenceTrace {
  std::string label;
  std::vector<double> values;
};

// values against iteration, one curve with markers per trace in plotColour(index), a log y axis
// (values ≤ 0 or NaN are left out), a legend of the labels; 900 × 560 px.
cv::Mat convergencePlot(const std::vector<ConvergenceTrace>& traces, const std::string& title,
                        const std::string& y_label = "RMS residual (m)");

// A method's name as it appears in file names: '+' written '_' ("features+iconic" → "features_iconic").
std::string methodFileName(const std::string& method);

// Writes dir/view_<view>_features.png (featuresPicture). Every file is written whole or not at
// all (eval/scenario/io.hpp); throws std::runtime_error naming a file that cannot be written.
void writeFeaturesPicture(const std::filesystem::path& dir, int view, const perception::ElevationMap& map,
                          const std::vector<perception::Feature>& features, const std::string& title);

// One registration method's outcome for the pair pictures.
struct RegisteredMap {
  std::string method;
  const perception::ElevationMap* after = nullptr;  // map J at the method's estimate, on map I's grid
  std::vector<double> rms_m;                        // the residual per iteration
};

// The pictures of pair (i, j) in `dir`: pair_I_J_difference_METHOD.png (beforeAfterPicture of
// `before` and each method's map against `reference`, all on one span, differenceSpan of before)
// for each method with a trace, and pair_I_J_convergence.png (convergencePlot of every method
// with a trace) when there is one. Throws like writeFeaturesPicture, and std::invalid_argument
// for maps on different grids.
void writePairPictures(const std::filesystem::path& dir, int i, int j, const perception::ElevationMap& reference,
                       const perception::ElevationMap& before, const std::vector<RegisteredMap>& methods,
                       const std::string& title);

// A grid of success rates over initial errors (a convergence basin): row 0 at the bottom.
struct SuccessGrid {
  std::string title, subtitle;   // the method; what a cell shows (criterion, trials; '\n' between lines)
  std::string row_axis, col_axis;
  std::vector<std::string> row_labels, col_labels;
  std::vector<int> successes, trials;  // row-major; a cell of 0 trials is left blank
  std::vector<std::string> notes;      // row-major: lines ('\n' between) under "k/n" (empty: none)
};

// One cell per initial error, filled from light grey (no success) to blue (all), "k/n" in it and
// its note below; the axes labelled with the values. Throws std::invalid_argument when the
// vectors do not match the labels' grid.
cv::Mat successHeatmap(const SuccessGrid& grid, int width = 620, int height = 470);

// The 95 % basin boundary of each method: over the column values x (initial rotation), the
// largest row value y (initial translation) up to which every cell of that column succeeds at
// least `level` (NaN, a break in the line, when the first cell already fails). One line with
// markers per method, method k lifted by (k − (M−1)/2) % of the translation range so that equal
// boundaries stay visible; the axes cover the whole grid and a strip on the right for the legend.
struct BasinBoundary {
  std::string label;
  std::vector<double> rate;  // row-major over rows (translations) × cols (rotations), in [0, 1]
};
cv::Mat basinBoundaryPlot(const std::vector<double>& translations_m, const std::vector<double>& rotations_deg,
                          const std::vector<BasinBoundary>& methods, double level, const std::string& title);

}  // namespace ambler::eval
