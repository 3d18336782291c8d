// The simulated leg (sim/leg.cpp) against closed forms: a flat and a tilted plane, the Bekker law
// on sand, a flat-topped rock, a ledge, and the quasi-static resting disk.
#include <gtest/gtest.h>

#include <thread>

#include <cmath>
#include <cstdio>
#include <numbers>
#include <vector>

#include <Eigen/Geometry>

#include "fixtures.hpp"
#include "sim/leg.hpp"
#include "sim/world.hpp"

namespace ambler::sim {
namespace {

using test::TempDir;

constexpr double kDeg = std::numbers::pi / 180.0;

void print(const char* what, const LegOutcome& o) {
  std::printf("%-28s settled %d t %.3f s  xyz (%.5f %.5f %.5f)  tilt %.3f deg  sink %.5f m  "
              "slip %.5f m  drift %.6f m  load %.0f N  pair contacts %d ncon %d nefc %d%s\n",
              what, o.settled, o.time_s, o.x_m, o.y_m, o.z_m, o.tilt_deg, o.sink_m, o.slip_m,
              o.drift_m, o.load_n, o.max_pair_contacts, o.max_contacts, o.max_rows, o.contact_cap_reached ? " CAP" : "");
}

// A heightfield world from `terrain` in a temporary directory.
struct LegWorld {
  TempDir dir;
  std::filesystem::path xml;
  explicit LegWorld(const terrains::Terrain& t) : xml(writeWorld(t, dir.path(), "leg_test")) {}
};

// z = 0 for x <= edge, z = height beyond the next sample: a ledge one cell wide.
terrains::Terrain ledge(double edge, double height, double cell, double half = 1.0) {
  auto t = test::planeTerrain(0, 0, 0, half, cell);
  for (int r = 0; r < t.ground.rows(); ++r)
    for (int c = 0; c < t.ground.cols(); ++c)
      if (t.ground.position(r, c).x() > edge + 1e-9) t.ground.at(r, c) = height;
  return t;
}

// A flat plane with one box-shaped (flat-topped) rock of half sizes (hx, hy, hz) resting on it.
terrains::Terrain planeWithSlab(double hx, double hy, double hz, double cell) {
  auto t = test::planeTerrain(0, 0, 0, 1.0, cell);
  terrains::Rock rock;
  rock.center = {0, 0, hz};
  for (int i = 0; i < 8; ++i)
    rock.vertices.emplace_back((i & 1 ? 1 : -1) * hx, (i & 2 ? 1 : -1) * hy, (i & 4 ? 1 : -1) * hz);
  // Counter-clockwise seen from outside.
  rock.faces = {{0, 2, 1}, {1, 2, 3}, {4, 5, 6}, {5, 7, 6}, {0, 1, 4}, {1, 5, 4},
                {2, 6, 3}, {3, 6, 7}, {0, 4, 2}, {2, 4, 6}, {1, 3, 5}, {3, 7, 5}};
  rock.diameter_m = 2 * std::sqrt(4 * hx * hy / std::numbers::pi);
  t.rocks.push_back(rock);
  return t;
}

// The excursion rule's test (docs/leg.md, "A step"), against its definition: poses within v·w of
// the window's first sole and ω·w of its axis are still; one pose beyond either bound is not. A
// jitter in place (sole ±2 µm, axis ±3·10⁻⁵ rad, as seen in the sandbox) is still; a creep at
// 3 mm/s over 50 ms (0.15 mm > 0.1 mm) and a turn at 0.03 rad/s (1.5 mrad > 1 mrad) are not.
TEST(LegStillness, ExcursionRuleAgainstItsBounds) {
  const double v = 2e-3, omega = 0.02, w = 0.05, dt = 1e-3;
  const int n = int(std::lround(w / dt)) + 1;
  const Eigen::Vector3d axis0 = Eigen::Vector3d(0.0178, -0.0086, 1).normalized();
  const auto tilted = [&](double angle) {  // axis0 turned by `angle` about x
    return (Eigen::AngleAxisd(angle, Eigen::Vector3d::UnitX()) * axis0).normalized();
  };
  std::vector<Eigen::Vector3d> soles, axes;
  for (int k = 0; k < n; ++k) {
    soles.push_back(Eigen::Vector3d(-0.8257, 2.2756, -0.0166) + Eigen::Vector3d(2e-6 * std::sin(k), 0, 0));
    axes.push_back(tilted(3e-5 * std::sin(0.7 * k)));
  }
  EXPECT_TRUE(ambler::sim::stillOverWindow(soles, axes, v * w, omega * w));
  std::vector<Eigen::Vector3d> creep = soles, turn = axes;
  for (int k = 0; k < n; ++k) creep[k].y() += 3e-3 * k * dt;
  for (int k = 0; k < n; ++k) turn[k] = tilted(0.03 * k * dt);
  EXPECT_FALSE(ambler::sim::stillOverWindow(creep, axes, v * w, omega * w));
  EXPECT_FALSE(ambler::sim::stillOverWindow(soles, turn, v * w, omega * w));
  // The bounds are strict and tested against the first pose: a sole exactly v·w away is not still.
  std::vector<Eigen::Vector3d> edge = soles;
  edge.back() = soles.front() + Eigen::Vector3d(0, v * w, 0);
  EXPECT_FALSE(ambler::sim::stillOverWindow(edge, axes, v * w, omega * w));
  EXPECT_FALSE(ambler::sim::stillOverWindow({soles[0]}, {axes[0]}, v * w, omega * w));
  EXPECT_FALSE(ambler::sim::stillOverWindow(soles, {axes[0], axes[1]}, v * w, omega * w));
}

TEST(Leg, BekkerSinkageOfTheAmblerFoot) {
  // 30 cm disk, b = radius: 4.1 kN gives p = 58.0 kPa and z = 5.09 cm.
  LegConfig c;
  EXPECT_NEAR(bekkerSinkage(4100, c), 0.0509, 0.0005);
  EXPECT_DOUBLE_EQ(bekkerSinkage(0, c), 0.0);
}

// MuJoCo's stiff contacts (solref 4 ms, solimp 0.99) penetrate a0·(1−d)/(k·d²) at rest, with
// a0 = load / mass ≈ 160 m/s², d = 0.99, k = 1/(d·τ)² ≈ 6.4e4 s⁻²: about 0.03 mm. Sinkage on rigid
// ground is held to 0.1 mm.
constexpr double kRigidSink = 1e-4;

TEST(Leg, SettlesLevelOnAFlatRockPlane) {
  LegWorld w(test::planeTerrain(0, 0, 0, 1.0, 0.05));
  const LegOutcome o = stepLeg(w.xml, 0.013, -0.021, LegConfig{});
  print("flat rock, 5 cm cells", o);
  EXPECT_TRUE(o.settled);
  EXPECT_LT(o.tilt_deg, 0.1);
  EXPECT_LT(o.slip_m, 1e-3);
  EXPECT_NEAR(o.sink_m, 0.0, kRigidSink);
  EXPECT_NEAR(o.x_m, 0.013, 1e-3);
  EXPECT_NEAR(o.y_m, -0.021, 1e-3);
  EXPECT_NEAR(o.load_n, 4000, 40);  // the contacts carry the commanded load
  EXPECT_FALSE(o.contact_cap_reached);
}

// On a 10° plane the passive ankle lays the foot flat on it. The foot first touches with its
// uphill rim and then turns about the ankle, which the leg holds 5 cm above the sole, so the sole
// centre travels t·sin 10° = 8.7 mm downhill: that seating is the slip reported here.
TEST(Leg, LiesFlatOnATenDegreePlane) {
  LegWorld w(test::planeTerrain(std::tan(10 * kDeg), 0, 0, 1.0, 0.05));
  const LegConfig c;
  const LegOutcome o = stepLeg(w.xml, 0.0, 0.0, c);
  print("10 deg plane, 5 cm cells", o);
  EXPECT_TRUE(o.settled);
  EXPECT_NEAR(o.tilt_deg, 10.0, 0.5);
  EXPECT_NEAR(o.sink_m, 0.0, kRigidSink);
  EXPECT_NEAR(o.slip_m, c.foot_thickness_m * std::sin(10 * kDeg), 1e-3);
}

// Flat sand: the sinkage under two loads follows Bekker's law at a fine and a coarse grid. The
// law, worked by hand for the foot on LegConfig's dry sand (docs/leg.md, "Sand"): p = W/(π·b²)
// with b = 0.15 m, the foot's radius; z = (p/(k_c/b + k_φ))^(1/n) with n = 1.1,
// k_c = 0.99 kN/m^(n+1), k_φ = 1528.43 kN/m^(n+2): 26.50 mm under 2 kN, 49.76 mm under 4 kN.
//
// How far the simulated foot may rest from it follows from how the sand yields (sim/leg.cpp):
// - short by one yield step, 0.1 mm: the sand is lowered only once the law asks 0.1 mm more;
// - short by the lag of the soil force's filter (τ = 20 ms on 1 ms steps, 0.95 kept a step): after
//   the last yield step the foot falls 0.1 mm under the load alone (W/25 kg ≥ 80 m/s²: ≤ 1.6 ms,
//   two steps without contact), so the filtered force loses 1 − 0.95² of W; in the 50 ms the foot
//   then rests before it counts as settled it wins back all but 0.95⁵⁰ of that. The force is then
//   short by 0.75 % of W, the sinkage by 1/n of that (z ∝ W^(1/n)): 0.18 mm at 2 kN, 0.34 at 4 kN;
// - deeper by the stiff contact's penetration, ≈ 0.03 mm, which kRigidSink bounds.
TEST(Leg, SinksInSandByTheBekkerLaw) {
  const double b = 0.15, n = 1.1, k_c = 0.99e3, k_phi = 1528.43e3;
  const double force_short = (1 - std::pow(0.95, 2)) * std::pow(0.95, 50);
  for (double cell : {0.02, 0.10}) {
    LegWorld w(test::planeTerrain(0, 0, 0, 1.0, cell));
    for (double load : {2000.0, 4000.0}) {
      LegConfig c;
      c.soil = Soil::Sand;
      c.load_n = load;
      const LegOutcome o = stepLeg(w.xml, 0.0, 0.0, c);
      const double p = load / (std::numbers::pi * b * b);
      const double z = std::pow(p / (k_c / b + k_phi), 1.0 / n);
      const double short_of_z = 1e-4 + z * force_short / n;
      char what[64];
      std::snprintf(what, sizeof what, "sand, %.0f cm cells, %.0f N", cell * 100, load);
      print(what, o);
      std::printf("%-28s Bekker sinkage %.5f m, measured - Bekker %+.5f m (allowed -%.5f to +%.5f m)\n", "", z,
                  o.sink_m - z, short_of_z, kRigidSink);
      EXPECT_TRUE(o.settled) << what;
      EXPECT_GE(o.sink_m, z - short_of_z) << what;
      EXPECT_LE(o.sink_m, z + kRigidSink) << what;
      EXPECT_LT(o.tilt_deg, 0.1) << what;
      EXPECT_LT(o.slip_m, 1e-3) << what;
      EXPECT_FALSE(o.contact_cap_reached) << what;
    }
  }
}

// Rigid heightfields of 2, 5 and 10 cm cells: the foot neither falls through (sink within the
// contact penetration) nor jitters (the sole centre moves < 0.1 mm over the 0.2 s hold).
TEST(Leg, NeitherFallsThroughNorJittersOnHeightfields) {
  for (double cell : {0.02, 0.05, 0.10}) {
    LegWorld w(test::planeTerrain(0, 0, 0, 1.0, cell));
    const LegOutcome o = stepLeg(w.xml, 0.0, 0.0, LegConfig{});
    char what[64];
    std::snprintf(what, sizeof what, "flat rock, %.0f cm cells", cell * 100);
    print(what, o);
    EXPECT_TRUE(o.settled) << what;
    EXPECT_NEAR(o.sink_m, 0.0, kRigidSink) << what;
    EXPECT_NEAR(o.z_m, 0.0, kRigidSink) << what;
    EXPECT_LT(o.drift_m, 1e-4) << what;
    EXPECT_LT(o.tilt_deg, 0.1) << what;
    EXPECT_FALSE(o.contact_cap_reached) << what;
  }
}

// A flat-topped rock (a 60 × 60 × 15 cm slab mesh) on sand: the foot stays on its top face, and
// the rock stays rigid: no sinkage although the soil is sand.
TEST(Leg, StaysOnTheFlatFaceOfARockOnSand) {
  LegWorld w(planeWithSlab(0.3, 0.3, 0.075, 0.05));
  for (const Eigen::Vector2d& at : {Eigen::Vector2d(0, 0), Eigen::Vector2d(0.12, 0.05)}) {
    LegConfig c;
    c.soil = Soil::Sand;
    const LegOutcome o = stepLeg(w.xml, at.x(), at.y(), c);
    print("slab on sand", o);
    EXPECT_TRUE(o.settled);
    EXPECT_NEAR(o.z_m, 0.15, kRigidSink);
    EXPECT_NEAR(o.sink_m, 0.0, kRigidSink);
    EXPECT_LT(o.tilt_deg, 0.1);
    EXPECT_LT(o.slip_m, 1e-3);
  }
}

// Half over a 10 cm ledge (centre 1 cm past the top edge): the foot TILTS, it does not slip. It
// rocks over the edge until the contact on the edge comes under the ankle (the ankle sits 5 cm
// above the sole, so tilting by θ moves the sole under it by t·sin θ), and rests there on the
// edge alone, the same 8.5° at any ledge height taller than that.
TEST(Leg, HalfOverALedgeTiltsAndDoesNotSlip) {
  LegWorld w(ledge(0.0, 0.10, 0.05));  // the ledge's top edge is at x = 0.05
  const LegOutcome o = stepLeg(w.xml, 0.04, 0.0, LegConfig{});
  print("half over a 10 cm ledge", o);
  EXPECT_TRUE(o.settled);
  EXPECT_GT(o.tilt_deg, 5.0);
  EXPECT_LT(o.tilt_deg, 12.0);
  EXPECT_LT(o.slip_m, 2e-3);
  EXPECT_GT(o.z_m, 0.09);  // still on the upper level
}

// Every field to the bit.
void expectSame(const LegOutcome& a, const LegOutcome& b) {
  EXPECT_EQ(a.x_m, b.x_m);
  EXPECT_EQ(a.y_m, b.y_m);
  EXPECT_EQ(a.z_m, b.z_m);
  EXPECT_EQ(a.tilt_deg, b.tilt_deg);
  EXPECT_EQ(a.sink_m, b.sink_m);
  EXPECT_EQ(a.slip_m, b.slip_m);
  EXPECT_EQ(a.drift_m, b.drift_m);
  EXPECT_EQ(a.load_n, b.load_n);
  EXPECT_EQ(a.time_s, b.time_s);
  EXPECT_EQ(a.max_pair_contacts, b.max_pair_contacts);
  EXPECT_EQ(a.max_contacts, b.max_contacts);
  EXPECT_EQ(a.max_rows, b.max_rows);
  EXPECT_EQ(a.settled, b.settled);
  EXPECT_EQ(a.contact_cap_reached, b.contact_cap_reached);
}

// A Leg is built once and stepped many times: each step resets MuJoCo's state and puts the sand
// back, so a step after others, on sand the earlier steps lowered, is the step stepLeg makes on a
// model built for it, to the bit. So is a step of a Leg cropped to a region (the slab kept, its
// mesh copied from the world's model), first and after others.
TEST(Leg, StepsAreIndependentOfEachOther) {
  LegWorld w(planeWithSlab(0.3, 0.3, 0.075, 0.10));
  LegConfig c;
  c.soil = Soil::Sand;
  const LegOutcome fresh = stepLeg(w.xml, 0.5, 0.5, c);  // sand beside the slab
  Leg whole(w.xml, c);
  const LegOutcome first = whole.step(0.5, 0.5);
  whole.step(0.1, 0.0);  // on the slab
  whole.step(0.5, 0.6);  // sand, overlapping the first crater
  const LegOutcome again = whole.step(0.5, 0.5);
  print("sand, fresh model", fresh);
  print("sand, fourth step", again);
  expectSame(first, fresh);
  expectSame(again, fresh);
  EXPECT_FALSE(whole.cropped());

  Leg cropped(w.xml, LegRegion{0.0, 0.6, 0.0, 0.6}, c);
  EXPECT_TRUE(cropped.cropped());
  expectSame(cropped.step(0.5, 0.5), fresh);
  expectSame(cropped.step(0.1, 0.0), stepLeg(w.xml, 0.1, 0.0, c));
  cropped.step(0.5, 0.6);
  expectSame(cropped.step(0.5, 0.5), fresh);
  EXPECT_EQ(cropped.fallbacks(), 0);
  EXPECT_THROW(cropped.step(0.7, 0.5), std::invalid_argument);
  EXPECT_THROW(Leg(w.xml, LegRegion{0.6, 0.0, 0.0, 0.6}, c), std::invalid_argument);

  // A clone, taken after steps lowered the sand, steps as the original does; the two step at
  // once on two threads and still give stepLeg's outcome.
  Leg twin = cropped.clone();
  EXPECT_TRUE(twin.cropped());
  EXPECT_EQ(twin.terrainGeoms(), cropped.terrainGeoms());
  LegOutcome a, b;
  std::thread other([&] { a = twin.step(0.5, 0.5); });
  b = cropped.step(0.5, 0.5);
  other.join();
  expectSame(a, fresh);
  expectSame(b, fresh);
}

// The culled heightfield collision (LegConfig::cull_prisms, sim/leg_hfield.hpp) runs MuJoCo
// 2.2.2's heightfield × mesh algorithm on the same prisms in the same order, with the same support
// functions, and skips only prisms that a separating plane keeps more than 10 µm from a foot tile,
// where MPR finds no contact: the contacts, and so every step, are MuJoCo's own to the bit. Checked
// on a tilted plane, a ledge the foot tilts over, sand beside a rock and the rock's face.
TEST(Leg, CullingPrismsChangesNoOutcome) {
  struct Case {
    const char* what;
    terrains::Terrain terrain;
    Eigen::Vector2d at;
    Soil soil;
  };
  const std::vector<Case> cases{
      {"10 deg plane", test::planeTerrain(std::tan(10 * kDeg), 0, 0, 1.0, 0.05), {0.0, 0.0}, Soil::Rock},
      {"half over a 10 cm ledge", ledge(0.0, 0.10, 0.05), {0.04, 0.0}, Soil::Rock},
      {"sand beside a slab", planeWithSlab(0.3, 0.3, 0.075, 0.10), {0.5, 0.5}, Soil::Sand},
      {"on the slab, sand", planeWithSlab(0.3, 0.3, 0.075, 0.10), {0.12, 0.05}, Soil::Sand}};
  for (const Case& k : cases) {
    SCOPED_TRACE(k.what);
    LegWorld w(k.terrain);
    LegConfig culled;
    culled.soil = k.soil;
    LegConfig mujoco = culled;
    mujoco.cull_prisms = false;
    const LegOutcome a = stepLeg(w.xml, k.at.x(), k.at.y(), culled);
    print(k.what, a);
    expectSame(a, stepLeg(w.xml, k.at.x(), k.at.y(), mujoco));
  }
}

// leg.xml (the world plus the leg) is plain MJCF that MuJoCo loads, e.g. in `simulate`.
TEST(Leg, WritesALegWorldThatLoads) {
  LegWorld w(planeWithSlab(0.3, 0.3, 0.075, 0.05));
  const auto xml = writeLegWorld(w.xml, LegConfig{});
  EXPECT_EQ(xml.filename(), "leg.xml");
  const World world = World::load(xml);
  EXPECT_EQ(world.geomCount(), 2 + 2 + 25);  // terrain, rock; shaft, disk; 25 foot tiles
}

TEST(RestingDisk, PlanesAreExact) {
  const auto flat = test::planeTerrain(0, 0, 0.3, 1.0, 0.05);
  const auto r0 = restingDisk(flat.ground.heights().cast<float>(), 0.05, -1, -1, 0.01, 0.02, 0.3);
  ASSERT_TRUE(r0.has_value());
  EXPECT_NEAR(r0->z_m, 0.3, 1e-6);
  EXPECT_NEAR(r0->tilt_deg, 0.0, 1e-6);
  const auto tilted = test::planeTerrain(std::tan(10 * kDeg), 0, 0, 1.0, 0.05);
  const auto r1 = restingDisk(tilted.ground.heights().cast<float>(), 0.05, -1, -1, 0.1, 0.0, 0.3);
  ASSERT_TRUE(r1.has_value());
  EXPECT_NEAR(r1->z_m, 0.1 * std::tan(10 * kDeg), 1e-5);  // float heights
  EXPECT_NEAR(r1->tilt_deg, 10.0, 1e-3);
  EXPECT_FALSE(restingDisk(flat.ground.heights().cast<float>(), 0.05, -1, -1, 5, 5, 0.3));
}

// restingDisk against MuJoCo where geometry decides: a foot 3 cm past the edge of a 5 cm ledge
// rocks over until its rim meets the lower ground, resting on the edge and the rim.
TEST(RestingDisk, MatchesTheLegOnALowLedge) {
  const auto t = ledge(0.0, 0.05, 0.05);
  LegWorld w(t);
  const LegOutcome o = stepLeg(w.xml, 0.02, 0.0, LegConfig{});
  const auto rest = restingDisk(t.ground.heights().cast<float>(), 0.05, -1, -1, 0.02, 0.0, 0.3);
  ASSERT_TRUE(rest.has_value());
  print("3 cm past a 5 cm ledge", o);
  std::printf("%-28s restingDisk z %.5f m tilt %.3f deg\n", "", rest->z_m, rest->tilt_deg);
  EXPECT_TRUE(o.settled);
  EXPECT_NEAR(o.tilt_deg, rest->tilt_deg, 0.5);
  EXPECT_NEAR(o.z_m, rest->z_m, 2e-3);
}

}  // namespace
}  // namespace ambler::sim
