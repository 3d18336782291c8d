#pragma once
// Convex hulls of small point sets: the 3-D hull as a closed triangle mesh (for rock meshes, which
// MuJoCo collides by their hull anyway) and the area of a 2-D hull (a rock's plan-view footprint).
#include <Eigen/Core>
#include <vector>

namespace ambler::terrains {

struct HullMesh {
  std::vector<Eigen::Vector3d> vertices;  // only the hull's vertices, in input order
  std::vector<Eigen::Vector3i> faces;     // triangles, counter-clockwise seen from outside
};

// The convex hull of `points` (incremental, O(n²): meant for tens to hundreds of points).
// Points on or within ~1e-10 of the hull's surface (relative to its size) are not vertices.
// Throws std::invalid_argument if the points are (nearly) coplanar or fewer than four.
HullMesh convexHull(const std::vector<Eigen::Vector3d>& points);

// The area of the convex hull of 2-D points (0 for fewer than three or collinear points).
double convexHullArea(std::vector<Eigen::Vector2d> points);

// True if every vertex lies on or behind every face's plane, within `tolerance` (metres).
bool isConvex(const std::vector<Eigen::Vector3d>& vertices,
              const std::vector<Eigen::Vector3i>& faces, double tolerance = 1e-9);

// True if every edge is shared by exactly two faces with opposite directions (a closed,
// consistently oriented surface) and no face is degenerate (repeated vertex).
bool isClosed(const std::vector<Eigen::Vector3i>& faces);

}  // namespace ambler::terrains
