// sim::Leg: the leg's MuJoCo model built once (the whole world, or the world cropped to a footfall
// region) and stepped many times; stepLeg is one step of a whole-world Leg. See docs/leg.md.
#include <mujoco/mujoco.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <limits>
#include <memory>
#include <numbers>
#include <stdexcept>
#include <vector>

#include "base/atomic_file.hpp"
#include "base/read_file.hpp"
#include "sim/leg.hpp"
#include "sim/leg_crop.hpp"
#include "sim/leg_hfield.hpp"

namespace ambler::sim {

namespace {

constexpr double kGravity = 9.81;
constexpr double kDeg = 180.0 / std::numbers::pi;
constexpr double kSandStep = 1e-4;  // m: the sand under the foot yields in steps this large

std::string num(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.9g", v);
  return buf;
}

struct ModelDeleter { void operator()(mjModel* m) const { mj_deleteModel(m); } };
struct DataDeleter { void operator()(mjData* d) const { mj_deleteData(d); } };
using ModelPtr = std::unique_ptr<mjModel, ModelDeleter>;
using DataPtr = std::unique_ptr<mjData, DataDeleter>;

ModelPtr loadText(const std::string& xml, const std::filesystem::path& dir) {
  // MuJoCo 2.2.2 loads only from files; <include> resolves against the file's directory.
  static std::atomic<int> counter{0};
  const auto tmp = dir / ("leg_" + std::to_string(getpid()) + "_" +
                          std::to_string(counter++) + ".xml");
  std::ofstream(tmp) << xml;
  std::array<char, 1000> err{};
  mjModel* m = mj_loadXML(tmp.c_str(), nullptr, err.data(), int(err.size()));
  std::filesystem::remove(tmp);
  if (!m) throw std::runtime_error(dir.string() + ": MuJoCo could not load the leg world: " +
                                   err.data());
  return ModelPtr(m);
}

// Loads the leg's MJCF `xml`, whose <include> names `include_name`, from memory: the cropped world
// is all inline (heightfield data set after compiling, meshes as vertices and faces).
ModelPtr loadFromMemory(const std::string& xml, const std::string& include_name, const std::string& include_text,
                        const std::string& what) {
  struct VfsDeleter {
    void operator()(mjVFS* v) const {
      mj_deleteVFS(v);
      delete v;
    }
  };
  std::unique_ptr<mjVFS, VfsDeleter> vfs(new mjVFS);
  mj_defaultVFS(vfs.get());
  for (const auto& [name, text] : {std::pair{std::string("leg.xml"), &xml}, std::pair{include_name, &include_text}}) {
    if (mj_makeEmptyFileVFS(vfs.get(), name.c_str(), int(text->size())) != 0)
      throw std::runtime_error(what + ": MuJoCo could not hold the cropped leg world in memory");
    std::memcpy(vfs->filedata[mj_findFileVFS(vfs.get(), name.c_str())], text->data(), text->size());
  }
  std::array<char, 1000> err{};
  mjModel* m = mj_loadXML("leg.xml", vfs.get(), err.data(), int(err.size()));
  if (!m) throw std::runtime_error(what + ": MuJoCo could not load the cropped leg world: " + err.data());
  return ModelPtr(m);
}

// The world's MJCF text; a file that cannot be read is named in the one line.
std::string worldText(const std::filesystem::path& world_xml) {
  try {
    return base::readFile(world_xml);
  } catch (const base::ReadError& e) {
    throw std::runtime_error(world_xml.string() + ": " + e.what());
  }
}

// The leg's handles into a loaded model.
struct Rig {
  int leg = -1, foot = -1, hfield_geom = -1;
  int qx = -1, qy = -1, qz = -1, vz = -1;  // qpos / qvel addresses of the leg's slides
  int act_x = -1, act_y = -1, act_z = -1;
};

int require(int id, const char* what) {
  if (id < 0) throw std::runtime_error(std::string("leg world: no ") + what);
  return id;
}

Rig rig(const mjModel* m) {
  Rig r;
  r.leg = require(mj_name2id(m, mjOBJ_BODY, "leg"), "body leg");
  r.foot = require(mj_name2id(m, mjOBJ_BODY, "foot"), "body foot");
  r.hfield_geom = mj_name2id(m, mjOBJ_GEOM, "terrain");
  if (r.hfield_geom < 0 || m->geom_type[r.hfield_geom] != mjGEOM_HFIELD)
    for (int g = 0; g < m->ngeom && r.hfield_geom < 0; ++g)
      if (m->geom_type[g] == mjGEOM_HFIELD) r.hfield_geom = g;
  auto joint = [m](const char* name) { return require(mj_name2id(m, mjOBJ_JOINT, name), name); };
  r.qx = m->jnt_qposadr[joint("leg_x")];
  r.qy = m->jnt_qposadr[joint("leg_y")];
  r.qz = m->jnt_qposadr[joint("leg_z")];
  r.vz = m->jnt_dofadr[joint("leg_z")];
  r.act_x = require(mj_name2id(m, mjOBJ_ACTUATOR, "leg_x"), "actuator leg_x");
  r.act_y = require(mj_name2id(m, mjOBJ_ACTUATOR, "leg_y"), "actuator leg_y");
  r.act_z = require(mj_name2id(m, mjOBJ_ACTUATOR, "leg_z"), "actuator leg_z");
  return r;
}

struct FootPose {
  Eigen::Vector3d sole;  // sole centre
  Eigen::Vector3d axis;  // foot z axis
};

FootPose footPose(const mjData* d, int foot, double thickness) {
  const double* p = d->xpos + 3 * foot;
  const double* R = d->xmat + 9 * foot;
  const Eigen::Vector3d axis(R[2], R[5], R[8]);
  return {Eigen::Vector3d(p[0], p[1], p[2]) - thickness * axis, axis};
}

// The height the probe's rays start from: above everything in the model.
double probeTop(const mjModel* m) { return m->stat.center[2] + 2 * m->stat.extent + 10.0; }

// Highest point of the world's own geoms (group 0: terrain and rocks, not the leg) on a grid of
// vertical rays from `top` over the disk of radius r about (x, y); with `plane`, the deepest point above
// the plane through `sole` with normal `axis` instead. nullopt if no ray hits.
std::optional<double> probeFootprint(const mjModel* m, const mjData* d, double top, double x, double y,
                                     double r, double step, const FootPose* plane = nullptr) {
  const mjtByte groups[mjNGROUP] = {1, 0, 0, 0, 0, 0};
  const int n = int(std::ceil(r / step));
  std::optional<double> best;
  for (int i = -n; i <= n; ++i)
    for (int j = -n; j <= n; ++j) {
      const double dx = i * step, dy = j * step;
      if (dx * dx + dy * dy > r * r) continue;
      const mjtNum pnt[3] = {x + dx, y + dy, top}, dir[3] = {0, 0, -1};
      int geom = -1;
      const mjtNum t = mj_ray(m, d, pnt, dir, groups, 1, -1, &geom);
      if (t < 0) continue;
      double v = top - t;
      if (plane) {
        const auto& s = plane->sole;
        const auto& a = plane->axis;
        v -= s.z() - (a.x() * (pnt[0] - s.x()) + a.y() * (pnt[1] - s.y())) / a.z();
      }
      best = best ? std::max(*best, v) : v;
    }
  return best;
}

// Vertical force on the foot from its contacts (all, or only those with geom `only`), and the
// most contacts of any one foot-geom/other-geom pair.
struct ContactSum {
  double fz = 0;
  int max_pair = 0;
  bool touching = false;
};

ContactSum footContacts(const mjModel* m, mjData* d, int foot, int only = -1) {
  ContactSum s;
  std::vector<std::pair<int, int>> pairs;
  for (int i = 0; i < d->ncon; ++i) {
    const mjContact& c = d->contact[i];
    const bool foot1 = m->geom_bodyid[c.geom1] == foot, foot2 = m->geom_bodyid[c.geom2] == foot;
    if (!foot1 && !foot2) continue;
    s.touching = true;
    pairs.emplace_back(c.geom1, c.geom2);
    if (only >= 0 && c.geom1 != only && c.geom2 != only) continue;
    mjtNum f[6];
    mj_contactForce(m, d, i, f);
    // f is in the contact frame; its normal points from geom1 to geom2, the force on geom2.
    double fz = f[0] * c.frame[2] + f[1] * c.frame[5] + f[2] * c.frame[8];
    s.fz += foot2 ? fz : -fz;
  }
  std::sort(pairs.begin(), pairs.end());
  for (std::size_t i = 0; i < pairs.size();) {
    std::size_t j = i;
    while (j < pairs.size() && pairs[j] == pairs[i]) ++j;
    s.max_pair = std::max(s.max_pair, int(j - i));
    i = j;
  }
  return s;
}

// Sand: lowers every heightfield vertex whose triangles can reach under the foot (within
// radius + one cell diagonal of the sole centre) to `sink` below its original height.
void lowerSand(mjModel* m, const mjData* d, int geom, const std::vector<float>& original,
               double cx, double cy, double reach, double sink) {
  const int h = m->geom_dataid[geom];
  const int nrow = m->hfield_nrow[h], ncol = m->hfield_ncol[h];
  const double* size = m->hfield_size + 4 * h;
  const double* g = d->geom_xpos + 3 * geom;
  const double dx = 2 * size[0] / (ncol - 1), dy = 2 * size[1] / (nrow - 1);
  const double lower = sink / size[2];  // in normalised units
  float* data = m->hfield_data + m->hfield_adr[h];
  const int c0 = std::max(0, int(std::floor((cx - reach - g[0] + size[0]) / dx)));
  const int c1 = std::min(ncol - 1, int(std::ceil((cx + reach - g[0] + size[0]) / dx)));
  const int r0 = std::max(0, int(std::floor((cy - reach - g[1] + size[1]) / dy)));
  const int r1 = std::min(nrow - 1, int(std::ceil((cy + reach - g[1] + size[1]) / dy)));
  for (int r = r0; r <= r1; ++r)
    for (int c = c0; c <= c1; ++c) {
      const double x = g[0] - size[0] + c * dx, y = g[1] - size[1] + r * dy;
      if (std::hypot(x - cx, y - cy) > reach) continue;
      const std::size_t i = std::size_t(r) * ncol + c;
      data[i] = std::min(data[i], float(original[i] - lower));
    }
}

// mj_resetData (MuJoCo 2.2.2's _resetData) without its memset of the whole arena, which holds the
// njmax² constraint matrix (109 MB with njmax 3000: 11 ms, a tenth of a step). What mj_step reads
// before it writes is set as mj_resetData sets it: qpos = qpos0; zero velocity, activation,
// controls, applied forces, acceleration and its warm start; mocap poses; time and the diagnostics. The rest of
// the arena is output that mj_step writes before reading: a step after other steps equals the same
// step on a fresh model to the bit (tests/sim/test_leg.cpp, StepsAreIndependentOfEachOther).
void resetState(const mjModel* m, mjData* d) {
  d->pstack = 0;
  d->maxuse_stack = d->maxuse_con = d->maxuse_efc = 0;
  std::memset(d->warning, 0, sizeof d->warning);
  std::memset(d->timer, 0, sizeof d->timer);
  std::memset(d->solver, 0, sizeof d->solver);
  d->solver_iter = d->solver_nnz = 0;
  mju_zero(d->solver_fwdinv, 2);
  d->ne = d->nf = d->nefc = d->ncon = 0;
  d->time = 0;
  mju_zero(d->energy, 2);
  mju_copy(d->qpos, m->qpos0, m->nq);
  mju_zero(d->qvel, m->nv);
  mju_zero(d->act, m->na);
  mju_zero(d->ctrl, m->nu);
  mju_zero(d->qfrc_applied, m->nv);
  mju_zero(d->xfrc_applied, 6 * m->nbody);
  mju_zero(d->qacc, m->nv);
  mju_zero(d->qacc_warmstart, m->nv);
  mju_zero(d->act_dot, m->na);
  mju_zero(d->userdata, m->nuserdata);
  mju_zero(d->sensordata, m->nsensordata);
  for (int b = 0; b < m->nbody; ++b)
    if (const int id = m->body_mocapid[b]; id >= 0) {
      mju_copy3(d->mocap_pos + 3 * id, m->body_pos + 3 * b);
      mju_copy4(d->mocap_quat + 4 * id, m->body_quat + 4 * b);
    }
}

// A box in the world's x and y.
struct Box {
  double x0, x1, y0, y1;
  bool contains(double x, double y) const { return x >= x0 && x <= x1 && y >= y0 && y <= y1; }
  Box grown(double e) const { return {x0 - e, x1 + e, y0 - e, y1 + e}; }
};

// One step of the leg (docs/leg.md, "A step") on a freshly reset model whose heightfield holds
// `original`, its probe's rays cast from `probe_top`. nullopt when the sole centre leaves `bounds`
// (the terrain the model holds).
std::optional<LegOutcome> simulate(mjModel* m, mjData* d, const Rig& g, const LegConfig& c,
                                   const std::vector<float>& original, double probe_top, const std::string& where,
                                   double x, double y, const Box* bounds) {
  // The foot's heightfield contacts without MPR on prisms that cannot touch it (sim/leg_hfield.cpp).
  const hfield::Scope culling(m, c.cull_prisms);
  mj_forward(m, d);
  const double radius = 0.5 * c.foot_diameter_m, t = c.foot_thickness_m;
  double probe_step = 0.01;
  if (g.hfield_geom >= 0) {
    const int h = m->geom_dataid[g.hfield_geom];
    probe_step = std::min(probe_step, m->hfield_size[4 * h] / (m->hfield_ncol[h] - 1));
  }
  const auto top = probeFootprint(m, d, probe_top, x, y, radius, probe_step);
  if (!top) throw std::runtime_error(where + ": no terrain under the foot at (" + num(x) + ", " + num(y) + ")");

  const double weight = (c.leg_mass_kg + c.foot_mass_kg) * kGravity;
  const double z0 = *top + c.clearance_m + t;  // ankle height at the start
  d->qpos[g.qx] = x;
  d->qpos[g.qy] = y;
  d->qpos[g.qz] = z0;
  d->ctrl[g.act_x] = x;
  d->ctrl[g.act_y] = y;
  mj_forward(m, d);

  // Sand: lowered from the original heightfield, which is put back for the sinkage probe.
  int hid = -1;
  double cell = 0;
  if (g.hfield_geom >= 0) {
    hid = m->geom_dataid[g.hfield_geom];
    cell = std::max(2 * m->hfield_size[4 * hid] / (m->hfield_ncol[hid] - 1),
                    2 * m->hfield_size[4 * hid + 1] / (m->hfield_nrow[hid] - 1));
  }
  const double reach = radius + std::sqrt(2.0) * cell;
  double soil_force = 0, sink_applied = 0;
  const double filter_tau = 0.02, sink_rate = 0.25;  // s, m/s: sand yields no faster

  // Vertical servo: a position command descending at descent_speed, tracked by a PD loop with
  // gravity compensation, whose push is capped at the load allowed so far (0 before contact, a
  // ramp to load_n after it): the leg lowers until the foot carries the allowed load.
  const double kp = 2e4, kd = 2 * std::sqrt(kp * (c.leg_mass_kg + c.foot_mass_kg));
  double z_cmd = z0;
  double t_contact = -1, settle_since = -1;
  Eigen::Vector2d first_contact = Eigen::Vector2d::Zero();
  LegOutcome out;
  out.drift_m = std::numeric_limits<double>::quiet_NaN();
  auto pose = [&] { return footPose(d, g.foot, t); };

  auto measure = [&] {
    const FootPose p = pose();
    out.x_m = p.sole.x();
    out.y_m = p.sole.y();
    out.z_m = p.sole.z();
    out.tilt_deg = std::acos(std::clamp(p.axis.z(), -1.0, 1.0)) * kDeg;
    out.slip_m = t_contact >= 0 ? (p.sole.head<2>() - first_contact).norm() : 0.0;
    out.load_n = footContacts(m, d, g.foot).fz;
    out.time_s = d->time;
    // Sinkage against the true terrain: probe with the heightfield as the world gave it.
    std::vector<float> modified;
    if (hid >= 0) {
      float* p0 = m->hfield_data + m->hfield_adr[hid];
      modified.assign(p0, p0 + original.size());
      std::copy(original.begin(), original.end(), p0);
    }
    out.sink_m = probeFootprint(m, d, probe_top, p.sole.x(), p.sole.y(), radius, probe_step, &p).value_or(0.0);
    if (hid >= 0) std::copy(modified.begin(), modified.end(), m->hfield_data + m->hfield_adr[hid]);
  };

  const double dt = m->opt.timestep;
  double hold_until = -1;
  Eigen::Vector3d settled_at = Eigen::Vector3d::Zero();
  // The foot's poses over the last settle window (the excursion rule at the time limit).
  const int window_steps = std::max(1, int(std::lround(c.settle_window_s / dt)));
  std::vector<Eigen::Vector3d> recent_soles(std::size_t(window_steps) + 1), recent_axes(recent_soles.size());
  long pose_count = 0;
  while (d->time < c.time_limit_s + c.hold_s) {
    const double vz = d->qvel[g.vz];
    const double allowed = t_contact < 0 ? 0.0 : c.load_n * std::min(1.0, (d->time - t_contact) / c.load_ramp_s);
    // After contact the command runs ahead by 2× load/kp, so the cap, not the PD, sets the load.
    z_cmd = t_contact < 0 ? z_cmd - c.descent_speed_m_s * dt : d->qpos[g.qz] - 2 * c.load_n / kp;
    const double u = weight + kp * (z_cmd - d->qpos[g.qz]) + kd * (-c.descent_speed_m_s - vz);
    // Before contact the servo may push with the foot's weight only (free descent).
    d->ctrl[g.act_z] = std::clamp(u, t_contact < 0 ? 0.0 : weight - allowed, weight + c.load_n);
    mj_step(m, d);
    if (bounds && !bounds->contains(pose().sole.x(), pose().sole.y())) return std::nullopt;

    const ContactSum contacts = footContacts(m, d, g.foot);
    out.max_pair_contacts = std::max(out.max_pair_contacts, contacts.max_pair);
    out.max_contacts = std::max(out.max_contacts, d->ncon);
    out.max_rows = std::max(out.max_rows, d->nefc);
    if (contacts.max_pair >= mjMAXCONPAIR || d->warning[mjWARN_CONTACTFULL].number > 0 ||
        d->warning[mjWARN_CNSTRFULL].number > 0)
      out.contact_cap_reached = true;
    if (contacts.touching && t_contact < 0) {
      t_contact = d->time;
      first_contact = pose().sole.head<2>();
    }

    if (c.soil == Soil::Sand && t_contact >= 0) {
      const double fz = footContacts(m, d, g.foot, g.hfield_geom).fz;
      // Quasi-static Bekker: the soil sees the contact force, but never more than the load the
      // leg commands, so impacts of the foot following the yielding sand do not dig it deeper.
      soil_force += (std::clamp(fz, 0.0, allowed) - soil_force) * dt / filter_tau;
      const double target = bekkerSinkage(soil_force, c);
      // Yield in steps of at least 0.1 mm: each step drops the foot a little, and a creep of
      // ever smaller steps as the force converges would keep it from ever settling.
      if (target > sink_applied + kSandStep) {
        sink_applied = std::min(target, sink_applied + sink_rate * dt);
        const FootPose p = pose();
        lowerSand(m, d, g.hfield_geom, original, p.sole.x(), p.sole.y(), reach, sink_applied);
        mj_forward(m, d);
      }
    }

    if (hold_until >= 0) {
      out.drift_m = std::max(out.drift_m, (pose().sole - settled_at).norm());
      if (d->time >= hold_until) break;
      continue;
    }
    mjtNum vel[6];
    mj_objectVelocity(m, d, mjOBJ_BODY, g.foot, vel, 0);
    const bool slow = Eigen::Vector3d(vel[3], vel[4], vel[5]).norm() < c.settle_speed_m_s &&
                      Eigen::Vector3d(vel[0], vel[1], vel[2]).norm() < c.settle_angular_speed_rad_s;
    const bool loaded = t_contact >= 0 && d->time >= t_contact + c.load_ramp_s;
    settle_since = (slow && loaded) ? (settle_since < 0 ? d->time : settle_since) : -1;
    bool settled = settle_since >= 0 && d->time - settle_since >= c.settle_window_s;
    if (loaded) {
      const FootPose p = pose();
      const std::size_t slot = std::size_t(pose_count++ % long(recent_soles.size()));
      recent_soles[slot] = p.sole, recent_axes[slot] = p.axis;
    }
    if (!settled && loaded && d->time >= c.time_limit_s && pose_count >= long(recent_soles.size())) {
      // The excursion rule: a foot that jitters in place (contact chatter: speeds crossing the
      // thresholds every few milliseconds while its pose stays put) never meets the speed rule.
      // What the speed rule guarantees is that over a window the foot moves less than v·w and
      // turns less than ω·w; if every pose of the last window is that close to the window's
      // first, the foot is as settled as the speed rule would have it. Only at the time limit, so
      // a step the speed rule settles is unchanged.
      std::vector<Eigen::Vector3d> soles, axes;  // in time order: the oldest first
      for (std::size_t k = 0; k < recent_soles.size(); ++k) {
        const std::size_t slot = std::size_t((pose_count + long(k)) % long(recent_soles.size()));
        soles.push_back(recent_soles[slot]), axes.push_back(recent_axes[slot]);
      }
      settled = out.settled_by_excursion = stillOverWindow(soles, axes, c.settle_speed_m_s * c.settle_window_s,
                                                             c.settle_angular_speed_rad_s * c.settle_window_s);
    }
    if (settled || d->time >= c.time_limit_s) {
      out.settled = settled;
      measure();
      if (!settled || c.hold_s <= 0) break;
      settled_at = pose().sole;
      hold_until = d->time + c.hold_s;
      out.drift_m = 0;
    }
  }
  return out;
}

}  // namespace

std::filesystem::path writeLegWorld(const std::filesystem::path& world_xml, const LegConfig& c) {
  const std::string text = worldText(world_xml);
  const auto out = world_xml.parent_path() / "leg.xml";
  base::writeFileAtomic(out, legXml(world_xml.filename().string(), text, c));
  return out;
}

struct Leg::Impl {
  std::filesystem::path world_xml;
  LegConfig config;
  std::optional<Box> region, bounds;  // the footfall centres; where the sole centre may go
  ModelPtr model;
  DataPtr data;
  Rig rig;
  std::vector<float> original;  // the heightfield as built, put back before every step
  double probe_top = 0;         // the whole world's: the crop's rays start where stepLeg's do
  bool cropped = false;
  int kept = 0, dropped = 0, fallbacks = 0;

  // The model and its handles, the heightfield saved.
  void setUp(ModelPtr m) {
    model = std::move(m);
    data.reset(mj_makeData(model.get()));
    if (!data) throw std::runtime_error(world_xml.string() + ": MuJoCo could not allocate the leg's data");
    rig = sim::rig(model.get());
    if (config.cull_prisms) hfield::install();  // MuJoCo's collision table, set before any step runs
    if (config.soil == Soil::Sand && rig.hfield_geom < 0)
      throw std::runtime_error(world_xml.string() + ": sand needs a heightfield geom");
    if (rig.hfield_geom >= 0) {
      const mjModel* mm = model.get();
      const int h = mm->geom_dataid[rig.hfield_geom];
      const float* p = mm->hfield_data + mm->hfield_adr[h];
      original.assign(p, p + std::size_t(mm->hfield_nrow[h]) * mm->hfield_ncol[h]);
    }
    kept = 0;
    for (int g = 0; g < model->ngeom; ++g) kept += model->geom_bodyid[g] == 0;
  }

  ModelPtr wholeWorld() const {
    return loadText(legXml(world_xml.filename().string(), worldText(world_xml), config), world_xml.parent_path());
  }
};

Leg::Leg(const std::filesystem::path& world_xml, const LegConfig& config) : impl_(std::make_unique<Impl>()) {
  impl_->world_xml = world_xml;
  impl_->config = config;
  impl_->setUp(impl_->wholeWorld());
  impl_->probe_top = probeTop(impl_->model.get());
}

Leg::Leg(const std::filesystem::path& world_xml, const LegRegion& r, const LegConfig& config)
    : impl_(std::make_unique<Impl>()) {
  if (!(std::isfinite(r.x_min) && std::isfinite(r.x_max) && std::isfinite(r.y_min) && std::isfinite(r.y_max)) ||
      r.x_min > r.x_max || r.y_min > r.y_max)
    throw std::invalid_argument("Leg: the footfall region must be finite with x_min <= x_max and y_min <= y_max");
  Impl& s = *impl_;
  s.world_xml = world_xml;
  s.config = config;
  ModelPtr whole = s.wholeWorld();
  // The sole centre may wander a foot radius from the region (seating, slip: step() reruns a foot
  // that goes further on the whole world); the foot reaches a radius beyond its sole centre, and
  // its thickness more where it tilts (its top rim sits over the ankle's offset).
  const double radius = 0.5 * config.foot_diameter_m;
  const Box region{r.x_min, r.x_max, r.y_min, r.y_max};
  s.region = region;
  s.probe_top = probeTop(whole.get());
  const Box reach = region.grown(2 * radius + config.foot_thickness_m);
  const std::optional<LegCrop> crop = cropWorld(whole.get(), reach.x0, reach.x1, reach.y0, reach.y1);
  ModelPtr m;
  if (crop) {
    m = loadFromMemory(legXml("cropped_world.xml", crop->xml, config), "cropped_world.xml", crop->xml,
                       world_xml.string());
    m->opt = whole->opt;  // the world's options, exactly
    if (!copyWorldGeoms(whole.get(), crop->kept, m.get())) m.reset();
  }
  if (!m) {  // a world the crop cannot copy: the whole world
    s.setUp(std::move(whole));
    return;
  }
  s.bounds = region.grown(radius);
  s.cropped = true;
  s.setUp(std::move(m));
  s.dropped = crop->dropped;
}

Leg::Leg(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}

Leg Leg::clone() const {
  const Impl& s = *impl_;
  auto copy = std::make_unique<Impl>();
  copy->world_xml = s.world_xml;
  copy->config = s.config;
  copy->region = s.region, copy->bounds = s.bounds;
  copy->probe_top = s.probe_top;
  copy->cropped = s.cropped;
  copy->dropped = s.dropped;
  mjModel* m = mj_copyModel(nullptr, s.model.get());
  if (!m) throw std::runtime_error(s.world_xml.string() + ": MuJoCo could not copy the leg's model");
  copy->setUp(ModelPtr(m));
  copy->original = s.original;  // the heightfield as built (this one's may be lowered by its last step)
  return Leg(std::move(copy));
}

Leg::Leg(Leg&&) noexcept = default;
Leg& Leg::operator=(Leg&&) noexcept = default;
Leg::~Leg() = default;

LegOutcome Leg::step(double x, double y) {
  Impl& s = *impl_;
  if (s.region && !s.region->contains(x, y))
    throw std::invalid_argument("Leg::step: (" + num(x) + ", " + num(y) + ") lies outside the footfall region [" +
                                num(s.region->x0) + ", " + num(s.region->x1) + "] x [" + num(s.region->y0) + ", " +
                                num(s.region->y1) + "] the leg was built for");
  mjModel* m = s.model.get();
  mjData* d = s.data.get();
  resetState(m, d);
  if (s.rig.hfield_geom >= 0)
    std::copy(s.original.begin(), s.original.end(), m->hfield_data + m->hfield_adr[m->geom_dataid[s.rig.hfield_geom]]);
  const std::optional<LegOutcome> out =
      simulate(m, d, s.rig, s.config, s.original, s.probe_top, s.world_xml.string(), x, y, s.bounds ? &*s.bounds : nullptr);
  if (out) return *out;
  ++s.fallbacks;  // the foot went past the cropped terrain's margin
  return Leg(s.world_xml, s.config).step(x, y);
}

bool Leg::cropped() const { return impl_->cropped; }
int Leg::terrainGeoms() const { return impl_->kept; }
int Leg::droppedGeoms() const { return impl_->dropped; }
int Leg::fallbacks() const { return impl_->fallbacks; }

bool stillOverWindow(const std::vector<Eigen::Vector3d>& soles, const std::vector<Eigen::Vector3d>& axes,
                     double max_move_m, double max_turn_rad) {
  if (soles.size() < 2 || soles.size() != axes.size()) return false;
  for (std::size_t k = 1; k < soles.size(); ++k) {
    const double turned = std::acos(std::clamp(axes[k].dot(axes[0]), -1.0, 1.0));
    if (!((soles[k] - soles[0]).norm() < max_move_m) || !(turned < max_turn_rad)) return false;
  }
  return true;
}

}  // namespace ambler::sim
