#pragma once
// Features of an elevation map (paper §4.1): points of high surface curvature, grouped into
// connected sets, each classified as a point, a line segment or a region (docs/matching.md,
// "Features"). Onboard code: it sees only the map.
#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "perception/elevation_map.hpp"
#include "perception/raster.hpp"

namespace ambler::perception {

enum class FeatureType : std::uint8_t { Point, Line, Region };

struct Feature {
  FeatureType type = FeatureType::Point;
  Eigen::Vector3d position = Eigen::Vector3d::Zero();   // map frame: the set's curvature-weighted centre
  Eigen::Vector3d direction = Eigen::Vector3d::Zero();  // lines: the unit axis (x ≥ 0 half); else 0
  double length_m = 0;    // lines: the set's extent along its axis
  double extent_m = 0;    // the largest distance of a cell of the set from its centre
  double strength = 0;    // mean |κ| of the set's cells, 1/m (κ the most convex principal curvature)
  int cells = 0;          // cells in the set
};

struct FeatureConfig {
  double curvature_min = 1.0;   // 1/m: a cell is a feature cell where the surface bends down at least this much
  double noise_sigmas = 3.0;    // and by more than this many σ of the curvature estimate
  int window_max = 4;           // the quadratic fit's largest half-width, cells
  int min_cells = 3;            // smaller sets are dropped
  double point_extent_m = 0.4;  // a set no more than this from its centre is a point
  double line_elongation = 3.0; // a longer set whose length / width reaches this is a line
};

// The surface's principal curvatures at each known cell, from a weighted least-squares quadratic
// z ≈ a + b·x + c·y + d·x² + e·x·y + f·y² over the known cells of a square window about it. The
// window's half-width is the smallest (1 … window_max cells) whose curvature σ, from the fit's
// covariance with the map's σ_z, is below curvature_min / noise_sigmas (the largest if none is).
// k_convex is the most convex principal curvature (the most negative, 1/m; a peak's or a
// ridge's), k_other the other; sigma their σ. NaN where a cell is not known or the fit has fewer
// than 6 cells or is singular.
struct CurvatureField {
  Raster<float> k_convex, k_other, sigma;
  Raster<std::uint8_t> half_width;  // the window used, cells (0: none)
};
CurvatureField principalCurvatures(const ElevationMap& map, const FeatureConfig& config = {});

// The map's features: cells whose k_convex ≤ −curvature_min and ≤ −noise_sigmas·σ, grouped into
// 8-connected sets of at least min_cells, each classified by its shape (docs/matching.md). Only
// convex features are taken (peaks, ridges, lips): concave creases (a step's foot, a crater's
// floor) lie where a sensor sees least. Deterministic, in raster order. Throws
// std::invalid_argument for a config out of range.
std::vector<Feature> extractFeatures(const ElevationMap& map, const FeatureConfig& config = {});

}  // namespace ambler::perception
