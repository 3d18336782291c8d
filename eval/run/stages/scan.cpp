// The scan stage: one range image per view from the ERIM emulator at the view's true pose, scored
// against the true ranges; scans/view_<k>_range.tiff, _meta.json, .ply and .png.
#include <cstdio>

#include "base/random.hpp"
#include "eval/pictures/figures.hpp"
#include "eval/scenario/io.hpp"
#include "eval/score/metrics.hpp"
#include "eval/run/runner.hpp"
#include "eval/scenario/scan_reader.hpp"
#include "eval/run/stages.hpp"
#include "perception/sensor_geometry.hpp"

namespace ambler::eval::stages {

namespace {

std::vector<Eigen::Vector3f> returnsInWorld(const perception::RangeImage& img) {
  std::vector<Eigen::Vector3f> pts;
  for (int r = 0; r < img.rows(); ++r)
    for (int c = 0; c < img.cols(); ++c)
      if (img.valid(r, c)) pts.push_back(img.pointWorld(r, c).cast<float>());
  return pts;
}

void run(RunState& s) {
  const Scenario& sc = s.scenario;
  const perception::SensorModel& sensor = sc.sensor;
  std::filesystem::create_directories(s.out / "scans");
  const sim::ErimScanner scanner(*s.scene, sensor);
  s.metrics["scan"] = nlohmann::ordered_json::array();
  s.views.resize(sc.views.size());
  for (int k = 0; k < int(sc.views.size()); ++k) {
    const ViewSpec& v = sc.views[k];
    ViewState& view = s.views[k];
    view.T_WS = perception::sensorPose(v.xyz_m, v.rpy_rad);
    base::Stopwatch t;
    view.scan = scanner.scan(view.T_WS, base::viewSeed(sc.seed, k));
    s.addTime("scan", t.seconds());
    const sim::Scan& scan = *view.scan;
    const std::filesystem::path base = s.out / "scans" / viewName(k);
    writeScan(base, scan.image, v);
    writePly(base.string() + ".ply", returnsInWorld(scan.image));
    writePng(base.string() + ".png",
             rangePicture(scan.image, sensor.max_range_m, sc.name + ": " + viewName(k) + " range"));
    const ScanMetrics m = scanMetrics(scan, sensor);
    s.metrics["scan"].push_back(toJson(m, k));
    char line[160];
    std::snprintf(line, sizeof line, "scan      %s: %dx%d, %.1f%% returned, range error RMS %.4f m",
                  viewName(k).c_str(), sensor.rows, sensor.cols, 100.0 * m.valid_fraction, m.range_error_rms_m);
    s.say(line);
  }
}

}  // namespace

Stage scan() {
  return {"scan", [](const Scenario& sc) { return !sc.traverse; }, run};  // a traverse scans its stops
}

}  // namespace ambler::eval::stages
