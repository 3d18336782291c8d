#pragma once
// The two-view Mars scene that the eval and integration tests run, as scenario YAML: Mars-like
// ground (fractal relief, rocks, craters) seen by two sensors looking 30° down along +y, the
// second a little further on and turned. The defaults: the demo's 20 × 20 m patch at 5 cm with
// its rocks (scenarios/demo.yaml) and three craters, view 0 the demo's, view 1 0.3 m aside,
// 0.8 m further on and turned 5°, mapped on 10 cm cells without the Cartesian baseline. small():
// an 8 × 8 m patch at 10 cm scanned at 32 × 128 pixels from 2 m, a run in a fraction of the
// time. Each field is YAML text, written into the scenario as given; an empty optional field
// leaves its key out, so the scenario's default holds.
#include <string>

namespace ambler::test {

// The ERIM with its noise, range quantisation and mixed pixels off.
inline constexpr const char* kNoiseFreeSensor = "{noise_k: 0, quantization_m: 0, mixed_pixels: false}";

struct TwoViewMars {
  std::string name = "two_view_mars";
  int seed = 5;
  std::string size_m = "[20, 20]";
  std::string cell_m = "0.05";
  std::string relief_m;  // optional
  std::string rocks = "{abundance_k: 0.08, min_diameter_m: 0.1, max_diameter_m: 1.0}";
  std::string craters = "{count: 3, min_diameter_m: 1.0, max_diameter_m: 4.0}";  // optional
  std::string sensor;  // optional: the ERIM's defaults
  std::string view0 = "{xyz_m: [0, -6, 3.0], rpy_deg: [0, -30, 0]}";
  std::string view1 = "{xyz_m: [0.3, -5.2, 3.0], rpy_deg: [0, -30, 5]}";
  // The map section, on 10 cm cells: no map (and no stage after it) without a region.
  std::string map_region = "{x_m: [-4, 4], y_m: [-2, 6]}";
  std::string map_baseline = "none";  // optional: the Cartesian baseline

  static TwoViewMars small() {
    TwoViewMars s;
    s.size_m = "[8, 8]";
    s.cell_m = "0.1";
    s.sensor = "{rows: 32, cols: 128}";
    s.view0 = "{xyz_m: [0, -3.5, 2.0], rpy_deg: [0, -30, 0]}";
    return s;
  }

  // The scenario text, each line ending in a newline, so that further sections (matching:,
  // merge:, ...) can be appended.
  std::string yaml() const {
    std::string y = "name: " + name + "\nseed: " + std::to_string(seed) + "\nterrain:\n  kind: mars\n";
    y += "  size_m: " + size_m + "\n  cell_m: " + cell_m + "\n";
    if (!relief_m.empty()) y += "  relief_m: " + relief_m + "\n";
    y += "  rocks: " + rocks + "\n";
    if (!craters.empty()) y += "  craters: " + craters + "\n";
    if (!sensor.empty()) y += "sensor: " + sensor + "\n";
    y += "views:\n  - " + view0 + "\n  - " + view1 + "\n";
    if (!map_region.empty()) {
      y += "map:\n  cell_m: 0.10\n  region: " + map_region + "\n";
      if (!map_baseline.empty()) y += "  baseline: " + map_baseline + "\n";
    }
    return y;
  }
};

}  // namespace ambler::test
