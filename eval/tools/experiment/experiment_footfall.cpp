// The footfall study (docs/experiments/footfall.md): the sandbox's footfalls stepped on by the leg
// over many trials (footfall_trials.yaml: 200 a soil) and on poorly seen ground
// (footfall_poorly_seen.yaml: half of R unseen). Per soil and method: successes (tilt ≤ 5°, slip
// ≤ 1 cm, settled) with a Wilson 95 % interval, the tilt and slip, the true percentile and the
// regret, the same leg on the truth's best candidate, and where each miss comes from (the map,
// the method, the leg, or ground where nothing holds); tilt and slip histograms. Two sweeps, then
// a report that reads only their results.csv files.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <optional>
#include <string>
#include <vector>

#include "eval/scenario/io.hpp"
#include "eval/score/footfall_score.hpp"
#include "eval/score/stats.hpp"
#include "eval/tools/experiment/experiment.hpp"
#include "eval/tools/experiment/experiment_internal.hpp"

namespace ambler::eval {
namespace {

namespace fs = std::filesystem;
using namespace experiment_detail;

// The goal of a step (docs/experiments/footfall.md).
constexpr double kTiltDeg = 5.0, kSlipM = 0.01;  // as missCause's

// The two sweeps: their file stems, which are also their results' directories.
const std::vector<std::string> kSweeps{"footfall_trials", "footfall_poorly_seen"};
const std::vector<std::string> kSoils{"sand", "rock"};

std::string ff(std::size_t k, const std::string& key) { return "footfall." + std::to_string(k) + "." + key; }

}  // namespace

namespace {

bool success(const Results& r, std::size_t run, const std::string& prefix) {
  return r.cell(run, prefix + "settled") == "true" && r.value(run, prefix + "tilt_deg") <= kTiltDeg &&
         r.value(run, prefix + "slip_m") <= kSlipM;
}

// One soil's and method's trials.
struct Tally {
  int trials = 0, successes = 0, best_trials = 0, best_successes = 0;
  int causes[5] = {0, 0, 0, 0, 0};  // by MissCause
  int soil = 0;  // of the Leg misses on sand, those whose spot held on rigid ground (the same trial on rock)
  std::vector<double> tilt, slip, percentile, regret;
};

// The same trial on the other soil: the run whose axis cells are this run's but for leg.soil
// (none when the sweep has no soil axis).
std::optional<std::size_t> otherSoil(const Results& r, std::size_t run) {
  const auto key = [&](std::size_t k) {
    std::string text;
    for (const SweepAxis& a : r.sweep().axes)
      if (a.key != "leg.soil") text += r.cell(k, a.key) + "\x1f";
    return text;
  };
  const std::string mine = key(run), soil = r.cell(run, "leg.soil");
  if (soil.empty()) return std::nullopt;
  for (const auto& group : r.groups())
    for (const std::size_t other : group)
      if (other != run && r.cell(other, "leg.soil") != soil && key(other) == mine) return other;
  return std::nullopt;
}

Tally tally(const Results& r, std::size_t k, const std::string& soil) {
  Tally t;
  for (const auto& group : r.groups())
    for (const std::size_t run : group) {
      const Scenario& sc = r.scenario(run);
      if (!sc.leg || (sc.leg->soil == Soil::Sand ? "sand" : "rock") != soil) continue;
      if (!std::isfinite(r.value(run, ff(k, "x_m")))) continue;  // no candidate: no step
      ++t.trials;
      const bool ok = success(r, run, ff(k, "leg."));
      t.successes += ok;
      const double tilt = r.value(run, ff(k, "leg.tilt_deg")), slip = r.value(run, ff(k, "leg.slip_m"));
      t.tilt.push_back(tilt), t.slip.push_back(slip);
      if (const double p = r.value(run, ff(k, "truth_percentile")); std::isfinite(p)) t.percentile.push_back(p);
      if (const double g = r.value(run, ff(k, "regret")); std::isfinite(g)) t.regret.push_back(g);
      if (std::isfinite(r.value(run, ff(k, "truth_best.leg.tilt_deg")))) {
        ++t.best_trials;
        t.best_successes += success(r, run, ff(k, "truth_best.leg."));
      }
      const MissCause c = missCause(tilt, slip, r.cell(run, ff(k, "leg.settled")) == "true",
                                    r.value(run, ff(k, "leg.predicted_tilt_deg")),
                                    r.value(run, ff(k, "truth_best.leg.predicted_tilt_deg")),
                                    r.value(run, "footfall_region.min_predicted_tilt_deg"));
      ++t.causes[int(c)];
      if (c == MissCause::Leg && soil == "sand")
        if (const auto rigid = otherSoil(r, run)) t.soil += success(r, *rigid, ff(k, "leg."));
    }
  return t;
}

std::vector<std::string> methods(const Results& r) {
  std::vector<std::string> out;
  const std::size_t first = r.groups().front().front();
  for (std::size_t k = 0; r.hasColumn(ff(k, "method")); ++k) out.push_back(r.cell(first, ff(k, "method")));
  return out;
}

std::string rate(int k, int n) {
  if (!n) return "—";
  const Interval ci = wilsonInterval(k, n);
  return std::to_string(k) + "/" + std::to_string(n) + " = " + number(100.0 * k / n, 1) + " % (" +
         number(100 * ci.lo, 1) + "–" + number(100 * ci.hi, 1) + " %)";
}

std::string table(const std::vector<Tally>& tallies, const std::string& soil, const std::vector<std::string>& names) {
  std::string md =
      "| method | tilt ≤ 5°, slip ≤ 1 cm (95 % CI) | tilt median / p95 / max, ° | slip median / max, mm | "
      "true percentile median / p90 | regret median | the truth's best, stepped on | misses: map / method / leg / "
      "ground |\n|---|---|---|---|---|---|---|---|\n";
  for (std::size_t k = 0; k < names.size(); ++k) {
    const Tally& t = tallies[k];
    std::string line = "|";
    appendCell(line, "`" + names[k] + "`");
    appendCell(line, rate(t.successes, t.trials));
    appendCell(line, number(median(t.tilt), 2) + " / " + number(quantile(t.tilt, 0.95), 2) + " / " +
                         number(t.tilt.empty() ? kNaN : *std::max_element(t.tilt.begin(), t.tilt.end()), 2));
    appendCell(line, number(1000 * median(t.slip), 1) + " / " +
                         number(t.slip.empty() ? kNaN : 1000 * *std::max_element(t.slip.begin(), t.slip.end()), 1));
    appendCell(line, number(100 * median(t.percentile), 0) + " % / " + number(100 * quantile(t.percentile, 0.9), 0) + " %");
    appendCell(line, format("%.3g", median(t.regret)));
    appendCell(line, rate(t.best_successes, t.best_trials));
    appendCell(line, std::to_string(t.causes[int(MissCause::Map)]) + " / " + std::to_string(t.causes[int(MissCause::Method)]) +
                         " / " + std::to_string(t.causes[int(MissCause::Leg)]) +
                         (soil == "sand" ? " (" + std::to_string(t.soil) + ")" : std::string()) + " / " +
                         std::to_string(t.causes[int(MissCause::Ground)]));
    md += line + "\n";
  }
  return md;
}

// Cumulative histograms of tilt or slip per method: the share of steps at or below each value (a
// staircase through the sorted values), with the goal's bound; where a method's line crosses the
// bound is its share of steps within it.
cv::Mat histogram(const std::vector<Tally>& tallies, const std::vector<std::string>& names, bool tilt,
                  const std::string& title) {
  PlotSpec spec;
  spec.title = title;
  spec.x_label = tilt ? "foot tilt [deg]" : "slip [mm]";
  spec.y_label = "share of steps at or below";
  for (std::size_t k = 0; k < names.size(); ++k) {
    const Tally& t = tallies[k];
    std::vector<double> v = tilt ? t.tilt : t.slip;
    if (v.empty()) continue;
    if (!tilt)
      for (double& x : v) x *= 1000;
    std::sort(v.begin(), v.end());
    Series s;
    s.label = names[k];
    s.x.push_back(0), s.y.push_back(0);
    for (std::size_t i = 0; i < v.size(); ++i) {
      s.x.push_back(v[i]), s.y.push_back(double(i) / double(v.size()));
      s.x.push_back(v[i]), s.y.push_back(double(i + 1) / double(v.size()));
    }
    spec.series.push_back(std::move(s));
  }
  Series goal;
  goal.label = tilt ? "goal: 5 deg" : "goal: 10 mm";
  goal.colour = cv::Scalar(0, 0, 0);
  const double g = tilt ? kTiltDeg : 1000 * kSlipM;
  goal.x = {g, g}, goal.y = {0, 1};
  spec.series.push_back(goal);
  return renderPlot(spec, kPanelWidth, kPanelHeight);
}

std::string report(const std::vector<Sweep>& sweeps, const ExperimentOptions& opt) {
  std::string md =
      "Footfalls chosen by every method on the rover's map and stepped on by the leg (docs/leg.md). A step "
      "succeeds when the leg settles with the foot tilted at most 5° and slipped at most 1 cm; the interval is "
      "Wilson's 95 % score interval. True percentile: the share of R's candidates the truth scores better by the "
      "method's own criterion; regret: the true score minus the truth's best in R, in the method's units "
      "(docs/footfall.md). The truth's best: the same leg on the candidate the method would choose on the true "
      "surface. Misses (docs/experiments/footfall.md, \"Where the misses come from\"): **ground**, no candidate of R "
      "rests a rigid disk within 5° on the truth; **leg**, the rigid disk rests within 5° at the chosen spot but "
      "the leg did not hold; **map**, the chosen spot tilts a rigid disk beyond 5° but the method's choice on the "
      "true surface would not; **method**, both would. In brackets, on sand: of the leg's misses, those whose spot held "
      "when the same trial was stepped on rigid ground (the sand's sinkage, not the leg's dynamics).\n";
  for (std::size_t i = 0; i < sweeps.size(); ++i) {
    const Results r(sweeps[i], opt.out / kSweeps[i] / "results.csv");
    const std::vector<std::string> names = methods(r);
    md += "\n## " + kSweeps[i] + " (" + std::to_string(sweeps[i].runs.size()) + " runs)\n";
    // How well R is seen.
    std::vector<double> unknown;
    for (const auto& group : r.groups())
      for (const std::size_t run : group) unknown.push_back(1 - r.value(run, "footfall_region.known_fraction"));
    md += "\nR unknown or in shadow on the map: median " + number(100 * median(unknown), 1) + " %, from " +
          number(100 * quantile(unknown, 0), 1) + " to " + number(100 * quantile(unknown, 1), 1) + " %.\n";
    for (const std::string& soil : kSoils) {
      std::vector<Tally> tallies;  // per method, read once for the table and both histograms
      for (std::size_t k = 0; k < names.size(); ++k) tallies.push_back(tally(r, k, soil));
      md += "\n**" + soil + "**\n\n" + table(tallies, soil, names);
      const std::string stem = kSweeps[i] + "_" + soil;
      writeFigure(opt.out / (stem + "_tilt.png"), histogram(tallies, names, true, kSweeps[i] + ", " + soil + ": foot tilt"));
      writeFigure(opt.out / (stem + "_slip.png"), histogram(tallies, names, false, kSweeps[i] + ", " + soil + ": slip"));
    }
  }
  if (opt.quick) md += "\n(--quick: the first and last value of every axis and the first seed only.)\n";
  return md;
}

std::vector<Sweep> footfallSweeps(const ExperimentOptions& opt) {
  std::vector<std::string> files;
  for (const std::string& name : kSweeps) files.push_back(name + ".yaml");
  return experimentSweeps(opt, files, [](const Scenario& sc) { return sc.footfall && sc.leg; }, "footfall and leg sections");
}

}  // namespace

std::string runFootfall(const ExperimentOptions& opt) {
  const std::vector<Sweep> sweeps = footfallSweeps(opt);
  return runSweepsAndReport(sweeps, kSweeps, opt, "footfall", [&] { return writeTable(opt, report(sweeps, opt)); });
}

std::string reportFootfall(const ExperimentOptions& opt) { return writeTable(opt, report(footfallSweeps(opt), opt)); }

}  // namespace ambler::eval
