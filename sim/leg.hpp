#pragma once
// A single simulated Ambler leg that steps on a chosen footfall (§5 of the paper): a body on a
// vertical prismatic joint, servoed horizontally, with a 30 cm disk foot on a passive two-axis
// ankle. The leg lowers the foot until it carries the load, waits until it settles and reports
// the foot's tilt, sinkage and slip. Sand sinks by the Bekker pressure–sinkage law (the
// heightfield under the foot is lowered at run time), not by contact softness. See docs/leg.md.
// sim::Leg builds the leg's MuJoCo model once for many steps; stepLeg builds it for one.
#include <Eigen/Core>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>

namespace ambler::sim {

enum class Soil { Rock, Sand };

struct LegConfig {
  double foot_diameter_m = 0.30;
  double foot_thickness_m = 0.05;
  // The foot collides as convex prisms: the disk cut by a square grid of this pitch. MuJoCo
  // 2.2.2 keeps at most 50 contacts per geom pair, the first in the heightfield's row order, so a
  // single cylinder on a 2 cm grid would be held only along its -y rim.
  double foot_tile_m = 0.06;
  double load_n = 4000;  // vertical load on the ground at rest, the leg's own weight included
  Soil soil = Soil::Rock;
  // Bekker p = (k_c/b + k_phi)·z^n, p in Pa, z in m; b = the foot's radius (Wong's convention
  // for a circular plate). Dry sand, Wong, Theory of Ground Vehicles (table of Bekker terrain
  // values, dry sand after the Land Locomotion Laboratory).
  double bekker_n = 1.1, bekker_kc = 0.99e3, bekker_kphi = 1528.43e3;
  double leg_mass_kg = 20.0, foot_mass_kg = 5.0;
  double friction = 1.0;                      // sliding friction of the foot on any surface
  double lateral_stiffness_n_per_m = 2e5;     // the leg's horizontal position servo
  double descent_speed_m_s = 0.2;
  double clearance_m = 0.03;                  // start: sole this far above the highest point
  double load_ramp_s = 0.2;                   // load rises linearly from first contact
  double settle_speed_m_s = 2e-3;             // settled: foot speeds below these ...
  double settle_angular_speed_rad_s = 0.02;
  double settle_window_s = 0.05;              // ... for this long, after the ramp
  double hold_s = 0.2;  // after settling, watch the foot this long (drift_m); 0: stop when settled
  double time_limit_s = 3.0;                  // settled = false if not settled by then
  double timestep_s = 1e-3;
  // Skip the heightfield prisms that a separating plane shows cannot touch a foot tile instead of
  // running MPR on them (sim/leg_hfield.hpp): the same contacts, a third of the time. false: MuJoCo
  // 2.2.2's own heightfield collision, every prism under a tile's bounding box.
  bool cull_prisms = true;
};

struct LegOutcome {
  double x_m = 0, y_m = 0, z_m = 0;  // sole centre once settled (or at the time limit)
  double tilt_deg = 0;                // foot axis from vertical
  double sink_m = 0;     // deepest point of the true terrain above the sole plane, in the footprint
  double slip_m = 0;     // horizontal travel of the sole centre from first contact to settled
  // Largest excursion of the sole centre during the hold after settling; NaN when there was no
  // hold (hold_s = 0, or not settled).
  double drift_m = 0;
  double load_n = 0;     // vertical contact force on the foot when settled
  double time_s = 0;     // simulated time at settling
  int max_pair_contacts = 0;  // most contacts seen between one foot geom and one other geom
  int max_contacts = 0, max_rows = 0;  // most contacts (d->ncon) and constraint rows (d->nefc)
  bool settled = false;
  // Settled by the excursion rule (docs/leg.md, "A step"): at the time limit the speeds never
  // stayed under the settle speeds for a window, but over the last window the foot moved and
  // turned less than those speeds allow (it jitters in place).
  bool settled_by_excursion = false;
  // Contacts were dropped: a foot-geom/terrain-geom pair hit MuJoCo's 50 (mjMAXCONPAIR) or the
  // model's contact or constraint buffer filled (heightfields much finer than 2 cm).
  bool contact_cap_reached = false;
};

// The Bekker sinkage z of the foot under `load_n`: (p / (k_c/b + k_phi))^(1/n), p = load/area.
double bekkerSinkage(double load_n, const LegConfig& config);

// The MJCF of the world in `world_file` (a file name in the same directory, pulled in with
// <include>) with the leg added at the origin, so it opens in MuJoCo's `simulate`.
std::string legXml(const std::string& world_file, const std::string& world_xml_text,
                   const LegConfig& config);
// Writes legXml() beside `world_xml` as leg.xml and returns its path. Throws on I/O errors.
std::filesystem::path writeLegWorld(const std::filesystem::path& world_xml, const LegConfig& config);

// Steps the leg on (x, y) of the world in `world_xml`: moves the foot above it, lowers it until
// load_n is carried, waits until it settles. The world's files are not changed (a temporary
// leg_<pid>_<n>.xml is written beside them for MuJoCo's <include> and removed). Throws
// std::invalid_argument for a bad config, std::runtime_error if MuJoCo cannot load the world or
// no terrain lies under (x, y).
LegOutcome stepLeg(const std::filesystem::path& world_xml, double x, double y,
                   const LegConfig& config);

// The footfall centres a Leg may step on: a box in the world's x and y, metres.
struct LegRegion {
  double x_min = 0, x_max = 0, y_min = 0, y_max = 0;
};

// The leg built once for many steps on one world (docs/leg.md, "One leg per run"): the world and
// the leg compiled into one MuJoCo model at construction; each step() resets the state and the
// heightfield and runs what stepLeg runs, so steps are independent of each other and of order.
class Leg {
 public:
  // The whole world: stepLeg's model. Throws as stepLeg does.
  Leg(const std::filesystem::path& world_xml, const LegConfig& config);
  // The world cropped to what the foot can touch from centres in `region`: the world's static
  // geoms whose bounding sphere reaches the region grown by twice the foot's radius and its
  // thickness (heightfields and planes always, whole), each the world's to the bit, so that a
  // step computes what stepLeg computes. A world with moving bodies, tendons, equality
  // constraints, contact pairs, excludes or mocap bodies is kept whole. Throws as stepLeg does,
  // and std::invalid_argument for an empty or non-finite region.
  Leg(const std::filesystem::path& world_xml, const LegRegion& region, const LegConfig& config);
  Leg(Leg&&) noexcept;
  Leg& operator=(Leg&&) noexcept;
  ~Leg();

  // Steps on (x, y), as stepLeg(world_xml, x, y, config). A step whose sole centre leaves the
  // region grown by the foot's radius is rerun on the whole world (stepLeg). Throws
  // std::invalid_argument if (x, y) lies outside the region, std::runtime_error if no terrain
  // lies under it.
  LegOutcome step(double x, double y);

  // An independent copy (the model copied, its own MuJoCo data; no file is read): its steps equal
  // this leg's bit for bit, and the two may step at once on two threads.
  Leg clone() const;

  bool cropped() const;       // the terrain was cropped (false: the whole world)
  int terrainGeoms() const;   // the world's geoms in the leg's model
  int droppedGeoms() const;   // the world's geoms left out by the crop
  int fallbacks() const;      // steps rerun on the whole world so far

 private:
  struct Impl;
  explicit Leg(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

// The excursion rule's test (docs/leg.md, "A step"): every pose of a window (sole centres and foot
// axes, unit vectors, in order) lies within `max_move_m` of the first's sole centre and within
// `max_turn_rad` of its axis. False for fewer than two poses or lists of different lengths.
bool stillOverWindow(const std::vector<Eigen::Vector3d>& soles, const std::vector<Eigen::Vector3d>& axes,
                     double max_move_m, double max_turn_rad);

// The rest pose of a rigid disk lowered vertically onto a height grid, without dynamics: the
// plane under the disk that puts its centre lowest with no terrain point above it (the disk
// touches, pivots about the contact, then about the line of two contacts, until the centre lies
// over the contacts). heights(r, c) sits at (x0 + c·cell, y0 + r·cell), cells split along
// (r,c)–(r+1,c+1) as in MuJoCo; NaN cells are ignored. z_m: the sole plane at (x, y).
struct DiskRest {
  double z_m = 0, tilt_deg = 0;
};
std::optional<DiskRest> restingDisk(const Eigen::MatrixXf& heights, double cell_m, double x0,
                                    double y0, double x, double y, double diameter_m);

}  // namespace ambler::sim
