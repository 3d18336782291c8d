#pragma once
// Iconic matching (paper §4.2): the error E of eq. 6 between map 1 and range image 2 under a
// candidate transform, and its gradient by eq. 7–8 (docs/matching.md, "Iconic matching").
#include <Eigen/Geometry>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include "perception/elevation_map.hpp"
#include "perception/locus_mapper.hpp"
#include "perception/rigid_transform.hpp"

namespace ambler::perception {

using Matrix6d = Eigen::Matrix<double, 6, 6>;

struct IconicError {
  double E = 0;                              // Σ ‖f₁(u, v) − g(u, v, T)‖² over the overlap, m² (or the robust cost)
  double sum_r2 = 0;                         // Σ r² (the plain E, whatever the loss)
  double sum_u2 = 0;                         // Σ (r/σ)² (weighted; Σ r² otherwise)
  PoseVector gradient = PoseVector::Zero();  // ∂E/∂ν
  Matrix6d JtJ = Matrix6d::Zero();           // Σ J·Jᵀ of the residuals' Jacobians (Gauss–Newton; JᵀWJ weighted)
  long overlap = 0;                          // lines where both maps are known
};

// ν = (r, t) is T: map 1's frame → image 2's map frame (u′ = R·u + t, v′ = R·v). For every Known
// cell of map1, the vertical line (u, v) through its centre is moved to (u′, v′) and met with
// image 2 by the generalized locus algorithm (image2.intersect: no resampling of map 2), g is
// that point taken back by T⁻¹ (eq. 5), and E sums ‖f₁ − g‖² where image 2 has a Known crossing.
// The gradient (eq. 7–8) goes through the surface at each hit: for a locally planar surface with
// normal n at the crossing, s = n·(p − u′)/(n·v′), so ∂s/∂ν = −n·(∂u′/∂ν + s·∂v′/∂ν)/(n·v′), with
// ∂R/∂r from the exponential map (Gallego & Yezzi's closed form). In parallel over map rows;
// deterministic.
// With cauchy_c > 0 the cost is robust: E = Σ c²·ln(1 + r²/c²) (Cauchy), its gradient Σ 2w·r·J and
// JᵀJ weighted by w = 1/(1 + r²/c²), so that lines that disagree far beyond c (overlap borders,
// shadows, rocks seen from one side) pull little.
//
// With `reference_normals` (map 1's surface normals, referenceNormals), the Jacobian takes the
// normal of map 1's surface at the cell, moved into image 2's frame, instead of image 2's at the
// hit: the same at the solution, and far less noisy than a normal from one 2×2 cell of a noisy
// image (Gauss-Newton's point-to-plane form). E is unchanged; the gradient is then approximate.
//
// `weighted`: each residual is divided by its σ, σ² = σ₁² + σ₂² (map 1's σ_z at the cell and image
// 2's σ along the moved line at the hit, LocusHit::sigma), so E = Σ (r/σ)² (or the Cauchy cost of
// r/σ, cauchy_c then in units of σ), the gradient Σ 2w·(r/σ)·J/σ and JtJ = JᵀWJ = Σ w·J·Jᵀ/σ². σ is
// taken as fixed in the derivatives (it changes with ν only through where the line meets image 2).
// stride: the lines of every stride-th row and column only.
IconicError iconicError(const ElevationMap& map1, const LocusMapper& image2, const PoseVector& nu,
                        bool with_gradient = true, double cauchy_c = 0,
                        const std::vector<Eigen::Vector3d>* reference_normals = nullptr, int stride = 1,
                        bool weighted = false);

// Each line's normalized residual u = r/σ at ν, σ² = σ₁² + σ₂² (iconicError's weighted form), per
// cell of map 1 in row-major order; NaN where the cell or the line's crossing with image 2 is not
// Known. What verification and acceptance read (perception/acceptance.hpp). Deterministic.
// stride: the lines of every stride-th row and column only (NaN elsewhere); hints (IconicResult::
// hints near ν), if given and not empty, start the searches (the values are the same).
std::vector<double> normalizedResiduals(const ElevationMap& map1, const LocusMapper& image2, const PoseVector& nu,
                                        int stride = 1, const std::vector<int>* hints = nullptr);

// Map 1's unit surface normals (row-major per cell; NaN where the cell or its neighbours are not
// known, and there image 2's normal at the hit is used): from central differences of the known
// elevations two cells either side (one where two are not known).
std::vector<Eigen::Vector3d> referenceNormals(const ElevationMap& map);

struct IconicOptions {
  int max_iterations = 100;
  double min_relative_decrease = 1e-6;  // stop when the mean squared residual falls by less than this
  double floor_m = 1e-4;                // or when the RMS residual is below this (what the sensor allows)
  double min_step_m = 1e-4;             // LM: or when a step moves no line point more than this
  // LM: the Cauchy loss's scale c = max(robust_sigmas·√2·σ̃, 2·RMS of the residuals), σ̃ the median
  // σ_z of map 1 (at least 1 mm): it starts as wide as the misalignment (the first steps are plain
  // least squares) and narrows to the noise of a difference of two maps. 0: plain least squares.
  double robust_sigmas = 3.0;
  // LM: coarse to fine, the lines of every stride-th cell in each direction first (4: 40 cm lines on
  // a 10 cm map), each level started from the one before; the last stride should be 1.
  std::vector<int> strides{4, 2, 1};
  // Weighted LM: the locus mapper map 1 was made with (its image and edges, in map 1's frame), so
  // that the covariance counts the pixels of image 1 that map 1's lines share. Null: map 1's lines
  // are taken to share pixels as their crossings with image 2 do (docs/matching.md).
  const LocusMapper* map1_source = nullptr;
  // Weighted LM: after LM stops (at the narrowest loss of the last level, the first step the cost
  // refuses ends it), up to this many Gauss–Newton steps taken whatever the cost says, kept only
  // while each is shorter than the one before: the root of Σ g·r = 0 that the covariance
  // describes, not the local minimum of the counts' staircase LM stopped in (docs/matching.md,
  // "Calibration"). 0: off (LM's own stopping rules).
  int polish_iterations = 2;
  // The polish's first step is taken only if it lies inside the estimate's own 99.9 % region,
  // δᵀ·JᵀWJ·δ ≤ χ²₆'s 99.9 % point (JᵀWJ of r/σ, so in χ² units): a longer one says LM did not end
  // near the root (a stall, a nearly free direction), and LM's estimate is kept.
  double polish_max_mahalanobis2 = 22.458;
  // Weighted LM's covariance: the sandwich's bread A with the derivative ψ′ of the Cauchy influence
  // (the M-estimator's own sandwich; weightedCovariance). Off: the weight w that the Gauss–Newton
  // matrix holds fixed, which takes the cost for steeper than it is (docs/matching.md,
  // "Calibration", the bread).
  bool influence_bread = true;
  // The paper's descent as printed (iconicPaperDescent): its gain k = paper_gain/λ_max(JᵀJ at ν0),
  // fixed for the run, and its own iteration cap (a fixed-gain descent needs far more iterations
  // than the methods above).
  double paper_gain = 0.5;
  int paper_max_iterations = 2000;
  // iconicGradientDescent's four departures from the paper's descent, each of which can be turned
  // off (ambler experiment descent; docs/experiments/descent.md): map 1's normals in the Jacobian
  // (off: image 2's at the hit); the annealed Cauchy loss (off: plain squares); the gain
  // A·diag(AᵀHA)⁻¹·Aᵀ with rotations about map 1's centroid (off: the identity); the backtracking
  // on k over the common lines (off: one gain, k = paper_gain/λ_max of the gain-weighted JᵀJ at ν0,
  // with iconicPaperDescent's stop rules and paper_max_iterations). All four off is that descent.
  bool descent_reference_normals = true;
  bool descent_robust_loss = true;
  bool descent_centroid_gain = true;
  bool descent_backtracking = true;
};

struct IconicResult {
  PoseVector nu = PoseVector::Zero();  // the estimate of T (map 1 → image 2's frame)
  int iterations = 0;
  std::vector<double> rms_m;           // RMS residual per iteration (the first: at the start)
  std::vector<double> E_m2;            // and eq. 6's E there, Σ r² over the lines of the overlap
  std::vector<long> lines;             // and that overlap
  long overlap = 0;
  // Descent and LM: σ²·(JᵀJ)⁻¹ at the estimate, σ² = E/(N − 6). Weighted: the sandwich of
  // weightedCovariance (the pixels that neighbouring lines share, image 2's own slopes); no σ²
  // from the residuals.
  Matrix6d covariance = Matrix6d::Zero();
  bool converged = false;
  // Whether the surface leaves some motion unconstrained (degeneracy()), and which: the
  // parameters ("rx", "ry", "rz", "tx", "ty", "tz") that dominate each weak direction.
  bool degenerate = false;
  std::vector<std::string> free_directions;
  // Each line's last bracket in image 2 at the estimate (per cell of map 1; −1: none; empty when
  // the method keeps none): a later evaluation near ν starts its searches there.
  std::vector<int> hints;
  // Each line's normalized residual at the estimate, as normalizedResiduals(map1, image2, nu)
  // gives it (empty when the method does not keep them): the verdict reads them.
  std::vector<double> residuals_u;
  // Whether the method stopped at a minimum of its own cost (stepMahalanobis2 of that cost at the
  // estimate, at the loss's last scale): about 0 at a minimum, large where the method stalled
  // short of one. NaN where the method does not say.
  double step_mahalanobis2 = std::numeric_limits<double>::quiet_NaN();
};

// One Gauss–Newton step of a cost at its evaluation point, δ = −H⁻¹·∂E/∂ν/2 (H = e.JtJ, the
// loss's weights in it), and its squared length in the uncertainty of that cost's minimum,
// δᵀ·H·δ/σ² (σ: the residuals' noise in the cost's units; 1 for normalized residuals). It is the
// decrease of E/σ² the step predicts: χ²₆-distributed at the true pose, 0 at the cost's minimum.
// Directions H does not constrain (eigenvalues below 1e-12 of the largest) are left out. NaN with
// 6 lines or fewer.
double stepMahalanobis2(const IconicError& e, double sigma2);

struct Degeneracy {
  bool degenerate = false;
  std::vector<std::string> free_directions;
};

// The weak directions of JᵀJ: rotations expressed in metres at `length_m` (so that all six are
// in m²), the eigenvectors whose eigenvalue is below `ratio` of the largest are unconstrained
// (σ at least 1/√ratio, 100 times, the best-determined direction's by default); each is named by
// its largest component. A level plane leaves tx, ty and rz free; a sinusoid along x leaves ty.
Degeneracy degeneracy(const Matrix6d& JtJ, double length_m, double ratio = 1e-4);
// The same with the rotations taken about `pivot` (map 1's frame) instead of its origin: ν = A·μ,
// μ = (r, t′), t = t′ + pivot × r. A rotation about a far-away origin drags a translation of its
// lever arm with it, and JᵀJ's eigenvalues then depend on where the map lies in its frame, not
// only on its shape; about the map's own centroid (knownCentroid) they do not. The names are μ's.
Degeneracy degeneracy(const Matrix6d& JtJ, double length_m, const Eigen::Vector3d& pivot, double ratio = 1e-4);

// The mean (x, y, z) of a map's known cells in its frame (the origin when none is known).
Eigen::Vector3d knownCentroid(const ElevationMap& map);

// The paper's gradient descent (eq. 4), ν ← ν − K·∂E/∂ν, with the gain K = k·A·diag(AᵀHA)⁻¹·Aᵀ:
// ν = A·μ takes rotations about the centroid of map 1's known cells, and each μ_i steps on its own
// scale 1/(AᵀHA)_ii, H = JᵀJ (rotations and translations have different units; the paper leaves k
// to the user). k is halved until the cost (over the lines both poses have) decreases and grown
// again after each success, until the decrease is below min_relative_decrease (at the loss's
// narrowest scale) or the RMS below floor_m. As LM: map 1's normals in the gradient, the annealed Cauchy loss; one level,
// the lines of options.strides' last stride. Each departure can be turned off (IconicOptions::descent_*);
// with all four off the result is iconicPaperDescent's, bit for bit.
IconicResult iconicGradientDescent(const ElevationMap& map1, const LocusMapper& image2, const PoseVector& nu0,
                                   const IconicOptions& options = {});

// The paper's descent as printed (eq. 4–8), with nothing added: the baseline the methods above
// depart from. E = Σ (f₁ − g)² over the vertical lines of map 1's Known cells that meet image 2
// (eq. 6: plain squares, no robust loss, no weights, not divided by N), ∂E/∂ν through image 2's
// surface normal at each hit (eq. 7–8, not map 1's normals): iconicError(map1, image2, ν) with its
// defaults, every line (stride 1).
// - The update is ν ← ν − k·∂E/∂ν. Eq. 4 prints ν + k·∂E/∂ν, which climbs E for k > 0: a sign
//   typo (the text calls it a descent).
// - One scalar gain k for the whole run. The paper leaves k open; the plain rule nearest to it is
//   k = paper_gain/λ_max(JᵀJ), JᵀJ (IconicError::JtJ) at ν0, computed once. For E = Σr² the
//   Hessian is ≈ 2·JᵀJ, so a step multiplies the offset from the minimum along the eigenvector of
//   λ by 1 − 2kλ: a fixed gain is stable for k < 1/λ_max. paper_gain = 1 is that bound itself
//   (the stiffest direction's factor is −1 in the quadratic model: it does not shrink, and what
//   E has beyond the quadratic decides whether it grows: on the caps it overshot at step 4); the
//   default, 0.5, is the textbook safe gain, 1/L for L = 2·λ_max.
//   The weakest direction shrinks by 1 − 2k·λ_min per step: of order λ_max/λ_min steps, and
//   rotations (acting through lever arms of metres) against horizontal translations make that
//   ratio large (about 1.4e4 on the caps of the tests). No rescaling of the parameters, no line
//   search: those are iconicGradientDescent's departures.
// - Stop rules, the paper's ("ΔE small enough, or E itself small enough") made plain, E compared
//   as printed (each pose's sum over the lines it has, not over common lines): stop when the RMS
//   residual √(E/N) < floor_m (converged); when the relative decrease (E_i − E_i+1)/E_i is below
//   min_relative_decrease (converged); when E does not decrease (ΔE ≥ 0: the previous ν, the lower
//   E, is kept; converged only if the rise is below min_relative_decrease of E, i.e. ΔE is small
//   either way, otherwise the gain overshot); or after paper_max_iterations steps (not converged).
//   As printed, E also rises when a line enters the overlap, which stops the descent too. A step
//   that would leave 6 lines or fewer (E over almost no lines is no match) is not taken.
// iterations: the steps computed (a refused last one included); rms_m, E_m2 and lines at ν0 and
// after each step taken (E_m2 falls strictly). Covariance and degeneracy as the others', from the
// plain error at the estimate. Deterministic.
IconicResult iconicPaperDescent(const ElevationMap& map1, const LocusMapper& image2, const PoseVector& nu0,
                                const IconicOptions& options = {});

// Levenberg–Marquardt on the same residuals r = z₁ − s: (JᵀJ + λ·diag JᵀJ)·δ = −Jᵀr, λ divided by 10
// after a step that lowers the cost (over the lines both poses have) and, after one that does not,
// multiplied by 10 until the step is at most half as long; coarse to fine (options.strides), the
// Cauchy loss annealed, map 1's normals in J; each line's search starts at its last bracket.
IconicResult iconicLevenbergMarquardt(const ElevationMap& map1, const LocusMapper& image2, const PoseVector& nu0,
                                      const IconicOptions& options = {});

// Levenberg–Marquardt on the residuals weighted by 1/(σ₁² + σ₂²) (iconicError's `weighted`; the
// paper's future work), with the same levels, steps and stopping rules, the Cauchy loss in units of
// the normalized residual r/σ (its scale from 2·RMS(r/σ) down to robust_sigmas), then up to
// options.polish_iterations Gauss–Newton steps (IconicOptions), and the covariance of
// weightedCovariance.
IconicResult iconicWeighted(const ElevationMap& map1, const LocusMapper& image2, const PoseVector& nu0,
                            const IconicOptions& options = {});

// The covariance of the weighted estimate at ν (Cauchy scale c in units of σ, map 1's normals in
// the Jacobian), the sandwich A⁻¹·S·A⁻ᵀ of the estimating equation Σ g·r = 0, g = w·J/σ²: a
// crossing of a line with an image is interpolated from the four pixels around it, so two lines
// whose crossings share pixels err together; S sums, per pixel of each image, the weighted
// Jacobians of the lines that read it, each line's σ spread over its pixels as its bilinear
// weights spread it. A = Σ g·J₂ᵀ, J₂ the line's Jacobian through image 2's own bilinear patch at
// the crossing (how r actually moves: the counts' staircase and the noise), not map 1's smoothed
// normal that g takes (docs/matching.md, "Calibration"). With no pixel shared, J₂ = J and c = 0
// (or every |u| ≪ c), S = A = H = JᵀWJ and the covariance is H⁻¹. map1_source as in IconicOptions (may be null).
// influence_bread (IconicOptions, on by default): A = Σ (ψ′(u)/w)·g·J₂ᵀ, the estimating equation's own derivative,
// ψ′(u) = (1 − u²/c²)/(1 + u²/c²)² the Cauchy influence's at the line's u = r/σ, where g holds its
// weight w = 1/(1 + u²/c²); off, A holds w.
Matrix6d weightedCovariance(const ElevationMap& map1, const LocusMapper& image2, const PoseVector& nu, double c,
                            const std::vector<Eigen::Vector3d>& reference_normals,
                            const LocusMapper* map1_source, bool influence_bread = true);

// Registering a view with these (the believed pose, map J, every method): perception/registration.hpp.

// ∂R/∂r_k for R = exp([r]×) (k = 0, 1, 2): (r_k·[r]× + [r × (I − R)·e_k]×)·R / |r|², and [e_k]× at
// r = 0.
Eigen::Matrix3d rotationDerivative(const Eigen::Vector3d& r, int k);

}  // namespace ambler::perception
