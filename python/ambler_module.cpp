// The Python module `ambler` (docs/python.md): load a scenario (with overrides, keys as in the YAML,
// dotted for nesting), run it, and read its metrics, maps and scans as Python and numpy objects.
// The C++ work runs without the GIL; the project's one-line errors arrive as Python exceptions
// with the same text (ValueError for bad input, RuntimeError for a failed run).
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

#include "base/temp_dir.hpp"
#include "eval/run/runner.hpp"
#include "eval/scenario/scenario.hpp"
#include "eval/tools/sweep/sweep.hpp"

namespace py = pybind11;
namespace fs = std::filesystem;

namespace ambler::eval {
namespace {

// A loaded scenario and where it came from (relative paths in it resolve against its file).
struct PyScenario {
  Scenario scenario;
};

// The scenario in `path` with `overrides` applied: each key (dotted for nesting, as a sweep's axis)
// set to its value written as YAML flow text (JSON is YAML), checked by the scenario reader as a
// one-run sweep over the file, so a bad key or value fails with the reader's line.
PyScenario loadScenarioWith(const fs::path& path, const py::kwargs& overrides) {
  if (overrides.empty()) return {loadScenario(path)};
  const py::object dumps = py::module_::import("json").attr("dumps");
  std::string text = "name: python\nbase: " + fs::absolute(path).string() + "\naxes:\n";
  for (const auto& [key, value] : overrides)
    text += "  " + py::cast<std::string>(key) + ": [" + py::cast<std::string>(dumps(value)) + "]\n";
  Sweep sweep = parseSweep(text, path);
  Scenario s = std::move(sweep.runs.front());
  s.name = loadScenario(path).name;  // the sweep names its runs NAME_K: keep the file's
  return {std::move(s)};
}

// A map's rasters as numpy arrays that view the C++ memory, kept alive by the run that owns it.
struct PyMap {
  std::shared_ptr<RunProducts> owner;
  const perception::ElevationMap* map = nullptr;
};

template <class T>
py::array view(const perception::Raster<T>& r, const py::object& base) {
  py::array a(py::dtype::of<T>(), {py::ssize_t(r.rows()), py::ssize_t(r.cols())},
              {py::ssize_t(sizeof(T) * r.cols()), py::ssize_t(sizeof(T))}, r.data(), base);
  a.attr("setflags")(py::arg("write") = false);  // the run's products: read-only views
  return a;
}

// One run: its directory, metrics (as metrics.json), maps and scans.
struct PyRun {
  std::shared_ptr<RunProducts> products;
  std::optional<base::TempDir> temporary;  // out, when the caller gave none: removed with the run
  fs::path out;
  py::object metrics;
};

std::shared_ptr<PyRun> run(const PyScenario& sc, const std::optional<fs::path>& out) {
  auto r = std::make_shared<PyRun>();
  if (out) {
    r->out = *out;
  } else {
    r->out = r->temporary.emplace("python").path();
  }
  RunOptions opt;
  opt.out = r->out;
  opt.progress = false;
  {
    py::gil_scoped_release release;
    r->products = std::make_shared<RunProducts>(runScenarioKeeping(sc.scenario, opt));
  }
  r->metrics = py::module_::import("json").attr("loads")(r->products->metrics.dump());
  return r;
}

}  // namespace
}  // namespace ambler::eval

PYBIND11_MODULE(ambler, m) {
  using namespace ambler::eval;
  m.doc() = "ambler: the planetary-rover terrain-mapping testbed from Python (docs/python.md)";
  py::register_exception<ScenarioError>(m, "ScenarioError", PyExc_ValueError);
  py::register_exception<SweepError>(m, "OverrideError", PyExc_ValueError);

  py::class_<PyScenario>(m, "Scenario")
      .def_property_readonly("name", [](const PyScenario& s) { return s.scenario.name; })
      .def_property_readonly("seed", [](const PyScenario& s) { return s.scenario.seed; })
      .def_property_readonly("file", [](const PyScenario& s) { return s.scenario.file.string(); });

  py::class_<PyMap>(m, "Map")
      .def_property_readonly("elevation", [](py::object self) { return view(self.cast<PyMap&>().map->elevation(), self); })
      .def_property_readonly("sigma", [](py::object self) { return view(self.cast<PyMap&>().map->sigma(), self); })
      .def_property_readonly("state", [](py::object self) { return view(self.cast<PyMap&>().map->state(), self); })
      .def_property_readonly("ceiling", [](py::object self) { return view(self.cast<PyMap&>().map->shadowCeiling(), self); })
      .def_property_readonly("cell_m", [](const PyMap& p) { return p.map->grid().cell; })
      .def_property_readonly("x_min_m", [](const PyMap& p) { return p.map->grid().x_min; })
      .def_property_readonly("y_max_m", [](const PyMap& p) { return p.map->grid().y_max; })
      .def_property_readonly("transform", [](const PyMap& p) {
        // T_WM, the map frame in the world: a 4 × 4 (row 0 of the rasters at y_max, column 0 at x_min).
        const Eigen::Matrix4d T = p.map->grid().T_WM.matrix();
        py::array_t<double> a({4, 4});
        for (int i = 0; i < 4; ++i)
          for (int j = 0; j < 4; ++j) a.mutable_at(i, j) = T(i, j);
        return a;
      });

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
      });

  m.def("load_scenario", &loadScenarioWith, py::arg("path"),
        "The scenario in PATH; keyword overrides set keys as in the YAML, dotted for nesting "
        "(load_scenario(p, seed=3, **{'map.cell_m': 0.05})).");
  m.def("run", &run, py::arg("scenario"), py::arg("out") = py::none(),
        "Runs the scenario into OUT (a temporary directory, removed with the Run, when None).");
}
