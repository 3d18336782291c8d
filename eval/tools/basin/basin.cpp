// `ambler basin` (eval/tools/basin/basin.hpp; docs/basin.md). The pair is built once per process (world,
// scans, view I's map: the ordinary stages, written to out/pair/); the draws are then registered
// in any order and on any number of threads, and their rows assembled in one canonical order, so
// basin.csv has the same bytes however it was produced.
#include "eval/tools/basin/basin.hpp"

#include <algorithm>
#include <atomic>
#include <charconv>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <mutex>
#include <numbers>
#include <optional>
#include <thread>
#include <tuple>

#include <nlohmann/json.hpp>

#include "base/random.hpp"
#include "base/read_file.hpp"
#include "base/text.hpp"
#include "base/digest.hpp"
#include "eval/scenario/io.hpp"
#include "eval/pictures/match_figures.hpp"
#include "eval/run/pair_registration.hpp"
#include "eval/run/stages.hpp"
#include "eval/score/stats.hpp"
#include "eval/score/registration_score.hpp"
#include "eval/tools/jobs.hpp"
#include "eval/tools/sweep/sweep.hpp"

namespace ambler::eval {
namespace {

namespace fs = std::filesystem;

constexpr std::uint64_t kBasinStream = 7001;  // the trials' directions: independent of terrain and noise
const std::vector<std::string> kHeader{"method", "translation_m", "rotation_deg", "trial", "translation_error_m",
                                       "rotation_error_deg", "success", "iterations", "time_s",
                                       "accepted", "false_accept"};


std::size_t drawCount(const BasinGrid& g) {
  return g.translation_m.size() * g.rotation_deg.size() * std::size_t(g.trials);
}

struct Draw {
  std::size_t t = 0, r = 0;  // indices into the grid's axes
  int trial = 0;
};
// Draw u of the grid: translation slowest, then rotation, then trial.
Draw draw(const BasinGrid& g, std::size_t u) {
  const std::size_t trials = std::size_t(g.trials), per_t = g.rotation_deg.size() * trials;
  return {u / per_t, (u % per_t) / trials, int(u % trials)};
}

// The methods' names: the scenario's, then the user's own.
std::vector<std::string> methodNames(const Scenario& sc, const BasinOptions& opt) {
  std::vector<std::string> names;
  for (const MatchMethod m : sc.matching->methods) names.emplace_back(matchMethodName(m));
  for (const CustomMethod& m : opt.custom) names.push_back(m.name);
  return names;
}

void validate(const Scenario& sc, const BasinOptions& opt) {
  const std::string file = sc.file.empty() ? sc.name : sc.file.string();
  try {
    checkCustomMethods(opt.custom, "basin");
  } catch (const std::invalid_argument& e) {
    throw BasinError(e.what());
  }
  if (sc.traverse) throw BasinError(file + ": traverse: not yet supported by ambler basin (it registers one pair of views)");
  if (!sc.matching) throw BasinError(file + ": matching: a basin registers the scenario's pair by its matching methods; "
                                            "the scenario has no matching section");
  if (!sc.map) throw BasinError(file + ": map: a basin needs the map section (view I's map is the reference)");
  const BasinGrid& g = opt.grid;
  if (g.translation_m.empty()) throw BasinError("--translation-m: expected at least one value");
  if (g.rotation_deg.empty()) throw BasinError("--rotation-deg: expected at least one value");
  if (g.trials < 1) throw BasinError("--trials: expected an integer >= 1, got " + std::to_string(g.trials));
  if (opt.jobs < 1) throw BasinError("--jobs: expected an integer >= 1, got " + std::to_string(opt.jobs));
  if (opt.shard && std::size_t(opt.shard->count) > drawCount(g))
    throw BasinError("--shard: " + std::to_string(opt.shard->index) + "/" + std::to_string(opt.shard->count) +
                     ": the basin has " + std::to_string(drawCount(g)) + " draws, so at most that many shards");
}

// The rows of one draw: one per method, in the scenario's order.
using Rows = std::vector<std::vector<std::string>>;

// A draw's rows as the journal's payload (one line of JSON) and back.
std::string rowsPayload(const Rows& rows) { return nlohmann::json(rows).dump(); }

Rows rowsFromPayload(const std::string& payload, const fs::path& journal, std::size_t u, std::size_t methods) {
  Rows rows;
  try {
    rows = nlohmann::json::parse(payload).get<Rows>();
  } catch (const std::exception& e) {
    throw JournalError(journal.string() + ": draw " + std::to_string(u) + ": its recorded rows are not readable (" +
                       e.what() + "); run without --resume to start over");
  }
  if (rows.size() != methods || std::any_of(rows.begin(), rows.end(), [](const auto& r) { return r.size() != kHeader.size(); }))
    throw JournalError(journal.string() + ": draw " + std::to_string(u) + ": recorded " + std::to_string(rows.size()) +
                       " rows, the scenario has " + std::to_string(methods) +
                       " methods; run without --resume to start over");
  return rows;
}

// What the journal's records depend on: the scenario (its methods, terrain, sensor, seed), the
// grid, the measured times and the split.
std::string journalIdentity(const Scenario& sc, const BasinOptions& opt) {
  std::string text = "basin\ntiming=" + std::string(opt.timing ? "1" : "0") + "\nshard=" +
                     (opt.shard ? std::to_string(opt.shard->index) + "/" + std::to_string(opt.shard->count) : "") +
                     "\ntranslation_m=";
  for (const double t : opt.grid.translation_m) text += csvNumber(t) + ",";
  text += "\nrotation_deg=";
  for (const double r : opt.grid.rotation_deg) text += csvNumber(r) + ",";
  text += "\ntrials=" + std::to_string(opt.grid.trials) + "\nvertical=" + (opt.grid.vertical_axis ? "1" : "0") +
          "\ncustom=";
  for (const CustomMethod& m : opt.custom) text += m.name + ",";
  text += "\n" + resolvedYaml(sc);
  return base::digest(text);
}

// The scenario as the basin builds its pair: no Cartesian baseline, no composite.
Scenario pairScenario(const Scenario& sc) {
  Scenario p = sc;
  p.map->baseline = Baseline::None;
  p.merge.reset();
  return p;
}

// Success counts and median final translation error per cell and method, from basin.csv's
// records (header first), for the figures.
struct Tally {
  std::vector<std::vector<int>> ok, n;               // [method][cell]
  std::vector<std::vector<int>> accepted, false_accept;  // [method][cell]: the rover's verdict
  std::vector<std::vector<std::vector<double>>> err;  // [method][cell] translation errors
  std::vector<std::vector<double>> ok_err;            // [method] translation errors of the successes
};

// For each rotation, the largest translation up to which every cell reaches `level` (NaN: not
// even the first); what basin_boundary.png draws.
std::vector<double> boundary(const BasinGrid& g, const std::vector<double>& rate, double level) {
  std::vector<double> out;
  for (std::size_t j = 0; j < g.rotation_deg.size(); ++j) {
    double reached = std::numeric_limits<double>::quiet_NaN();
    for (std::size_t i = 0; i < g.translation_m.size() && rate[i * g.rotation_deg.size() + j] >= level; ++i)
      reached = g.translation_m[i];
    out.push_back(reached);
  }
  return out;
}

// basin.md: the grid, the criterion, and per method its successes and its 95 % boundary.
std::string summary(const Scenario& sc, const BasinOptions& opt, const Tally& t,
                    const std::vector<BasinBoundary>& methods) {
  const BasinGrid& g = opt.grid;
  const MatchingSpec& spec = *sc.matching;
  const auto [i, j] = spec.pairs.front();
  std::string md = "<!-- written by `ambler basin` from basin.csv -->\n\n";
  md += "Scenario `" + sc.name + "`, views " + std::to_string(i) + "-" + std::to_string(j) + "; " +
        std::to_string(g.translation_m.size()) + " initial translations x " + std::to_string(g.rotation_deg.size()) +
        " rotations (" + (g.vertical_axis ? "about the vertical" : "about a random axis") + ") x " +
        std::to_string(g.trials) + " trials per cell, every method on the same draws. A trial succeeds within " +
        csvNumber(100 * spec.success_translation_m) + " cm and " + csvNumber(spec.success_rotation_deg) +
        "°.\n\n";
  md += "The 95 % boundary: for each initial rotation, the largest initial translation up to which every "
        "cell succeeds in at least 95 % of its trials (— where even the first cell does not).\n\n";
  md += "Accepted: the rover's verdict (docs/matching.md, \"Acceptance\"), gated by the declared prior; a false "
        "accept is accepted and not a success, a false reject a success not accepted.\n\n";
  md += "| method | successes | accepted | false accepts | false rejects | median translation error of the successes |";
  for (const double r : g.rotation_deg) md += " " + csvNumber(r) + "° |";
  md += "\n|---|---:|---:|---:|---:|---:|";
  for (std::size_t k = 0; k < g.rotation_deg.size(); ++k) md += "---:|";
  md += "\n";
  for (std::size_t m = 0; m < methods.size(); ++m) {
    int ok = 0, n = 0;
    for (std::size_t c = 0; c < t.ok[m].size(); ++c) ok += t.ok[m][c], n += t.n[m][c];
    char buf[64];
    std::snprintf(buf, sizeof buf, "%d/%d (%.0f %%)", ok, n, n ? 100.0 * ok / n : 0.0);
    int acc = 0, fa = 0;
    for (std::size_t c = 0; c < t.ok[m].size(); ++c) acc += t.accepted[m][c], fa += t.false_accept[m][c];
    md += "| " + methods[m].label + " | " + buf + " | " + std::to_string(acc) + " | " + std::to_string(fa) + " | " +
          std::to_string(ok - (acc - fa)) + " | ";
    if (t.ok_err[m].empty()) {
      md += "— |";
    } else {
      std::snprintf(buf, sizeof buf, "%.1f mm |", 1000 * median(t.ok_err[m]));
      md += buf;
    }
    for (const double b : boundary(g, methods[m].rate, 0.95)) {
      if (std::isfinite(b)) {
        md += ' ';
        md += csvNumber(b);
        md += " m |";
      } else {
        md += " — |";
      }
    }
    md += "\n";
  }
  return md;
}

void writeFigures(const Scenario& sc, const BasinOptions& opt, const std::vector<std::vector<std::string>>& records) {
  const BasinGrid& g = opt.grid;
  const MatchingSpec& spec = *sc.matching;
  const std::size_t cells = g.translation_m.size() * g.rotation_deg.size();
  const std::vector<std::string> names = methodNames(sc, opt);
  std::map<std::string, std::size_t> method_index;
  for (std::size_t m = 0; m < names.size(); ++m) method_index[names[m]] = m;
  Tally t;
  t.ok.assign(names.size(), std::vector<int>(cells, 0));
  t.n = t.ok;
  t.accepted = t.ok;
  t.false_accept = t.ok;
  t.err.assign(names.size(), std::vector<std::vector<double>>(cells));
  t.ok_err.assign(names.size(), {});
  std::map<std::string, std::size_t> t_index, r_index;
  for (std::size_t i = 0; i < g.translation_m.size(); ++i) t_index[csvNumber(g.translation_m[i])] = i;
  for (std::size_t i = 0; i < g.rotation_deg.size(); ++i) r_index[csvNumber(g.rotation_deg[i])] = i;
  for (std::size_t k = 1; k < records.size(); ++k) {
    const auto& row = records[k];
    const std::size_t m = method_index.at(row[0]);
    const std::size_t cell = t_index.at(row[1]) * g.rotation_deg.size() + r_index.at(row[2]);
    ++t.n[m][cell];
    if (row[6] == "true") ++t.ok[m][cell];
    if (row[9] == "true") ++t.accepted[m][cell];
    if (row[10] == "true") ++t.false_accept[m][cell];
    double e = 0;
    if (std::from_chars(row[4].data(), row[4].data() + row[4].size(), e).ec == std::errc()) {
      t.err[m][cell].push_back(e);
      if (row[6] == "true") t.ok_err[m].push_back(e);
    }
  }
  const std::string criterion = "success: within " + csvNumber(100 * spec.success_translation_m) + " cm and " +
                                csvNumber(spec.success_rotation_deg) + " deg; " + std::to_string(g.trials) +
                                " trials per cell";
  std::vector<BasinBoundary> boundaries;
  for (std::size_t m = 0; m < names.size(); ++m) {
    SuccessGrid h;
    const std::string& name = names[m];
    h.title = sc.name + ": " + name;
    h.subtitle = criterion + "\nin a cell: successes/trials; median error; acc: accepted; FA: false accepts";
    h.row_axis = "initial translation";
    h.col_axis = g.vertical_axis ? "initial rotation (yaw)" : "initial rotation (about a random axis)";
    for (const double v : g.translation_m) h.row_labels.push_back(csvNumber(v) + " m");
    for (const double v : g.rotation_deg) h.col_labels.push_back(csvNumber(v) + " deg");
    BasinBoundary b{name, {}};
    for (std::size_t c = 0; c < cells; ++c) {
      h.successes.push_back(t.ok[m][c]);
      h.trials.push_back(t.n[m][c]);
      std::string note;
      if (!t.err[m][c].empty()) {
        const double med = median(t.err[m][c]);
        char buf[32];
        std::snprintf(buf, sizeof buf, med < 0.1 ? "%.1f cm" : "%.2f m", med < 0.1 ? 100 * med : med);
        note = buf;
      }
      note += "\nacc " + std::to_string(t.accepted[m][c]) + " FA " + std::to_string(t.false_accept[m][c]);
      h.notes.push_back(note);
      b.rate.push_back(t.n[m][c] ? t.ok[m][c] / double(t.n[m][c]) : 0.0);
    }
    const int width = std::max(620, 110 + 20 + 92 * int(g.rotation_deg.size()));
    const int height = std::max(470, 146 + 58 * int(g.translation_m.size()));
    writePng(opt.out / ("basin_" + methodFileName(name) + ".png"), successHeatmap(h, width, height));
    boundaries.push_back(std::move(b));
  }
  writeText(opt.out / "basin.md", summary(sc, opt, t, boundaries));
  writePng(opt.out / "basin_boundary.png",
           basinBoundaryPlot(g.translation_m, g.rotation_deg, boundaries, 0.95,
                             sc.name + ": 95% basin boundary, " + std::to_string(g.trials) + " trials per cell (lines 1% apart)"));
}

}  // namespace

std::vector<double> parseBasinAxis(const std::string& text, const std::string& option, double max) {
  std::vector<double> out;
  const auto parts = base::split(text, ',');
  for (const std::string& raw : parts) {
    const auto b = raw.find_first_not_of(" \t"), e = raw.find_last_not_of(" \t");
    const std::string p = b == std::string::npos ? "" : raw.substr(b, e - b + 1);
    double v = 0;
    const auto [end, ec] = std::from_chars(p.data(), p.data() + p.size(), v);
    if (p.empty() || ec != std::errc() || end != p.data() + p.size() || !std::isfinite(v))
      throw BasinError(option + ": expected comma-separated numbers, got " + yamlQuoted(text));
    if (v < 0) throw BasinError(option + ": " + p + " is negative; the axis is a magnitude (>= 0)");
    if (v > max) throw BasinError(option + ": " + p + " is beyond " + csvNumber(max));
    if (!out.empty() && v <= out.back())
      throw BasinError(option + ": values must increase, got " + p + " after " + csvNumber(out.back()));
    out.push_back(v);
  }
  if (out.empty()) throw BasinError(option + ": expected at least one value");
  return out;
}

Eigen::Isometry3d basinError(std::uint64_t seed, int trial, double translation_m, double rotation_deg,
                             const Eigen::Isometry3d& T_WS_j, bool vertical_axis) {
  base::Rng rng(base::streamKey(seed, kBasinStream, std::uint64_t(trial)));
  const double heading = rng.uniform(0, 2 * std::numbers::pi);
  // A uniform axis on the sphere: z uniform in [−1, 1], its azimuth uniform.
  const double z = rng.uniform(-1, 1), azimuth = rng.uniform(0, 2 * std::numbers::pi);
  const double s = std::sqrt(std::max(0.0, 1 - z * z));
  // In sensor J's frame: the world's vertical there is R_WS_jᵀ·z.
  const Eigen::Vector3d axis = vertical_axis ? Eigen::Vector3d(T_WS_j.linear().transpose() * Eigen::Vector3d::UnitZ())
                                             : Eigen::Vector3d(s * std::cos(azimuth), s * std::sin(azimuth), z);
  const Eigen::Vector3d h_world(std::cos(heading), std::sin(heading), 0);
  Eigen::Isometry3d E = Eigen::Isometry3d::Identity();
  E.linear() = Eigen::AngleAxisd(rotation_deg * std::numbers::pi / 180.0, axis).toRotationMatrix();
  // T_WS_j·E moves sensor J by R_WS_j·t: horizontal in the world for t = R_WS_jᵀ·h.
  E.translation() = T_WS_j.linear().transpose() * (translation_m * h_world);
  return E;
}

namespace {

// The scenario's registration with the basin's prior: it covers every error the grid tries, and
// the verdict gates by it (taken as three σ), whatever the scenario's odometry model says of the
// views' distance.
// basin.csv's records: the header, then the rows by method (the scenario's order), then by draw.
std::vector<std::vector<std::string>> byMethod(const std::vector<Rows>& rows, std::size_t methods) {
  std::vector<std::vector<std::string>> records{kHeader};
  for (std::size_t m = 0; m < methods; ++m)
    for (const Rows& r : rows) records.push_back(r[m]);
  return records;
}

perception::RegistrationConfig basinConfig(const Scenario& sc, const BasinGrid& g) {
  perception::RegistrationConfig config = registrationConfig(sc);
  config.prior_translation_m = std::max(config.prior_translation_m, g.translation_m.back());
  config.prior_rotation_deg = std::max(config.prior_rotation_deg, g.rotation_deg.back());
  config.odometry.reset();
  config.acceptance.prior = {config.prior_translation_m / 3, config.prior_rotation_deg / 3};
  return config;
}

}  // namespace

fs::path runBasin(const Scenario& scenario, const BasinOptions& opt) {
  validate(scenario, opt);
  const BasinGrid& g = opt.grid;
  const auto say = [&](const std::string& line) {
    if (opt.progress) std::fprintf(stderr, "ambler: %s\n", line.c_str());
  };
  const Scenario sc = pairScenario(scenario);
  const MatchingSpec& spec = *sc.matching;
  const auto [pi, pj] = spec.pairs.front();
  const std::vector<std::size_t> todo = shardItems(drawCount(g), opt.shard);
  const std::vector<std::string> names = methodNames(sc, opt);
  // With --resume, what an earlier attempt recorded, checked before anything runs or is written.
  const fs::path journal_file =
      opt.out / (opt.shard ? shardName(*opt.shard, "basin", ".journal") : "basin.journal");
  const std::string identity = journalIdentity(scenario, opt);
  const bool resuming = opt.resume && fs::exists(journal_file);
  const JournalContents done = opt.resume ? readJournal(journal_file, identity, drawCount(g)) : JournalContents{};
  std::vector<Rows> rows(todo.size());
  const std::vector<std::size_t> pending =  // indices into todo
      unrecordedItems(done, todo, journal_file, "draws", opt.shard ? "shard" : "basin",
                      [&](std::size_t i, const std::string& payload) {
                        rows[i] = rowsFromPayload(payload, journal_file, todo[i], names.size());
                      });
  say("basin " + sc.name + ": views " + std::to_string(pi) + "-" + std::to_string(pj) + ", " +
      std::to_string(g.translation_m.size()) + " translations x " + std::to_string(g.rotation_deg.size()) +
      " rotations x " + std::to_string(g.trials) + " trials, " + std::to_string(todo.size()) + " of " +
      std::to_string(drawCount(g)) + " draws" +
      (opt.shard ? " (shard " + std::to_string(opt.shard->index) + " of " + std::to_string(opt.shard->count) + ")"
                 : std::string()) +
      " x " + std::to_string(names.size()) + " methods -> " + opt.out.string());

  // The pair: the ordinary stages, into out/pair/ (the world stage makes the directories once
  // the views are checked against the terrain).
  RunState s{sc, opt.out / "pair", opt.progress};
  for (const Stage& stage : {stages::world(), stages::scan(), stages::map()}) stage.run(s);
  writeText(opt.out / "pair" / "scenario.resolved.yaml", resolvedYaml(sc));  // as a run's; `ambler report` shows it
  const perception::RegistrationConfig config = basinConfig(sc, g);
  const ViewState& vi = s.views[std::size_t(pi)];
  const ViewState& vj = s.views[std::size_t(pj)];
  const PairRegistration pair(*vi.locus, vi.T_WS, *vj.locus, vj.T_WS, config, spec.methods);

  // The draws an earlier attempt registered, then the journal open for this one's.
  JournalWriter journal(journal_file, identity, resuming, done.valid_bytes);
  if (opt.resume)
    say("resuming: " + std::to_string(todo.size() - pending.size()) + " of " + std::to_string(todo.size()) +
        " draws recorded in " + journal_file.string() +
        (done.torn_tail ? " (a draw cut short while being recorded is registered again)" : ""));

  Progress progress("basin " + sc.name, todo.size(), todo.size() - pending.size(), Progress::modeFor(opt.progress),
                    std::chrono::seconds(1));
  progress.setLinePrefix("basin ");
  std::mutex mutex;            // guards first_failure
  std::string first_failure;  // a registration that threw, reported once
  const std::optional<JobFailure> failure = runJobs(todo, pending, opt.jobs, journal, progress, [&](std::size_t i) {
    const Draw d = draw(g, todo[i]);
    const double t_m = g.translation_m[d.t], r_deg = g.rotation_deg[d.r];
    const Eigen::Isometry3d T_0 = pair.trueRelative() * basinError(sc.seed, d.trial, t_m, r_deg, vj.T_WS, g.vertical_axis);
    std::string verdicts;
    // One row per method, built-in or the user's, in the order of `names`.
    const auto score = [&](const std::string& name, const auto& method) {
      std::vector<std::string> row{name, csvNumber(t_m), csvNumber(r_deg), std::to_string(d.trial)};
      try {
        const PairResult res = pair.run(method, T_0);
        const bool ok = isSuccess(res.error, spec);
        row.insert(row.end(), {csvNumber(res.error.translation_m), csvNumber(res.error.rotation_deg),
                               ok ? "true" : "false", std::to_string(res.reg.iterations),
                               opt.timing ? csvNumber(res.seconds) : "",
                               res.reg.assessment.accepted ? "true" : "false",
                               res.reg.assessment.accepted && !ok ? "true" : "false"});
        verdicts += " " + name + (ok ? " ok" : " FAILED");
      } catch (const std::invalid_argument& e) {
        // A method that gives up (no overlap left, too few points) has not converged.
        row.insert(row.end(), {"", "", "false", "0", "", "false", "false"});
        verdicts += " " + name + " GAVE UP";
        const std::lock_guard lock(mutex);
        if (first_failure.empty()) first_failure = name + ": " + e.what();
      }
      rows[i].push_back(std::move(row));
    };
    for (const MatchMethod m : spec.methods) score(matchMethodName(m), m);
    for (const CustomMethod& m : opt.custom) score(m.name, m);
    return JobRecord{rowsPayload(rows[i]),
                     csvNumber(t_m) + " m " + csvNumber(r_deg) + " deg trial " + std::to_string(d.trial) + ":" + verdicts};
  });
  progress.finish();
  if (failure)
    throw BasinError(opt.out.string() + ": draw " + std::to_string(failure->item) + ": " + failure->message);
  if (!first_failure.empty()) say("basin: a method gave up (counted as a failure), e.g. " + first_failure);

  const std::vector<std::vector<std::string>> records = byMethod(rows, names.size());
  std::string text;
  for (const auto& record : records) text += csvLine(record);
  const fs::path csv = opt.out / (opt.shard ? shardName(*opt.shard, "basin") : "basin.csv");
  writeText(csv, text);
  if (!opt.shard) writeFigures(sc, opt, records);
  say("wrote " + csv.string() + " (" + std::to_string(records.size() - 1) + " rows)" +
      (opt.shard ? std::string() : ", basin_*.png"));
  return csv;
}

fs::path mergeBasin(const Scenario& scenario, const BasinOptions& opt) {
  validate(scenario, opt);
  const BasinGrid& g = opt.grid;
  const auto files = shardFiles(opt.out, "basin");
  const std::vector<std::string> names = methodNames(scenario, opt);
  const std::size_t draws = drawCount(g), methods = names.size();
  std::map<std::string, std::size_t> method_index, t_index, r_index;
  for (std::size_t m = 0; m < methods; ++m) method_index[names[m]] = m;
  for (std::size_t i = 0; i < g.translation_m.size(); ++i) t_index[csvNumber(g.translation_m[i])] = i;
  for (std::size_t i = 0; i < g.rotation_deg.size(); ++i) r_index[csvNumber(g.rotation_deg[i])] = i;
  std::vector<std::optional<std::vector<std::string>>> rows(methods * draws);
  for (const auto& [shard, path] : files) {
    std::string text;
    try {
      text = base::readFile(path);
    } catch (const base::ReadError& e) {
      throw BasinError(path.string() + ": " + e.what());
    }
    const auto records = parseResultsCsv(text);
    if (!records || records->empty() || records->front() != kHeader)
      throw BasinError(path.string() + ": not a basin CSV (expected the header " + csvLine(kHeader).substr(0, 40) + "...)");
    for (std::size_t k = 1; k < records->size(); ++k) {
      const auto& row = (*records)[k];
      const std::string where = path.string() + ": row " + std::to_string(k + 1);  // the header is row 1, as in sweeps
      if (row.size() != kHeader.size()) throw BasinError(where + ": expected " + std::to_string(kHeader.size()) + " cells");
      const auto m = method_index.find(row[0]);
      const auto t = t_index.find(row[1]);
      const auto r = r_index.find(row[2]);
      int trial = -1;
      std::from_chars(row[3].data(), row[3].data() + row[3].size(), trial);
      if (m == method_index.end()) throw BasinError(where + ": method " + row[0] + " is not one of the scenario's");
      if (t == t_index.end()) throw BasinError(where + ": translation " + row[1] + " m is not on --translation-m");
      if (r == r_index.end()) throw BasinError(where + ": rotation " + row[2] + " deg is not on --rotation-deg");
      if (trial < 0 || trial >= g.trials) throw BasinError(where + ": trial " + row[3] + " is not below --trials");
      const std::size_t u = (t->second * g.rotation_deg.size() + r->second) * std::size_t(g.trials) + std::size_t(trial);
      if (u % std::size_t(shard.count) != std::size_t(shard.index - 1))
        throw BasinError(where + ": the draw belongs to another shard of " + std::to_string(shard.count));
      auto& slot = rows[m->second * draws + u];
      if (slot) throw BasinError(where + ": a second row of " + row[0] + " at " + row[1] + " m, " + row[2] +
                                 " deg, trial " + row[3]);
      slot = row;
    }
  }
  std::string text = csvLine(kHeader);
  std::vector<std::vector<std::string>> records{kHeader};
  for (std::size_t k = 0; k < rows.size(); ++k) {
    if (!rows[k]) {
      const Draw d = draw(g, k % draws);
      throw BasinError(opt.out.string() + ": no row of " + names[k / draws] + " at " +
                       csvNumber(g.translation_m[d.t]) + " m, " + csvNumber(g.rotation_deg[d.r]) + " deg, trial " +
                       std::to_string(d.trial) + " in the shards");
    }
    text += csvLine(*rows[k]);
    records.push_back(*rows[k]);
  }
  const fs::path csv = opt.out / "basin.csv";
  writeText(csv, text);
  writeFigures(scenario, opt, records);
  if (opt.progress)
    std::fprintf(stderr, "ambler: merged %zu shards into %s (%zu rows), basin_*.png\n", files.size(),
                 csv.string().c_str(), records.size() - 1);
  return csv;
}

}  // namespace ambler::eval
