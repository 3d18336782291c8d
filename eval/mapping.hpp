#pragma once
// The onboard mapping of one scan as a scenario asks for it: unwrap, detect occluding edges, the
// locus map, and the Cartesian baseline.
#include <optional>

#include "eval/scenario.hpp"
#include "perception/cartesian_mapper.hpp"
#include "perception/elevation_map.hpp"
#include "perception/locus_mapper.hpp"
#include "perception/range_edges.hpp"

namespace ambler::eval {

struct MapBuild {
  perception::RangeImage image;                 // the measured image after unwrapping
  long unwrapped = 0;                           // pixels moved by a multiple of the interval
  std::optional<perception::EdgeMask> edges;    // shadows: gnc
  perception::ElevationMap locus;
  double locus_seconds = 0;                     // unwrap + edges + locus map
};

perception::MapGrid mapGrid(const MapSpec& spec);
perception::LocusConfig locusConfig(const MapSpec& map, const SensorSpec& sensor);

// Unwraps, finds edges (if asked) and builds the locus map of `measured` on the spec's grid, with
// locusConfig(map, sensor) or, if given, `config`.
MapBuild buildLocusMap(const perception::RangeImage& measured, const MapSpec& map, const SensorSpec& sensor,
                       const perception::LocusConfig* config = nullptr);

// The Cartesian baseline with the given gap filling on the same grid.
perception::ElevationMap buildCartesianMap(const perception::RangeImage& image, const MapSpec& map,
                                           perception::GapFill fill);

}  // namespace ambler::eval
