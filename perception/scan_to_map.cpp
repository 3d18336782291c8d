#include "perception/scan_to_map.hpp"

#include <stdexcept>

namespace ambler::perception {

ScanMap scanToMap(const RangeImage& measured, const SensorModel& sensor, const Eigen::Isometry3d& T_WS,
                  const MapGrid& grid, const ScanToMapConfig& config) {
  validate(sensor);
  if (grid.rows <= 0 || grid.cols <= 0 || !(grid.cell > 0))
    throw std::invalid_argument("scanToMap: the grid is empty");
  if (!grid.gravityAligned()) throw std::invalid_argument("scanToMap: the map frame is not gravity-aligned");
  ScanMap out;
  out.image = measured;
  out.image.T_WS = T_WS;
  out.sensor = sensor;
  if (sensor.ambiguity_m > 0) out.unwrapped = unwrapRanges(out.image, sensor);
  if (config.shadows != ShadowMethod::None) out.edges = detectRangeEdges(out.image, sensor, config.gnc);
  const LocusMapper mapper(out.image, sensor, out.edges ? &*out.edges : nullptr, config.locus, grid.T_WM);
  out.map = mapper.map(grid);
  return out;
}

ElevationMap mapAtPose(const ScanMap& scan, const Eigen::Isometry3d& T_WS, const MapGrid& grid,
                       const LocusConfig& locus) {
  RangeImage image = scan.image;
  image.T_WS = T_WS;
  const LocusMapper mapper(image, scan.sensor, scan.edges ? &*scan.edges : nullptr, locus, grid.T_WM);
  return mapper.map(grid);
}

}  // namespace ambler::perception
