#pragma once
// From one range image to an elevation map, as the rover would run it: unwrap the ranges the
// ambiguity interval folded, find the occluding edges that bound range shadows (GNC), and map by
// the locus algorithm on the asked grid (docs/architecture.md, "The map stage").
#include <Eigen/Geometry>
#include <cstdint>
#include <optional>

#include "perception/elevation_map.hpp"
#include "perception/locus_mapper.hpp"
#include "perception/range_edges.hpp"
#include "perception/range_image.hpp"
#include "perception/sensor_model.hpp"

namespace ambler::perception {

// How range shadows are found.
enum class ShadowMethod : std::uint8_t {
  None,       // no edge detection: every crossing is taken as a surface
  Gnc,        // occluding edges by graduated non-convexity (range_edges.hpp)
  GncBridge,  // the same edges less the occlusions too shallow to matter, which are bridged with a σ
              // that covers what they may hide (docs/range_edges.md, "Shallow occlusions")
};

// The edge detector's and the mapper's settings for a shadow method: Gnc leaves both as given;
// GncBridge sets GncConfig::occlusion_depth_k = kBridgeDepthK, LocusConfig::bridge_sigma and
// far_gap_scanlines = 1.
// (Inline: the scenario reader calls it, and links no perception code.)
constexpr double kBridgeDepthK = 3.0;
inline void applyShadowMethod(ShadowMethod m, GncConfig& gnc, LocusConfig& locus) {
  if (m != ShadowMethod::GncBridge) return;
  gnc.occlusion_depth_k = kBridgeDepthK;
  locus.bridge_sigma = true;
  locus.far_gap_scanlines = 1.0;
}

struct ScanToMapConfig {
  ShadowMethod shadows = ShadowMethod::Gnc;
  LocusConfig locus;
  GncConfig gnc;
};

// One scan's map and what was made on the way.
struct ScanMap {
  RangeImage image;                              // the measured image after unwrapping, at the pose used
  SensorModel sensor;                            // the model it was taken with
  long unwrapped = 0;                            // pixels moved by a multiple of the interval
  std::optional<Raster<std::uint8_t>> edges;     // the edge mask (GNC, with or without bridging)
  ElevationMap map;                              // on the asked grid, in its frame
};

// The map of `measured`, taken by `sensor` from pose T_WS (the pose the rover believes; it
// replaces the image's), on `grid` (any gravity-aligned frame). Deterministic: the same inputs
// give the same bits on any ISA and thread count. Throws std::invalid_argument for a sensor model
// out of range or a grid that is empty or not gravity-aligned.
ScanMap scanToMap(const RangeImage& measured, const SensorModel& sensor, const Eigen::Isometry3d& T_WS,
                  const MapGrid& grid, const ScanToMapConfig& config = {});

// The same scan mapped again from another pose (a believed or corrected one) on any grid: the
// unwrapped image and its edges do not depend on the pose, so only the locus map is made again.
// Gives the bits scanToMap gives for the measured image at that pose.
ElevationMap mapAtPose(const ScanMap& scan, const Eigen::Isometry3d& T_WS, const MapGrid& grid,
                       const LocusConfig& locus);

}  // namespace ambler::perception
