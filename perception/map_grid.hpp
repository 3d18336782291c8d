#pragma once
// The raster convention of every map: north-up like a GeoTIFF. Raster row r, column c is the cell
// centred at x = x_min + (c + 0.5)·cell, y = y_max − (r + 0.5)·cell.
#include <Eigen/Core>
#include <cmath>
#include <optional>

namespace ambler::perception {

struct MapGrid {
  double x_min = 0.0;
  double y_max = 0.0;
  double cell = 0.1;
  int rows = 0;
  int cols = 0;

  // The grid of `cell` covering [x0, x1] × [y0, y1] (rounded outwards to whole cells).
  static MapGrid covering(double x0, double x1, double y0, double y1, double cell) {
    MapGrid g;
    g.cell = cell;
    g.cols = std::max(1, int(std::ceil((x1 - x0) / cell - 1e-9)));
    g.rows = std::max(1, int(std::ceil((y1 - y0) / cell - 1e-9)));
    g.x_min = x0;
    g.y_max = y1;
    return g;
  }

  Eigen::Vector2d center(int r, int c) const {
    return {x_min + (c + 0.5) * cell, y_max - (r + 0.5) * cell};
  }
  // The cell containing (x, y), if inside.
  std::optional<Eigen::Vector2i> cellOf(double x, double y) const {
    const int c = int(std::floor((x - x_min) / cell));
    const int r = int(std::floor((y_max - y) / cell));
    if (r < 0 || r >= rows || c < 0 || c >= cols) return std::nullopt;
    return Eigen::Vector2i(r, c);
  }
  long cells() const { return long(rows) * cols; }
};

}  // namespace ambler::perception
