#pragma once
// The generalized locus algorithm (paper §3.1 and footnote 2): the intersection of any line in
// space with the surface seen in a range image, found in image space — no Cartesian resampling,
// any resolution, any sensor orientation. Range shadows (§3.2) come from an edge mask of the
// image; each result carries σ along the line from the sensor's noise model (§3.3, docs/locus.md).
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

#include "perception/elevation_map.hpp"
#include "perception/range_edges.hpp"
#include "perception/range_image.hpp"
#include "perception/sensor_model.hpp"

namespace ambler::perception {

struct LocusConfig {
  double epsilon_rad = 1e-5;  // the search stops when the bracket in φ is narrower than this
  bool bisection = false;     // true: plain bisection as in the paper; false: Hermite, IQI steps
                              // (the same bracket and stopping rule, fewer evaluations)
  double z_margin_m = 0.3;    // lines are searched within the returns' bounds ± this margin (docs/locus.md)
  bool roughness = true;      // σ includes the surface's roughness between pixels (docs/locus.md)
  double roughness_hurst = 0.7;  // H of the fBm assumed between pixels (0.5: Brownian)
  // σ also includes the footprint's averaging of the rough surface (with the sensor's mixed pixels and
  // roughness; docs/locus.md, "The footprint"). Off for single maps: feature detection reads σ as
  // the noise of its curvature fits, and this error is a smooth bias that every view of a cell
  // shares, which only the composite must not average away (docs/composite.md); the merge turns it on.
  bool footprint_sigma = false;
  // Trust the sample next to an occluding edge to place the edge (docs/locus.md, "The samples
  // either side of an edge"). Off for the maps a run writes and scores: a cell that may lie over a
  // shadow is unseen, not known, as a footfall planner needs. On for the maps registration
  // matches: a matcher wants every surface sample, and a mixed sample's few centimetres at a rim
  // are within what its robust costs absorb, while the rim cells it would lose carry the convex
  // features feature matching pairs (docs/matching.md).
  bool trust_edge_samples = false;
  // σ for maps that bridge shallow occlusions (docs/locus.md, "Bridged occlusions"; the scenario's
  // `shadows: gnc_bridge`): with a term for the ground a bracket may hide, from its links' jumps
  // beyond the trend.
  // The SIMD lanes do not compute it: with it on, every cell takes the scalar search.
  bool bridge_sigma = false;
  // How far the far surface of an occluding edge without a mixed pixel is carried back into the
  // gap, in scanlines (docs/locus.md, "The gap at an occluding edge"): 0.5, where the edge's shadow
  // ends on average; 1, the whole gap (no visible far-side cell is called shadow, fewer hidden
  // ones are).
  double far_gap_scanlines = 0.5;
  bool vectorized = true;  // maps: the common case in SIMD lanes (8 AVX-512 or 2 × 4 AVX2) where
                           // the CPU has them (the same bits as the scalar search; false: scalar)
};

struct LocusHit {
  CellState state = CellState::Unseen;
  Eigen::Vector3d point = Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN());
  double s = std::numeric_limits<double>::quiet_NaN();      // position along the line
  double sigma = std::numeric_limits<double>::quiet_NaN();  // σ of s (σ_z for vertical lines)
  // Shadow: the point of the line under the lowest sampled ray that passes over it (its z is the
  // shadow ceiling of a map cell); NaN where the line runs behind a seen surface from its top.
  Eigen::Vector3d ceiling = Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN());
  double phi = 0, theta = 0, rho = 0;                       // where the line met the image
  int evaluations = 0;                                      // Δ evaluations spent
  int bracket_row = -1;  // the upper scanline of the two that bracket the crossing; −1: none found
};

struct LocusSample;


// The SIMD lanes maps run their common case in (LocusMapper::laneIsa).
enum class LaneIsa { None = 0, Avx2 = 1, Avx512 = 2 };

// Caps the lanes every mapper of the process runs (LocusMapper::laneIsa) while it lives, and
// restores the cap before it when it goes out of scope. Not for concurrent use from two threads.
class LaneIsaCap {
 public:
  explicit LaneIsaCap(LaneIsa cap);
  ~LaneIsaCap();
  LaneIsaCap(const LaneIsaCap&) = delete;
  LaneIsaCap& operator=(const LaneIsaCap&) = delete;

 private:
  LaneIsa previous_;
};

class LocusMapper {
 public:
  // `image` (and `edges`, if given: same size) must outlive the mapper; `sensor` is the model the
  // image was taken with (its σ_ρ, SensorModel::rangeVariance, gives σ along a line; its beam the
  // footprint's term). Construction tabulates,
  // once per image and in parallel, what every search needs per 2×2 pixel cell (which pixels
  // returned, which are edge pixels, the local normal and roughness of σ). Throws
  // std::invalid_argument if the image's scan angles are not evenly spaced or sizes differ.
  // The mapper works in the gravity-aligned map frame T_WM (default: the world): lines, points
  // and maps are in M.
  LocusMapper(const RangeImage& image, const SensorModel& sensor, const Raster<std::uint8_t>* edges,
              const LocusConfig& config = {}, const Eigen::Isometry3d& T_WM = Eigen::Isometry3d::Identity());

  // f(u, v): where the line u + s·v (map frame, v unit, pointing away from the ground: the
  // search runs from +v towards −v) meets the surface the sensor saw. Thread-safe.
  LocusHit intersect(const Eigen::Vector3d& u, const Eigen::Vector3d& v) const;
  // The same, starting the scanline search at *hint (the upper scanline of a bracket found before:
  // a neighbouring line's, or this line's at a nearby pose) and updating it; hint may be null or
  // −1 (none). The crossing is the one the walk from the line's top finds (docs/locus.md).
  LocusHit intersect(const Eigen::Vector3d& u, const Eigen::Vector3d& v, int* hint) const;

  // The unit normal, in the map frame, of the surface the search met at a Known `hit` (the image's
  // ranges interpolated bilinearly in its scan angles, as the search interpolates them): the
  // cross product of the surface's derivatives in φ and θ, oriented towards the sensor. What a
  // derivative of f(u, v) by the line's pose needs (the iconic gradient, paper eq. 8).
  Eigen::Vector3d surfaceNormal(const LocusHit& hit) const;

  const RangeImage& image() const { return image_; }
  const SensorModel& sensor() const { return sensor_; }
  const Eigen::Isometry3d& mapFrame() const { return T_WM_; }

  // The elevation at any (x, y): the vertical line through it.
  LocusHit elevationAt(double x, double y) const {
    return intersect({x, y, 0.0}, Eigen::Vector3d::UnitZ());
  }

  // A map on `grid`: vertical lines through the cell centres, in parallel over rows. Each group of
  // kLanes cells of a map row starts its scanline search at the last bracket found in the groups
  // before it (docs/locus.md); the map does not depend on the ISA or the number of threads.
  // lane_cells, if given, receives how many cells the SIMD lanes completed. Throws
  // std::invalid_argument if the grid's frame is not the mapper's.
  ElevationMap map(const MapGrid& grid, long* lane_cells = nullptr) const;

  static constexpr int kLanes = 8;  // map cells per group (one AVX-512 batch, or two AVX2 ones)
  // The lanes this process runs: AVX-512 (F and DQ) where the CPU and OS support it, else AVX2,
  // else none — at most the cap of the innermost LaneIsaCap alive (for tests and benchmarks: the
  // results are the same bits at every setting).
  static LaneIsa laneIsa();
  static bool lanesAvailable() { return laneIsa() != LaneIsa::None; }

  // The map at resolution `cell_m` inside a polygon (x, y vertices, map frame): the grid covers
  // the polygon's bounding box; cells whose centre is outside the polygon stay Unseen.
  ElevationMap mapPolygon(const std::vector<Eigen::Vector2d>& polygon, double cell_m) const;

 private:
  struct Line {
    Eigen::Vector3d a, b;  // the line a + s·b in the sensor frame
    // Per scanline r: 1/(b_z·cosφ_r − b_y·sinφ_r), the reciprocal of the denominator of the line's
    // crossing with the scan plane (0 where the line is parallel to it). Set for the vertical
    // direction, which every map shares (tabulated once per image); null for other directions.
    const double* inv_den = nullptr;
  };
  // Per 2×2 pixel cell (r0, c0): the inputs of σ (docs/locus.md) — the local normal in the sensor
  // frame and the mean squared second difference of the ranges across scanlines and along them
  // (NaN: none available).
  struct CellSigma {
    Eigen::Vector3d normal;
    double d2_rows, d2_cols;
  };

  // Δ = ρ_line − I at fractional row rf, whose scan angle has sine sp and cosine cp; inv_den is
  // 1/(b_z·cp − b_y·sp) (0: the line is parallel to that scan plane).
  LocusSample evaluate(const Line& l, double rf, double sp, double cp, double inv_den) const;
  // dΔ/dφ at a sample m taken where the scan angle has sine sp and cosine cp, with
  // inv_den = 1/(b_z·cp − b_y·sp), where the image's bilinear patch has the partial derivatives
  // dI_dfr (across scanlines) and dI_dfc (along them).
  double slope(const Line& l, double sp, double cp, double inv_den, const LocusSample& m, double dI_dfr,
               double dI_dfc) const;
  // dΔ/dφ at sample m, taken on scanline r_m (r_m ≥ 0) or at φ_m between scanlines (r_m = −1, as
  // atPhi(l, r1, φ_m) takes it), with I the bilinear patch of the 2×2 cell (r_cell, c_cell).
  double slopeInPatch(const Line& l, int r1, double phi_m, int r_m, const LocusSample& m, int r_cell,
                      int c_cell) const;
  // The root in [φa, φb] of the cubic Hermite interpolant through (φa, y0 < 0, slope g0) and
  // (φb, y1 > 0, slope g1).
  static double hermiteRoot(double phi_a, double y0, double g0, double phi_b, double y1, double g1);
  // (f(x) − offset)·scale for f = asin or atan, tabulated (see the constructor): with f = atan and
  // x = tan θ, the column coordinate (θ − θ0)/Δθ; with f = asin and x = sin φ in the scan plane,
  // the row coordinate (φ0 − φ)/Δφ. Quadratic Taylor polynomials about the middles of kSize
  // intervals over |x| ≤ limit; beyond that, libm.
  struct AngleTable {
    struct Poly {
      double x, c0, c1, c2;  // ≈ c0 + c1·(x' − x) + c2·(x' − x)² near x
    };
    bool is_atan = false;
    double offset = 0, scale = 1, limit = 0, index_scale = 0, step = 0;  // step: the intervals' width
    std::vector<Poly> polys;
    AngleTable() = default;
    AngleTable(bool atan, double limit, double offset, double scale);
    double operator()(double x) const {
      if (!(std::abs(x) <= limit))
        return ((is_atan ? std::atan(x) : std::asin(std::clamp(x, -1.0, 1.0))) - offset) * scale;
      const Poly& e = polys[std::size_t((x + limit) * index_scale)];
      const double d = x - e.x;
      return e.c0 + d * (e.c1 + d * e.c2);
    }
    static constexpr int kSize = 4096;
  };
  // u + s·v in the sensor frame: a = R·u + t with R = T_SW's rotation, each component summed
  // left to right (the lanes repeat these operations exactly).
  Line lineOf(const Eigen::Vector3d& u, const Eigen::Vector3d& v) const;
  // One map cell's result as map() stores it.
  struct CellResult {
    CellState state;
    float z, sigma;  // Known: the elevation and σ_z; Shadow: z is the ceiling
    int bracket_row;
  };
  // The cells (row, c0 + k), k < n ≤ kLanes, of `grid` whose search from `hint` takes the common path
  // (a bracket within a few scanlines of the hint, the Hermite estimate, a probe pair that
  // closes it, no edge or missing pixel in the final 2×2 cell), in the SIMD lanes of `isa` with
  // the scalar search's operations: bit k of the result is set where lane k finished into out[k]
  // (locus_lanes.cpp).
  unsigned mapLanes(LaneIsa isa, const MapGrid& grid, int row, int c0, int n, int hint, CellResult* out) const;
  LocusSample atRow(const Line& l, int r) const;
  LocusSample atPhi(const Line& l, int r_ref, double phi) const;
  double sigmaAlongLine(int r0, int c0, double fr, double fc, double rho, const Eigen::Vector3d& p,
                        const Eigen::Vector3d& b) const;
  // σ with LocusConfig::bridge_sigma (sum_w2: the bilinear weights' Σw²; var_pixel: σ_p² at rho;
  // rough: sigmaAlongLine's roughness variance, in range).
  double bridgeSigmaAlongLine(int r0, int c0, double fr, double fc, double rho, const Eigen::Vector3d& p,
                              const Eigen::Vector3d& b, double sum_w2, double var_pixel, double rough) const;
  // A surface's course across scanlines: inverse range fitted by least squares against k, its
  // samples at scanlines first + k·step (k = 0…3, y0 the first's range, the rest read in sample s's
  // columns), up to the first missing one. inverseAt(t): the fit carried t scanlines before the
  // first sample; sigma(var_p, t): that value's σ in range for a per-sample range variance var_p.
  struct InverseRangeFit {
    int n = 0;
    double k_mean = 0, s_kk = 0, slope = 0, at_mean = 0;
    double inverseAt(double t) const { return at_mean - slope * (t + k_mean); }
    double sigma(double var_p, double t) const {
      return std::sqrt(var_p * (1.0 / n + (t + k_mean) * (t + k_mean) / s_kk));
    }
  };
  InverseRangeFit fitInverseRange(double y0, int first, int step, const LocusSample& s) const;
  // At an occluding edge between the scanlines r1 (s1: the line in front of what it saw) and
  // r2 = r1 ± 1 (s2: behind the near surface): could the line be on either surface, extended
  // past its last sample into the gap (docs/locus.md)?
  bool meetsSurfaceInGap(int r1, int r2, const LocusSample& s1, const LocusSample& s2) const;
  // The image at scanline r in sample s's columns: its range interpolated as s was (NaN off the
  // image), and whether a pixel with weight there is an occluding-edge pixel.
  double rangeAt(int r, const LocusSample& s) const;
  bool edgeAt(int r, const LocusSample& s) const;
  // Whether the one of the scanlines r1, r2 that has edge pixels is a mixed pixel the edge
  // detector took for part of the other surface (docs/locus.md).
  bool linkedMixedPixel(int r1, int r2, const LocusSample& s1, const LocusSample& s2) const;
  // Whether the line, crossing the bracket (r1, r2) next to an occluding edge, may be past the
  // edge, which the bracket's edge-side sample (r1 on the near side, r2 on the far side; it may be
  // mixed below the detector's threshold) misplaces: judged from the clean samples' surface
  // carried to that scanline, with three σ of that extension (docs/locus.md).
  bool pastUntrustedEdgeSample(bool near_side, int r1, int r2, const LocusSample& s1, const LocusSample& s2) const;
  // Whether the line above the scanline bracket (r1, r1 + 1) that a hint found is provably in
  // front of everything the sensor saw, so that the walk down the line from its top would find
  // the same bracket first (docs/locus.md, "The highest crossing"): every pixel on the top side
  // of r1, across the columns the line sweeps between r1 and its top s_top, is farther than the
  // line's farthest point there. s1 is the sample at r1 and s2 at r1 + 1.
  bool clearAbove(const Line& l, double s_top, int r1, const LocusSample& s1) const;
  // The end of a search: the final bracket [lo, hi] (narrower than ε) inside the scanline bracket
  // (r1, s1; r2, s2) of the line u + s·v, classified (known or shadow) and written into `hit`.
  void finish(const Line& l, const Eigen::Vector3d& u, const Eigen::Vector3d& v, int r1, int r2,
              const LocusSample& s1, const LocusSample& s2, double phi_lo, const LocusSample& lo,
              double phi_hi, const LocusSample& hi, LocusHit& hit) const;
  int cellIndex(int r0, int c0) const { return r0 * (cols_ - 1) + c0; }

  const RangeImage& image_;
  const Raster<std::uint8_t>* edges_;
  SensorModel sensor_;
  LocusConfig config_;
  Eigen::Isometry3d T_WM_;  // the map frame
  Eigen::Matrix3d rot_SW_;    // T_SW = T_WS⁻¹: rotation
  Eigen::Vector3d trans_SW_;  // and translation
  Eigen::Vector3d up_;  // world z in the sensor frame
  int rows_, cols_;
  std::vector<double> roughness_g_;  // the fBm interpolation factor over f: across scanlines, then along
  double phi0_, dphi_, theta0_, dtheta_;
  double inv_dtheta_, inv_dphi_;
  double quantization_var_;  // sensor_.quantizationVariance(), for the lanes
  double last_row_, last_col_;  // rows − 1 and cols − 1: the largest fractional row and column
  std::vector<double> sin_phi_, cos_phi_, sin_theta_, cos_theta_;
  AngleTable column_of_;  // over tan θ
  AngleTable row_of_;     // over sin φ
  std::vector<double> vertical_inv_den_;  // Line::inv_den of the vertical direction (world z)
  std::vector<std::uint8_t> cell_flags_;  // per 2×2 cell: bits 0–3 edge pixels, bit 4 all returned
  std::vector<CellSigma> cell_sigma_;
  // With LocusConfig::bridge_sigma, per 2×2 cell: the mean squared second difference of the
  // returns' heights across and along scanlines (m²), and the largest jump beyond the trend of the
  // cell's links across and along them (m of range).
  struct CellBridge {
    double d2z_rows, d2z_cols, jump_rows, jump_cols;
  };
  std::vector<CellBridge> cell_bridge_;
  // above_min_[k][r][c]: the smallest range of the pixels in rows < r and columns [c, c + 2^k)
  // (no return counts as +∞), for clearAbove's band queries, in above_levels_ levels.
  std::vector<float> above_min_;
  int above_levels_ = 0;
  Eigen::AlignedBox3d bounds_;  // world bounds of the returns, ± margin
};

}  // namespace ambler::perception
