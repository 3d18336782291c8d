#pragma once
// 2-D Delaunay triangulation by sweep-hull: points sorted by distance from a seed triangle join a
// growing convex hull, each new triangle made Delaunay by edge flips. O(n log n), about a
// millisecond for the few thousand vertices of a map. The structure follows V. Agafonkin's
// Delaunator (© Mapbox, ISC licence), with its robust-orientation fallback.
#include <Eigen/Core>
#include <array>
#include <vector>

namespace ambler::perception {

// The triangles of the Delaunay triangulation of `points`, as index triples into `points`, all in
// the same rotational sense. None for fewer than three points or all collinear; of points closer
// than 2⁻⁵² apart only one is used. Same input, same output.
std::vector<std::array<int, 3>> delaunayTriangles(const std::vector<Eigen::Vector2d>& points);

}  // namespace ambler::perception
