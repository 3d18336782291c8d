// The rover's traverse loop (perception/traverse.hpp) on a plane seen by an exact sensor: the
// windows on the corridor's lattice, the pose it carries from stop to stop by odometry, what it
// does with an accepted and a rejected registration, and the composite it merges.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "perception/composite.hpp"
#include "perception/odometry.hpp"
#include "perception/sensor_geometry.hpp"
#include "perception/traverse.hpp"
#include "synthetic.hpp"

namespace ambler::perception {
namespace {

constexpr double kDeg = std::numbers::pi / 180;
const test::Plane kPlane{0.02, -0.01, 0.3};

SensorModel exactSensor() {
  SensorModel s;
  s.noise_k = 0, s.quantization_m = 0, s.ambiguity_m = 0, s.mixed_pixels = false;
  return s;
}

// A level body at (x, y) on the plane's height there, heading ψ (the plane's tilt left out: the
// tests want the poses odometry composes, not the terrain's).
Eigen::Isometry3d bodyAt(double x, double y, double heading) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(heading, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  T.translation() = Eigen::Vector3d(x, y, kPlane.z(x, y));
  return T;
}

LocaliserConfig planeConfig(TraverseReference reference) {
  LocaliserConfig c;
  c.reference = reference;
  c.corridor = MapGrid::covering(-10, 30, -12, 12, 0.1);
  c.map.shadows = ShadowMethod::None;
  return c;
}

// A registrar that returns a fixed verdict and moves the believed pose by `shift` (metres in x).
Registrar fixedRegistrar(bool accepted, double shift, int* calls) {
  return [=](const ReferenceView&, const ScanMap&, const Eigen::Isometry3d& believed, const RegistrationConfig&) {
    ++*calls;
    RegistrationResult r;
    r.correction = Eigen::Isometry3d(Eigen::Translation3d(shift, 0, 0));
    r.corrected_WS = r.correction * believed;
    r.nu = vectorFromPose(r.correction.inverse());
    r.assessment.accepted = accepted;
    return r;
  };
}

// Walks `n` stops 1 m apart along +x from x = 0 with exact odometry.
std::vector<Eigen::Isometry3d> walk(Localiser& rover, int n) {
  std::vector<Eigen::Isometry3d> truth;
  const SensorModel sensor = exactSensor();
  for (int k = 0; k < n; ++k) {
    truth.push_back(bodyAt(k, 0, 0));
    const RangeImage image = test::planeImage(kPlane, sensorOnBody(truth.back(), rover.config().mount));
    if (k == 0)
      rover.start(image, sensor, truth[0]);
    else
      rover.step(image, sensor, stepBetween(truth[k - 1], truth[k]), tiltOf(truth[k].linear()));
  }
  return truth;
}

TEST(Localiser, WindowsLieOnTheCorridorsLattice) {
  int calls = 0;
  const Localiser rover(planeConfig(TraverseReference::None), fixedRegistrar(true, 0, &calls));
  const MapGrid& g = rover.config().corridor;
  // A sensor at (2, 0) heading +x (yaw −90° in the sensor convention): the region x ∈ [−5, 5]
  // right, y ∈ [3, 14] forward covers world x ∈ [5, 16], y ∈ [−5, 5].
  const Eigen::Isometry3d T = sensorPose({2, 0, 3}, {0, -30 * kDeg, -90 * kDeg});
  const CorridorWindow w = rover.window(T);
  EXPECT_EQ(w.col0, int(std::lround((5 - g.x_min) / g.cell)));
  EXPECT_EQ(w.row0, int(std::lround((g.y_max - 5) / g.cell)));
  EXPECT_EQ(w.grid.cols, 110);
  EXPECT_EQ(w.grid.rows, 100);
  EXPECT_NEAR(w.grid.x_min, 5.0, 1e-12);
  EXPECT_NEAR(w.grid.y_max, 5.0, 1e-12);
  // Clipped where the corridor ends.
  const CorridorWindow far = rover.window(sensorPose({25, 0, 3}, {0, -30 * kDeg, -90 * kDeg}));
  EXPECT_EQ(far.col0 + far.grid.cols, g.cols);
}

TEST(Localiser, WithExactOdometryAndNoRegistrationTheEstimateIsTheTruth) {
  int calls = 0;
  Localiser rover(planeConfig(TraverseReference::None), fixedRegistrar(true, 0, &calls));
  const std::vector<Eigen::Isometry3d> truth = walk(rover, 6);
  EXPECT_EQ(calls, 0);
  ASSERT_EQ(rover.stops().size(), truth.size());
  for (std::size_t k = 0; k < truth.size(); ++k) {
    EXPECT_LT((rover.stops()[k].estimated_WB.matrix() - truth[k].matrix()).norm(), 1e-12) << k;
    EXPECT_FALSE(rover.stops()[k].registered);
  }
  // The composite holds the plane where the stops saw it (an exact sensor: within the search's
  // tolerance of a millimetre), and it is known exactly where some stop's image covers the plane:
  // every cell whose centre lies a pixel inside some stop's field of view (and inside that stop's
  // window) is known, and none more than a pixel outside every one.
  const ElevationMap& c = rover.composite();
  const RangeImage blank = test::planeImage(kPlane, Eigen::Isometry3d::Identity());
  const double dphi = std::abs(blank.phi[0] - blank.phi[1]), dtheta = std::abs(blank.theta[1] - blank.theta[0]);
  const double phi_max = blank.phi.front(), theta_max = blank.theta.back();
  long known = 0, inside = 0;
  for (int r = 0; r < c.grid().rows; ++r)
    for (int col = 0; col < c.grid().cols; ++col) {
      const Eigen::Vector2d p = c.grid().center(r, col);
      const Eigen::Vector3d q(p.x(), p.y(), kPlane.z(p.x(), p.y()));
      bool well_inside = false, near = false;
      for (std::size_t k = 0; k < truth.size(); ++k) {
        const Eigen::Isometry3d T = rover.stops()[k].estimated_WS;
        const CorridorWindow w = rover.window(T);
        if (r < w.row0 || r >= w.row0 + w.grid.rows || col < w.col0 || col >= w.col0 + w.grid.cols) continue;
        const Spherical a = cartesianToSpherical(T.inverse() * q);
        const double fp = phi_max - std::abs(a.phi), ft = theta_max - std::abs(a.theta);
        well_inside |= fp > dphi && ft > dtheta;
        near |= fp > -dphi && ft > -dtheta;
      }
      const bool is_known = c.stateAt(r, col) == CellState::Known;
      if (is_known) {
        EXPECT_NEAR(c.elevation()(r, col), q.z(), 2e-3);
        EXPECT_TRUE(near) << r << " " << col;
        ++known;
      }
      if (well_inside) {
        EXPECT_TRUE(is_known) << r << " " << col;
        ++inside;
      }
    }
  EXPECT_GE(known, inside);
  EXPECT_GT(inside, 10000);  // six stops' fields of view, about 125 m² of 0.01 m² cells
}

TEST(Localiser, ARejectedRegistrationKeepsTheDeadReckonedPose) {
  int calls = 0;
  Localiser rover(planeConfig(TraverseReference::Composite), fixedRegistrar(false, 0.5, &calls));
  walk(rover, 4);
  EXPECT_EQ(calls, 3);
  for (std::size_t k = 1; k < rover.stops().size(); ++k) {
    const StopEstimate& e = rover.stops()[k];
    EXPECT_TRUE(e.registered);
    EXPECT_FALSE(e.accepted);
    EXPECT_TRUE(e.estimated_WB.matrix() == e.predicted_WB.matrix());  // bit for bit
    EXPECT_TRUE(e.estimated_WS.matrix() == e.predicted_WS.matrix());
    EXPECT_DOUBLE_EQ(e.since_fix_m, double(k));  // the distance since the start
  }
}

TEST(Localiser, AnAcceptedRegistrationMovesThePoseAndTheNextPrediction) {
  int calls = 0;
  Localiser rover(planeConfig(TraverseReference::Previous), fixedRegistrar(true, 0.25, &calls));
  const std::vector<Eigen::Isometry3d> truth = walk(rover, 3);
  EXPECT_EQ(calls, 2);
  const StopEstimate& s1 = rover.stops()[1];
  EXPECT_TRUE(s1.accepted);
  EXPECT_TRUE(s1.estimated_WS.matrix() == s1.registration->corrected_WS.matrix());
  // Each accepted correction moves the stop 0.25 m in world x, and the next prediction starts
  // from the corrected pose: stop k is k·0.25 m ahead of the truth.
  for (int k = 1; k < 3; ++k) {
    const Eigen::Vector3d d = rover.stops()[k].estimated_WB.translation() - truth[k].translation();
    EXPECT_NEAR(d.x(), 0.25 * k, 1e-12) << k;
    EXPECT_NEAR(d.y(), 0, 1e-12) << k;
    EXPECT_NEAR(rover.stops()[k].since_fix_m, 1.0, 1e-15);
  }
}

TEST(Localiser, RefusesACorridorOutsideTheWorldFrame) {
  LocaliserConfig c = planeConfig(TraverseReference::None);
  c.corridor.T_WM = mapFrame({0, 0, 0}, 0.1);
  int calls = 0;
  EXPECT_THROW(Localiser(c, fixedRegistrar(true, 0, &calls)), std::invalid_argument);
  c.corridor = MapGrid{};
  EXPECT_THROW(Localiser(c, fixedRegistrar(true, 0, &calls)), std::invalid_argument);
}

// cropMap copies the window's cells; priorNuCovariance gives back the sensor-frame σ it was made
// from through sensorPoseCovariance.
TEST(Localiser, CropAndPriorCovariance) {
  ElevationMap m(MapGrid::covering(0, 4, 0, 3, 1.0));
  m.setKnown(1, 2, 0.5f, 0.01f);
  m.setShadow(2, 3, 1.5f);
  CorridorWindow w;
  w.row0 = 1, w.col0 = 2;
  w.grid = MapGrid::covering(2, 4, 0, 2, 1.0);
  const ElevationMap c = cropMap(m, w);
  EXPECT_EQ(c.stateAt(0, 0), CellState::Known);
  EXPECT_EQ(c.elevation()(0, 0), 0.5f);
  EXPECT_EQ(c.stateAt(1, 1), CellState::Shadow);
  EXPECT_EQ(c.shadowCeiling()(1, 1), 1.5f);
  w.row0 = 2;
  EXPECT_THROW(cropMap(m, w), std::invalid_argument);
  const Eigen::Isometry3d B = sensorPose({3, -4, 3}, {2 * kDeg, -30 * kDeg, 40 * kDeg});
  const Matrix6d P = priorNuCovariance({0.2, 3.0}, B);
  const Matrix6d E = sensorPoseCovariance(PoseVector::Zero(), P, B);
  const double r = 3.0 * kDeg;
  Matrix6d expected = Matrix6d::Zero();
  expected.diagonal() << r * r, r * r, r * r, 0.04, 0.04, 0.04;
  EXPECT_LT((E - expected).norm(), 1e-9);
}

// The drift's σ on a sloped plane z = s·x, in closed form: a horizontal shift δ of the surface
// changes its height at a fixed point by −s·δx, a turn δψ about the vertical through the sensor at
// c moves a point p by δψ·(−(p_y − c_y), p_x − c_x), and the height error adds, so
//   σ_z² = v² + s²·(h² + ψ²·(p_y − c_y)²),  h = a·d, v = b·d, ψ = c·√d.
// registrationSigma of driftNuCovariance must give it cell by cell (to first order: the
// covariance is linearised at ν = 0, exact here because it is evaluated there).
TEST(Localiser, DriftCovarianceOnASlopeIsTheClosedForm) {
  const double slope = 0.3, d = 37.0;
  LocalisationDrift drift;
  drift.translation_sigma_per_m = 0.004, drift.vertical_sigma_per_m = 0.001, drift.heading_sigma_deg_per_sqrt_m = 0.08;
  const double h = 0.004 * d, v = 0.001 * d, psi = 0.08 * kDeg * std::sqrt(d);
  const Eigen::Isometry3d T_WS = sensorPose({1.5, -2.0, 3.0}, {3 * kDeg, -30 * kDeg, 25 * kDeg});
  ElevationMap m(MapGrid::covering(-6, 8, 0, 10, 0.5));
  for (int r = 0; r < m.grid().rows; ++r)
    for (int c = 0; c < m.grid().cols; ++c) m.setKnown(r, c, float(slope * m.grid().center(r, c).x()), 0.01f);
  const Raster<float> sigma = registrationSigma(m, PoseVector::Zero(), driftNuCovariance(drift, d, T_WS));
  int checked = 0;
  for (int r = 2; r < m.grid().rows - 2; ++r)  // the normals need two neighbours each side
    for (int c = 2; c < m.grid().cols - 2; ++c) {
      const Eigen::Vector2d p = m.grid().center(r, c);
      const double dy = p.y() - T_WS.translation().y();
      const double expected = std::sqrt(v * v + slope * slope * (h * h + psi * psi * dy * dy));
      // float elevations (relative 6e-8) in the normals' differences: 1e-5 relative is ample.
      ASSERT_NEAR(sigma(r, c), expected, 1e-5 * expected) << r << " " << c;
      ++checked;
    }
  EXPECT_EQ(checked, (m.grid().rows - 4) * (m.grid().cols - 4));
  // No distance, no drift.
  const Matrix6d zero = driftNuCovariance(drift, 0.0, T_WS);
  EXPECT_EQ(zero.norm(), 0.0);
}

// The composite's σ carries the drift the rover believes it has at its last fix: on a level plane
// only the vertical drift moves the surface, so a cell last merged from stop k alone (seen by no
// other) has σ² = σ_map² + (b·d_k)² with σ_map the same view's σ without drift.
TEST(Localiser, TheCompositesSigmaCarriesTheDriftOfTheLastFix) {
  int calls = 0;
  LocaliserConfig with = planeConfig(TraverseReference::Composite);
  with.drift = LocalisationDrift{0.0, 0.01, 0.0};
  Localiser drifting(with, fixedRegistrar(true, 0, &calls));
  Localiser plain(planeConfig(TraverseReference::Composite), fixedRegistrar(true, 0, &calls));
  Localiser three(with, fixedRegistrar(true, 0, &calls));
  walk(drifting, 4);
  walk(plain, 4);
  walk(three, 3);
  for (int k = 1; k < 4; ++k) EXPECT_DOUBLE_EQ(drifting.stops()[std::size_t(k)].fix_distance_m, double(k));
  // The cells only the last stop (d = 3 m) maps: known after four stops, not after three.
  const ElevationMap& a = drifting.composite();
  const ElevationMap& b = plain.composite();
  const double vd = 0.01 * 3.0;
  int checked = 0;
  for (int r = 0; r < a.grid().rows; ++r)
    for (int c = 0; c < a.grid().cols; ++c) {
      if (a.stateAt(r, c) != CellState::Known || three.composite().stateAt(r, c) == CellState::Known) continue;
      ASSERT_EQ(b.stateAt(r, c), CellState::Known);
      const double s0 = b.sigma()(r, c);
      // float σ (relative 6e-8), the plane's slopes of 0.02 and 0.01 in its normals (a vertical
      // shift moves a sloped surface's height by the same δz: no other term).
      EXPECT_NEAR(a.sigma()(r, c), std::sqrt(s0 * s0 + vd * vd), 1e-6) << r << " " << c;
      EXPECT_EQ(a.elevation()(r, c), b.elevation()(r, c));
      ++checked;
    }
  EXPECT_GT(checked, 100);
}

// drift.shared: the drift's σ as the part every view of a cell shares. On the level plane only the
// vertical drift moves the surface, by b·d_k at stop k, the same at every cell: fully correlated
// between the views of a cell, it does not average down, so a cell's σ is at least the smallest
// b·d_k among its views (there: d ≥ 1 m for stops 1–3; stop 0 has none). Counted as each view's
// own it averages down, and the composite's σ of a cell seen by several drifting views is smaller.
// A cell only one stop maps has the same σ either way (sharing changes nothing for one view).
TEST(Localiser, ASharedDriftDoesNotAverageDown) {
  int calls = 0;
  LocaliserConfig shared = planeConfig(TraverseReference::Composite);
  shared.drift = LocalisationDrift{0.0, 0.01, 0.0};
  LocaliserConfig own = shared;
  own.drift->shared = false;
  ASSERT_TRUE(shared.drift->shared);  // the default
  Localiser a(shared, fixedRegistrar(true, 0, &calls)), b(own, fixedRegistrar(true, 0, &calls));
  Localiser first(shared, fixedRegistrar(true, 0, &calls));
  walk(a, 4);
  walk(b, 4);
  walk(first, 1);  // stop 0 alone: the cells it sees carry no drift
  int single = 0, several = 0, smaller = 0;
  for (int r = 0; r < a.composite().grid().rows; ++r)
    for (int c = 0; c < a.composite().grid().cols; ++c) {
      if (a.composite().stateAt(r, c) != CellState::Known) continue;
      ASSERT_EQ(b.composite().stateAt(r, c), CellState::Known);
      if (first.composite().stateAt(r, c) == CellState::Known) continue;
      const double sa = a.composite().sigma()(r, c), sb = b.composite().sigma()(r, c);
      EXPECT_GE(sa, 0.01 * 1.0 * (1 - 1e-6)) << r << " " << c;
      if (sa == sb) {
        ++single;
      } else {
        ++several;
        EXPECT_GT(sa, sb) << r << " " << c;
        if (sb < 0.01 * 1.0) ++smaller;
      }
    }
  EXPECT_GT(single, 0);
  EXPECT_GT(several, 100);
  EXPECT_GT(smaller, 0);  // averaged down below any one view's drift: what sharing prevents
}

}  // namespace
}  // namespace ambler::perception
