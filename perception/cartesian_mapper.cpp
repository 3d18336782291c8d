#include "perception/cartesian_mapper.hpp"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <limits>
#include <stdexcept>
#include <vector>

#include "perception/delaunay.hpp"

namespace ambler::perception {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr float kNaNf = std::numeric_limits<float>::quiet_NaN();

void checkGrid(const MapGrid& grid) {
  if (grid.rows <= 0 || grid.cols <= 0 || !(grid.cell > 0.0) || !std::isfinite(grid.cell))
    throw std::invalid_argument("cartesianMap: the map grid is empty or its cell size is not > 0");
  if (!grid.gravityAligned()) throw std::invalid_argument("cartesianMap: the map frame is not gravity-aligned");
}

// `grid` grown by `pad` cells on every side.
MapGrid padded(const MapGrid& grid, int pad) {
  return {grid.x_min - pad * grid.cell, grid.y_max + pad * grid.cell, grid.cell, grid.rows + 2 * pad,
          grid.cols + 2 * pad, grid.T_WM};
}

using Mask = Raster<bool>;

// Nearest marked cell of every cell, exact in the Euclidean metric: for each column the nearest
// marked row (two sweeps), then per row the lower envelope of the parabolas (c − c')² + Δr(c')²
// (Felzenszwalb & Huttenlocher 2012). Returns the linear index of the nearest marked cell, −1 where
// the grid has none. Linear time whatever the distance.
std::vector<long> nearestMarked(const Mask& marked) {
  const int R = int(marked.rows()), C = int(marked.cols());
  std::vector<int> near_row(std::size_t(R) * C, -1);
  for (int c = 0; c < C; ++c) {
    int last = -1;
    for (int r = 0; r < R; ++r) {
      if (marked(r, c)) last = r;
      near_row[std::size_t(r) * C + c] = last;
    }
    int next = -1;
    for (int r = R - 1; r >= 0; --r) {
      if (marked(r, c)) next = r;
      int& best = near_row[std::size_t(r) * C + c];
      if (next >= 0 && (best < 0 || next - r < r - best)) best = next;  // a tie keeps the upper row
    }
  }
  std::vector<long> nearest(std::size_t(R) * C, -1);
  std::vector<int> v(C);          // columns whose parabolas form the envelope
  std::vector<double> z(C + 1);   // where each envelope parabola starts
  std::vector<double> f(C);
  for (int r = 0; r < R; ++r) {
    const int* rows_of = &near_row[std::size_t(r) * C];
    int k = -1;
    for (int q = 0; q < C; ++q) {
      if (rows_of[q] < 0) continue;  // no marked cell in this column
      f[q] = double(r - rows_of[q]) * (r - rows_of[q]);
      double s = -std::numeric_limits<double>::infinity();
      while (k >= 0) {
        s = ((f[q] + double(q) * q) - (f[v[k]] + double(v[k]) * v[k])) / (2.0 * (q - v[k]));
        if (s > z[k]) break;
        --k;
      }
      if (k < 0) s = -std::numeric_limits<double>::infinity();
      v[++k] = q;
      z[k] = s;
      z[k + 1] = std::numeric_limits<double>::infinity();
    }
    if (k < 0) continue;  // nothing marked anywhere
    for (int c = 0, j = 0; c < C; ++c) {
      while (z[j + 1] < c) ++j;
      nearest[std::size_t(r) * C + c] = long(rows_of[v[j]]) * C + v[j];
    }
  }
  return nearest;
}

void fillNearest(const CartesianBins& bins, double max_gap_m, ElevationMap& map) {
  const MapGrid& grid = map.grid();
  const std::vector<long> nearest = nearestMarked((bins.count.array() > 0).matrix());
  const double reach = max_gap_m / grid.cell + 1e-9;  // in cells; the slack absorbs rounding only
  for (int r = 0; r < grid.rows; ++r)
    for (int c = 0; c < grid.cols; ++c) {
      const long n = nearest[std::size_t(r) * grid.cols + c];
      if (bins.count(r, c) > 0 || n < 0) continue;
      const long nr = n / grid.cols, nc = n % grid.cols;
      if (double(nr - r) * (nr - r) + double(nc - c) * (nc - c) > reach * reach) continue;
      map.setKnown(r, c, float(bins.mean_z(nr, nc)), kNaNf);
    }
}

void fillLinear(const CartesianBins& bins, double max_gap_m, ElevationMap& map) {
  const MapGrid& grid = map.grid();
  // Vertices in cell units (u right, v down; cell (r, c) centred at (c + ½, r + ½)).
  struct Vertex {
    double u, v, z;
  };
  // A binned cell all of whose neighbours within 2√2 + √2/2 cells are binned too cannot be a vertex
  // of a triangle that covers an empty cell: every disk of diameter 2√2 through its centroid holds
  // a whole binned cell, hence a centroid, so its Delaunay triangles stay inside that disk. Leaving
  // such cells out (most of the near field) changes no triangle that fills a cell.
  constexpr double kInner2 = 4.0 * 4.0;  // (2√2 + √2/2)² ≈ 12.5, rounded up
  const std::vector<long> nearest_empty = nearestMarked((bins.count.array() == 0).matrix());
  const auto needed = [&](int r, int c) {
    if (r < 4 || c < 4 || r >= grid.rows - 4 || c >= grid.cols - 4) return true;  // no cells beyond
    const long n = nearest_empty[std::size_t(r) * grid.cols + c];
    if (n < 0) return false;
    const double dr = double(n / grid.cols - r), dc = double(n % grid.cols - c);
    return dr * dr + dc * dc <= kInner2;
  };
  std::vector<Vertex> vertices;
  std::vector<Eigen::Vector2d> uv;
  for (int r = 0; r < grid.rows; ++r)
    for (int c = 0; c < grid.cols; ++c) {
      if (bins.count(r, c) == 0 || !needed(r, c)) continue;
      vertices.push_back({(bins.mean_x(r, c) - grid.x_min) / grid.cell,
                          (grid.y_max - bins.mean_y(r, c)) / grid.cell, bins.mean_z(r, c)});
      uv.emplace_back(vertices.back().u, vertices.back().v);
    }

  const double longest = max_gap_m / grid.cell + std::sqrt(2.0);  // in cells
  const auto len2 = [](const Vertex& p, const Vertex& q) {
    return (p.u - q.u) * (p.u - q.u) + (p.v - q.v) * (p.v - q.v);
  };
  for (const auto& tri : delaunayTriangles(uv)) {
    const Vertex &a = vertices[tri[0]], &b = vertices[tri[1]], &c = vertices[tri[2]];
    if (std::max({len2(a, b), len2(b, c), len2(c, a)}) > longest * longest) continue;  // spans a hole
    const double det = (b.u - a.u) * (c.v - a.v) - (c.u - a.u) * (b.v - a.v);
    if (std::abs(det) < 1e-12) continue;  // degenerate: no interior
    const int c0 = std::max(0, int(std::ceil(std::min({a.u, b.u, c.u}) - 0.5)));
    const int c1 = std::min(grid.cols - 1, int(std::floor(std::max({a.u, b.u, c.u}) - 0.5)));
    const int r0 = std::max(0, int(std::ceil(std::min({a.v, b.v, c.v}) - 0.5)));
    const int r1 = std::min(grid.rows - 1, int(std::floor(std::max({a.v, b.v, c.v}) - 0.5)));
    for (int r = r0; r <= r1; ++r)
      for (int col = c0; col <= c1; ++col) {
        if (map.stateAt(r, col) != CellState::Unseen) continue;  // binned, or filled already
        const double pu = col + 0.5, pv = r + 0.5;
        const double wb = ((pu - a.u) * (c.v - a.v) - (c.u - a.u) * (pv - a.v)) / det;
        const double wc = ((b.u - a.u) * (pv - a.v) - (pu - a.u) * (b.v - a.v)) / det;
        const double wa = 1.0 - wb - wc;
        constexpr double kOnEdge = -1e-9;  // centres on a shared edge belong to the first triangle
        if (wa < kOnEdge || wb < kOnEdge || wc < kOnEdge) continue;
        map.setKnown(r, col, float(wa * a.z + wb * b.z + wc * c.z), kNaNf);
      }
  }
}

// Eq. 1 for every pixel, rotated into the world, binned into `grid` grown by `pad` cells. The cell
// is found with the grid's own arithmetic (as MapGrid::cellOf), so a padded binning agrees bit for
// bit with binPoints inside the grid. One thread, in pixel order: floating-point sums depend on
// their order, and the whole image takes a fraction of a millisecond.
CartesianBins binPadded(const RangeImage& image, const MapGrid& unpadded, int pad) {
  const MapGrid grid = padded(unpadded, pad);
  const int rows = image.rows(), cols = image.cols();
  std::vector<double> sin_phi(rows), cos_phi(rows), sin_theta(cols), cos_theta(cols);
  for (int r = 0; r < rows; ++r) sin_phi[r] = std::sin(image.phi[r]), cos_phi[r] = std::cos(image.phi[r]);
  for (int c = 0; c < cols; ++c)
    sin_theta[c] = std::sin(image.theta[c]), cos_theta[c] = std::cos(image.theta[c]);
  // The sensor's pose in the map frame (the world's bits when the frame is the world).
  const Eigen::Isometry3d T_MS =
      grid.inWorldFrame() ? image.T_WS : Eigen::Isometry3d(grid.T_WM.inverse() * image.T_WS);
  const Eigen::Matrix3d R = T_MS.linear();
  const Eigen::Vector3d t = T_MS.translation();

  struct Sums {  // z about the cell's first z, so that the spread needs no cancelling of large sums
    int n = 0;
    double x = 0, y = 0, z0 = 0, dz = 0, dz2 = 0;
  };
  std::vector<Sums> sums(grid.cells());
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < cols; ++c) {
      const float rho = image.range(r, c);
      if (!std::isfinite(rho)) continue;
      const Eigen::Vector3d beam(sin_theta[c], cos_phi[r] * cos_theta[c], sin_phi[r] * cos_theta[c]);
      const Eigen::Vector3d p = R * (double(rho) * beam) + t;
      const double u = std::floor((p.x() - unpadded.x_min) / grid.cell) + pad;
      const double v = std::floor((unpadded.y_max - p.y()) / grid.cell) + pad;
      if (!(u >= 0 && u < grid.cols && v >= 0 && v < grid.rows)) continue;
      Sums& s = sums[std::size_t(v) * grid.cols + std::size_t(u)];
      if (s.n++ == 0) s.z0 = p.z();
      const double dz = p.z() - s.z0;
      s.x += p.x(), s.y += p.y(), s.dz += dz, s.dz2 += dz * dz;
    }

  CartesianBins bins;
  bins.count.resize(grid.rows, grid.cols);
  bins.mean_x.resize(grid.rows, grid.cols), bins.mean_y.resize(grid.rows, grid.cols);
  bins.mean_z.resize(grid.rows, grid.cols), bins.sem_z.resize(grid.rows, grid.cols);
  for (long i = 0; i < grid.cells(); ++i) {
    const Sums& s = sums[i];
    bins.count.data()[i] = s.n;
    bins.mean_x.data()[i] = s.n > 0 ? s.x / s.n : kNaN;
    bins.mean_y.data()[i] = s.n > 0 ? s.y / s.n : kNaN;
    bins.mean_z.data()[i] = s.n > 0 ? s.z0 + s.dz / s.n : kNaN;
    if (s.n < 2) {
      bins.sem_z.data()[i] = kNaN;  // one point has no spread
      continue;
    }
    const double m2 = std::max(0.0, s.dz2 - s.dz * s.dz / s.n);  // Σ(z − z̄)²
    bins.sem_z.data()[i] = std::sqrt(m2 / (double(s.n - 1) * s.n));
  }
  return bins;
}

}  // namespace

CartesianBins binPoints(const RangeImage& image, const MapGrid& grid) {
  checkGrid(grid);
  return binPadded(image, grid, 0);
}

ElevationMap cartesianMap(const RangeImage& image, const MapGrid& grid, const CartesianConfig& config) {
  checkGrid(grid);
  if (!(config.max_gap_m >= 0.0) || !std::isfinite(config.max_gap_m))
    throw std::invalid_argument("cartesianMap: max_gap_m must be finite and >= 0");
  // Points just outside the grid still serve the cells at its border, as the locus algorithm's
  // would: bin into a margin as wide as a fill can reach, fill, then crop.
  // The margin is capped at the map's own size, which bounds memory whatever max_gap_m is.
  const bool linear = config.gap_fill == GapFill::Linear;
  const double reach = config.max_gap_m / grid.cell + (linear ? std::sqrt(2.0) : 0.0);  // in cells
  const double limit = double(grid.rows) + grid.cols;
  const int pad = config.gap_fill == GapFill::None ? 0 : int(std::min(std::ceil(reach), limit)) + 1;
  const CartesianBins bins = binPadded(image, grid, pad);
  ElevationMap work(padded(grid, pad));
  for (int r = 0; r < work.grid().rows; ++r)
    for (int c = 0; c < work.grid().cols; ++c)
      if (bins.count(r, c) > 0) work.setKnown(r, c, float(bins.mean_z(r, c)), float(bins.sem_z(r, c)));
  switch (config.gap_fill) {
    case GapFill::None: break;
    case GapFill::Nearest: fillNearest(bins, config.max_gap_m, work); break;
    case GapFill::Linear: fillLinear(bins, config.max_gap_m, work); break;
  }
  if (pad == 0) return work;
  ElevationMap map(grid);
  map.elevation() = work.elevation().block(pad, pad, grid.rows, grid.cols);
  map.sigma() = work.sigma().block(pad, pad, grid.rows, grid.cols);
  map.state() = work.state().block(pad, pad, grid.rows, grid.cols);
  return map;
}

}  // namespace ambler::perception
