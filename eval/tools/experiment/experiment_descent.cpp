// The descent experiment (docs/experiments/descent.md): iconicGradientDescent's four departures
// from the paper's descent as printed (IconicOptions::descent_*), measured on the acceptance
// experiment's pairs (acceptance_{mars,fractal,dem}_seeds.yaml, the first N seeds of each): the
// ladder from the literal descent to iconic_robust, one departure added at a time, and
// iconic_robust with each departure off alone, every variant from the same believed pose. The run
// writes results.csv (one row per pair and variant); the report reads only that file.
#include <algorithm>
#include <charconv>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <map>
#include <string>
#include <vector>

#include "eval/tools/experiment/experiment.hpp"
#include "eval/tools/experiment/experiment_internal.hpp"
#include "eval/scenario/io.hpp"
#include "eval/tools/progress.hpp"
#include "eval/run/run_state.hpp"
#include "eval/run/stages.hpp"
#include "eval/score/stats.hpp"
#include "eval/score/registration_score.hpp"
#include "eval/tools/shards.hpp"
#include "perception/iconic.hpp"
#include "perception/locus_mapper.hpp"
#include "perception/rigid_transform.hpp"

namespace ambler::eval {
namespace {

namespace fs = std::filesystem;
using namespace experiment_detail;

const std::vector<std::string> kTerrains{"mars", "fractal", "dem"};

// A variant: which of the four departures are on.
struct Variant {
  const char* name;
  bool normals, robust, gain, backtracking;
};
// The ladder, then iconic_robust less one departure. iconic_robust less the Cauchy loss is the
// ladder's fourth rung, so it is run once.
const std::vector<Variant> kVariants{
    {"literal", false, false, false, false},
    {"+backtracking", false, false, false, true},
    {"+diagonal gain", false, false, true, true},
    {"+map-1 normals (= iconic_robust - Cauchy)", true, false, true, true},
    {"iconic_robust (+Cauchy)", true, true, true, true},
    {"iconic_robust - backtracking", true, true, true, false},
    {"iconic_robust - diagonal gain", true, true, false, true},
    {"iconic_robust - map-1 normals", false, true, true, true},
};

const std::vector<std::string> kHeader{"terrain",
                                       "seed",
                                       "variant",
                                       "reference_normals",
                                       "robust_loss",
                                       "centroid_gain",
                                       "backtracking",
                                       "initial_translation_error_m",
                                       "initial_rotation_error_deg",
                                       "translation_error_m",
                                       "rotation_error_deg",
                                       "success",
                                       "iterations",
                                       "converged",
                                       "overlap",
                                       "time_s"};

const char* flag(bool b) { return b ? "true" : "false"; }

// The departures a variant has on, by their letters (N, C, G, B), or "none".
std::string departures(const Variant& v) {
  const std::string on = std::string(v.normals ? "N" : "") + (v.robust ? "C" : "") + (v.gain ? "G" : "") +
                         (v.backtracking ? "B" : "");
  return on.empty() ? "none" : on;
}

// The sweeps, each cut to its first `seeds` runs.
std::vector<Sweep> descentSweeps(const DescentOptions& opt) {
  std::vector<Sweep> sweeps;
  for (const std::string& t : kTerrains) {
    Sweep s = experimentSweep(opt.experiment.sweeps / ("acceptance_" + t + "_seeds.yaml"), opt.experiment.quick);
    requireAxes(s, {"seed"});
    const std::size_t n = opt.experiment.quick ? 1 : std::size_t(opt.seeds);
    if (n > s.runs.size())
      throw SweepError("--seeds: " + std::to_string(n) + " is more than the " + std::to_string(s.runs.size()) +
                       " seeds of " + s.file.string());
    s.runs.resize(n);
    for (const Scenario& sc : s.runs) {
      if (!sc.matching || !sc.map)
        throw SweepError(s.file.string() + ": the experiment needs the map and matching sections in every run");
      if (sc.traverse) throw SweepError(s.file.string() + ": traverse: not yet supported by the descent experiment");
    }
    sweeps.push_back(std::move(s));
  }
  return sweeps;
}

// One pair (the scenario's first): its views scanned and mapped as a run does (into `dir`), then
// every variant from the believed pose the match stage gives it. One CSV row per variant.
std::vector<std::vector<std::string>> registerPair(const Scenario& scenario, const std::string& terrain,
                                                   const fs::path& dir, bool timing, std::string& detail) {
  Scenario sc = scenario;  // no Cartesian baseline, no composite: the pair alone
  sc.map->baseline = Baseline::None;
  sc.merge.reset();
  RunState s{sc, dir, false};
  for (const Stage& stage : {stages::world(), stages::scan(), stages::map()}) stage.run(s);
  const perception::RegistrationConfig config = registrationConfig(sc);
  const MatchingSpec& spec = *sc.matching;
  const auto [i, j] = spec.pairs.front();
  const ViewState& vi = s.views[std::size_t(i)];
  const ViewState& vj = s.views[std::size_t(j)];
  // Map I as registration maps it (eval/run/pair_registration.cpp), image J at the believed pose.
  const perception::ScanMap& view_i = *vi.locus;
  const perception::ScanMap& view_j = *vj.locus;
  const perception::ElevationMap map_i = perception::referenceView(view_i, view_i.map.grid(), config, false).map;
  const Eigen::Isometry3d T_IJ = vi.T_WS.inverse() * vj.T_WS;  // the truth, for scoring only
  const Eigen::Isometry3d T_0 = spec.initialEstimate(T_IJ, sc.seed, i, j);
  const Eigen::Isometry3d believed_WS = vi.T_WS * T_0;
  perception::RangeImage image = view_j.image;
  image.T_WS = believed_WS;
  const perception::LocusMapper mapper(image, view_j.sensor, view_j.edges ? &*view_j.edges : nullptr, config.locus);
  const perception::PoseError start = perception::poseError(T_IJ, T_0);
  detail = terrain + " seed " + std::to_string(sc.seed) + " (start " + number(100 * start.translation_m) + " cm " +
           number(start.rotation_deg) + " deg):";
  std::vector<std::vector<std::string>> rows;
  for (const Variant& v : kVariants) {
    perception::IconicOptions options = config.iconic;
    options.descent_reference_normals = v.normals;
    options.descent_robust_loss = v.robust;
    options.descent_centroid_gain = v.gain;
    options.descent_backtracking = v.backtracking;
    const base::Stopwatch watch;
    const perception::IconicResult r =
        perception::iconicGradientDescent(map_i, mapper, perception::PoseVector::Zero(), options);
    const double seconds = watch.seconds();
    const Eigen::Isometry3d T_est = vi.T_WS.inverse() * perception::poseFromVector(r.nu).inverse() * believed_WS;
    const perception::PoseError err = perception::poseError(T_IJ, T_est);
    const bool ok = isSuccess(err, spec);
    rows.push_back({terrain, std::to_string(sc.seed), v.name, flag(v.normals), flag(v.robust), flag(v.gain),
                    flag(v.backtracking), csvNumber(start.translation_m), csvNumber(start.rotation_deg),
                    csvNumber(err.translation_m), csvNumber(err.rotation_deg), flag(ok),
                    std::to_string(r.iterations), flag(r.converged), std::to_string(r.overlap),
                    timing ? csvNumber(seconds) : ""});
    detail.append(" ").append(departures(v)).append(ok ? ":ok" : ":FAILED");
  }
  return rows;
}

// The q-quantile of `v`, linear between order statistics (R's type 7); NaN when empty.
double quantile(std::vector<double> v, double q) {
  if (v.empty()) return kNaN;
  std::sort(v.begin(), v.end());
  const double h = q * double(v.size() - 1);
  const std::size_t lo = std::size_t(std::floor(h)), hi = std::min(lo + 1, v.size() - 1);
  return v[lo] + (h - double(lo)) * (v[hi] - v[lo]);
}

double cellValue(const std::string& text) {
  double x = kNaN;
  if (text.empty() || std::from_chars(text.data(), text.data() + text.size(), x).ec != std::errc()) return kNaN;
  return x;
}

// One variant's figures over a set of rows.
struct Figures {
  int runs = 0, success = 0;
  std::vector<double> t_err, r_err, iterations, seconds;
};

std::string row(const std::string& variant, const Figures& f) {
  std::string line = "|";
  appendCell(line, variant);
  appendCell(line, std::to_string(f.success) + "/" + std::to_string(f.runs) +
                       (f.runs ? " (" + number(100.0 * f.success / f.runs, 0) + " %)" : ""));
  appendCell(line, number(1000 * median(f.t_err)));
  appendCell(line, number(1000 * quantile(f.t_err, 0.95)));
  appendCell(line, number(median(f.r_err)));
  appendCell(line, number(quantile(f.r_err, 0.95)));
  appendCell(line, number(median(f.iterations), 0));
  appendCell(line, f.seconds.empty() ? "—" : number(1000 * median(f.seconds)));
  return line + "\n";
}

std::string report(const DescentOptions& opt) {
  const fs::path csv = opt.experiment.out / "results.csv";
  const auto records = parseResultsCsv(readFile(csv));
  if (!records || records->empty() || records->front() != kHeader)
    throw SweepError(csv.string() + ": not a results.csv of `ambler experiment descent` (its header differs)");
  std::map<std::string, std::size_t> variant_index;
  for (std::size_t v = 0; v < kVariants.size(); ++v) variant_index[kVariants[v].name] = v;
  // [terrain (the last: all)][variant]
  std::vector<std::vector<Figures>> figures(kTerrains.size() + 1, std::vector<Figures>(kVariants.size()));
  std::vector<std::map<std::string, int>> seeds(kTerrains.size());
  bool timed = false;
  for (std::size_t k = 1; k < records->size(); ++k) {
    const auto& r = (*records)[k];
    const std::string where = csv.string() + ": row " + std::to_string(k + 1);
    if (r.size() != kHeader.size()) throw SweepError(where + ": expected " + std::to_string(kHeader.size()) + " cells");
    const auto t = std::find(kTerrains.begin(), kTerrains.end(), r[0]);
    const auto v = variant_index.find(r[2]);
    if (t == kTerrains.end()) throw SweepError(where + ": terrain " + r[0] + " is not one of mars, fractal, dem");
    if (v == variant_index.end())
      throw SweepError(where + ": variant " + yamlQuoted(r[2]) + " is not one of the experiment's");
    const std::size_t ti = std::size_t(t - kTerrains.begin());
    ++seeds[ti][r[1]];
    for (const std::size_t g : {ti, kTerrains.size()}) {
      Figures& f = figures[g][v->second];
      ++f.runs;
      f.success += r[11] == "true";
      for (const auto& [column, out] : {std::pair{9, &f.t_err}, {10, &f.r_err}, {12, &f.iterations}, {15, &f.seconds}})
        if (const double x = cellValue(r[std::size_t(column)]); std::isfinite(x)) out->push_back(x);
    }
    timed = timed || !r[15].empty();
  }
  std::string md =
      "iconicGradientDescent (`iconic_robust`) with its departures from the paper's descent turned on one at a time "
      "(the ladder) and off one at a time (iconic_robust − X), every variant from the same believed pose: the "
      "acceptance experiment's pairs (its terrains and seeds; the initial error drawn from the odometry prior). "
      "Success: within the scenario's bounds (matching.success: 5 cm and 0.5° here). Errors of every run, "
      "successes or not; p95: the 95th percentile (linear between order statistics). Time: the descent's wall "
      "time, median" +
      std::string(timed ? " (measured with --timing: it differs from run to run and machine to machine)"
                        : " (not measured: run with --timing)") +
      ".\n\nDepartures: **N** map 1's normals in the Jacobian, **C** the annealed Cauchy loss, **G** the diagonal "
      "gain about map 1's centroid, **B** backtracking on k over the common lines; without B one fixed gain "
      "k = 0.5/λ_max and the paper's stop rules (at most 2 000 steps).\n";
  std::vector<std::size_t> order{kTerrains.size()};  // all terrains, then each
  for (std::size_t t = 0; t < kTerrains.size(); ++t) order.push_back(t);
  for (const std::size_t g : order) {
    int pairs = 0;
    for (std::size_t t = 0; t < kTerrains.size(); ++t)
      if (g == t || g == kTerrains.size()) pairs += int(seeds[t].size());
    md += "\n### " + (g == kTerrains.size() ? std::string("all terrains") : kTerrains[g]) + " (" +
          std::to_string(pairs) + " pairs)\n\n"
          "| variant | success | median translation error (mm) | p95 (mm) | median rotation error (°) | p95 (°) | "
          "median iterations | median time (ms) |\n|---|---:|---:|---:|---:|---:|---:|---:|\n";
    for (std::size_t v = 0; v < kVariants.size(); ++v) {
      std::string label = "`";
      label.append(kVariants[v].name).append("` (").append(departures(kVariants[v])).append(")");
      md += row(label, figures[g][v]);
    }
  }
  return md;
}

std::string writeReport(const DescentOptions& opt) {
  const std::string md = report(opt);
  writeText(opt.experiment.out / "table.md", md);
  return md;
}

}  // namespace

std::string runDescent(const DescentOptions& opt) {
  if (opt.seeds < 1) throw SweepError("--seeds: expected an integer >= 1, got " + std::to_string(opt.seeds));
  const auto start = std::chrono::steady_clock::now();
  const std::vector<Sweep> sweeps = descentSweeps(opt);
  std::size_t pairs = 0;
  for (const Sweep& s : sweeps) pairs += s.runs.size();
  if (opt.experiment.progress)
    std::fprintf(stderr, "ambler: experiment descent: %zu pairs x %zu variants -> %s\n", pairs, kVariants.size(),
                 opt.experiment.out.string().c_str());
  Progress progress("descent", pairs, 0, Progress::modeFor(opt.experiment.progress));
  progress.setLinePrefix("descent ");
  const fs::path scratch = opt.experiment.out / "pair.tmp";
  std::string text = csvLine(kHeader);
  for (std::size_t t = 0; t < sweeps.size(); ++t)
    for (const Scenario& sc : sweeps[t].runs) {
      std::string detail;
      // The pair's scans and maps are not kept (`ambler run` on the scenario and seed makes them again).
      for (const auto& r : registerPair(sc, kTerrains[t], scratch, opt.timing, detail)) text += csvLine(r);
      fs::remove_all(scratch);
      progress.step(detail);
    }
  progress.finish();
  writeText(opt.experiment.out / "results.csv", text);
  const std::string md = writeReport(opt);
  if (opt.experiment.progress) {
    const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    std::fprintf(stderr, "ambler: experiment descent: %zu pairs in %.1f s -> %s\n", pairs, s,
                 opt.experiment.out.string().c_str());
  }
  return md;
}

std::string reportDescent(const DescentOptions& opt) { return writeReport(opt); }

}  // namespace ambler::eval
