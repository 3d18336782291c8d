#pragma once
// A traverse's ground truth and its odometry (docs/traverse.md): the stops along the path, the
// body's true pose at each on the true terrain, and the steps odometry measures between them,
// with the scenario's seeded errors. Simulation only: the rover sees the measured steps.
#include <Eigen/Geometry>
#include <cstdint>
#include <vector>

#include "eval/scenario/scenario.hpp"
#include "perception/odometry.hpp"
#include "terrains/terrain.hpp"

namespace ambler::eval {

// A stop on the path: its position (x, y) and the heading of the path there (radians from world
// x; at a waypoint, the heading of the segment that leaves it; at the end, of the last segment).
struct PathStop {
  Eigen::Vector2d xy = Eigen::Vector2d::Zero();
  double heading_rad = 0;
  double distance_m = 0;  // along the path from its start
};

// The stops every spacing_m along the polyline, from its start; the last stop is the path's end
// when the length is a whole number of spacings (within 1e-9 m), else the last whole spacing.
// Throws std::invalid_argument for fewer than 2 waypoints, a non-finite waypoint, a zero-length segment
// (≤ 1e-9 m) or a spacing that is not positive and finite.
std::vector<PathStop> stopsAlongPath(const std::vector<Eigen::Vector2d>& waypoints, double spacing_m);

// The body's true pose at a stop: B's origin on the least-squares plane z = a·x + b·y + c fitted
// to the terrain's surface (terrains::surfaceAt) at the points of a polar grid over the disk of
// radius footprint_radius_m about the stop (the centre, and rings at r/3, 2r/3 and r of 6, 12 and 18
// points), B's z the plane's upward normal, B's x the path's heading projected on the plane along the
// vertical (so the pose's heading, perception::headingOf, is the stop's).
// Throws std::invalid_argument when a sample falls outside the terrain or the radius is not positive and finite.
Eigen::Isometry3d bodyPoseOnTerrain(const terrains::Terrain& terrain, const PathStop& stop, double footprint_radius_m);

// What odometry measures of each step k−1 → k (k ≥ 1; element 0 is a zero step): the exact step
// (perception::stepBetween) with TraverseOdometry's errors, drawn from base::Rng streams keyed by
// (seed, stop). All zero errors give the exact steps bit for bit. Throws std::invalid_argument for a
// negative or non-finite σ, a non-finite heading bias or a translation bias not above −1.
std::vector<perception::OdometryStep> measuredSteps(const std::vector<Eigen::Isometry3d>& true_WB,
                                                    const TraverseOdometry& odometry, std::uint64_t seed);

// Dead reckoning alone: the start pose, then each measured step integrated with the true tilt at
// each stop (the inclinometer). Throws std::invalid_argument unless there is one step per pose.
std::vector<Eigen::Isometry3d> deadReckoning(const std::vector<Eigen::Isometry3d>& true_WB,
                                             const std::vector<perception::OdometryStep>& steps);

}  // namespace ambler::eval
