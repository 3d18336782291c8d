// Registration from Python, and a user's own method in a run, the basin and the matching
// experiment (docs/python.md, "Your own method"). A Python function becomes an
// eval::CustomMethod: it is called with view I, scan J and the believed pose, under the GIL, and
// what it returns is scored by the project as a built-in method's estimate is.
#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>

#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "eval/run/pair_registration.hpp"
#include "eval/tools/basin/basin.hpp"
#include "eval/tools/experiment/experiment.hpp"
#include "eval/tools/shards.hpp"
#include "python/bindings.hpp"

namespace ambler::python {
namespace {

namespace fs = std::filesystem;
using eval::CustomEstimate;
using eval::CustomMethod;
using eval::CustomMethods;
using eval::MatchMethod;
using eval::PairRegistration;
using eval::PairResult;

// One registration by a built-in method (ambler.Registration): what ambler.register returns, and
// what a user's method may return to be scored with the method's own verdict.
struct PyRegistration {
  std::shared_ptr<const PairResult> result;
  std::string method;
};

MatchMethod methodFromName(const std::string& name, const char* what) {
  if (const auto m = eval::matchMethodFromName(name)) return *m;
  std::string names;
  for (const MatchMethod m : eval::matchMethods()) names += std::string(names.empty() ? "" : ", ") + eval::matchMethodName(m);
  throw py::value_error(std::string(what) + ": unknown method " + eval::yamlQuoted(name) + " (expected one of " + names + ")");
}

// Scan J as a method may see it: its image, edges and sensor, the pose it was taken from and its
// map (made at that pose) left out.
std::shared_ptr<const perception::ScanMap> withoutPose(const perception::ScanMap& scan) {
  auto s = std::make_shared<perception::ScanMap>();
  s->image = scan.image;
  s->image.T_WS = Eigen::Isometry3d::Identity();
  s->sensor = scan.sensor;
  s->unwrapped = scan.unwrapped;
  s->edges = scan.edges;
  return s;
}

// view_i registered against scan_j from the believed relative pose T_0 (sensor J in sensor I's
// frame) by a built-in method, with view_i's registration configuration: the same result as the
// run's or the basin's own registration of that pair.
PyRegistration registerPair(const PyView& view_i, const PyScan& scan_j, const py::handle& T_initial,
                            const std::string& method_name) {
  const MatchMethod method = methodFromName(method_name, "register");
  if (!scan_j.scan)
    throw py::value_error("register: scan_j is a raw scan (World.scan): map it first (ambler.map_scan), which "
                          "unwraps it and finds its edges, and pass the View's .scan");
  const Eigen::Isometry3d T_0 = poseFromArray(T_initial, "register: T_initial");
  const Eigen::Isometry3d& T_WS_i = view_i.scan->image.T_WS;
  auto result = std::make_shared<PairResult>();
  {
    py::gil_scoped_release release;
    try {
      // The "truth" a PairRegistration scores against is unknown here: T_0 stands in, and the
      // scores are not shown.
      const PairRegistration pair(*view_i.scan, T_WS_i, *scan_j.scan, T_WS_i * T_0, *view_i.config, {method});
      *result = pair.run(method, T_0);
    } catch (const std::invalid_argument& e) {
      throw py::value_error(std::string("register: ") + e.what());
    }
  }
  return {std::move(result), method_name};
}

// What a user's function returned, as the project scores it: an ambler.Registration, a 4 × 4
// pose, a (pose, covariance) pair or a dict with "T" and optionally "covariance" and "iterations".
CustomEstimate estimateFrom(const py::object& r, const std::string& name) {
  const std::string what = "custom method " + name;
  CustomEstimate e;
  if (py::isinstance<PyRegistration>(r)) {
    const PyRegistration& reg = r.cast<const PyRegistration&>();
    e.T = reg.result->T_est;
    e.iterations = reg.result->reg.iterations;
    e.registered = *reg.result;
    return e;
  }
  py::object T = r, cov = py::none(), iterations = py::none();
  if (py::isinstance<py::dict>(r)) {
    const py::dict d = r.cast<py::dict>();
    if (!d.contains("T")) throw py::value_error(what + ": the returned dict has no \"T\"");
    T = d["T"];
    if (d.contains("covariance")) cov = d["covariance"];
    if (d.contains("iterations")) iterations = d["iterations"];
  } else if (py::isinstance<py::tuple>(r)) {
    const py::tuple t = r.cast<py::tuple>();
    if (t.size() != 2) throw py::value_error(what + ": return a 4 x 4 pose, (pose, covariance) or a dict");
    T = t[0], cov = t[1];
  }
  e.T = poseFromArray(T, (what + ": the returned pose").c_str());
  if (!cov.is_none()) {
    const auto a = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(cov);
    if (!a || a.ndim() != 2 || a.shape(0) != 6 || a.shape(1) != 6)
      throw py::value_error(what + ": the covariance must be a 6 x 6 array (rx ry rz tx ty tz)");
    perception::Matrix6d C;
    for (int i = 0; i < 6; ++i)
      for (int j = 0; j < 6; ++j) C(i, j) = a.at(i, j);
    e.covariance_pose = C;
  }
  if (!iterations.is_none()) e.iterations = iterations.cast<int>();
  return e;
}

// A Python function as a CustomMethod. The function is shared and released under the GIL, so the
// method may be copied and called on any thread (the basin's jobs, a sweep's runs).
CustomMethod customMethod(const std::string& name, const py::function& fn) {
  std::shared_ptr<py::function> f(new py::function(fn), [](py::function* p) {
    py::gil_scoped_acquire gil;
    delete p;
  });
  return {name, [f, name](const PairRegistration& pair, const Eigen::Isometry3d& T_0) {
            py::gil_scoped_acquire gil;
            // Copies the method owns (it may keep them): view I as the run has it, scan J without its pose.
            const PyView view_i{std::make_shared<const perception::ScanMap>(pair.viewI()),
                                std::make_shared<const perception::RegistrationConfig>(pair.config())};
            const PyScan scan_j{withoutPose(pair.scanJ())};
            try {
              return estimateFrom((*f)(view_i, scan_j, poseArray(T_0)), name);
            } catch (py::error_already_set& e) {
              throw std::runtime_error("custom method " + name + ": " + e.what());
            } catch (const py::value_error& e) {
              throw std::runtime_error(e.what());
            }
          }};
}

CustomMethods customMethods(const std::optional<py::dict>& custom) {
  CustomMethods out;
  if (!custom) return out;
  for (const auto& [key, value] : *custom) {
    if (!py::isinstance<py::str>(key)) throw py::value_error("custom: the keys are the methods' names (str)");
    if (!py::isinstance<py::function>(value))
      throw py::value_error("custom: " + key.cast<std::string>() + ": expected a function fn(map_i, scan_j, T_initial)");
    out.push_back(customMethod(key.cast<std::string>(), value.cast<py::function>()));
  }
  try {
    eval::checkCustomMethods(out, "custom");
  } catch (const std::invalid_argument& e) {
    throw py::value_error(e.what());
  }
  return out;
}

// ambler.basin: the scenario's basin (eval::runBasin or mergeBasin) with the user's methods.
std::string basin(const PyScenario& sc, const fs::path& out, const std::optional<std::vector<std::string>>& methods,
                  const std::optional<py::dict>& custom, const std::optional<std::string>& translation_m,
                  const std::optional<std::string>& rotation_deg, int trials, const std::string& rotation_axis,
                  const std::optional<std::string>& shard, bool merge, int jobs, bool timing, bool resume,
                  bool progress) {
  eval::Scenario scenario = sc.scenario;
  if (methods && scenario.matching) {
    scenario.matching->methods.clear();
    for (const std::string& m : *methods) scenario.matching->methods.push_back(methodFromName(m, "basin: methods"));
  }
  eval::BasinOptions opt;
  opt.out = out;
  if (translation_m) opt.grid.translation_m = eval::parseBasinAxis(*translation_m, "translation_m", 100.0);
  if (rotation_deg) opt.grid.rotation_deg = eval::parseBasinAxis(*rotation_deg, "rotation_deg", 180.0);
  opt.grid.trials = trials;
  if (rotation_axis != "random" && rotation_axis != "vertical")
    throw py::value_error("rotation_axis: expected \"random\" or \"vertical\", got " + eval::yamlQuoted(rotation_axis));
  opt.grid.vertical_axis = rotation_axis == "vertical";
  if (shard) opt.shard = eval::parseShard(*shard);
  opt.jobs = jobs, opt.timing = timing, opt.resume = resume, opt.progress = progress;
  opt.custom = customMethods(custom);
  py::gil_scoped_release release;
  fs::create_directories(out);
  return (merge ? eval::mergeBasin(scenario, opt) : eval::runBasin(scenario, opt)).string();
}

std::string experimentMatching(const fs::path& out, const fs::path& sweeps, const std::optional<py::dict>& custom,
                               bool quick, int jobs, bool progress) {
  eval::ExperimentOptions opt;
  opt.out = out, opt.sweeps = sweeps, opt.quick = quick, opt.jobs = jobs, opt.progress = progress;
  opt.custom = customMethods(custom);
  py::gil_scoped_release release;
  return eval::runMatching(opt);
}

}  // namespace

CustomMethods customMethodsFrom(const std::optional<py::dict>& custom) { return customMethods(custom); }

void bindRegistration(py::module_& m) {
  py::register_exception<eval::BasinError>(m, "BasinError", PyExc_ValueError);
  py::register_exception<eval::ShardError>(m, "ShardError", PyExc_ValueError);

  py::class_<PyRegistration>(m, "Registration", "One registration by a built-in method (ambler.register)")
      .def_readonly("method", &PyRegistration::method)
      .def_property_readonly("T", [](const PyRegistration& r) { return poseArray(r.result->T_est); })
      .def_property_readonly("iterations", [](const PyRegistration& r) { return r.result->reg.iterations; })
      .def_property_readonly("accepted", [](const PyRegistration& r) { return r.result->reg.assessment.accepted; })
      .def_property_readonly("reject_reasons", [](const PyRegistration& r) { return r.result->reg.assessment.reject_reasons; })
      .def_property_readonly("covariance_pose", [](const PyRegistration& r) -> py::object {
        // Of sensor J's pose (rx ry rz tx ty tz in its frame), where the method gives ν's.
        const perception::RegistrationResult& reg = r.result->reg;
        if (!reg.ran_iconic || reg.iconic.degenerate || !reg.iconic.covariance.allFinite()) return py::none();
        const perception::Matrix6d C = perception::sensorPoseCovariance(reg.nu, reg.iconic.covariance, r.result->believed_WS);
        py::array_t<double> a({6, 6});
        for (int i = 0; i < 6; ++i)
          for (int j = 0; j < 6; ++j) a.mutable_at(i, j) = C(i, j);
        return a;
      });

  m.def("register", &registerPair, py::arg("view_i"), py::arg("scan_j"), py::arg("T_initial"),
        py::arg("method") = "iconic_lm",
        "Registers scan J against view I from T_INITIAL (sensor J in sensor I's frame, 4 x 4) by a built-in "
        "method, with view I's registration configuration. Returns an ambler.Registration.");
  m.def("basin", &basin, py::arg("scenario"), py::arg("out"), py::arg("methods") = py::none(),
        py::arg("custom") = py::none(), py::arg("translation_m") = py::none(), py::arg("rotation_deg") = py::none(),
        py::arg("trials") = 10, py::arg("rotation_axis") = "random", py::arg("shard") = py::none(),
        py::arg("merge") = false, py::arg("jobs") = 1, py::arg("timing") = false, py::arg("resume") = false,
        py::arg("progress") = false,
        "`ambler basin` with a user's own methods: CUSTOM maps a name to fn(map_i, scan_j, T_initial). "
        "Returns basin.csv's path (a shard's CSV with SHARD).");
  m.def("experiment_matching", &experimentMatching, py::arg("out"), py::arg("sweeps") = "scenarios/experiments",
        py::arg("custom") = py::none(), py::arg("quick") = false, py::arg("jobs") = 1, py::arg("progress") = false,
        "`ambler experiment matching` with a user's own methods in every run. Returns table.md's markdown.");
}

}  // namespace ambler::python
