// The stages one by one from Python (docs/python.md, "Stage by stage"): a scenario's world, a scan
// from any pose, the map of a scan or of a user's range image, the composite of views, and the
// footfalls on any elevation arrays. Each calls the function the run's stage calls (eval/run/stages/),
// so the same inputs give the run's bits. Arrays come out as read-only views of the objects that
// hold them; footfall inputs are read where numpy holds them when their layout allows.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "base/random.hpp"
#include "base/temp_dir.hpp"
#include "eval/run/run_state.hpp"
#include "eval/run/stages.hpp"
#include "perception/composite.hpp"
#include "perception/footfall.hpp"
#include "perception/placement.hpp"
#include "perception/sensor_geometry.hpp"
#include "python/bindings.hpp"
#include "sim/erim_scanner.hpp"

namespace ambler::python {

namespace {

// A scenario's world as the world stage builds it (its MJCF in a temporary directory, the Embree
// scene, the ground truth): the stage's own RunState, kept for the scans. `scenario` and `dir`
// outlive `state`, which refers to both.
struct PyWorld {
  std::unique_ptr<const eval::Scenario> scenario;
  std::unique_ptr<base::TempDir> dir;
  std::unique_ptr<eval::RunState> state;
};

std::shared_ptr<PyWorld> makeWorld(const PyScenario& sc) {
  auto w = std::make_shared<PyWorld>();
  w->scenario = std::make_unique<const eval::Scenario>(sc.scenario);
  w->dir = std::make_unique<base::TempDir>("world");
  w->state.reset(new eval::RunState{*w->scenario, w->dir->path() / "run", false});
  py::gil_scoped_release release;
  eval::stages::world().run(*w->state);
  return w;
}

// View k of the scenario, or ValueError naming `what` and the views there are.
const eval::ViewSpec& viewOf(const eval::Scenario& sc, int k, const char* what) {
  if (k < 0 || k >= int(sc.views.size()))
    throw py::value_error(std::string(what) + ": no view " + std::to_string(k) + " (the scenario has " +
                          std::to_string(sc.views.size()) + ")");
  return sc.views[std::size_t(k)];
}

// The scan the scan stage makes: the scenario's sensor at T_WS (a raw scan, not unwrapped).
PyScan scanFrom(const PyWorld& w, const py::handle& pose, const std::optional<std::uint64_t>& seed) {
  const Eigen::Isometry3d T_WS = poseFromArray(pose, "World.scan: sensor_pose");
  const eval::Scenario& sc = *w.scenario;
  auto raw = std::make_shared<RawScan>();
  {
    py::gil_scoped_release release;
    const sim::ErimScanner scanner(*w.state->scene, sc.sensor);
    raw->image = scanner.scan(T_WS, seed ? *seed : base::viewSeed(sc.seed, 0)).image;
  }
  raw->sensor = sc.sensor;
  return PyScan{nullptr, std::move(raw)};
}

const eval::MapSpec& mapSpec(const eval::Scenario& sc, const char* what) {
  if (!sc.map)
    throw py::value_error(std::string(what) + ": the scenario has no map section (the grid and shadow method)");
  return *sc.map;
}

// A view of `image` (ranges as the sensor reported them) mapped as the map stage maps it: on the
// scenario's map grid, unwrapped, edges by its shadow method, locus at T_WS.
PyView mapImage(const perception::RangeImage& image, const perception::SensorModel& sensor,
                const Eigen::Isometry3d& T_WS, const eval::Scenario& sc, const char* what) {
  const eval::MapSpec& spec = mapSpec(sc, what);
  auto scan = std::make_shared<perception::ScanMap>();
  {
    py::gil_scoped_release release;
    *scan = perception::scanToMap(image, sensor, T_WS, spec.grid(), spec.scanToMapConfig());
  }
  return PyView{std::move(scan), std::make_shared<perception::RegistrationConfig>(eval::registrationConfig(sc))};
}

// map_scan: a raw scan mapped (scanToMap); a view's scan, already unwrapped, mapped again at
// another pose from its unwrapped image and edges (mapAtPose: the bits scanToMap gives there).
PyView mapScan(const PyScan& scan, const py::handle& pose, const PyScenario& sc) {
  const Eigen::Isometry3d T_WS = poseFromArray(pose, "map_scan: sensor_pose");
  if (scan.raw) return mapImage(scan.raw->image, scan.raw->sensor, T_WS, sc.scenario, "map_scan");
  const eval::MapSpec& spec = mapSpec(sc.scenario, "map_scan");
  auto out = std::make_shared<perception::ScanMap>();
  {
    py::gil_scoped_release release;
    out->image = scan.scan->image;
    out->image.T_WS = T_WS;
    out->sensor = scan.scan->sensor;
    out->unwrapped = scan.scan->unwrapped;
    out->edges = scan.scan->edges;
    out->map = perception::mapAtPose(*scan.scan, T_WS, spec.grid(), spec.scanToMapConfig().locus);
  }
  const auto config = std::make_shared<perception::RegistrationConfig>(eval::registrationConfig(sc.scenario));
  return PyView{std::move(out), config};
}

// map_range_image: a user's range image (rows × cols of the scenario's sensor, metres as the
// sensor reported them, NaN = no return) with the sensor's pixel angles. Copied: mapping unwraps
// a copy of the image in any case.
PyView mapRangeImage(const py::handle& range, const py::handle& pose, const PyScenario& sc) {
  const perception::SensorModel& sensor = sc.scenario.sensor;
  const auto a = py::array_t<float, py::array::c_style | py::array::forcecast>::ensure(range);
  if (!a || a.ndim() != 2 || a.shape(0) != sensor.rows || a.shape(1) != sensor.cols)
    throw py::value_error("map_range_image: range: expected a " + std::to_string(sensor.rows) + " x " +
                          std::to_string(sensor.cols) + " array of ranges (the scenario's sensor)");
  perception::RangeImage image =
      perception::RangeImage::blank(sensor.rows, sensor.cols, sensor.fov_v_rad, sensor.fov_h_rad);
  for (int r = 0; r < sensor.rows; ++r)
    for (int c = 0; c < sensor.cols; ++c) {
      const float v = a.at(r, c);
      if (!std::isnan(v) && !(v >= 0 && std::isfinite(v)))
        throw py::value_error("map_range_image: range[" + std::to_string(r) + ", " + std::to_string(c) + "] = " +
                              std::to_string(v) + ": expected a range >= 0 or NaN (no return)");
      image.range(r, c) = v;
    }
  return mapImage(image, sensor, poseFromArray(pose, "map_range_image: sensor_pose"), sc.scenario, "map_range_image");
}

// The composite of `views` as the merge stage builds it with `poses: true` (buildComposite; view 0
// the reference, every other view placed at its pose with no σ added): each at its own sensor pose,
// or at poses[k]; on the scenario's merge grid (its map grid without a merge section).
PyMap merge(const std::vector<PyView>& views, const PyScenario& sc, const std::optional<py::sequence>& poses) {
  const eval::Scenario& s = sc.scenario;
  mapSpec(s, "merge");
  if (views.empty()) throw py::value_error("merge: no views");
  if (poses && poses->size() != views.size())
    throw py::value_error("merge: " + std::to_string(poses->size()) + " poses for " + std::to_string(views.size()) +
                          " views");
  std::vector<const perception::ScanMap*> scans;
  std::vector<perception::ViewPlacement> placements;
  for (std::size_t k = 0; k < views.size(); ++k) {
    const std::string what = "merge: poses[" + std::to_string(k) + "]";
    const Eigen::Isometry3d T_WS = poses ? poseFromArray((*poses)[k], what.c_str()) : views[k].scan->image.T_WS;
    scans.push_back(views[k].scan.get());
    placements.push_back({k == 0 ? perception::PlacementHow::Reference : perception::PlacementHow::True, T_WS, {}});
  }
  const perception::MapGrid grid = s.merge ? s.merge->grid() : s.map->grid();
  auto composite = std::make_shared<perception::ElevationMap>();
  {
    py::gil_scoped_release release;
    *composite = perception::buildComposite(scans, placements, grid, eval::locusConfig(s));
  }
  // The views' scans stay with their View objects; the composite is its own.
  return PyMap{composite, composite.get()};
}

// ---- Footfalls on arrays.

// A 2-d array of T read in place when it is T with contiguous rows (any stride between them),
// else a C-contiguous copy in T (numpy's cast). `keep` holds whichever is read.
template <class T>
struct Layer {
  py::array keep;
  Eigen::Index stride = 0;  // between rows, in elements
  perception::RasterView<T> view() const {
    return {static_cast<const T*>(keep.data()), keep.shape(0), keep.shape(1), Eigen::OuterStride<>(stride)};
  }
};

template <class T>
Layer<T> layerOf(const py::handle& h, const char* name, py::ssize_t rows, py::ssize_t cols) {
  py::array a = py::array::ensure(h);
  const auto bad = [&] {
    return py::value_error(std::string("evaluate_footfalls: ") + name + ": expected a " + std::to_string(rows) + " x " +
                           std::to_string(cols) + " array (the elevation's shape)");
  };
  if (!a || a.ndim() != 2 || a.shape(0) != rows || a.shape(1) != cols) throw bad();
  const auto size = py::ssize_t(sizeof(T));
  const bool in_place = a.dtype().is(py::dtype::of<T>()) && (cols == 1 || a.strides(1) == size) &&
                        (rows == 1 || (a.strides(0) >= size * cols && a.strides(0) % size == 0));
  if (!in_place) a = py::array_t<T, py::array::c_style | py::array::forcecast>::ensure(a);
  if (!a) throw bad();
  return {a, rows > 1 ? Eigen::Index(a.strides(0) / size) : Eigen::Index(cols)};
}

// One method's scores (ambler.Footfall), with the grid to place its best cell, and the addresses
// the evaluation read its layers at (for checking that an input was not copied).
struct PyFootfall {
  std::shared_ptr<const perception::FootfallScores> scores;
  perception::MapGrid grid;
  py::dict read_from;
};

// The footfall section's region R, methods and foot (its defaults without a scenario), then the
// arguments: region (x0, x1, y0, y1), methods by name, the foot's keywords.
struct Foot {
  eval::FootfallSpec spec;
  perception::FootfallConfig config;
};
Foot footOf(const std::optional<std::vector<double>>& region, const std::optional<std::vector<std::string>>& methods,
            const std::optional<PyScenario>& scenario, const py::dict& keywords) {
  const bool section = scenario && scenario->scenario.footfall;
  Foot f{section ? *scenario->scenario.footfall : eval::FootfallSpec{}, {}};
  if (region) {
    if (region->size() != 4) throw py::value_error("evaluate_footfalls: region: expected (x0, x1, y0, y1) in metres");
    f.spec.x_m = {(*region)[0], (*region)[1]}, f.spec.y_m = {(*region)[2], (*region)[3]};
  } else if (!section) {
    throw py::value_error("evaluate_footfalls: region: expected (x0, x1, y0, y1), or a scenario with a footfall "
                          "section");
  }
  if (methods) {
    f.spec.methods.clear();
    for (const std::string& name : *methods) f.spec.methods.push_back(perception::footfallMethodFromName(name));
  }
  f.config.foot_diameter_m = f.spec.foot_diameter_m;
  if (section) f.config.sinkage_m = eval::soilSinkage(scenario->scenario);  // as the footfall stage sets it
  for (const auto& [key, value] : keywords) {
    const std::string k = py::cast<std::string>(key);
    double* target = k == "foot_diameter_m"            ? &f.config.foot_diameter_m
                     : k == "min_support_fraction"     ? &f.config.min_support_fraction
                     : k == "max_normal_deviation_deg" ? &f.config.max_normal_deviation_deg
                     : k == "moment_weight"            ? &f.config.moment_weight
                     : k == "max_unknown_fraction"     ? &f.config.max_unknown_fraction
                     : k == "sigma_k"                  ? &f.config.sigma_k
                     : k == "sinkage_m"                ? &f.config.sinkage_m
                     : k == "rigid_height_m"           ? &f.config.rigid_height_m
                     : k == "rigid_width_m"            ? &f.config.rigid_width_m
                                                       : nullptr;
    if (!target)
      throw py::value_error("evaluate_footfalls: unknown keyword '" + k + "' (foot_diameter_m, min_support_fraction, "
                            "max_normal_deviation_deg, moment_weight, max_unknown_fraction, sigma_k, sinkage_m, "
                            "rigid_height_m, rigid_width_m)");
    if (!py::isinstance<py::float_>(value) && !py::isinstance<py::int_>(value))
      throw py::value_error("evaluate_footfalls: " + k + ": expected a number");
    *target = py::cast<double>(value);
  }
  f.spec.foot_diameter_m = f.config.foot_diameter_m;  // the candidates lie a foot radius inside R
  return f;
}

std::vector<PyFootfall> evaluateFootfalls(const py::handle& elevation, const py::handle& sigma, const py::handle& state,
                                          double cell_m, double x_min_m, double y_max_m, const py::object& ceiling,
                                          const std::optional<std::vector<double>>& region,
                                          const std::optional<std::vector<std::string>>& methods,
                                          const std::optional<PyScenario>& scenario, const py::dict& keywords) {
  const py::array z0 = py::array::ensure(elevation);
  if (!z0 || z0.ndim() != 2 || z0.shape(0) < 1 || z0.shape(1) < 1)
    throw py::value_error("evaluate_footfalls: elevation: expected a 2-d array of heights");
  const py::ssize_t rows = z0.shape(0), cols = z0.shape(1);
  if (!(cell_m > 0) || !std::isfinite(cell_m) || !std::isfinite(x_min_m) || !std::isfinite(y_max_m))
    throw py::value_error("evaluate_footfalls: expected cell_m > 0 and a finite x_min_m and y_max_m");
  perception::MapGrid grid;
  grid.rows = int(rows), grid.cols = int(cols), grid.cell = cell_m, grid.x_min = x_min_m, grid.y_max = y_max_m;
  const Foot foot = footOf(region, methods, scenario, keywords);
  const Layer<float> z = layerOf<float>(z0, "elevation", rows, cols), s = layerOf<float>(sigma, "sigma", rows, cols);
  const Layer<std::uint8_t> st = layerOf<std::uint8_t>(state, "state", rows, cols);
  py::object ceil = ceiling;
  if (ceil.is_none()) {  // no shadow ceilings: NaN everywhere
    py::array_t<float> a({rows, cols});
    std::fill(a.mutable_data(), a.mutable_data() + rows * cols, std::numeric_limits<float>::quiet_NaN());
    ceil = a;
  }
  const Layer<float> c = layerOf<float>(ceil, "ceiling", rows, cols);
  const perception::ElevationLayers layers(grid, z.view(), s.view(), c.view(), st.view());
  const perception::CellRegion candidates = foot.spec.candidates(grid);
  std::vector<perception::FootfallScores> scores;
  {
    py::gil_scoped_release release;
    scores = perception::evaluateFootfalls(layers, candidates, foot.config, foot.spec.methods);
  }
  py::dict read_from;
  read_from["elevation"] = reinterpret_cast<std::uintptr_t>(layers.elevation.data());
  read_from["sigma"] = reinterpret_cast<std::uintptr_t>(layers.sigma.data());
  read_from["state"] = reinterpret_cast<std::uintptr_t>(layers.state.data());
  read_from["ceiling"] = reinterpret_cast<std::uintptr_t>(layers.ceiling.data());
  std::vector<PyFootfall> out;
  for (perception::FootfallScores& f : scores)
    out.push_back({std::make_shared<const perception::FootfallScores>(std::move(f)), grid, read_from});
  return out;
}

void bindFootfall(py::module_& m) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  py::class_<PyFootfall>(m, "Footfall", "One footfall method's scores over a map (lower is better) and its choice")
      .def_property_readonly("method",
                             [](const PyFootfall& f) { return std::string(perception::footfallMethodName(f.scores->method)); })
      .def_property_readonly("score",
                             [](py::object self) { return view(self.cast<PyFootfall&>().scores->score, self); })
      .def_property_readonly("tilt_deg", [](py::object self) -> py::object {
        const PyFootfall& f = self.cast<PyFootfall&>();
        return f.scores->tilt_deg.size() ? py::object(view(f.scores->tilt_deg, self)) : py::object(py::none());
      })
      .def_property_readonly("best", [](const PyFootfall& f) -> py::object {
        const auto& best = f.scores->best;
        return best ? py::object(py::make_tuple(best->x(), best->y())) : py::object(py::none());
      })
      .def_property_readonly("best_score", [](const PyFootfall& f) { return f.scores->best_score; })
      .def_property_readonly("x_m", [nan](const PyFootfall& f) {
        return f.scores->best ? f.grid.center(f.scores->best->x(), f.scores->best->y()).x() : nan;
      })
      .def_property_readonly("y_m", [nan](const PyFootfall& f) {
        return f.scores->best ? f.grid.center(f.scores->best->x(), f.scores->best->y()).y() : nan;
      })
      .def_readonly("read_from", &PyFootfall::read_from);
  m.def(
      "evaluate_footfalls",
      [](const py::handle& elevation, const py::handle& sigma, const py::handle& state, double cell_m, double x_min_m,
         double y_max_m, const py::object& ceiling, const std::optional<std::vector<double>>& region,
         const std::optional<std::vector<std::string>>& methods, const std::optional<PyScenario>& scenario,
         const py::kwargs& foot) {
        return evaluateFootfalls(elevation, sigma, state, cell_m, x_min_m, y_max_m, ceiling, region, methods, scenario,
                                 foot);
      },
      py::arg("elevation"), py::arg("sigma"), py::arg("state"), py::arg("cell_m"), py::arg("x_min_m"),
      py::arg("y_max_m"), py::kw_only(), py::arg("ceiling") = py::none(), py::arg("region") = py::none(),
      py::arg("methods") = py::none(), py::arg("scenario") = py::none(),
      "Every candidate foot centre of region R = (x0, x1, y0, y1) (the scenario's footfall.region by default) scored "
      "by each method, on the layers of a map (row 0 at y_max_m, column 0 at x_min_m); keywords foot_diameter_m, "
      "min_support_fraction, max_normal_deviation_deg, moment_weight, max_unknown_fraction, sigma_k set the foot, "
      "sinkage_m (the scenario's sand under its leg's load by default), rigid_height_m and rigid_width_m the soil. "
      "float32 / uint8 arrays with contiguous rows are read in place, others copied.");
}

}  // namespace

void bindStages(py::module_& m) {
  py::class_<PyWorld, std::shared_ptr<PyWorld>>(m, "World", "A scenario's world as the world stage builds it")
      .def("scan", &scanFrom, py::arg("sensor_pose"), py::arg("seed") = py::none(),
           "The ERIM scan from SENSOR_POSE (4 x 4, T_WS) with the scenario's sensor, as the sensor reports it; "
           "seed None: the scan stage's seed of view 0 (view_seed(k) for view k)")
      .def_property_readonly("views", [](const PyWorld& w) { return int(w.scenario->views.size()); })
      .def("view_pose", [](const PyWorld& w, int k) {
        const eval::ViewSpec& v = viewOf(*w.scenario, k, "World.view_pose");
        return poseArray(perception::sensorPose(v.xyz_m, v.rpy_rad));
      }, py::arg("k"), "The scenario's view K's sensor pose T_WS, as the scan stage takes it")
      .def("view_seed", [](const PyWorld& w, int k) {
        viewOf(*w.scenario, k, "World.view_seed");
        return base::viewSeed(w.scenario->seed, k);
      }, py::arg("k"), "The seed the scan stage scans view K with")
      .def("height", py::vectorize([](const PyWorld* w, double x, double y) {
        return w->state->truth->elevation(x, y).value_or(std::numeric_limits<double>::quiet_NaN());
      }), py::arg("x"), py::arg("y"), "The true height at (x, y) of the world (NaN off the terrain); arrays broadcast")
      .def("truth_map", [](const PyWorld& w) {
        const eval::MapSpec& spec = mapSpec(*w.scenario, "World.truth_map");
        auto map = std::make_shared<perception::ElevationMap>(w.state->truth->elevation(spec.grid()));
        return PyMap{map, map.get()};
      }, "The ground truth on the scenario's map grid (known everywhere the terrain is, sigma 0)")
      .def("visibility", [](const PyWorld& w, const py::object& sensor_pose) {
        const eval::MapSpec& spec = mapSpec(*w.scenario, "World.visibility");
        const Eigen::Isometry3d T = poseFromArray(sensor_pose, "World.visibility: sensor_pose");
        perception::Raster<std::uint8_t> vis;
        {
          py::gil_scoped_release release;
          vis = w.state->truth->visibility(w.state->truth->elevation(spec.grid()), T, w.scenario->sensor);
        }
        py::array_t<std::uint8_t> a({py::ssize_t(vis.rows()), py::ssize_t(vis.cols())});
        std::copy(vis.data(), vis.data() + vis.size(), a.mutable_data());
        return a;
      }, py::arg("sensor_pose"),
      "What the scenario's sensor at SENSOR_POSE (4 x 4, T_WS) sees of the true surface at each cell centre of the "
      "map grid, as the map metrics score it: uint8, 0 out of view, 1 visible, 2 hidden (a range shadow)");

  m.def("world", &makeWorld, py::arg("scenario"),
        "The scenario's world as the world stage builds it (ambler.ScenarioError for a view under the terrain)");
  m.def("map_scan", &mapScan, py::arg("scan"), py::arg("sensor_pose"), py::arg("scenario"),
        "The View of SCAN mapped at SENSOR_POSE as the map stage maps it (the scenario's map grid and shadows); "
        "a view's scan (unwrapped) is mapped again from its image and edges");
  m.def("map_range_image", &mapRangeImage, py::arg("range"), py::arg("sensor_pose"), py::arg("scenario"),
        "The View of a range image (the scenario's sensor's rows x cols, metres as reported, NaN: no return) "
        "mapped at SENSOR_POSE as the map stage maps a scan");
  m.def("merge", &merge, py::arg("views"), py::arg("scenario"), py::arg("poses") = py::none(),
        "The composite of VIEWS as the merge stage builds it with poses: true: view 0 the reference, each at its "
        "sensor pose (or POSES[k]), on the scenario's merge grid");
  bindFootfall(m);
}

}  // namespace ambler::python
