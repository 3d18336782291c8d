#include "perception/range_image.hpp"

#include <limits>

#include "perception/sensor_geometry.hpp"

namespace ambler::perception {

RangeImage RangeImage::blank(int rows, int cols, double fov_v, double fov_h) {
  RangeImage image;
  image.range = Raster<float>::Constant(rows, cols, std::numeric_limits<float>::quiet_NaN());
  image.phi.resize(rows);
  image.theta.resize(cols);
  for (int r = 0; r < rows; ++r) image.phi[r] = rowAngle(r, rows, fov_v);
  for (int c = 0; c < cols; ++c) image.theta[c] = colAngle(c, cols, fov_h);
  return image;
}

int RangeImage::validCount() const {
  int n = 0;
  for (int r = 0; r < rows(); ++r)
    for (int c = 0; c < cols(); ++c) n += valid(r, c);
  return n;
}

Eigen::Vector3d RangeImage::pointSensor(int r, int c) const {
  return sphericalToCartesian(range(r, c), phi[r], theta[c]);
}

}  // namespace ambler::perception
