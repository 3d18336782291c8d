#pragma once
// What the Python module's files share (docs/python.md): numpy views of C++ rasters kept alive by
// their owner, and the objects the module hands out for a map, a scan and a view (a scan with the
// map made from it). ambler_module.cpp defines the module and the whole-run API; registration.cpp
// registration, the basin and the matching experiment with a user's own method; stages.cpp the
// stages one by one.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <Eigen/Geometry>
#include <memory>
#include <optional>

#include "eval/run/pair_registration.hpp"
#include "eval/scenario/scenario.hpp"
#include "perception/elevation_map.hpp"
#include "perception/raster.hpp"
#include "perception/registration.hpp"
#include "perception/scan_to_map.hpp"

namespace ambler::python {

namespace py = pybind11;

// A read-only numpy array viewing `r`'s memory; `base` keeps that memory alive.
template <class T>
py::array view(const perception::Raster<T>& r, const py::object& base) {
  py::array a(py::dtype::of<T>(), {py::ssize_t(r.rows()), py::ssize_t(r.cols())},
              {py::ssize_t(sizeof(T) * r.cols()), py::ssize_t(sizeof(T))}, r.data(), base);
  a.attr("setflags")(py::arg("write") = false);
  return a;
}

// A 4 × 4 numpy array (a copy) of a pose, and back (throws ValueError naming `what` for a shape
// other than 4 × 4, a non-finite entry or a rotation part that is not a rotation).
py::array_t<double> poseArray(const Eigen::Isometry3d& T);
Eigen::Isometry3d poseFromArray(const py::handle& a, const char* what);

// A loaded scenario (ambler.Scenario; relative paths in it resolve against its file).
struct PyScenario {
  eval::Scenario scenario;
};

// A map: its rasters as read-only views (ambler.Map). `owner` keeps `map` alive.
struct PyMap {
  std::shared_ptr<const void> owner;
  const perception::ElevationMap* map = nullptr;
};

// A scan as the sensor reported it (stages.cpp: World.scan): its ranges still folded by the
// ambiguity interval, no edges yet, and the sensor model it was taken with.
struct RawScan {
  perception::RangeImage image;
  perception::SensorModel sensor;
};

// A scan as the rover has it (ambler.Scan), without the pose it was taken from (a method must not
// see where view J truly is): a view's (`scan`: the range image unwrapped, its edges and the sensor
// model) or, from World.scan, one not mapped yet (`raw`). One of the two is set.
struct PyScan {
  std::shared_ptr<const perception::ScanMap> scan;  // image.T_WS is not shown
  std::shared_ptr<const RawScan> raw;               // image.T_WS is not shown
  const perception::RangeImage& image() const { return scan ? scan->image : raw->image; }
  const perception::SensorModel& sensor() const { return scan ? scan->sensor : raw->sensor; }
};

// A view (ambler.View): a scan with the locus map made from it at `scan->image.T_WS` (its
// `sensor_pose`), and the registration configuration registration uses for it (the scenario's, or
// in a basin the basin's, whose prior covers the grid).
struct PyView {
  std::shared_ptr<const perception::ScanMap> scan;
  std::shared_ptr<const perception::RegistrationConfig> config;
};

// The user's own methods of a `custom` argument ({name: fn(map_i, scan_j, T_initial)}), as the
// project runs them (registration.cpp). Throws ValueError for a bad name or a value not callable.
eval::CustomMethods customMethodsFrom(const std::optional<py::dict>& custom);

// Binds Map, Scan and View (ambler_module.cpp), the registration API (registration.cpp) and the
// stages (stages.cpp).
void bindTypes(py::module_& m);
void bindRegistration(py::module_& m);
void bindStages(py::module_& m);

}  // namespace ambler::python
