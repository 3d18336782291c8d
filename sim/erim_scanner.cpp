#include "sim/erim_scanner.hpp"

#include <tbb/blocked_range2d.h>
#include <tbb/parallel_for.h>

#include <array>
#include <cstdint>
#include <cmath>
#include <cstring>
#include <limits>
#include <numbers>
#include <stdexcept>
#include <string>

#include "perception/sensor_geometry.hpp"
#include "sim/erim_kernel.hpp"
#include "sim/ray_scene.hpp"
#include "base/random.hpp"

namespace ambler::sim {

namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();
constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();

// Footprint cubature (unit disk): offsets and weights.
struct Footprint {
  std::array<double, kFootprintSamples> du{}, dv{}, w{};
};

Footprint footprint() {
  Footprint f;
  f.w[0] = 0.25;
  const double r = std::sqrt(2.0 / 3.0);
  for (int k = 1; k < kFootprintSamples; ++k) {
    const double a = (k - 1) * std::numbers::pi / 3.0;
    f.du[k] = r * std::cos(a);
    f.dv[k] = r * std::sin(a);
    f.w[k] = 0.125;
  }
  return f;
}

// Precomputed sin/cos of the scan angles of one footprint sample.
struct AngleTable {
  std::vector<double> sin_phi, cos_phi, sin_theta, cos_theta;
};

AngleTable angleTable(const perception::RangeImage& img, double dphi, double dtheta) {
  AngleTable t;
  for (double phi : img.phi) {
    t.sin_phi.push_back(std::sin(phi + dphi));
    t.cos_phi.push_back(std::cos(phi + dphi));
  }
  for (double theta : img.theta) {
    t.sin_theta.push_back(std::sin(theta + dtheta));
    t.cos_theta.push_back(std::cos(theta + dtheta));
  }
  return t;
}

}  // namespace

double measureRange(double rho, double normal, const perception::SensorModel& sensor) {
  return kernel::Measurement(sensor)(rho, normal);
}

ErimScanner::ErimScanner(const RayScene& scene, perception::SensorModel sensor)
    : scene_(scene), sensor_(sensor) {
  perception::validate(sensor_);
}

Eigen::Vector3d pixelDirection(const perception::RangeImage& image, int r, int c) {
  const double ct = std::cos(image.theta[c]);
  return image.T_WS.linear() *
         Eigen::Vector3d(std::sin(image.theta[c]), std::cos(image.phi[r]) * ct, std::sin(image.phi[r]) * ct);
}

std::optional<Eigen::Vector3d> Scan::trueHit(int r, int c) const {
  const float t = true_range(r, c);
  if (!std::isfinite(t)) return std::nullopt;
  return image.T_WS.translation() + double(t) * pixelDirection(image, r, c);
}


Scan ErimScanner::scan(const Eigen::Isometry3d& T_WS, std::uint64_t seed) const {
  Scan out;
  scan(T_WS, seed, out);
  return out;
}

namespace {

// One 4×4 tile: its rays (one packet per footprint sample) and their hits.
struct Tile {
  int r0 = 0, c0 = 0;
  bool full = false;  // all 16 pixels inside the image
  alignas(64) int valid[16];
  alignas(64) double cx[16], cy[16], cz[16];  // the central rays in double, for exact distances
  std::array<RayHitPacket16, kFootprintSamples> hits;
};

// What every tile of one scan shares.
struct ScanJob {
  const RayScene& scene;
  kernel::Isa isa;
  int rows, cols, samples;
  std::array<kernel::AngleTables, kFootprintSamples> angles;
  double R[9];  // row-major
  Eigen::Vector3d o;
  const Footprint& fp;
  double max_range, dropout;
  kernel::MeasureTile measure;  // pixel0 set per tile
  Scan& out;

  void cast(Tile& t, int tr, int tc) const {
    t.r0 = tr * 4, t.c0 = tc * 4;
    t.full = t.r0 + 4 <= rows && t.c0 + 4 <= cols;
    for (int i = 0; i < 16; ++i) t.valid[i] = t.full || (t.r0 + i / 4 < rows && t.c0 + i % 4 < cols) ? -1 : 0;
    for (int k = 0; k < samples; ++k) {
      RayHitPacket16& p = t.hits[k];
      kernel::tileDirections(isa, angles[k], R, t.r0, t.c0, rows, cols, p.dx, p.dy, p.dz, k == 0 ? t.cx : nullptr,
                             t.cy, t.cz);
      for (int i = 0; i < 16; ++i) p.tfar[i] = kInf;
      scene.intersect16(t.valid, p);
    }
  }

  // Refinement, the reported range and the three outputs of a cast tile.
  void finish(Tile& t, kernel::SlowDraws& slow) const {
    RayHitPacket16& centre = t.hits[0];
    scene.refine16(t.valid, o, t.cx, t.cy, t.cz, centre);
    // The reported range: the power-weighted mean over the footprint (returned power of an
    // extended target falls as 1/ρ²). Fewer than half the footprint returning: no return.
    alignas(64) double rho[16];
    alignas(64) float true_range[16];
    alignas(64) int geom[16];
    kernel::centreHits(isa, centre.tfar, centre.geom, max_range, true_range, geom, samples == 1 ? rho : nullptr);
    if (samples > 1)
      for (int i = 0; i < 16; ++i) {
        double hit_w = 0, sum_w = 0, sum_wt = 0;
        for (int k = 0; k < samples; ++k) {
          if (!t.hits[k].hit(i)) continue;
          const double d = t.hits[k].tfar[i];
          hit_w += fp.w[k];
          sum_w += fp.w[k] / (d * d);
          sum_wt += fp.w[k] / d;
        }
        const double value = hit_w >= 0.5 ? sum_wt / sum_w : kInf;
        rho[i] = value <= max_range ? value : kNaN;
      }
    kernel::MeasureTile m = measure;
    m.pixel0 = std::uint64_t(t.r0) * cols + t.c0;
    if (dropout > 0)
      for (int i = 0; i < 16; ++i) {
        const std::uint64_t key = kernel::noiseKey(m.stream, m.pixel0 + std::uint64_t(i / 4) * cols + i % 4);
        if (base::toUnit(base::mix64(~key)) < dropout) rho[i] = kNaN;
      }
    unsigned lanes = 0;
    for (int i = 0; i < 16; ++i) lanes |= unsigned(t.valid[i] & 1) << i;
    alignas(64) float reported[16];
    kernel::measureTile(isa, m, rho, lanes, reported, slow);
    // Four consecutive pixels of each output per tile row, copied whole.
    const auto copyRows = [&](int n) {
      for (int a = 0; a < 4 && t.r0 + a < rows; ++a) {
        std::memcpy(&out.true_range(t.r0 + a, t.c0), true_range + 4 * a, n * sizeof(float));
        std::memcpy(&out.geom(t.r0 + a, t.c0), geom + 4 * a, n * sizeof(int));
        std::memcpy(&out.image.range(t.r0 + a, t.c0), reported + 4 * a, n * sizeof(float));
      }
    };
    if (t.full)
      copyRows(4);  // a constant size: one 16-byte move each
    else
      copyRows(std::min(4, cols - t.c0));
    if (slow.nearlyFull()) kernel::finishSlowDraws(m, slow, out.image.range.data());
  }
};

}  // namespace

void ErimScanner::scan(const Eigen::Isometry3d& T_WS, std::uint64_t seed, Scan& out) const {
  const int rows = sensor_.rows, cols = sensor_.cols;
  // Every pixel of every output is written below, so reused buffers need no clearing.
  if (out.image.rows() != rows || out.image.cols() != cols) {
    out.image = perception::RangeImage::blank(rows, cols, sensor_.fov_v_rad, sensor_.fov_h_rad);
    out.true_range.resize(rows, cols);
    out.geom.resize(rows, cols);
  } else {
    for (int r = 0; r < rows; ++r) out.image.phi[r] = perception::rowAngle(r, rows, sensor_.fov_v_rad);
    for (int c = 0; c < cols; ++c) out.image.theta[c] = perception::colAngle(c, cols, sensor_.fov_h_rad);
  }
  out.image.T_WS = T_WS;

  const Footprint fp = footprint();
  const int samples = sensor_.mixed_pixels ? kFootprintSamples : 1;
  const double radius = 0.5 * sensor_.beamDivergence();
  std::vector<AngleTable> tables;
  for (int k = 0; k < samples; ++k)
    tables.push_back(angleTable(out.image, radius * fp.dv[k], radius * fp.du[k]));
  const kernel::Measurement measure(sensor_);
  ScanJob job{scene_, kernel::activeIsa(), rows, cols, samples, {}, {}, T_WS.translation(), fp,
              sensor_.max_range_m, sensor_.dropout,
              {&measure, &base::zigguratTables(), base::mix64(seed), sensor_.noise_k > 0, 0, std::uint64_t(cols)},
              out};
  for (int k = 0; k < samples; ++k)
    job.angles[k] = {tables[k].sin_phi.data(), tables[k].cos_phi.data(), tables[k].sin_theta.data(),
                     tables[k].cos_theta.data()};
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) job.R[3 * i + j] = T_WS.linear()(i, j);

  const int tile_rows = (rows + 3) / 4, tile_cols = (cols + 3) / 4;
  tbb::parallel_for(tbb::blocked_range2d<int>(0, tile_rows, 0, tile_cols), [&](const auto& range) {
    Tile tile;
    const Eigen::Vector3f of = job.o.cast<float>();
    for (int k = 0; k < samples; ++k)
      for (int i = 0; i < 16; ++i) {
        RayHitPacket16& p = tile.hits[k];
        p.ox[i] = of.x(), p.oy[i] = of.y(), p.oz[i] = of.z();
        p.tnear[i] = 0.0f;
      }
    kernel::SlowDraws slow;
    for (int tr = range.rows().begin(); tr != range.rows().end(); ++tr)
      for (int tc = range.cols().begin(); tc != range.cols().end(); ++tc) {
        job.cast(tile, tr, tc);
        job.finish(tile, slow);
      }
    kernel::finishSlowDraws(job.measure, slow, out.image.range.data());
  });
}

}  // namespace ambler::sim
