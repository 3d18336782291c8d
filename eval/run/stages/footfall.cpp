// The footfall stage (docs/scenario.md, "footfall"; docs/footfall.md): every candidate centre of
// the region scored on the chosen map by each method (perception::evaluateFootfalls), the best
// one chosen, and scored again on the true surface: its true score and the share of the region's
// candidates that the truth scores better (its true percentile). footfall/METHOD.json,
// footfall/METHOD_score.tiff, footfall/choices.png, metrics.footfall.
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

#include "eval/score/footfall_score.hpp"
#include "eval/pictures/figures.hpp"
#include "eval/scenario/io.hpp"
#include "eval/pictures/plot.hpp"
#include "eval/run/stages.hpp"

namespace ambler::eval::stages {

namespace {

// The map's relief around the region (0.5 m beyond it), the region's outline and each method's
// foot where it chose, in plotColour(k), with a legend of method and true percentile.
cv::Mat choicesPicture(const perception::ElevationMap& map, const FootfallSpec& spec,
                       const std::vector<FootfallChoice>& choices, const std::string& title) {
  const perception::MapGrid& g = map.grid();
  const auto col = [&](double x) { return std::clamp(int(std::floor((x - g.x_min) / g.cell)), 0, g.cols - 1); };
  const auto row = [&](double y) { return std::clamp(int(std::floor((g.y_max - y) / g.cell)), 0, g.rows - 1); };
  const int c0 = col(spec.x_m[0] - 0.5), c1 = col(spec.x_m[1] + 0.5);
  const int r0 = row(spec.y_m[1] + 0.5), r1 = row(spec.y_m[0] - 0.5);
  const perception::Raster<float> crop = map.elevation().block(r0, c0, r1 - r0 + 1, c1 - c0 + 1);
  const Relief relief = reliefImage(crop, g.cell);
  const int k = std::max(1, 600 / std::max(1, int(crop.cols())));
  cv::Mat img;
  cv::resize(relief.image, img, cv::Size(), k, k, cv::INTER_NEAREST);
  const double px = k / g.cell;  // pixels per metre
  const auto at = [&](double x, double y) {
    return cv::Point(int(std::lround((x - (g.x_min + c0 * g.cell)) * px)), int(std::lround(((g.y_max - r0 * g.cell) - y) * px)));
  };
  cv::rectangle(img, at(spec.x_m[0], spec.y_m[1]), at(spec.x_m[1], spec.y_m[0]), cv::Scalar(255, 255, 255), 2, cv::LINE_AA);
  for (std::size_t i = 0; i < choices.size(); ++i) {
    if (!std::isfinite(choices[i].x_m)) continue;
    cv::circle(img, at(choices[i].x_m, choices[i].y_m), int(std::lround(0.5 * spec.foot_diameter_m * px)),
               plotColour(int(i)), 2, cv::LINE_AA);
  }
  cv::Mat framed = framePicture(img, title, colourRamp(cv::COLORMAP_VIRIDIS), relief.lo, relief.hi, "m");
  const int line = 20, legend_h = line * int(choices.size()) + 8;
  cv::Mat out(framed.rows + legend_h, framed.cols, CV_8UC3, cv::Scalar(255, 255, 255));
  framed.copyTo(out(cv::Rect(0, 0, framed.cols, framed.rows)));
  for (std::size_t i = 0; i < choices.size(); ++i) {
    const int y = framed.rows + line * int(i) + 14;
    cv::circle(out, {16, y - 4}, 6, plotColour(int(i)), 2, cv::LINE_AA);
    char text[160];
    std::snprintf(text, sizeof text, "%s: (%.2f, %.2f) m, true percentile %s", choices[i].method.c_str(), choices[i].x_m,
                  choices[i].y_m, std::isfinite(choices[i].truth_percentile)
                                      ? (std::to_string(int(std::lround(100 * choices[i].truth_percentile))) + "%").c_str()
                                      : "-");
    cv::putText(out, text, {30, y}, cv::FONT_HERSHEY_SIMPLEX, 0.45, cv::Scalar(0, 0, 0), 1, cv::LINE_AA);
  }
  return out;
}

void run(RunState& s) {
  const Scenario& sc = s.scenario;
  const FootfallSpec& spec = *sc.footfall;
  const perception::ElevationMap& map = spec.map_view < 0 ? *s.composite : s.views[std::size_t(spec.map_view)].locus->map;
  const std::string map_name = spec.map_view < 0 ? "composite" : viewName(spec.map_view);
  const perception::MapGrid& grid = map.grid();
  s.footfall_truth = s.truth->elevation(grid);
  const perception::ElevationMap& truth = *s.footfall_truth;
  const perception::CellRegion region = spec.candidates(grid);
  perception::FootfallConfig config;
  config.foot_diameter_m = spec.foot_diameter_m;
  config.sinkage_m = soilSinkage(sc);
  base::Stopwatch t;
  const std::vector<perception::FootfallScores> scores = perception::evaluateFootfalls(map, region, config, spec.methods);
  s.addTime("footfall", t.seconds());
  // The true surface scored by the same criteria: σ 0, every cell known.
  const std::vector<perception::FootfallScores> truths = perception::evaluateFootfalls(truth, region, config, spec.methods);
  std::filesystem::create_directories(s.out / "footfall");
  // How well the map sees R (every cell of R, not only the candidate centres): what the
  // uncertainty-aware method is for (docs/footfall.md, "In the run").
  {
    const perception::CellRegion all = perception::regionOfBox(grid, spec.x_m[0], spec.x_m[1], spec.y_m[0], spec.y_m[1]);
    long known = 0, shadow = 0, cells = long(all.rows) * all.cols;
    for (int r = all.row0; r < all.row0 + all.rows; ++r)
      for (int c = all.col0; c < all.col0 + all.cols; ++c) {
        known += map.stateAt(r, c) == perception::CellState::Known;
        shadow += map.stateAt(r, c) == perception::CellState::Shadow;
      }
    const auto share = [&](long n) { return cells ? double(n) / double(cells) : std::numeric_limits<double>::quiet_NaN(); };
    nlohmann::ordered_json& j = s.metrics["footfall_region"];
    j["cells"] = cells;
    j["known_fraction"] = jsonNumber(share(known));
    j["shadow_fraction"] = jsonNumber(share(shadow));
    j["unseen_fraction"] = jsonNumber(share(cells - known - shadow));
    char line[160];
    std::snprintf(line, sizeof line, "footfall  region R on %s: %ld cells, %.1f%% known, %.1f%% shadow, %.1f%% unseen",
                  map_name.c_str(), cells, 100 * share(known), 100 * share(shadow), 100 * share(cells - known - shadow));
    s.say(line);
  }
  s.metrics["footfall"] = nlohmann::ordered_json::array();
  s.choices.clear();
  for (std::size_t m = 0; m < spec.methods.size(); ++m) {
    const std::string name(perception::footfallMethodName(spec.methods[m]));
    const FootfallChoice choice = scoreChoice(name, scores[m], truths[m], grid);
    s.choices.push_back(choice);
    const nlohmann::ordered_json j = toJson(choice);
    writeJson(s.out / "footfall" / (name + ".json"), j);
    writeGeoTiff(s.out / "footfall" / (name + "_score.tiff"), scores[m].score, grid, s.geo);
    s.metrics["footfall"].push_back(j);
    char line[240], regret[32] = "-";
    if (std::isfinite(choice.regret)) std::snprintf(regret, sizeof regret, "%.3g", choice.regret);
    std::snprintf(line, sizeof line, "footfall  %-21s (%.2f, %.2f) m on %s, score %.4g, true percentile %s, regret %s", name.c_str(),
                  choice.x_m, choice.y_m, map_name.c_str(), choice.score,
                  std::isfinite(choice.truth_percentile) ? (std::to_string(int(std::lround(100 * choice.truth_percentile))) + "%").c_str()
                                                         : "-",
                  regret);
    s.say(line);
  }
  writePng(s.out / "footfall" / "choices.png",
           choicesPicture(map, spec, s.choices, sc.name + ": footfalls on " + map_name + " (region R in white)"));
}

}  // namespace

Stage footfall() {
  return {"footfall", [](const Scenario& sc) { return sc.footfall.has_value(); }, run};
}

}  // namespace ambler::eval::stages
