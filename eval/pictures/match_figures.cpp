#include "eval/pictures/match_figures.hpp"

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <stdexcept>

#include "eval/pictures/figures.hpp"
#include "eval/pictures/legend.hpp"
#include "eval/scenario/io.hpp"
#include "eval/pictures/plot.hpp"

namespace ambler::eval {

const cv::Scalar kFeaturesIColour(255, 255, 255);     // white
const cv::Scalar kFeaturesJColour(255, 0, 255);       // magenta
const cv::Scalar kCorrespondenceColour(0, 215, 255);  // gold

namespace {

using perception::CellState;
using perception::ElevationMap;
using perception::Feature;
using perception::FeatureType;

constexpr int kShift = 4;                      // sub-pixel bits of drawing coordinates (1/16 px)
const cv::Scalar kOutline(0, 0, 0);            // under every mark, so it reads on any relief colour
const cv::Vec3b kNoData(40, 40, 40);           // reliefImage's unknown cells
const cv::Vec3b kUnknown(150, 150, 150);       // the difference pictures' cells not Known in both
constexpr int kLabelBand = 20, kPanelGap = 16;  // beforeAfterPicture: a label above each panel, the gap between

std::string format(const char* pattern, double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, pattern, v);
  return buf;
}

// The map's relief enlarged to the map pictures' size, and where a point of the map frame lands on it.
struct MapView {
  perception::MapGrid grid;
  int k = 1;
  Relief relief;
  cv::Mat picture;

  explicit MapView(const ElevationMap& map)
      : grid(map.grid()), k(cellEnlargement(grid.rows, grid.cols)), relief(reliefImage(map.elevation(), grid.cell)) {
    cv::resize(relief.image, picture, cv::Size(), k, k, cv::INTER_NEAREST);
  }
  // Pixel (px, py) of the picture covers [px, px + 1) × [py, py + 1) of k·(x − x_min)/cell,
  // k·(y_max − y)/cell; OpenCV puts pixel centres at integers, hence the half pixel. Far-off points
  // are clamped well outside the picture (drawing clips them) so the fixed-point coordinates fit an int.
  cv::Point at(double x, double y) const {
    const double px = std::clamp(k * (x - grid.x_min) / grid.cell - 0.5, -1e5, 1e5);
    const double py = std::clamp(k * (grid.y_max - y) / grid.cell - 0.5, -1e5, 1e5);
    return {int(std::lround(px * (1 << kShift))), int(std::lround(py * (1 << kShift)))};
  }
  // A radius of `m` metres in fixed-point pixels, at least 2.5 px (2.5 px for a NaN).
  int radius(double m) const {
    const double px = std::isfinite(m) ? std::clamp(m * k / grid.cell, 2.5, 1e5) : 2.5;
    return int(std::lround(px * (1 << kShift)));
  }
};

void dot(cv::Mat& img, cv::Point p, const cv::Scalar& colour) {
  cv::circle(img, p, 3 << kShift, kOutline, cv::FILLED, cv::LINE_8, kShift);
  cv::circle(img, p, 2 << kShift, colour, cv::FILLED, cv::LINE_8, kShift);
}

void ring(cv::Mat& img, cv::Point p, int radius, const cv::Scalar& colour) {
  cv::circle(img, p, radius, kOutline, 4, cv::LINE_8, kShift);
  cv::circle(img, p, radius, colour, 2, cv::LINE_8, kShift);
}

void segment(cv::Mat& img, cv::Point a, cv::Point b, const cv::Scalar& colour, int thickness) {
  cv::line(img, a, b, kOutline, thickness + 2, cv::LINE_8, kShift);
  cv::line(img, a, b, colour, thickness, cv::LINE_8, kShift);
}

// A region's disc: the picture blended 35 % towards `colour` inside the circle.
void tint(cv::Mat& img, cv::Point p, int radius, const cv::Scalar& colour) {
  cv::Mat mask(img.size(), CV_8UC1, cv::Scalar(0));
  cv::circle(mask, p, radius, cv::Scalar(255), cv::FILLED, cv::LINE_8, kShift);
  cv::Mat tinted;
  cv::addWeighted(img, 0.65, cv::Mat(img.size(), img.type(), colour), 0.35, 0.0, tinted);
  tinted.copyTo(img, mask);
}

// What of a feature to draw: its body (ring, segment, disc), its centre dot (points and regions), or both.
enum class Part { Body, Dot, Both };

// Draws `f` in `colour`: a point as a ring of its extent with a centre dot, a line as a segment
// of its length through its position (the horizontal part of its axis), a region as a tinted disc
// of its extent with a ring and a centre dot.
void drawFeature(cv::Mat& img, const MapView& v, const Feature& f, const cv::Scalar& colour, Part part) {
  if (!f.position.allFinite()) return;
  const cv::Point p = v.at(f.position.x(), f.position.y());
  const bool body = part != Part::Dot, centre = part != Part::Body;
  switch (f.type) {
    case FeatureType::Line: {
      if (!body) break;
      const Eigen::Vector2d h = f.direction.allFinite() && std::isfinite(f.length_m)
                                    ? Eigen::Vector2d(0.5 * f.length_m * f.direction.head<2>())
                                    : Eigen::Vector2d::Zero();
      segment(img, v.at(f.position.x() - h.x(), f.position.y() - h.y()),
              v.at(f.position.x() + h.x(), f.position.y() + h.y()), colour, 3);
      break;
    }
    case FeatureType::Region:
      if (body) tint(img, p, v.radius(f.extent_m), colour), ring(img, p, v.radius(f.extent_m), colour);
      if (centre) dot(img, p, colour);
      break;
    case FeatureType::Point:
      if (body) ring(img, p, v.radius(f.extent_m), colour);
      if (centre) dot(img, p, colour);
      break;
  }
}

// Regions first, then lines, then points, so that small marks stay on top of large ones; in
// featureColour, or in `colour` if given.
void drawFeatures(cv::Mat& img, const MapView& v, const std::vector<Feature>& features, Part part,
                  const cv::Scalar* colour = nullptr) {
  for (FeatureType type : {FeatureType::Region, FeatureType::Line, FeatureType::Point})
    for (const Feature& f : features)
      if (f.type == type) drawFeature(img, v, f, colour ? *colour : featureColour(type), part);
}

enum class Glyph { Ring, Segment, Disc, Box };
struct Mark {
  Glyph glyph;
  cv::Scalar colour;
  std::string label;
};

// The legend of the matching pictures: each mark as the picture draws it.
cv::Mat withLegend(const cv::Mat& canvas, const std::vector<Mark>& marks) {
  std::vector<LegendEntry> entries;
  for (const Mark& e : marks)
    entries.push_back({e.label, [e](cv::Mat& out, cv::Point at) {
                         const cv::Point c(at.x + 7, at.y + 7);
                         cv::Mat swatch = out(cv::Rect(at.x, at.y, 14, 14));
                         switch (e.glyph) {
                           case Glyph::Box:
                             swatch.setTo(e.colour);
                             cv::rectangle(out, cv::Rect(at.x, at.y, 14, 14), kOutline, 1);
                             break;
                           case Glyph::Segment:
                             segment(out, (c + cv::Point(-7, 5)) * (1 << kShift), (c + cv::Point(7, -5)) * (1 << kShift),
                                     e.colour, 3);
                             break;
                           case Glyph::Disc:
                             swatch.setTo(cv::Scalar(150, 150, 150));
                             tint(swatch, cv::Point(7, 7) * (1 << kShift), 6 << kShift, e.colour);
                             [[fallthrough]];
                           case Glyph::Ring:
                             ring(out, c * (1 << kShift), 6 << kShift, e.colour);
                             dot(out, c * (1 << kShift), e.colour);
                             break;
                         }
                       }});
  return ambler::eval::withLegend(canvas, entries);
}

void checkSameGrid(const ElevationMap& a, const ElevationMap& b, const char* what) {
  if (!a.grid().sameAs(b.grid()))
    throw std::invalid_argument(std::string(what) + ": the maps are not on the same grid");
}

// a − b per cell in coolWarmRamp(255) over [−span, span], enlarged; grey where not Known in both.
struct Difference {
  cv::Mat picture;
  double rms_m = 0;
  long cells = 0;
};
Difference difference(const ElevationMap& a, const ElevationMap& b, double span_m, const cv::Mat& ramp) {
  const int rows = a.grid().rows, cols = a.grid().cols;
  cv::Mat cells(rows, cols, CV_8UC3);
  Difference out;
  double sum2 = 0;
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < cols; ++c) {
      if (a.stateAt(r, c) != CellState::Known || b.stateAt(r, c) != CellState::Known) {
        cells.at<cv::Vec3b>(r, c) = kUnknown;
        continue;
      }
      const double d = double(a.elevation()(r, c)) - double(b.elevation()(r, c));
      const long level = std::clamp(std::lround(127.0 + 127.0 * d / span_m), 0L, 254L);
      cells.at<cv::Vec3b>(r, c) = ramp.at<cv::Vec3b>(0, int(level));
      sum2 += d * d;
      ++out.cells;
    }
  out.rms_m = out.cells ? std::sqrt(sum2 / double(out.cells)) : 0.0;
  const int k = cellEnlargement(rows, cols);
  cv::resize(cells, out.picture, cv::Size(), k, k, cv::INTER_NEAREST);
  return out;
}

std::string rmsText(const Difference& d) {
  return d.cells ? format("rms %.2f cm", 100.0 * d.rms_m) + ", " + std::to_string(d.cells) + " cells"
                 : std::string("no cell known in both");
}

void checkSpan(double span_m) {
  if (!(span_m > 0) || !std::isfinite(span_m)) throw std::invalid_argument("difference picture: the span must be > 0");
}

}  // namespace

cv::Scalar featureColour(FeatureType type) {
  switch (type) {
    case FeatureType::Point: return cv::Scalar(40, 40, 255);   // red
    case FeatureType::Line: return cv::Scalar(255, 0, 255);    // magenta
    case FeatureType::Region: return cv::Scalar(255, 255, 255);  // white
  }
  return cv::Scalar(0, 0, 0);
}

cv::Mat featuresPicture(const ElevationMap& map, const std::vector<Feature>& features, const std::string& title) {
  MapView v(map);
  drawFeatures(v.picture, v, features, Part::Both);
  long n[3] = {0, 0, 0};
  for (const Feature& f : features) ++n[int(f.type)];
  const cv::Mat framed = framePicture(v.picture, title + ": " + std::to_string(features.size()) + " features",
                                      colourRamp(cv::COLORMAP_VIRIDIS), v.relief.lo, v.relief.hi, "m");
  return withLegend(framed, {{Glyph::Ring, featureColour(FeatureType::Point), "points: " + std::to_string(n[0])},
                             {Glyph::Segment, featureColour(FeatureType::Line), "lines: " + std::to_string(n[1])},
                             {Glyph::Disc, featureColour(FeatureType::Region), "regions: " + std::to_string(n[2])},
                             {Glyph::Box, cv::Scalar(kNoData[0], kNoData[1], kNoData[2]), "unknown"}});
}

cv::Mat correspondencePicture(const ElevationMap& map_i, const std::vector<Feature>& features_i,
                              const std::vector<Feature>& features_j, const std::vector<std::pair<int, int>>& pairs,
                              const std::string& title) {
  for (const auto& [a, b] : pairs)
    if (a < 0 || a >= int(features_i.size()) || b < 0 || b >= int(features_j.size()))
      throw std::invalid_argument("correspondencePicture: pair (" + std::to_string(a) + ", " + std::to_string(b) +
                                  ") is out of range");
  MapView v(map_i);
  // The lines over the features' rings, segments and discs (pairs closer than a ring's radius
  // would hide under them), the centre dots over the lines.
  drawFeatures(v.picture, v, features_i, Part::Body, &kFeaturesIColour);
  drawFeatures(v.picture, v, features_j, Part::Body, &kFeaturesJColour);
  for (const auto& [a, b] : pairs) {
    const Eigen::Vector3d& p = features_i[std::size_t(a)].position;
    const Eigen::Vector3d& q = features_j[std::size_t(b)].position;
    if (p.allFinite() && q.allFinite())
      segment(v.picture, v.at(p.x(), p.y()), v.at(q.x(), q.y()), kCorrespondenceColour, 2);
  }
  drawFeatures(v.picture, v, features_i, Part::Dot, &kFeaturesIColour);
  drawFeatures(v.picture, v, features_j, Part::Dot, &kFeaturesJColour);
  const cv::Mat framed =
      framePicture(v.picture, title, colourRamp(cv::COLORMAP_VIRIDIS), v.relief.lo, v.relief.hi, "m");
  const auto n = [](std::size_t k) { return std::to_string(k); };
  return withLegend(framed, {{Glyph::Ring, kFeaturesIColour, "map I features: " + n(features_i.size())},
                             {Glyph::Ring, kFeaturesJColour, "map J features, moved: " + n(features_j.size())},
                             {Glyph::Segment, kCorrespondenceColour, "pairs: " + n(pairs.size())}});
}

cv::Mat differencePicture(const ElevationMap& a, const ElevationMap& b, double span_m, const std::string& title) {
  checkSameGrid(a, b, "differencePicture");
  checkSpan(span_m);
  const cv::Mat ramp = coolWarmRamp(255);
  const Difference d = difference(a, b, span_m, ramp);
  const cv::Mat framed =
      framePicture(d.picture, title + " (" + rmsText(d) + ")", ramp, -100 * span_m, 100 * span_m, "cm");
  return withLegend(framed, {{Glyph::Box, cv::Scalar(kUnknown[0], kUnknown[1], kUnknown[2]), "not known in both"}});
}

cv::Mat beforeAfterPicture(const ElevationMap& reference, const ElevationMap& before, const ElevationMap& after,
                           double span_m, const std::string& title, const std::string& after_label) {
  checkSameGrid(before, reference, "beforeAfterPicture");
  checkSameGrid(after, reference, "beforeAfterPicture");
  checkSpan(span_m);
  const cv::Mat ramp = coolWarmRamp(255);
  const Difference d0 = difference(before, reference, span_m, ramp), d1 = difference(after, reference, span_m, ramp);
  const int w = d0.picture.cols, h = d0.picture.rows;
  cv::Mat both(kLabelBand + h, 2 * w + kPanelGap, CV_8UC3, cv::Scalar(255, 255, 255));
  d0.picture.copyTo(both(cv::Rect(0, kLabelBand, w, h)));
  d1.picture.copyTo(both(cv::Rect(w + kPanelGap, kLabelBand, w, h)));
  cv::putText(both, "before: " + rmsText(d0), cv::Point(0, kLabelBand - 6), cv::FONT_HERSHEY_SIMPLEX, 0.45, kOutline,
              1, cv::LINE_AA);
  cv::putText(both, after_label + ": " + rmsText(d1), cv::Point(w + kPanelGap, kLabelBand - 6),
              cv::FONT_HERSHEY_SIMPLEX, 0.45, kOutline, 1, cv::LINE_AA);
  const cv::Mat framed = framePicture(both, title, ramp, -100 * span_m, 100 * span_m, "cm");
  return withLegend(framed, {{Glyph::Box, cv::Scalar(kUnknown[0], kUnknown[1], kUnknown[2]), "not known in both"}});
}

double differenceSpan(const ElevationMap& a, const ElevationMap& b) {
  checkSameGrid(a, b, "differenceSpan");
  std::vector<double> abs_d;
  for (int r = 0; r < a.grid().rows; ++r)
    for (int c = 0; c < a.grid().cols; ++c)
      if (a.stateAt(r, c) == CellState::Known && b.stateAt(r, c) == CellState::Known)
        abs_d.push_back(std::abs(double(a.elevation()(r, c)) - double(b.elevation()(r, c))));
  double v = 1e-3;
  if (!abs_d.empty()) {
    auto p99 = abs_d.begin() + std::ptrdiff_t(0.99 * double(abs_d.size() - 1));
    std::nth_element(abs_d.begin(), p99, abs_d.end());
    v = std::max(v, *p99);
  }
  // Up to the next 1, 2 or 5 · 10^e (10^e as an exact power for e ≥ 0, 1/10^−e below, like niceTicks).
  const int e = int(std::floor(std::log10(v)));
  const double decade = e >= 0 ? std::pow(10.0, e) : 1.0 / std::pow(10.0, -e);
  for (double m : {1.0, 2.0, 5.0, 10.0})
    if (m * decade >= v * (1 - 1e-12)) return m * decade;
  return 10 * decade;
}

cv::Mat convergencePlot(const std::vector<ConvergenceTrace>& traces, const std::string& title,
                        const std::string& y_label) {
  PlotSpec spec{title, "iteration", y_label, false, true, {}};
  for (const ConvergenceTrace& t : traces) {
    Series s;
    s.label = t.label;
    s.markers = true;
    for (std::size_t k = 0; k < t.values.size(); ++k) s.x.push_back(double(k)), s.y.push_back(t.values[k]);
    spec.series.push_back(std::move(s));
  }
  return renderPlot(spec);
}

std::string methodFileName(const std::string& method) {
  std::string out = method;
  std::replace(out.begin(), out.end(), '+', '_');
  return out;
}

void writeFeaturesPicture(const std::filesystem::path& dir, int view, const ElevationMap& map,
                          const std::vector<Feature>& features, const std::string& title) {
  writePng(dir / ("view_" + std::to_string(view) + "_features.png"), featuresPicture(map, features, title));
}

void writePairPictures(const std::filesystem::path& dir, int i, int j, const ElevationMap& reference,
                       const ElevationMap& before, const std::vector<RegisteredMap>& methods,
                       const std::string& title) {
  const std::string stem = "pair_" + std::to_string(i) + "_" + std::to_string(j);
  const std::string head = title + ": map " + std::to_string(j) + " - map " + std::to_string(i);
  const double span = differenceSpan(before, reference);
  std::vector<ConvergenceTrace> traces;
  for (const RegisteredMap& m : methods) {
    if (m.rms_m.empty()) continue;
    if (m.after)
      writePng(dir / (stem + "_difference_" + methodFileName(m.method) + ".png"),
               beforeAfterPicture(reference, before, *m.after, span, head + ", " + m.method + " (same scale)",
                                  "after " + m.method));
    traces.push_back({m.method, m.rms_m});
  }
  if (!traces.empty())
    writePng(dir / (stem + "_convergence.png"),
             convergencePlot(traces, title + ": views " + std::to_string(i) + "-" + std::to_string(j) +
                                         ", residual per iteration"));
}

namespace {

const cv::Scalar kInk(0, 0, 0), kPaper(255, 255, 255), kNone(242, 242, 242), kAll(180, 119, 31);  // BGR

void centred(cv::Mat& img, const std::string& s, cv::Point centre, double scale, const cv::Scalar& colour,
             int thickness = 1) {
  int baseline = 0;
  const cv::Size size = cv::getTextSize(s, cv::FONT_HERSHEY_SIMPLEX, scale, thickness, &baseline);
  cv::putText(img, s, {centre.x - size.width / 2, centre.y + size.height / 2}, cv::FONT_HERSHEY_SIMPLEX, scale, colour,
              thickness, cv::LINE_AA);
}

}  // namespace

namespace {

// A text's lines ('\n' between them; none for an empty text).
std::vector<std::string> lines(const std::string& text) {
  std::vector<std::string> out;
  if (text.empty()) return out;
  std::size_t b = 0;
  for (std::size_t e; (e = text.find('\n', b)) != std::string::npos; b = e + 1) out.push_back(text.substr(b, e - b));
  out.push_back(text.substr(b));
  return out;
}

}  // namespace

cv::Mat successHeatmap(const SuccessGrid& g, int width, int height) {
  const std::size_t rows = g.row_labels.size(), cols = g.col_labels.size();
  if (g.successes.size() != rows * cols || g.trials.size() != rows * cols ||
      (!g.notes.empty() && g.notes.size() != rows * cols))
    throw std::invalid_argument("successHeatmap: successes, trials and notes must have rows x cols entries");
  const std::vector<std::string> subtitle = lines(g.subtitle);
  const int left = 110, top = 84 + 16 * std::max(0, int(subtitle.size()) - 1), bottom = 62, right = 20;
  cv::Mat img(height, width, CV_8UC3, kPaper);
  centred(img, g.title, {width / 2, 20}, 0.7, kInk, 2);
  for (std::size_t i = 0; i < subtitle.size(); ++i)
    centred(img, subtitle[i], {width / 2, 44 + 16 * int(i)}, i ? 0.4 : 0.45, kInk);
  const int cw = (width - left - right) / int(std::max<std::size_t>(1, cols));
  const int ch = (height - top - bottom) / int(std::max<std::size_t>(1, rows));
  // The text's scale: "k/n" and the note's lines must fit a cell (the note's first line 36·text
  // under "k/n", each next one 22·text further, about 60·text for "k/n" and one line).
  std::size_t note_lines = 0;
  for (const std::string& n : g.notes) note_lines = std::max(note_lines, lines(n).size());
  const double tall = 60.0 + 22.0 * double(note_lines > 1 ? note_lines - 1 : 0);
  const double text = std::clamp(std::min(cw / 110.0, (ch - 6) / tall), 0.35, 0.7);
  for (std::size_t i = 0; i < rows; ++i) {
    const int y0 = top + int(rows - 1 - i) * ch;  // row 0 at the bottom
    centred(img, g.row_labels[i], {left / 2 + 8, y0 + ch / 2}, 0.5, kInk);
    for (std::size_t j = 0; j < cols; ++j) {
      const std::size_t k = i * cols + j;
      const int x0 = left + int(j) * cw;
      const int n = g.trials[k];
      const double f = n ? g.successes[k] / double(n) : 0;
      cv::rectangle(img, {x0, y0, cw, ch}, n ? kNone * (1 - f) + kAll * f : kPaper, cv::FILLED);
      cv::rectangle(img, {x0, y0, cw + 1, ch + 1}, kPaper, 2);
      if (!n) continue;
      const cv::Scalar ink = f > 0.5 ? kPaper : kInk;
      // "k/n" and the note's lines under it, the block centred in the cell.
      const std::vector<std::string> note = g.notes.empty() ? std::vector<std::string>{} : lines(g.notes[k]);
      const int first = int(36 * text), line = int(22 * text);
      const int block = note.empty() ? 0 : first + line * int(note.size() - 1);  // "k/n"'s centre to the last line's
      const int y = y0 + ch / 2 - block / 2;
      centred(img, std::to_string(g.successes[k]) + "/" + std::to_string(n), {x0 + cw / 2, y}, text, ink,
              text > 0.5 ? 2 : 1);
      for (std::size_t l = 0; l < note.size(); ++l)
        centred(img, note[l], {x0 + cw / 2, y + first + line * int(l)}, 0.65 * text, ink);
    }
  }
  for (std::size_t j = 0; j < cols; ++j)
    centred(img, g.col_labels[j], {left + int(j) * cw + cw / 2, height - bottom + 16}, std::min(0.5, 0.9 * text), kInk);
  centred(img, g.col_axis, {left + int(cols) * cw / 2, height - 16}, 0.5, kInk);
  const auto space = g.row_axis.find(' ');
  centred(img, g.row_axis.substr(0, space), {left / 2 + 8, top - 26}, 0.45, kInk);
  if (space != std::string::npos) centred(img, g.row_axis.substr(space + 1), {left / 2 + 8, top - 10}, 0.45, kInk);
  return img;
}

cv::Mat basinBoundaryPlot(const std::vector<double>& translations_m, const std::vector<double>& rotations_deg,
                          const std::vector<BasinBoundary>& methods, double level, const std::string& title) {
  const std::size_t rows = translations_m.size(), cols = rotations_deg.size();
  PlotSpec spec;
  spec.title = title;
  spec.x_label = "initial rotation (deg)";
  spec.y_label = "initial translation (m) reached";
  // Methods with the same boundary would hide each other: each line is lifted by a step of 1 % of
  // the translation range, centred on the true values (said in the caption).
  const double span = std::max(translations_m.back() - translations_m.front(), 1e-3);
  for (std::size_t k = 0; k < methods.size(); ++k) {
    const BasinBoundary& m = methods[k];
    if (m.rate.size() != rows * cols)
      throw std::invalid_argument("basinBoundaryPlot: " + m.label + ": rates must have rows x cols entries");
    const double lift = (double(k) - 0.5 * double(methods.size() - 1)) * 0.01 * span;
    Series s;
    s.label = m.label;
    s.markers = true;
    for (std::size_t j = 0; j < cols; ++j) {
      double reached = std::numeric_limits<double>::quiet_NaN();
      for (std::size_t i = 0; i < rows && m.rate[i * cols + j] >= level; ++i) reached = translations_m[i];
      s.x.push_back(rotations_deg[j]);
      s.y.push_back(reached + lift);
    }
    spec.series.push_back(std::move(s));
  }
  // The axes span the whole grid (invisible points at its corners) and a strip on the right for
  // the legend.
  const double room = rotations_deg.back() + 0.35 * std::max(rotations_deg.back() - rotations_deg.front(), 1.0);
  spec.series.push_back(Series{"", {rotations_deg.front(), room},
                               {translations_m.front(), translations_m.back()}, cv::Scalar(255, 255, 255), false,
                               false});
  return renderPlot(spec);
}

}  // namespace ambler::eval
