#pragma once
// A traverse's pictures (docs/traverse.md): the true, dead-reckoned and estimated paths over the
// shaded true terrain of the corridor, and the position error against distance travelled.
#include <Eigen/Geometry>
#include <filesystem>
#include <string>
#include <vector>

#include "perception/elevation_map.hpp"

namespace ambler::eval {

// traverse/paths.png: the three sensor paths (true black, dead reckoning red, estimate blue) over
// the shaded relief of `truth` (the corridor's true map), a dot at every stop.
void writePathsPicture(const std::filesystem::path& file, const perception::ElevationMap& truth,
                       const std::vector<Eigen::Isometry3d>& true_WS, const std::vector<Eigen::Isometry3d>& believed_WS,
                       const std::vector<Eigen::Isometry3d>& estimated_WS, const std::string& title);

// traverse/error.png: ‖position − true position‖ against distance along the true path, for the
// estimate and for dead reckoning alone.
void writeErrorPlot(const std::filesystem::path& file, const std::vector<double>& distance_m,
                    const std::vector<Eigen::Isometry3d>& true_WS, const std::vector<Eigen::Isometry3d>& believed_WS,
                    const std::vector<Eigen::Isometry3d>& estimated_WS, const std::string& title);

}  // namespace ambler::eval
