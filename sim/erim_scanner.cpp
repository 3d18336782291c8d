#include "sim/erim_scanner.hpp"

#include <tbb/blocked_range2d.h>
#include <tbb/parallel_for.h>

#include <array>
#include <cstdint>
#include <cmath>
#include <limits>
#include <numbers>
#include <stdexcept>
#include <string>

#include "perception/sensor_geometry.hpp"
#include "sim/ray_scene.hpp"
#include "terrains/random.hpp"

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

void requireConfig(bool ok, const std::string& what) {
  if (!ok) throw std::invalid_argument("ErimConfig: " + what);
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

namespace {

// The measurement model with its reciprocals precomputed: a division costs more than the rest.
struct Measurement {
  double k, ambiguity, inv_ambiguity, q, inv_q;
  explicit Measurement(const ErimConfig& c)
      : k(c.noise_k),
        ambiguity(c.ambiguity_m),
        inv_ambiguity(c.ambiguity_m > 0 ? 1.0 / c.ambiguity_m : 0.0),
        q(c.quantization_m),
        inv_q(c.quantization_m > 0 ? 1.0 / c.quantization_m : 0.0) {}

  // Round to nearest (ties to even) for 0 <= x < 2^51 with two additions: no libm call and no
  // integer conversion on the critical path. (IEEE semantics: the project builds with
  // -ffp-contract=off and never -ffast-math, which could fold this to x.)
  static double roundNearest(double x) {
    constexpr double kMagic = 0x1.8p52;
    return (x + kMagic) - kMagic;
  }

  // Straight-line (every branch a select), so a loop of it vectorises; with ambiguity or q zero
  // the reciprocals are zero and the corresponding steps leave m unchanged.
  double operator()(double rho, double normal) const {
    double m = rho + k * rho * rho * normal;
    m = m > 0.0 ? m : 0.0;
    double n = roundNearest(m * inv_ambiguity);
    n = n * ambiguity > m ? n - 1.0 : n;  // floor(m / ambiguity)
    m -= n * ambiguity;
    m = ambiguity > 0.0 && m >= ambiguity ? m - ambiguity : m;
    m = m < 0.0 ? m + ambiguity : m;
    const double counts = q * roundNearest(m * inv_q);
    m = q > 0.0 ? counts : m;
    // The top count rounds onto the interval's end, which is range 0 again.
    return ambiguity > 0.0 && m >= ambiguity ? 0.0 : m;
  }
};

// Noise and measurement for the 16 pixels of a tile. rho is NaN where nothing returns.
struct Tile16 {
  const Measurement* measure;
  const terrains::ZigguratTables* zig;
  std::uint64_t stream;
  bool noise;
  const std::uint64_t* pixel;
  const double* rho;
  float* out;
};

// Three passes over the lanes, so the pixels' long dependency chains (hash, table lookup,
// measurement) overlap instead of queueing behind one another.
void noiseAndMeasure16(const Tile16& t) {
  alignas(64) double normal[16];
  bool slow[16];
  for (int i = 0; i < 16; ++i) {
    // SplitMix64's own stream: the pixel index picks the draw, independent of threads.
    const std::uint64_t bits = terrains::mix64(t.stream + t.pixel[i] * 0x9E3779B97F4A7C15ull);
    const std::uint64_t layer = bits & 127;
    const double u = terrains::signedUnit52(bits);
    slow[i] = t.noise && !(std::abs(u) < t.zig->ratio[layer]);
    normal[i] = t.noise ? u * t.zig->x[layer] : 0.0;
  }
  for (int i = 0; i < 16; ++i)  // the ziggurat's rare edges and tail
    if (slow[i]) normal[i] = terrains::normalFromKey(t.stream + t.pixel[i] * 0x9E3779B97F4A7C15ull);
  for (int i = 0; i < 16; ++i)
    t.out[i] = t.rho[i] == t.rho[i] ? float((*t.measure)(t.rho[i], normal[i])) : kNaN;
}

}  // namespace

double measureRange(double rho, double normal, const ErimConfig& cfg) {
  return Measurement(cfg)(rho, normal);
}

ErimScanner::ErimScanner(const RayScene& scene, ErimConfig config)
    : scene_(scene), config_(config) {
  requireConfig(config.rows >= 1 && config.cols >= 1, "rows and cols must be positive");
  requireConfig(config.fov_v_rad > 0 && config.fov_v_rad < std::numbers::pi, "fov_v out of (0, pi)");
  requireConfig(config.fov_h_rad > 0 && config.fov_h_rad < std::numbers::pi, "fov_h out of (0, pi)");
  requireConfig(config.noise_k >= 0 && config.quantization_m >= 0 && config.ambiguity_m >= 0,
                "noise_k, quantization_m and ambiguity_m must be non-negative");
  requireConfig(config.max_range_m > 0, "max_range_m must be positive");
  requireConfig(config.beam_divergence_rad >= 0, "beam_divergence_rad must be non-negative");
  requireConfig(config.dropout >= 0 && config.dropout < 1, "dropout must be in [0, 1)");
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

double ErimScanner::beamDivergence() const {
  if (config_.beam_divergence_rad > 0) return config_.beam_divergence_rad;
  return std::max(config_.fov_v_rad / config_.rows, config_.fov_h_rad / config_.cols);
}

Scan ErimScanner::scan(const Eigen::Isometry3d& T_WS, std::uint64_t seed) const {
  Scan out;
  scan(T_WS, seed, out);
  return out;
}

void ErimScanner::scan(const Eigen::Isometry3d& T_WS, std::uint64_t seed, Scan& out) const {
  const int rows = config_.rows, cols = config_.cols;
  // Every pixel of every output is written below, so reused buffers need no clearing.
  if (out.image.rows() != rows || out.image.cols() != cols) {
    out.image = perception::RangeImage::blank(rows, cols, config_.fov_v_rad, config_.fov_h_rad);
    out.true_range.resize(rows, cols);
    out.geom.resize(rows, cols);
  } else {
    for (int r = 0; r < rows; ++r) out.image.phi[r] = perception::rowAngle(r, rows, config_.fov_v_rad);
    for (int c = 0; c < cols; ++c) out.image.theta[c] = perception::colAngle(c, cols, config_.fov_h_rad);
  }
  out.image.T_WS = T_WS;

  const Footprint fp = footprint();
  const int samples = config_.mixed_pixels ? kFootprintSamples : 1;
  const double radius = 0.5 * beamDivergence();
  std::vector<AngleTable> tables;
  for (int k = 0; k < samples; ++k)
    tables.push_back(angleTable(out.image, radius * fp.dv[k], radius * fp.du[k]));

  const Eigen::Matrix3d R = T_WS.linear();
  const Eigen::Vector3d o = T_WS.translation();
  const Measurement measure(config_);
  const std::uint64_t stream = terrains::mix64(seed);
  const terrains::ZigguratTables& zig = terrains::zigguratTables();
  const int tile_rows = (rows + 3) / 4, tile_cols = (cols + 3) / 4;

  tbb::parallel_for(tbb::blocked_range2d<int>(0, tile_rows, 0, tile_cols), [&](const auto& range) {
    std::array<RayHitPacket16, kFootprintSamples> hits;
    alignas(64) int valid[16];
    alignas(64) double cx[16], cy[16], cz[16];  // the central rays in double, for exact distances
    for (auto& p : hits)
      for (int i = 0; i < 16; ++i) {
        p.ox[i] = float(o.x());
        p.oy[i] = float(o.y());
        p.oz[i] = float(o.z());
        p.tnear[i] = 0.0f;
      }
    for (int tr = range.rows().begin(); tr != range.rows().end(); ++tr)
      for (int tc = range.cols().begin(); tc != range.cols().end(); ++tc) {
        for (int k = 0; k < samples; ++k) {
          const AngleTable& a = tables[k];
          RayHitPacket16& p = hits[k];
          for (int i = 0; i < 16; ++i) {
            const int r = std::min(tr * 4 + i / 4, rows - 1), c = std::min(tc * 4 + i % 4, cols - 1);
            valid[i] = (tr * 4 + i / 4 < rows && tc * 4 + i % 4 < cols) ? -1 : 0;
            const double ct = a.cos_theta[c];
            const Eigen::Vector3d d =
                R * Eigen::Vector3d(a.sin_theta[c], a.cos_phi[r] * ct, a.sin_phi[r] * ct);
            p.dx[i] = float(d.x());
            p.dy[i] = float(d.y());
            p.dz[i] = float(d.z());
            p.tfar[i] = kInf;
            if (k == 0) cx[i] = d.x(), cy[i] = d.y(), cz[i] = d.z();
          }
          scene_.intersect16(valid, p);
        }
        // The rest runs lane by lane in passes, so the 16 pixels' long dependency chains
        // (refinement, noise draw, measurement) overlap instead of queueing.
        alignas(64) double rho[16];
        scene_.refine16(valid, o, cx, cy, cz, hits[0]);
        for (int i = 0; i < 16; ++i) {
          // The reported range: the power-weighted mean over the footprint (returned power of an
          // extended target falls as 1/ρ²). Fewer than half the footprint returning: no return.
          double value = hits[0].hit(i) ? hits[0].tfar[i] : kInf;
          if (samples > 1) {
            double hit_w = 0, sum_w = 0, sum_wt = 0;
            for (int k = 0; k < samples; ++k) {
              if (!hits[k].hit(i)) continue;
              const double t = hits[k].tfar[i];
              hit_w += fp.w[k];
              sum_w += fp.w[k] / (t * t);
              sum_wt += fp.w[k] / t;
            }
            value = hit_w >= 0.5 ? sum_wt / sum_w : kInf;
          }
          rho[i] = value <= config_.max_range_m ? value : kNaN;
        }
        alignas(64) std::uint64_t pixel[16];
        for (int i = 0; i < 16; ++i) pixel[i] = std::uint64_t(tr * 4 + i / 4) * cols + tc * 4 + i % 4;
        if (config_.dropout > 0)
          for (int i = 0; i < 16; ++i)
            if (terrains::toUnit(terrains::mix64(~(stream + pixel[i] * 0x9E3779B97F4A7C15ull))) < config_.dropout)
              rho[i] = kNaN;
        alignas(64) float reported[16];
        noiseAndMeasure16({&measure, &zig, stream, config_.noise_k > 0, pixel, rho, reported});
        for (int i = 0; i < 16; ++i) {
          if (!valid[i]) continue;
          const int r = tr * 4 + i / 4, c = tc * 4 + i % 4;
          out.true_range(r, c) = hits[0].hit(i) ? hits[0].tfar[i] : kNaN;
          out.geom(r, c) = int(hits[0].geom[i]);
          out.image.range(r, c) = reported[i];
        }
      }
  });
}

}  // namespace ambler::sim
