#pragma once
// A regular grid of heights, triangulated exactly as MuJoCo 2.2.2 triangulates an hfield.
#include <Eigen/Core>
#include <optional>

namespace ambler::terrains {

using HeightMatrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

// Sample (r, c) sits at x = origin.x + c·cell, y = origin.y + r·cell: row 0 is the smallest y,
// as in MuJoCo's hfield data. Each cell is split along the diagonal (r,c)–(r+1,c+1), so the
// surface is the piecewise-linear interpolant on those two triangles.
class Heightfield {
 public:
  Heightfield() = default;
  // Throws std::invalid_argument for fewer than 2×2 samples or a non-positive cell.
  Heightfield(int rows, int cols, double cell_m, Eigen::Vector2d origin_m);

  int rows() const { return int(z_.rows()); }
  int cols() const { return int(z_.cols()); }
  double cell() const { return cell_; }
  const Eigen::Vector2d& origin() const { return origin_; }
  double xMin() const { return origin_.x(); }
  double yMin() const { return origin_.y(); }
  double xMax() const { return origin_.x() + (cols() - 1) * cell_; }
  double yMax() const { return origin_.y() + (rows() - 1) * cell_; }

  double& at(int r, int c) { return z_(r, c); }
  double at(int r, int c) const { return z_(r, c); }
  HeightMatrix& heights() { return z_; }
  const HeightMatrix& heights() const { return z_; }
  Eigen::Vector2d position(int r, int c) const {
    return origin_ + cell_ * Eigen::Vector2d(c, r);
  }
  bool contains(double x, double y) const {
    return x >= xMin() && x <= xMax() && y >= yMin() && y <= yMax();
  }

  // The height of the triangulated surface at (x, y); nullopt outside the grid.
  std::optional<double> height(double x, double y) const;

  double minHeight() const { return z_.minCoeff(); }
  double maxHeight() const { return z_.maxCoeff(); }

 private:
  HeightMatrix z_;
  double cell_ = 0.0;
  Eigen::Vector2d origin_ = Eigen::Vector2d::Zero();
};

}  // namespace ambler::terrains
