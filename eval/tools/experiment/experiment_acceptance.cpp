// The acceptance experiment (docs/experiments/acceptance.md): every matching method on three
// terrains (the demo's Mars-like ground, fractal ground with rocks and craters, the sample DEM)
// over 100 seeds each, the rover's initial error drawn from its odometry prior; per method its
// successes against the truth and the rover's own verdict: accepted, false accepts (accepted and
// not a success), false rejects (a success not accepted), and runs that ended further from the
// truth than they started without being flagged. Three sweeps, then a report that reads only
// their results.csv files.
#include <algorithm>
#include <cstdio>
#include <string>
#include <vector>

#include "eval/tools/experiment/experiment.hpp"
#include "eval/tools/experiment/experiment_internal.hpp"
#include "eval/scenario/io.hpp"

namespace ambler::eval {
namespace {

namespace fs = std::filesystem;
using namespace experiment_detail;

// The terrains: a sweep file each (acceptance_NAME_seeds.yaml) and its results' directory.
const std::vector<std::string> kTerrains{"mars", "fractal", "dem"};

std::string reg(std::size_t k, const char* key) { return "registration." + std::to_string(k) + "." + key; }

// One method's tally over a set of runs.
struct Tally {
  int runs = 0, success = 0, accepted = 0, false_accept = 0, false_reject = 0, worse_unflagged = 0;
  void add(const Tally& o) {
    runs += o.runs, success += o.success, accepted += o.accepted, false_accept += o.false_accept;
    false_reject += o.false_reject, worse_unflagged += o.worse_unflagged;
  }
};

Tally tally(const Results& r, std::size_t k) {
  Tally t;
  for (const auto& group : r.groups())
    for (const std::size_t run : group) {
      const bool ok = r.cell(run, reg(k, "success")) == "true";
      const bool acc = r.cell(run, reg(k, "accepted")) == "true";
      // Worse than it started: further in translation or in rotation than the believed pose.
      const bool worse = r.value(run, reg(k, "translation_error_m")) > r.value(run, reg(k, "initial_translation_error_m")) ||
                         r.value(run, reg(k, "rotation_error_deg")) > r.value(run, reg(k, "initial_rotation_error_deg"));
      ++t.runs;
      t.success += ok, t.accepted += acc, t.false_accept += acc && !ok, t.false_reject += ok && !acc;
      t.worse_unflagged += worse && acc;
    }
  return t;
}

// The methods, by their index in metrics.registration, named as in the first run.
std::vector<std::string> methods(const Results& r) {
  std::vector<std::string> out;
  const std::size_t first = r.groups().front().front();
  for (std::size_t k = 0; r.hasColumn(reg(k, "method")); ++k) out.push_back(r.cell(first, reg(k, "method")));
  return out;
}

std::string percent(int a, int b) { return b ? number(100.0 * a / b, 1) + " %" : "—"; }

std::string row(const std::string& terrain, const std::string& method, const Tally& t) {
  std::string line = "|";
  appendCell(line, terrain);
  appendCell(line, "`" + method + "`");
  appendCell(line, std::to_string(t.runs));
  appendCell(line, std::to_string(t.success) + " (" + percent(t.success, t.runs) + ")");
  appendCell(line, std::to_string(t.accepted));
  appendCell(line, std::to_string(t.false_accept));
  appendCell(line, std::to_string(t.false_reject) + " (" + percent(t.false_reject, t.success) + ")");
  appendCell(line, std::to_string(t.worse_unflagged));
  return line + "\n";
}

std::string report(const std::vector<Sweep>& sweeps, const ExperimentOptions& opt) {
  std::vector<Results> results;
  for (std::size_t i = 0; i < sweeps.size(); ++i)
    results.emplace_back(sweeps[i], opt.out / kTerrains[i] / "results.csv");
  const std::vector<std::string> names = methods(results.front());
  for (std::size_t i = 1; i < results.size(); ++i)
    if (methods(results[i]) != names)
      throw SweepError(sweeps[i].file.string() + ": the terrains' sweeps must list the same matching methods");
  std::string md =
      "The rover's verdict on each registration (docs/matching.md, \"Acceptance\") against the truth: "
      "success within the scenario's bounds; a **false accept** is accepted and not a success; a **false "
      "reject** a success not accepted (its share is of the successes); **worse, unflagged** ended further "
      "from the truth than the believed pose (in translation or rotation) and was accepted. " +
      std::to_string(sweeps.front().runs.size()) +
      " seeds a terrain (terrain, noise and the initial error drawn from the odometry prior within its 99 % "
      "region: `matching.draw_initial_error`).\n\n"
      "| terrain | method | runs | success | accepted | false accepts | false rejects | worse, unflagged |\n"
      "|---|---|---|---|---|---|---|---|\n";
  std::vector<Tally> total(names.size());
  for (std::size_t i = 0; i < results.size(); ++i)
    for (std::size_t k = 0; k < names.size(); ++k) {
      const Tally t = tally(results[i], k);
      total[k].add(t);
      md += row(kTerrains[i], names[k], t);
    }
  for (std::size_t k = 0; k < names.size(); ++k) md += row("**all**", names[k], total[k]);
  // The targets (docs/experiments/acceptance.md): of the two-stage methods, no false accept,
  // false rejects at most 5 % of the successes, none worse than it started unflagged.
  md += "\nTargets for every `features+X` method: no false accept, false rejects at most 5 % of the successes, "
        "none worse than it started unflagged.\n\n";
  for (std::size_t k = 0; k < names.size(); ++k) {
    if (names[k].rfind("features+", 0) != 0) continue;
    const Tally& t = total[k];
    const bool met = t.false_accept == 0 && 20 * t.false_reject <= t.success && t.worse_unflagged == 0;
    md += "- `" + names[k] + "`: " + (met ? "met" : "**not met**") + " (" + std::to_string(t.false_accept) +
          " false accepts, " + percent(t.false_reject, t.success) + " false rejects, " +
          std::to_string(t.worse_unflagged) + " worse unflagged)\n";
  }
  if (opt.quick) md += "\n(--quick: the first seed of each terrain only.)\n";
  return md;
}

std::vector<Sweep> acceptanceSweeps(const ExperimentOptions& opt) {
  std::vector<std::string> files;
  for (const std::string& t : kTerrains) files.push_back("acceptance_" + t + "_seeds.yaml");
  return experimentSweeps(opt, files, [](const Scenario& sc) { return sc.matching && !sc.matching->methods.empty(); },
                          "a matching section with methods");
}

}  // namespace

std::string runAcceptance(const ExperimentOptions& opt) {
  const std::vector<Sweep> sweeps = acceptanceSweeps(opt);
  return runSweepsAndReport(sweeps, kTerrains, opt, "acceptance", [&] { return writeTable(opt, report(sweeps, opt)); });
}

std::string reportAcceptance(const ExperimentOptions& opt) { return writeTable(opt, report(acceptanceSweeps(opt), opt)); }

}  // namespace ambler::eval
