#include "terrains/heightfield.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace ambler::terrains {

Heightfield::Heightfield(int rows, int cols, double cell_m, Eigen::Vector2d origin_m)
    : z_(HeightMatrix::Zero(rows, cols)), cell_(cell_m), origin_(origin_m) {
  if (rows < 2 || cols < 2) throw std::invalid_argument("Heightfield: needs at least 2x2 samples");
  if (!(cell_m > 0.0)) throw std::invalid_argument("Heightfield: cell must be positive");
}

std::optional<double> Heightfield::height(double x, double y) const {
  if (!contains(x, y)) return std::nullopt;
  const double u = (x - origin_.x()) / cell_;
  const double v = (y - origin_.y()) / cell_;
  const int c = std::clamp(int(std::floor(u)), 0, cols() - 2);
  const int r = std::clamp(int(std::floor(v)), 0, rows() - 2);
  const double fu = u - c;
  const double fv = v - r;
  const double h00 = z_(r, c), h01 = z_(r, c + 1), h10 = z_(r + 1, c), h11 = z_(r + 1, c + 1);
  // MuJoCo's triangles: {(r,c), (r+1,c+1), (r,c+1)} where fu >= fv, else {(r,c), (r+1,c+1), (r+1,c)}.
  if (fu >= fv) return h00 + fu * (h01 - h00) + fv * (h11 - h01);
  return h00 + fv * (h10 - h00) + fu * (h11 - h10);
}

}  // namespace ambler::terrains
