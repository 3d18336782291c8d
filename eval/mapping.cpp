#include "eval/mapping.hpp"

#include <algorithm>
#include <chrono>

namespace ambler::eval {

perception::MapGrid mapGrid(const MapSpec& spec) {
  return perception::MapGrid::covering(spec.x_m[0], spec.x_m[1], spec.y_m[0], spec.y_m[1], spec.cell_m);
}

perception::LocusConfig locusConfig(const MapSpec& map, const SensorSpec& sensor) {
  perception::LocusConfig c;
  c.epsilon_rad = map.epsilon_rad;
  c.noise_k = sensor.noise_k;
  c.quantization_m = sensor.quantization_m;
  return c;
}

MapBuild buildLocusMap(const perception::RangeImage& measured, const MapSpec& map, const SensorSpec& sensor,
                       const perception::LocusConfig* config) {
  const auto t0 = std::chrono::steady_clock::now();
  MapBuild b;
  b.image = measured;
  // The onboard code knows its sensor's noise model; zero noise still leaves float rounding, so
  // the model keeps a floor of one millimetre-scale count.
  perception::RangeNoise noise;
  noise.k = sensor.noise_k;
  noise.quantization_m = std::max(sensor.quantization_m, 1e-3);
  if (sensor.ambiguity_m > 0) b.unwrapped = perception::unwrapRanges(b.image, sensor.ambiguity_m, noise);
  if (map.shadows == "gnc") {
    perception::GncConfig gnc;
    gnc.noise = noise;
    b.edges = perception::detectRangeEdges(b.image, gnc);
  }
  const perception::LocusMapper mapper(b.image, b.edges ? &*b.edges : nullptr,
                                       config ? *config : locusConfig(map, sensor));
  b.locus = mapper.map(mapGrid(map));
  b.locus_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return b;
}

perception::ElevationMap buildCartesianMap(const perception::RangeImage& image, const MapSpec& map,
                                           perception::GapFill fill) {
  perception::CartesianConfig c;
  c.gap_fill = fill;
  return perception::cartesianMap(image, mapGrid(map), c);
}

}  // namespace ambler::eval
