// The Python module `ambler` (docs/python.md): load a scenario (with overrides, keys as in the YAML,
// dotted for nesting), run it, and read its metrics, maps and scans as Python and numpy objects.
// The C++ work runs without the GIL; the project's one-line errors arrive as Python exceptions
// with the same text (ValueError for bad input, RuntimeError for a failed run). The types Map,
// Scan and View are bound here; registration.cpp and stages.cpp add the rest (bindings.hpp).
#include <pybind11/eigen.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>

#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "base/read_file.hpp"
#include "base/temp_dir.hpp"
#include "python/bindings.hpp"
#include "eval/pictures/match_figures.hpp"
#include "eval/run/run_state.hpp"
#include "eval/run/runner.hpp"
#include "eval/tools/report/report.hpp"
#include "eval/scenario/scenario.hpp"
#include "eval/tools/sweep/sweep.hpp"

namespace fs = std::filesystem;

namespace ambler::python {

using eval::RunOptions;
using eval::RunProducts;
using eval::Scenario;

namespace {

// The scenario in `path` with `overrides` applied: each key (dotted for nesting, as a sweep's axis)
// set to its value written as YAML flow text (JSON is YAML), checked by the scenario reader as a
// one-run sweep over the file, so a bad key or value fails with the reader's line.
PyScenario loadScenarioWith(const fs::path& path, const py::kwargs& overrides) {
  if (overrides.empty()) return {eval::loadScenario(path)};
  const py::object dumps = py::module_::import("json").attr("dumps");
  std::string text = "name: python\nbase: " + fs::absolute(path).string() + "\naxes:\n";
  for (const auto& [key, value] : overrides)
    text += "  " + py::cast<std::string>(key) + ": [" + py::cast<std::string>(dumps(value)) + "]\n";
  eval::Sweep sweep = eval::parseSweep(text, path);
  Scenario s = std::move(sweep.runs.front());
  s.name = eval::loadScenario(path).name;  // the sweep names its runs NAME_K: keep the file's
  return {std::move(s)};
}

// One run: its directory, metrics (as metrics.json), maps and scans.
struct PyRun {
  std::shared_ptr<RunProducts> products;
  std::optional<base::TempDir> temporary;  // out, when the caller gave none: removed with the run
  fs::path out;
  py::object metrics;
  std::string footfall_map;  // the map the footfall stage chose on (view_K, composite), when it ran
};

std::shared_ptr<PyRun> run(const PyScenario& sc, const std::optional<fs::path>& out,
                           const std::optional<py::dict>& custom) {
  auto r = std::make_shared<PyRun>();
  if (out) {
    r->out = *out;
  } else {
    r->out = r->temporary.emplace("python").path();
  }
  RunOptions opt;
  opt.out = r->out;
  opt.progress = false;
  opt.custom = customMethodsFrom(custom);
  {
    py::gil_scoped_release release;
    r->products = std::make_shared<RunProducts>(eval::runScenarioKeeping(sc.scenario, opt));
  }
  r->metrics = py::module_::import("json").attr("loads")(r->products->metrics.dump());
  if (const auto& f = sc.scenario.footfall)
    r->footfall_map = f->map_view < 0 ? "composite" : eval::viewName(f->map_view);
  return r;
}

// One dict per registration of the run, in metrics.registration's order: its
// matching/pair_I_J_METHOD.json (docs/scenario.md, "The run directory") with T_true, T_initial,
// T_estimated (4 × 4) and covariance, covariance_pose (6 × 6, NaN where the JSON has null) as numpy
// arrays (copies).
py::list registrations(const PyRun& r) {
  const py::object loads = py::module_::import("json").attr("loads");
  const py::object array = py::module_::import("numpy").attr("array");
  py::list out;
  if (!r.products->metrics.contains("registration")) return out;
  for (const auto& m : r.products->metrics["registration"]) {
    const std::string stem = "pair_" + std::to_string(m["pair"][0].get<int>()) + "_" +
                             std::to_string(m["pair"][1].get<int>()) + "_" +
                             eval::methodFileName(m["method"].get<std::string>());
    py::dict d = loads(base::readFile(r.out / "matching" / (stem + ".json")));
    for (const char* key : {"T_true", "T_initial", "T_estimated", "covariance", "covariance_pose"})
      if (d.contains(key) && !d[key].is_none()) d[key] = array(d[key], py::arg("dtype") = "float64");
    out.append(d);
  }
  return out;
}

}  // namespace

py::array_t<double> poseArray(const Eigen::Isometry3d& T) {
  py::array_t<double> a({4, 4});
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j) a.mutable_at(i, j) = T.matrix()(i, j);
  return a;
}

Eigen::Isometry3d poseFromArray(const py::handle& h, const char* what) {
  const auto a = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(h);
  if (!a || a.ndim() != 2 || a.shape(0) != 4 || a.shape(1) != 4)
    throw py::value_error(std::string(what) + ": expected a 4 x 4 array (a pose)");
  Eigen::Matrix4d M;
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j) M(i, j) = a.at(i, j);
  if (!M.allFinite()) throw py::value_error(std::string(what) + ": the pose has a non-finite entry");
  const Eigen::Matrix3d R = M.topLeftCorner<3, 3>();
  // A rotation to double rounding (1e-6: poses that went through float32 still pass).
  if ((R.transpose() * R - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff() > 1e-6 || R.determinant() < 0 ||
      M.row(3) != Eigen::RowVector4d(0, 0, 0, 1))
    throw py::value_error(std::string(what) + ": not a rigid transform (the top-left 3 x 3 must be a rotation, "
                          "the last row 0 0 0 1)");
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.matrix() = M;
  return T;
}

void bindTypes(py::module_& m) {
  py::class_<PyMap>(m, "Map", "An elevation map: read-only numpy views of its rasters (docs/python.md)")
      .def_property_readonly("elevation", [](py::object self) { return view(self.cast<PyMap&>().map->elevation(), self); })
      .def_property_readonly("sigma", [](py::object self) { return view(self.cast<PyMap&>().map->sigma(), self); })
      .def_property_readonly("state", [](py::object self) { return view(self.cast<PyMap&>().map->state(), self); })
      .def_property_readonly("ceiling", [](py::object self) { return view(self.cast<PyMap&>().map->shadowCeiling(), self); })
      .def_property_readonly("cell_m", [](const PyMap& p) { return p.map->grid().cell; })
      .def_property_readonly("x_min_m", [](const PyMap& p) { return p.map->grid().x_min; })
      .def_property_readonly("y_max_m", [](const PyMap& p) { return p.map->grid().y_max; })
      // T_WM, the map frame in the world (row 0 of the rasters at y_max, column 0 at x_min).
      .def_property_readonly("transform", [](const PyMap& p) { return poseArray(p.map->grid().T_WM); });

  py::class_<PyScan>(m, "Scan", "A range image as the rover has it, with its sensor, without the pose it was "
                                "taken from: a view's (unwrapped, with its edges) or World.scan's (as the "
                                "sensor reported it: not unwrapped, no edges)")
      .def_property_readonly("range", [](py::object self) { return view(self.cast<PyScan&>().image().range, self); })
      .def_property_readonly("unwrapped", [](const PyScan& s) { return bool(s.scan); })
      .def_property_readonly("edges", [](py::object self) -> py::object {
        const PyScan& s = self.cast<PyScan&>();
        return s.scan && s.scan->edges ? py::object(view(*s.scan->edges, self)) : py::object(py::none());
      })
      .def_property_readonly("phi", [](const PyScan& s) { return py::array(py::cast(s.image().phi)); })
      .def_property_readonly("theta", [](const PyScan& s) { return py::array(py::cast(s.image().theta)); })
      .def_property_readonly("points", [](const PyScan& s) {
        // The returns in the sensor frame (eq. 1), row by row: an N × 3 copy.
        const perception::RangeImage& im = s.image();
        py::array_t<double> a({py::ssize_t(im.validCount()), py::ssize_t(3)});
        py::ssize_t n = 0;
        for (int r = 0; r < im.rows(); ++r)
          for (int c = 0; c < im.cols(); ++c)
            if (im.valid(r, c)) {
              const Eigen::Vector3d p = im.pointSensor(r, c);
              for (int k = 0; k < 3; ++k) a.mutable_at(n, k) = p[k];
              ++n;
            }
        return a;
      })
      .def_property_readonly("sensor_sigma_m", [](const PyScan& s) {
        // σ of each return's range as the noise model has it (NaN where nothing returned).
        const perception::RangeImage& im = s.image();
        py::array_t<float> a({im.rows(), im.cols()});
        for (int r = 0; r < im.rows(); ++r)
          for (int c = 0; c < im.cols(); ++c)
            a.mutable_at(r, c) = im.valid(r, c) ? float(s.sensor().rangeSigma(im.range(r, c))) : NAN;
        return a;
      });

  py::class_<PyView>(m, "View", "A scan and the locus map made from it at its sensor pose")
      .def_property_readonly("scan", [](const PyView& v) { return PyScan{v.scan}; })
      .def_property_readonly("map", [](const PyView& v) { return PyMap{v.scan, &v.scan->map}; })
      .def_property_readonly("sensor_pose", [](const PyView& v) { return poseArray(v.scan->image.T_WS); });
}

}  // namespace ambler::python

PYBIND11_MODULE(ambler, m) {
  using namespace ambler::python;
  using namespace ambler::eval;
  m.doc() = "ambler: the planetary-rover terrain-mapping testbed from Python (docs/python.md)";
  py::register_exception<ScenarioError>(m, "ScenarioError", PyExc_ValueError);
  py::register_exception<SweepError>(m, "OverrideError", PyExc_ValueError);
  bindTypes(m);
  bindRegistration(m);
  bindStages(m);

  py::class_<PyScenario>(m, "Scenario")
      .def_property_readonly("name", [](const PyScenario& s) { return s.scenario.name; })
      .def_property_readonly("seed", [](const PyScenario& s) { return s.scenario.seed; })
      .def_property_readonly("file", [](const PyScenario& s) { return s.scenario.file.string(); });

  py::class_<PyRun, std::shared_ptr<PyRun>>(m, "Run")
      .def_property_readonly("out", [](const PyRun& r) { return r.out.string(); })
      .def_readonly("metrics", &PyRun::metrics)
      .def_property_readonly("maps", [](const std::shared_ptr<PyRun>& r) {
        py::dict d;
        for (const auto& [name, map] : r->products->maps) d[py::str(name)] = PyMap{r->products, &map};
        return d;
      })
      .def_property_readonly("scans", [](py::object self) {
        const PyRun& r = self.cast<PyRun&>();
        py::list l;
        for (const auto& image : r.products->scans) l.append(view(image.range, self));
        return l;
      })
      .def_property_readonly("registrations", &registrations)
      .def_property_readonly("footfalls", [](const PyRun& r) {
        // metrics.footfall's choices, each with the map they were made on ("map": view_K, composite).
        py::list l;
        if (!r.metrics.contains("footfall")) return l;
        for (const py::handle& f : r.metrics["footfall"]) {
          py::dict d = py::reinterpret_borrow<py::dict>(f).attr("copy")();
          d["map"] = r.footfall_map;
          l.append(d);
        }
        return l;
      });

  m.def("load_scenario", &loadScenarioWith, py::arg("path"),
        "The scenario in PATH; keyword overrides set keys as in the YAML, dotted for nesting "
        "(load_scenario(p, seed=3, **{'map.cell_m': 0.05})).");
  m.def("report", [](const fs::path& dir, const std::optional<fs::path>& out) {
          py::gil_scoped_release release;
          return ambler::eval::writeReport(dir, out ? *out : dir / "report.html").string();
        }, py::arg("dir"), py::arg("out") = py::none(),
        "`ambler report`: the HTML report of a run, sweep or basin directory, to OUT (DIR/report.html). "
        "Returns its path.");
  m.def("run", &run, py::arg("scenario"), py::arg("out") = py::none(), py::arg("custom") = py::none(),
        "Runs the scenario into OUT (a temporary directory, removed with the Run, when None); CUSTOM maps a "
        "name to a registration method of your own, fn(map_i, scan_j, T_initial), run on every pair.");
}
