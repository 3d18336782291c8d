// Iconic matching's error and gradient (paper §4.2, eq. 5–8) on a smooth analytic surface: a dome
// (a sphere's cap) seen by a noise-free sensor. ∂R/∂r of the exponential map and ∂E/∂ν both agree
// with central finite differences; at the true transform E is only the interpolation's error.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <numbers>
#include <vector>
#include <cstdio>
#include <algorithm>

#include <Eigen/Eigenvalues>

#include "perception/iconic.hpp"
#include "perception/scan_to_map.hpp"
#include "synthetic.hpp"
#include "perception/sensor_geometry.hpp"

namespace ambler::perception {
namespace {

constexpr double kDeg = std::numbers::pi / 180.0;

using test::Dome;
using test::domeImage;
using test::domeMap;

TEST(Iconic, RotationDerivativeMatchesFiniteDifferences) {
  for (const Eigen::Vector3d& r : {Eigen::Vector3d(0.3, -0.2, 0.5), Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(1e-3, 2e-3, -1e-3)}) {
    for (int k = 0; k < 3; ++k) {
      const double h = 1e-6;
      PoseVector a = PoseVector::Zero(), b = PoseVector::Zero();
      a.head<3>() = r, b.head<3>() = r;
      a(k) += h, b(k) -= h;
      const Eigen::Matrix3d fd = (poseFromVector(a).linear() - poseFromVector(b).linear()) / (2 * h);
      // Central differences err by h²/6·|R'''| ≈ 2e-13 and by rounding, ε/h ≈ 2e-10.
      EXPECT_LT((rotationDerivative(r, k) - fd).cwiseAbs().maxCoeff(), 1e-9) << r.transpose() << " k " << k;
    }
  }
}

// ∂E/∂ν of eq. 7–8 against central differences of E, at a transform off the truth by about 2° and
// 5 cm. The search is converged to ε = 1e-12 rad, so E is smooth to ~1e-20 m² per line and the
// differences with h = 1e-6 err by (E'''·h²) and rounding ≪ 1e-4 of the gradient's size.
TEST(Iconic, GradientMatchesFiniteDifferences) {
  const Dome dome;
  const RangeImage image2 = domeImage(dome, sensorPose({0.5, -3, 3}, {0, -30 * kDeg, 5 * kDeg}));
  LocusConfig config;
  config.epsilon_rad = 1e-12;
  SensorModel noise_free;
  noise_free.noise_k = 0, noise_free.quantization_m = 0;
  const LocusMapper mapper(image2, noise_free, nullptr, config);
  const ElevationMap map1 = domeMap(dome);
  PoseVector nu;
  nu << 0.01, -0.02, 0.03, 0.05, -0.04, 0.02;
  const IconicError at = iconicError(map1, mapper, nu);
  ASSERT_GT(at.overlap, 1000);
  ASSERT_GT(at.E, 0.0);
  const double h = 1e-6;
  PoseVector fd;
  for (int k = 0; k < 6; ++k) {
    PoseVector a = nu, b = nu;
    a(k) += h, b(k) -= h;
    const IconicError ea = iconicError(map1, mapper, a, false), eb = iconicError(map1, mapper, b, false);
    ASSERT_EQ(ea.overlap, at.overlap) << k;  // the same lines on both sides: E is smooth here
    ASSERT_EQ(eb.overlap, at.overlap) << k;
    fd(k) = (ea.E - eb.E) / (2 * h);
  }
  EXPECT_LT((at.gradient - fd).norm(), 1e-4 * fd.norm()) << "analytic " << at.gradient.transpose() << "\nfd " << fd.transpose();
}

// At the true transform (map 1 and image 2 both in the world frame: ν = 0) the two surfaces differ
// only by the image's interpolation between pixels: ρ is interpolated linearly in the scan angles,
// which errs by ρ''·Δφ²/8 with ρ'' ≈ ρ·(1 + 2·cot²γ) at grazing angle γ — about 1 mm at 8 m and
// 20°; the locus tests bound it by 2 mm (grazing ≥ 10°, ρ ≤ 15 m). The truth is also where E is
// least: a transform 2° and 5 cm off has an E hundreds of times larger.
TEST(Iconic, ErrorAtTheTruthIsTheInterpolationsOnly) {
  const Dome dome;
  const RangeImage image2 = domeImage(dome, sensorPose({0.5, -3, 3}, {0, -30 * kDeg, 5 * kDeg}));
  LocusConfig config;
  SensorModel noise_free;
  noise_free.noise_k = 0, noise_free.quantization_m = 0;
  const LocusMapper mapper(image2, noise_free, nullptr, config);
  const IconicError e = iconicError(domeMap(dome), mapper, PoseVector::Zero());
  ASSERT_GT(e.overlap, 1000);
  EXPECT_LT(std::sqrt(e.E / e.overlap), 2e-3);
  PoseVector nu;
  nu << 0.01, -0.02, 0.03, 0.05, -0.04, 0.02;
  const IconicError off = iconicError(domeMap(dome), mapper, nu, false);
  EXPECT_GT(off.E / off.overlap, 100 * e.E / e.overlap);
}


using test::Caps;
using test::capsImage;

// Both iconic methods recover a transform from an initial error of 0.14 m and 1.8°. View 1 maps
// the caps in the world frame; view 2, 0.3 m aside and turned 4°, is mapped in a frame moved by
// (0.2, −0.1, 0.05) m and 3° of yaw, so the truth is that frame's T_M2W. Both use GNC edges, so
// that the caps' range shadows are left out (shadow cells of map 1, shadow crossings in image 2)
// rather than bridged. Noise-free, the only bias is the two interpolations' (≤ 2 mm per line, of
// both signs over ~2 000 lines): 5 mm and 0.05°, the bound docs/matching.md sets for noise-free
// terrain.
TEST(Iconic, DescentAndLevenbergMarquardtRecoverTheTransform) {
  const Caps caps;
  SensorModel ideal;
  ideal.noise_k = 0, ideal.quantization_m = 0, ideal.ambiguity_m = 0;
  const Eigen::Isometry3d T1 = sensorPose({0, -3, 3}, {0, -30 * kDeg, 0});
  const ElevationMap map1 =
      scanToMap(capsImage(caps, T1), ideal, T1, MapGrid::covering(-3, 3, 1.5, 8, 0.1)).map;
  const RangeImage image2 = capsImage(caps, sensorPose({0.3, -2.5, 3}, {0, -32 * kDeg, -4 * kDeg}));
  const Raster<std::uint8_t> edges2 = detectRangeEdges(image2, ideal);
  const Eigen::Isometry3d T_WM2 = mapFrame({0.2, -0.1, 0.05}, 3 * kDeg);
  const LocusMapper mapper(image2, ideal, &edges2, LocusConfig{}, T_WM2);
  const Eigen::Isometry3d truth = T_WM2.inverse();
  PoseVector start = vectorFromPose(truth);
  start += (PoseVector() << 0.005, -0.005, 0.03, 0.1, -0.08, 0.03).finished();
  const PoseError initial = poseError(truth, poseFromVector(start));
  ASSERT_GT(initial.translation_m, 0.1);
  enum class IconicMethod { LevenbergMarquardt, Weighted, Descent };
  for (const IconicMethod method : {IconicMethod::LevenbergMarquardt, IconicMethod::Weighted, IconicMethod::Descent}) {
    const char* name = method == IconicMethod::Descent ? "descent" : method == IconicMethod::Weighted ? "weighted" : "LM";
    const IconicResult res = method == IconicMethod::LevenbergMarquardt ? iconicLevenbergMarquardt(map1, mapper, start)
                             : method == IconicMethod::Weighted         ? iconicWeighted(map1, mapper, start)
                                                                        : iconicGradientDescent(map1, mapper, start);
    const PoseError err = poseError(truth, poseFromVector(res.nu));
    EXPECT_LT(err.translation_m, 5e-3) << name << " after " << res.iterations;
    EXPECT_LT(err.rotation_deg, 0.05) << name << " after " << res.iterations;
    EXPECT_GT(res.overlap, 1000);
    EXPECT_LT(res.rms_m.back(), res.rms_m.front());
    EXPECT_FALSE(res.degenerate) << "free: " << res.free_directions.size();
    std::printf("%s: %d iterations, RMS %.4f -> %.5f m, error %.2e m %.2e deg\n", name, res.iterations,
                res.rms_m.front(), res.rms_m.back(), err.translation_m, err.rotation_deg);
  }
}

}  // namespace
}  // namespace ambler::perception

namespace ambler::perception {
namespace {

// A level plane constrains only tz and the two tilts: tx, ty and rz are flagged free, and the
// covariance is not given. The caps constrain all six.
TEST(Iconic, PlaneIsDegenerateInXYAndYaw) {
  const test::Plane plane{0.0, 0.0, 0.0};
  const RangeImage image2 = test::planeImage(plane, sensorPose({0.3, -2.5, 3}, {0, -32 * kDeg, -4 * kDeg}));
  LocusConfig config;
  SensorModel noise_free;
  noise_free.noise_k = 0, noise_free.quantization_m = 0;
  const LocusMapper mapper(image2, noise_free, nullptr, config);
  ElevationMap map1(MapGrid::covering(-3, 3, 1.5, 8, 0.1));
  for (int r = 0; r < map1.grid().rows; ++r)
    for (int c = 0; c < map1.grid().cols; ++c) map1.setKnown(r, c, 0.0f, 1e-3f);
  PoseVector start;
  start << 0.01, -0.01, 0.02, 0.1, 0.1, 0.05;
  const IconicResult res = iconicLevenbergMarquardt(map1, mapper, start);
  EXPECT_TRUE(res.degenerate);
  EXPECT_EQ(res.free_directions, (std::vector<std::string>{"rz", "tx", "ty"}));
  EXPECT_TRUE(std::isnan(res.covariance(0, 0)));
  // What the plane does fix comes back: tz and the tilts (the free ones stay where they began).
  const Eigen::Isometry3d T = poseFromVector(res.nu);
  EXPECT_NEAR(T.translation().z(), 0.0, 1e-3);
  EXPECT_LT(std::abs(T.linear()(2, 0)) + std::abs(T.linear()(2, 1)), 1e-3);
}

// A sinusoid along x, z = A·sin(2πx/λ), slides into itself along y: its point-to-plane Jacobian
// rows (p × n, n) (the residual n·(R·p + t − q) differentiated at the identity) leave exactly ty
// free. degeneracy() on Σ J·Jᵀ over a 10 cm grid names ty alone; a sinusoid along both axes none.
TEST(Iconic, SinusoidAlongXIsDegenerateInY) {
  const double A = 0.1, lambda = 1.0, k = 2 * M_PI / lambda;
  const auto jtj = [&](bool both) {
    Matrix6d H = Matrix6d::Zero();
    for (double x = -3; x <= 3; x += 0.1)
      for (double y = 1.5; y <= 8; y += 0.1) {
        const double zx = A * k * std::cos(k * x), zy = both ? A * k * std::cos(k * y) : 0.0;
        const double z = A * std::sin(k * x) + (both ? A * std::sin(k * y) : 0.0);
        const Eigen::Vector3d p(x, y, z), n = Eigen::Vector3d(-zx, -zy, 1).normalized();
        Eigen::Matrix<double, 6, 1> J;
        J << p.cross(n), n;
        H += J * J.transpose();
      }
    return H;
  };
  const double half_diagonal = 0.5 * std::hypot(6.0, 6.5);
  const Degeneracy along_x = degeneracy(jtj(false), half_diagonal);
  EXPECT_TRUE(along_x.degenerate);
  EXPECT_EQ(along_x.free_directions, std::vector<std::string>{"ty"});
  EXPECT_FALSE(degeneracy(jtj(true), half_diagonal).degenerate);
}

}  // namespace
}  // namespace ambler::perception

namespace ambler::perception {
namespace {

// The caps seen from two poses, mapped from the first, as the recovery test has them.
struct CapsPair {
  Caps caps;
  SensorModel ideal;
  ElevationMap map1;
  RangeImage image2;
  CapsPair() {
    ideal.noise_k = 0, ideal.quantization_m = 0, ideal.ambiguity_m = 0;
    const Eigen::Isometry3d T1 = sensorPose({0, -3, 3}, {0, -30 * kDeg, 0});
    map1 = scanToMap(capsImage(caps, T1), ideal, T1, MapGrid::covering(-3, 3, 1.5, 8, 0.1)).map;
    image2 = capsImage(caps, sensorPose({0.3, -2.5, 3}, {0, -32 * kDeg, -4 * kDeg}));
  }
};

// The weighted cost is the plain one with each residual divided by σ = √(σ₁² + σ₂²): with σ₁ = 1 m on
// every cell (σ₂ ≤ a few mm here, so σ² = 1 + O(1e-5)) E, ∂E/∂ν and JᵀWJ are the plain ones to 1e-4.
TEST(Iconic, WeightedCostDividesEachResidualByItsSigma) {
  CapsPair p;
  for (int r = 0; r < p.map1.grid().rows; ++r)
    for (int c = 0; c < p.map1.grid().cols; ++c)
      if (p.map1.stateAt(r, c) == CellState::Known) p.map1.sigma()(r, c) = 1.0f;
  const LocusMapper mapper(p.image2, p.ideal, nullptr);
  PoseVector nu;
  nu << 0.005, -0.005, 0.03, 0.1, -0.08, 0.03;
  const IconicError plain = iconicError(p.map1, mapper, nu), weighted = iconicError(p.map1, mapper, nu, true, 0, nullptr, 1, true);
  ASSERT_GT(plain.overlap, 1000);
  EXPECT_EQ(weighted.overlap, plain.overlap);
  EXPECT_NEAR(weighted.E, plain.E, 1e-4 * plain.E);
  EXPECT_NEAR(weighted.sum_u2, plain.sum_r2, 1e-4 * plain.sum_r2);
  EXPECT_EQ(weighted.sum_r2, plain.sum_r2);
  EXPECT_LT((weighted.gradient - plain.gradient).norm(), 1e-4 * plain.gradient.norm());
  EXPECT_LT((weighted.JtJ - plain.JtJ).norm(), 1e-4 * plain.JtJ.norm());
}

// Map 1's known cells every 0.6 m (every sixth row and column): lines that share no pixel of
// either image (the test below says why).
ElevationMap everySixthCell(const ElevationMap& map) {
  ElevationMap sparse(map.grid());
  for (int r = 0; r < map.grid().rows; r += 6)
    for (int c = 0; c < map.grid().cols; c += 6)
      if (map.stateAt(r, c) == CellState::Known) sparse.setKnown(r, c, map.elevation()(r, c), map.sigma()(r, c));
  return sparse;
}

// Lines that share no pixel of either image are independent observations: with the Jacobian taken
// where the lines meet image 2 (map 1's normals not given, NaN: image 2's own at each hit, so that
// J = J₂ and A = H) the covariance is then the inverse information (JᵀWJ)⁻¹ itself. Map 1's cells
// every 0.6 m: the caps' pixels cover at most 25 cm of ground here (ρ·Δφ/sin γ at 9 m), so no two
// lines read the same pixel. With every cell (10 cm apart, several lines per pixel) the correction
// only adds: the covariance exceeds the naive one in every direction. With map 1's normals in g the
// sandwich differs from the naive inverse by what the two normals differ (noise-free caps: little).
TEST(Iconic, WeightedCovarianceOfLinesSharingNoPixelIsTheInverseInformation) {
  CapsPair p;
  const LocusMapper mapper(p.image2, p.ideal, nullptr);
  const Eigen::Isometry3d T1 = sensorPose({0, -3, 3}, {0, -30 * kDeg, 0});
  const RangeImage image1 = capsImage(p.caps, T1);
  const LocusMapper source(image1, p.ideal, nullptr);
  const ElevationMap sparse = everySixthCell(p.map1);
  const PoseVector nu = PoseVector::Zero();
  for (const bool all : {false, true}) {
    const ElevationMap& m = all ? p.map1 : sparse;
    const std::vector<Eigen::Vector3d> normals(std::size_t(m.grid().cells()),
                                               Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN()));
    const IconicError e = iconicError(m, mapper, nu, true, 0, &normals, 1, true);
    ASSERT_GT(e.overlap, all ? 1000 : 30);
    const Matrix6d naive = e.JtJ.ldlt().solve(Matrix6d::Identity());
    for (const LocusMapper* src : {&source, static_cast<const LocusMapper*>(nullptr)}) {
      const Matrix6d P = weightedCovariance(m, mapper, nu, 0, normals, src);
      if (!all) {
        EXPECT_LT((P - naive).norm(), 1e-9 * naive.norm()) << (src ? "with image 1" : "without");
      } else {
        // P − naive is positive definite: its least eigenvalue in the naive one's metric.
        const Eigen::LLT<Matrix6d> L(naive);
        const Matrix6d Li = L.matrixL().solve(Matrix6d::Identity());
        const Matrix6d ratio = Li * P * Li.transpose();
        EXPECT_GT(Eigen::SelfAdjointEigenSolver<Matrix6d>(ratio).eigenvalues().minCoeff(), 1.0)
            << (src ? "with image 1" : "without");
      }
    }
  }
}

// The sandwich's bread is the derivative of the estimating equation Σ ψ(u)·J/σ (u = r/σ), not the
// Gauss–Newton matrix: with the Cauchy loss ψ(u) = u/(1 + u²/c²), so A = Σ ψ′(u)·J·J₂ᵀ/σ² with
// ψ′(u) = (1 − u²/c²)/(1 + u²/c²)², while the weights the steps use are w = 1/(1 + u²/c²). On lines
// that share no pixel (the sparse map of the test above) and J = J₂ the covariance is then the
// M-estimator's closed form A⁻¹·S·A⁻¹ with S = Σ w²·J·Jᵀ/σ², each line's J·Jᵀ/σ² taken from a map
// holding that cell alone, from a pose off the truth (residuals of centimetres) with c their median
// |u|, so that the lines lie on both sides of the influence's turn at |u| = c
// (IconicOptions::influence_bread, the default). The bread with w instead is the same closed form
// with A_w = Σ w·J·Jᵀ/σ², and differs from it by more than 10 % here.
TEST(Iconic, WeightedCovarianceBreadIsTheInfluenceDerivative) {
  CapsPair p;
  const LocusMapper mapper(p.image2, p.ideal, nullptr);
  const ElevationMap sparse = everySixthCell(p.map1);
  const std::vector<Eigen::Vector3d> normals(std::size_t(sparse.grid().cells()),
                                             Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN()));
  PoseVector nu;
  nu << 0.002, -0.002, 0.01, 0.02, -0.015, 0.01;
  const std::vector<double> u = normalizedResiduals(sparse, mapper, nu);
  std::vector<double> au;
  for (const double x : u)
    if (std::isfinite(x)) au.push_back(std::abs(x));
  ASSERT_GT(au.size(), 30u);
  std::nth_element(au.begin(), au.begin() + long(au.size() / 2), au.end());
  const double c = au[au.size() / 2];
  Matrix6d A = Matrix6d::Zero(), S = Matrix6d::Zero(), A_w = Matrix6d::Zero();
  int beyond = 0;
  for (int r = 0; r < sparse.grid().rows; ++r)
    for (int col = 0; col < sparse.grid().cols; ++col) {
      const double ui = u[std::size_t(r) * sparse.grid().cols + col];
      if (!std::isfinite(ui)) continue;
      ElevationMap one(sparse.grid());
      one.setKnown(r, col, sparse.elevation()(r, col), sparse.sigma()(r, col));
      const Matrix6d M = iconicError(one, mapper, nu, true, 0, &normals, 1, true).JtJ;  // J·Jᵀ/σ²
      const double q = ui * ui / (c * c), w = 1 / (1 + q);
      A += w * (1 - q) / (1 + q) * M, S += w * w * M, A_w += w * M;
      beyond += q > 1;
    }
  EXPECT_GT(beyond, 10);
  const Matrix6d Ai = A.inverse(), Awi = A_w.inverse();
  const Matrix6d expected = Ai * S * Ai.transpose(), with_w = Awi * S * Awi.transpose();
  const Matrix6d P = weightedCovariance(sparse, mapper, nu, c, normals, nullptr);
  EXPECT_LT((P - expected).norm(), 1e-9 * expected.norm());
  // The weight's bread: the closed form with A_w, and the two differ here.
  const Matrix6d P_w = weightedCovariance(sparse, mapper, nu, c, normals, nullptr, false);
  EXPECT_LT((P_w - with_w).norm(), 1e-9 * with_w.norm());
  EXPECT_GT((with_w - expected).norm(), 0.1 * expected.norm());
}

}  // namespace
}  // namespace ambler::perception

namespace ambler::perception {
namespace {

// The recovery test's pair (GNC edges in image 2, map 2's frame moved by T_WM2) and its start, 0.14 m
// and 1.8° off the truth.
struct CapsRecovery {
  CapsPair pair;
  Raster<std::uint8_t> edges2 = detectRangeEdges(pair.image2, pair.ideal);
  Eigen::Isometry3d T_WM2 = mapFrame({0.2, -0.1, 0.05}, 3 * kDeg);
  LocusMapper mapper{pair.image2, pair.ideal, &edges2, LocusConfig{}, T_WM2};
  PoseVector truth = vectorFromPose(T_WM2.inverse());
  PoseVector start = truth + (PoseVector() << 0.005, -0.005, 0.03, 0.1, -0.08, 0.03).finished();
};

// One step of the paper's descent is ν0 − k·∂E/∂ν with k = paper_gain/λ_max(JᵀJ), E, its gradient
// and JᵀJ those of the plain eq. 6 (image 2's normals, every line) at ν0: the same sums and the same
// eigensolver, so the step agrees to rounding (1e-12 of its length); it lowers E.
TEST(Iconic, PaperDescentStepsAgainstTheGradient) {
  const CapsRecovery s;
  IconicOptions options;
  options.paper_max_iterations = 1;
  const IconicResult res = iconicPaperDescent(s.pair.map1, s.mapper, s.start, options);
  const IconicError e0 = iconicError(s.pair.map1, s.mapper, s.start, true, 0, nullptr, 1, false);
  const double lambda_max = Eigen::SelfAdjointEigenSolver<Matrix6d>(e0.JtJ).eigenvalues().maxCoeff();
  const PoseVector step = -(options.paper_gain / lambda_max) * e0.gradient;
  ASSERT_GT(e0.overlap, 1000);
  EXPECT_EQ(res.iterations, 1);
  ASSERT_EQ(res.E_m2.size(), 2u);  // the step was taken
  EXPECT_EQ(res.E_m2.front(), e0.E);
  EXPECT_LT(res.E_m2.back(), res.E_m2.front());
  EXPECT_LE((res.nu - (s.start + step)).norm(), 1e-12 * step.norm());
}

// The paper's descent is a fixed-gain iteration. Near the minimum E ≈ E* + δᵀ·JᵀJ·δ (δ = ν − ν*),
// so a step −k·∂E/∂ν = −2k·JᵀJ·δ multiplies δ's component along each eigenvector of JᵀJ (eigenvalue
// λ) by ρ = 1 − 2kλ, and after n steps by ρⁿ. On the caps λ spans 4.6 to 6.6e4 (ν in rad and m):
// the tilts, tz and yaw are stiff (rotations act through lever arms of metres); tx and ty, held
// only by the caps' flanks, are weak. With paper_gain 0.5 (k = 1/L for the Hessian L = 2·λ_max,
// the textbook safe gain: the default 1 is the stability bound itself, and from this start the
// stiffest direction grows after four steps), 2 000 steps bring every stiff direction to the
// truth (ρⁿ < 1e-5) and leave some 87 % of the start's offset along the weakest (ρⁿ =
// (1 − 4.6/6.6e4)^2000) and 28 % along ty (λ ≈ 42): the descent converges, at the rate its one
// gain allows. Tolerance per direction: |δ − ρⁿ·δ(0)| ≤ 0.1·|δ(0)| + 1e-3. JᵀJ is taken at ν0;
// along the path its eigenvalues change by up to 10 % (4.6, 46, 376, 736, 9.3e3, 6.4e4 at the
// truth), which moves ρⁿ = e^(−x) by at most 0.1·x·e^(−x) ≤ 0.037 of δ(0), and its eigenvectors
// turn, which shows a little of the weak directions' offset in the stiff ones: 0.1. The minimum of
// eq. 6 lies off the truth by the two interpolations' bias (6e-4 in ν here, Gauss–Newton from the
// truth; the recovery test bounds it by 5 mm and 0.05°): 1e-3. E falls at every step taken.
TEST(Iconic, PaperDescentConvergesAtTheRateOfItsFixedGain) {
  const CapsRecovery s;
  IconicOptions options;
  options.paper_gain = 0.5;
  const IconicResult res = iconicPaperDescent(s.pair.map1, s.mapper, s.start, options);
  const IconicError e0 = iconicError(s.pair.map1, s.mapper, s.start);
  const Eigen::SelfAdjointEigenSolver<Matrix6d> eig(e0.JtJ);
  const double k = options.paper_gain / eig.eigenvalues()(5);
  const int steps = int(res.E_m2.size()) - 1;  // the steps taken (a refused last one is not)
  ASSERT_GT(steps, 0);
  for (std::size_t i = 1; i < res.E_m2.size(); ++i) ASSERT_LE(res.E_m2[i], res.E_m2[i - 1]) << "step " << i;
  for (int i = 0; i < 6; ++i) {
    const PoseVector v = eig.eigenvectors().col(i);
    const double d0 = v.dot(s.start - s.truth), d = v.dot(res.nu - s.truth);
    const double predicted = std::pow(1 - 2 * k * eig.eigenvalues()(i), steps) * d0;
    EXPECT_NEAR(d, predicted, 0.1 * std::abs(d0) + 1e-3) << "direction " << i << ", λ " << eig.eigenvalues()(i);
    std::printf("paper descent: direction %d (λ %.3g): %+.2e -> %+.2e (predicted %+.2e)\n", i, eig.eigenvalues()(i), d0, d,
                predicted);
  }
  EXPECT_GT(res.overlap, 1000);
  EXPECT_LT(res.rms_m.back(), res.rms_m.front());
  EXPECT_FALSE(res.degenerate) << "free: " << res.free_directions.size();
  const PoseError initial = poseError(poseFromVector(s.truth), poseFromVector(s.start));
  const PoseError err = poseError(poseFromVector(s.truth), poseFromVector(res.nu));
  std::printf("paper descent: %d iterations (converged %d), RMS %.4f -> %.5f m, error %.3f m %.2f deg -> %.2e m %.2e deg\n",
              res.iterations, int(res.converged), res.rms_m.front(), res.rms_m.back(), initial.translation_m,
              initial.rotation_deg, err.translation_m, err.rotation_deg);
}

// iconicGradientDescent with its four departures off (image 2's normals, plain squares, the identity
// gain, one fixed gain k = paper_gain/λ_max(JᵀJ at ν0)) is the paper's descent as printed: the same
// sums over the same lines (each line's search hint finds the crossing found without it, bit for bit),
// the same eigensolver, the same step ν − k·∂E/∂ν (written 2k·(∂E/∂ν/2): scaling by 2 is exact) and
// the same stop rules, so ν, the trace and the stop agree exactly. From the recovery test's start
// (0.14 m, 1.8°), ended by each rule in turn: the step cap (300), a relative decrease below 1e-2, the
// RMS below 1 cm (it starts at 5.5 cm).
TEST(Iconic, DescentWithEveryDepartureOffIsThePaperDescent) {
  const CapsRecovery s;
  IconicOptions literal;
  literal.descent_reference_normals = literal.descent_robust_loss = false;
  literal.descent_centroid_gain = literal.descent_backtracking = false;
  literal.paper_max_iterations = 300;
  IconicOptions decrease = literal, floor = literal;
  decrease.min_relative_decrease = 1e-2;
  floor.floor_m = 0.01;
  for (const IconicOptions& options : {literal, decrease, floor}) {
    const IconicResult paper = iconicPaperDescent(s.pair.map1, s.mapper, s.start, options);
    const IconicResult ours = iconicGradientDescent(s.pair.map1, s.mapper, s.start, options);
    ASSERT_GT(paper.iterations, 1);
    EXPECT_EQ(ours.iterations, paper.iterations);
    EXPECT_EQ(ours.converged, paper.converged);
    EXPECT_EQ(ours.E_m2, paper.E_m2);
    for (int i = 0; i < 6; ++i) EXPECT_EQ(ours.nu(i), paper.nu(i)) << "component " << i;
    std::printf("paper and all-off: %d steps (converged %d), RMS %.4f m\n", paper.iterations, int(paper.converged),
                paper.rms_m.back());
  }
  // The switches reach the departures: with them on (the defaults) the descent is another, and reaches
  // the truth (the recovery test's bound).
  const IconicResult robust = iconicGradientDescent(s.pair.map1, s.mapper, s.start);
  EXPECT_LT(poseError(poseFromVector(s.truth), poseFromVector(robust.nu)).translation_m, 5e-3);
}

// Negative control: eq. 4 as printed, ν0 + k·∂E/∂ν, raises E (first order by k·|∂E/∂ν|²); the
// corrected sign lowers it.
TEST(Iconic, PaperDescentWithThePrintedSignClimbs) {
  const CapsRecovery s;
  const IconicError e0 = iconicError(s.pair.map1, s.mapper, s.start);
  ASSERT_GT(e0.overlap, 1000);
  const double k = 1.0 / Eigen::SelfAdjointEigenSolver<Matrix6d>(e0.JtJ).eigenvalues().maxCoeff();
  const IconicError printed = iconicError(s.pair.map1, s.mapper, s.start + k * e0.gradient, false);
  const IconicError corrected = iconicError(s.pair.map1, s.mapper, s.start - k * e0.gradient, false);
  EXPECT_GT(printed.E, e0.E);
  EXPECT_LT(corrected.E, e0.E);
  std::printf("E %.4f m2: printed + %.4f, corrected - %.4f (k|dE/dnu|^2 %.4f)\n", e0.E, printed.E, corrected.E,
              k * e0.gradient.squaredNorm());
}

// The same constrained surface (the sinusoid along both axes) moved 40 m from the origin of its
// frame: its rows (p × n, n) now carry a 40 m lever arm in every rotation. About the origin the
// eigenvalues change with that arm alone, so the shape's verdict would depend on where the map
// lies; about the surface's centroid the moved surface's JᵀJ is the first one's transformed by
// ν = A·μ exactly, and its verdict is the same as near the origin.
TEST(Iconic, DegeneracyAboutTheCentroidDoesNotDependOnWhereTheMapLies) {
  const double A = 0.1, k = 2 * M_PI;
  // The rows over the sinusoid along x (and along y too when `both`), moved by `shift`.
  const auto jtj = [&](bool both, const Eigen::Vector3d& shift, Eigen::Vector3d* centroid) {
    Matrix6d H = Matrix6d::Zero();
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    long n_points = 0;
    for (double x = -3; x <= 3; x += 0.1)
      for (double y = 1.5; y <= 8; y += 0.1) {
        const double zx = A * k * std::cos(k * x), zy = both ? A * k * std::cos(k * y) : 0.0;
        const double z = A * std::sin(k * x) + (both ? A * std::sin(k * y) : 0.0);
        const Eigen::Vector3d p = Eigen::Vector3d(x, y, z) + shift, n = Eigen::Vector3d(-zx, -zy, 1).normalized();
        Eigen::Matrix<double, 6, 1> J;
        J << p.cross(n), n;
        H += J * J.transpose();
        sum += p;
        ++n_points;
      }
    *centroid = sum / double(n_points);
    return H;
  };
  const double half_diagonal = 0.5 * std::hypot(6.0, 6.5);
  const Eigen::Vector3d far_away(40, 0, 0);
  Eigen::Vector3d c0, c1;
  const Matrix6d near = jtj(true, Eigen::Vector3d::Zero(), &c0), far = jtj(true, far_away, &c1);
  ASSERT_FALSE(degeneracy(near, half_diagonal, c0).degenerate);
  EXPECT_FALSE(degeneracy(far, half_diagonal, c1).degenerate);
  // About the far map's origin the lever arm makes the same shape read as degenerate.
  EXPECT_TRUE(degeneracy(far, half_diagonal).degenerate);
  // And the sinusoid along x alone keeps its one free direction, ty, wherever it lies.
  const Degeneracy d = degeneracy(jtj(false, far_away, &c1), half_diagonal, c1);
  EXPECT_TRUE(d.degenerate);
  EXPECT_EQ(d.free_directions, std::vector<std::string>{"ty"});
}


}  // namespace
}  // namespace ambler::perception
