// The leg's heightfield × foot-tile collision (docs/leg.md, "The foot's heightfield contacts").
// MuJoCo 2.2.2 collides a convex mesh with a heightfield by running MPR
// (libccd's ccdMPRPenetration) on every prism of the heightfield's cells under the mesh's bounding
// box whose top reaches the mesh's lowest point. Under the foot's 6 cm tiles on the sandbox's 2 cm
// sand that is ~210 MPR calls a collision pass, of which ~11 find a contact: a tile tilted by a few
// degrees, or a crater that keeps the sand's relief, puts most prisms of its box below the tile or
// beside it. This is the same computation in the same order — the same sub-grid, the same prisms,
// the same MPR on the same support functions and numbers, the same contacts — except that a prism
// that a separating plane shows to be more than kCullGap away from the tile is skipped instead of
// handed to MPR, which would have found no contact there. Installed in mjCOLLISIONFUNC for
// (heightfield, mesh) and active only on a thread inside a leg step that asks for it (a
// thread_local switch); everywhere else the table's original function runs.
#include "sim/leg_hfield.hpp"

#include <ccd/ccd.h>

#include <algorithm>
#include <array>
#include <cfloat>
#include <cmath>
#include <memory>
#include <mutex>
#include <vector>

namespace ambler::sim::hfield {

struct Context;

namespace {

// A pair farther apart than this along a separating plane is not handed to MPR (m; MPR's own
// tolerance is mjOption::mpr_tolerance, 1e-6 m by default).
constexpr double kCullGap = 1e-5;

// The prism of one heightfield triangle: three base vertices, then the three on the surface.
struct Prism {
  mjtNum v[6][3];
};

// The mesh geom in the heightfield's frame (MuJoCo's function swaps these into d->geom_xmat and
// geom_xpos for the call; here they are held aside).
struct Tile {
  const mjModel* m;
  int mesh;
  mjtNum mat[9], pos[3];
  mjtNum margin;
};

void prismSupport(const void* obj, const ccd_vec3_t* dir, ccd_vec3_t* vec) {
  const Prism* p = static_cast<const Prism*>(obj);
  const int first = dir->v[2] < 0 ? 0 : 3;  // the base for a downward direction, else the top
  int best_i = first;
  mjtNum best = mju_dot3(p->v[first], dir->v);
  for (int i = first + 1; i < first + 3; ++i)
    if (const mjtNum t = mju_dot3(p->v[i], dir->v); t > best) {
      best = t;
      best_i = i;
    }
  mju_copy3(vec->v, p->v[best_i]);
}

void prismCenter(const void* obj, ccd_vec3_t* c) {
  const Prism* p = static_cast<const Prism*>(obj);
  mju_zero3(c->v);
  for (int i = 0; i < 6; ++i) mju_addTo3(c->v, p->v[i]);
  mju_scl3(c->v, c->v, 1.0 / 6.0);
}

void prismFirstDir(const void*, const void*, ccd_vec3_t* d) { d->v[0] = 0, d->v[1] = 0, d->v[2] = 1; }

void tileCenter(const void* obj, ccd_vec3_t* c) { mju_copy3(c->v, static_cast<const Tile*>(obj)->pos); }

// The mesh's support point: the direction in the mesh's frame, the vertex farthest along it by
// climbing the convex hull's graph from its first vertex (a neighbour list scanned whole, its best
// taken, until none is better: mjModel::mesh_graph), or over all vertices when there is no graph;
// then half the margin along the direction, and back to the heightfield's frame.
void tileSupport(const void* obj, const ccd_vec3_t* dir_in, ccd_vec3_t* vec) {
  const Tile* t = static_cast<const Tile*>(obj);
  const mjModel* m = t->m;
  mjtNum dir[3], res[3];
  mju_rotVecMatT(dir, dir_in->v, t->mat);
  const float* vert = m->mesh_vert + 3 * m->mesh_vertadr[t->mesh];
  const auto along = [&](int i) {
    return dir[0] * mjtNum(vert[3 * i]) + dir[1] * mjtNum(vert[3 * i + 1]) + dir[2] * mjtNum(vert[3 * i + 2]);
  };
  int best_vert = -1;
  if (const int adr = m->mesh_graphadr[t->mesh]; adr < 0) {
    mjtNum best = -1e10;
    for (int i = 0; i < m->mesh_vertnum[t->mesh]; ++i)
      if (const mjtNum d = along(i); d > best) {
        best = d;
        best_vert = i;
      }
  } else {
    const int numvert = m->mesh_graph[adr];
    const int* edge_adr = m->mesh_graph + adr + 2;
    const int* global = edge_adr + numvert;
    const int* edge = global + numvert;
    int at = 0;
    mjtNum best = along(global[0]);
    for (bool better = true; better;) {
      better = false;
      // The list of the vertex the pass started from, scanned whole even after a better one.
      for (int e = edge_adr[at]; edge[e] >= 0; ++e)
        if (const mjtNum d = along(global[edge[e]]); d > best) {
          best = d;
          at = edge[e];
          better = true;
        }
    }
    best_vert = global[at];
  }
  for (int i = 0; i < 3; ++i) res[i] = best_vert < 0 ? 0 : mjtNum(vert[3 * best_vert + i]);
  for (int i = 0; i < 3; ++i) res[i] += dir[i] * t->margin / 2;
  mju_rotVecMat(vec->v, res, t->mat);
  mju_addTo3(vec->v, t->pos);
}

// libccd's ccdVec3Eq(v, origin): every component within DBL_EPSILON of 0.
bool nearOrigin(const ccd_vec3_t& v) {
  return std::abs(v.v[0]) < DBL_EPSILON && std::abs(v.v[1]) < DBL_EPSILON && std::abs(v.v[2]) < DBL_EPSILON;
}

// A convex mesh's face planes in its own frame, n·x <= d for the whole mesh (n outward, unit).
struct Plane {
  mjtNum n[3], d;
};
std::vector<Plane> facePlanes(const mjModel* m, int mesh) {
  std::vector<Plane> planes;
  const float* v = m->mesh_vert + 3 * m->mesh_vertadr[mesh];
  const int* f = m->mesh_face + 3 * m->mesh_faceadr[mesh];
  for (int k = 0; k < m->mesh_facenum[mesh]; ++k) {
    const float* a = v + 3 * f[3 * k];
    const float* b = v + 3 * f[3 * k + 1];
    const float* c = v + 3 * f[3 * k + 2];
    const mjtNum u[3] = {mjtNum(b[0]) - a[0], mjtNum(b[1]) - a[1], mjtNum(b[2]) - a[2]};
    const mjtNum w[3] = {mjtNum(c[0]) - a[0], mjtNum(c[1]) - a[1], mjtNum(c[2]) - a[2]};
    Plane p{{u[1] * w[2] - u[2] * w[1], u[2] * w[0] - u[0] * w[2], u[0] * w[1] - u[1] * w[0]}, 0};
    const mjtNum len = std::sqrt(mju_dot3(p.n, p.n));
    if (!(len > 0)) continue;
    for (mjtNum& x : p.n) x /= len;
    // Outward: the mesh's vertices lie behind the plane (a face listed either way round).
    mjtNum lo = 1e300, hi = -1e300;
    for (int i = 0; i < m->mesh_vertnum[mesh]; ++i) {
      const mjtNum t = p.n[0] * v[3 * i] + p.n[1] * v[3 * i + 1] + p.n[2] * v[3 * i + 2];
      lo = std::min(lo, t), hi = std::max(hi, t);
    }
    const mjtNum at = p.n[0] * a[0] + p.n[1] * a[1] + p.n[2] * a[2];
    if (hi - at > at - lo) {
      for (mjtNum& x : p.n) x = -x;
      hi = -lo;
    }
    p.d = hi;
    const bool seen = std::any_of(planes.begin(), planes.end(), [&](const Plane& q) {
      return std::abs(q.n[0] - p.n[0]) + std::abs(q.n[1] - p.n[1]) + std::abs(q.n[2] - p.n[2]) < 1e-9;
    });
    if (!seen) planes.push_back(p);
  }
  return planes;
}

}  // namespace

// The model a leg step culls on, with its meshes' face planes (none: the cull uses the other planes).
struct Context {
  const mjModel* model = nullptr;
  std::vector<std::vector<Plane>> planes;  // by mesh id
};

namespace {

struct State {
  mjfCollision original = nullptr;
};
thread_local const Context* active = nullptr;  // this thread is in a leg step that culls
State& state() {
  static State s;
  return s;
}

// What the culling needs of one tile, in the heightfield's frame: its vertices; its extent along
// the normal of the cells' diagonal (c, r)–(c+1, r+1), (dy, −dx) (x and y are its box lo/hi); its
// downward faces (the sole), below which a prism's six vertices may all lie; and the horizontal
// parts of its side faces' normals, along which the prism's triangle may lie beyond the tile's
// shadow. `on` is false for a mesh too large for the fixed arrays (then every prism goes to MPR).
struct Culler {
  static constexpr int kMax = 64;
  struct Axis {
    mjtNum a[2], lo, hi, gap;
  };
  bool on = false;
  int nv = 0, ndown = 0, naxes = 0;
  mjtNum gap = 0;
  const mjtNum *lo = nullptr, *hi = nullptr;
  std::array<std::array<mjtNum, 3>, kMax> tv;
  std::array<Plane, kMax> down;
  std::array<Axis, kMax + 1> axes;

  Culler(const Tile& tile, const std::vector<Plane>& local, mjtNum margin, mjtNum dx, mjtNum dy, const mjtNum* lo_,
         const mjtNum* hi_)
      : nv(tile.m->mesh_vertnum[tile.mesh]), gap(kCullGap + margin), lo(lo_), hi(hi_) {
    on = nv <= kMax && int(local.size()) <= kMax;
    if (!on) return;
    const float* mv = tile.m->mesh_vert + 3 * tile.m->mesh_vertadr[tile.mesh];
    for (int i = 0; i < nv; ++i) {
      const mjtNum p[3] = {mv[3 * i], mv[3 * i + 1], mv[3 * i + 2]};
      mju_rotVecMat(tv[i].data(), p, tile.mat);
      mju_addTo3(tv[i].data(), tile.pos);
    }
    axes[naxes++] = {{dy, -dx}, 0, 0, gap * std::hypot(dx, dy)};
    for (const Plane& pl : local) {
      Plane h;
      mju_rotVecMat(h.n, pl.n, tile.mat);
      h.d = pl.d + mju_dot3(h.n, tile.pos);
      if (h.n[2] < -0.5) down[ndown++] = h;
      else if (std::abs(h.n[2]) < 0.5) axes[naxes++] = {{h.n[0], h.n[1]}, 0, 0, gap * std::hypot(h.n[0], h.n[1])};
    }
    for (int k = 0; k < naxes; ++k) {
      Axis& ax = axes[k];
      ax.lo = 1e300, ax.hi = -1e300;
      for (int i = 0; i < nv; ++i) {
        const mjtNum t = ax.a[0] * tv[i][0] + ax.a[1] * tv[i][1];
        ax.lo = std::min(ax.lo, t), ax.hi = std::max(ax.hi, t);
      }
    }
  }

  // True when a plane separates the prism from the tile by more than `gap`.
  bool separated(const Prism& p) const {
    const mjtNum* a = p.v[3];
    const mjtNum* b = p.v[4];
    const mjtNum* c = p.v[5];
    // Under it: all six vertices beyond a downward face (the sole).
    for (int k = 0; k < ndown; ++k) {
      const Plane& pl = down[k];
      bool all = true;
      for (int i = 5; i >= 0 && all; --i) all = mju_dot3(pl.n, p.v[i]) > pl.d + gap;
      if (all) return true;
    }
    // Beside it: the triangle's x or y extent beyond the tile's box, or its extent along the
    // diagonal's normal or a side face's beyond the tile's.
    const mjtNum txlo = std::min({a[0], b[0], c[0]}), txhi = std::max({a[0], b[0], c[0]});
    const mjtNum tylo = std::min({a[1], b[1], c[1]}), tyhi = std::max({a[1], b[1], c[1]});
    if (txhi < lo[0] - gap || txlo > hi[0] + gap || tyhi < lo[1] - gap || tylo > hi[1] + gap) return true;
    for (int k = 0; k < naxes; ++k) {
      const Axis& ax = axes[k];
      const mjtNum pa = ax.a[0] * a[0] + ax.a[1] * a[1], pb = ax.a[0] * b[0] + ax.a[1] * b[1],
                   pc = ax.a[0] * c[0] + ax.a[1] * c[1];
      if (std::max({pa, pb, pc}) < ax.lo - ax.gap || std::min({pa, pb, pc}) > ax.hi + ax.gap) return true;
    }
    // Above it: every tile vertex above the plane of the triangle's top, under which the whole
    // column lies.
    const mjtNum u[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]}, w[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
    mjtNum n[3] = {u[1] * w[2] - u[2] * w[1], u[2] * w[0] - u[0] * w[2], u[0] * w[1] - u[1] * w[0]};
    if (n[2] < 0) n[0] = -n[0], n[1] = -n[1], n[2] = -n[2];
    const mjtNum need = mju_dot3(n, a) + gap * std::sqrt(mju_dot3(n, n));
    for (int i = 0; i < nv; ++i)
      if (n[0] * tv[i][0] + n[1] * tv[i][1] + n[2] * tv[i][2] <= need) return false;
    return true;
  }
};

int collide(const mjModel* m, const mjData* d, mjContact* con, int g1, int g2, mjtNum margin) {
  const State& s = state();
  if (!active || active->model != m || m->geom_type[g2] != mjGEOM_MESH || !s.original)
    return s.original(m, d, con, g1, g2, margin);
  const int hid = m->geom_dataid[g1];
  const int nrow = m->hfield_nrow[hid], ncol = m->hfield_ncol[hid];
  const float* data = m->hfield_data + m->hfield_adr[hid];
  const mjtNum* size = m->hfield_size + 4 * hid;
  const mjtNum *pos1 = d->geom_xpos + 3 * g1, *mat1 = d->geom_xmat + 9 * g1;
  const mjtNum *pos2 = d->geom_xpos + 3 * g2, *mat2 = d->geom_xmat + 9 * g2;

  // The mesh in the heightfield's frame; its bounding sphere, then its box, against the field's.
  Tile tile{m, m->geom_dataid[g2], {}, {}, 0};
  mjtNum vec[3];
  mju_sub3(vec, pos2, pos1);
  mju_mulMatTVec(tile.pos, mat1, vec, 3, 3);
  const mjtNum r2 = m->geom_rbound[g2];
  for (int i = 0; i < 2; ++i)
    if (size[i] < tile.pos[i] - r2 - margin || -size[i] > tile.pos[i] + r2 + margin) return 0;
  if (size[2] < tile.pos[2] - r2 - margin || -size[3] > tile.pos[2] + r2 + margin) return 0;
  mju_mulMatTMat(tile.mat, mat1, mat2, 3, 3, 3);
  mjtNum lo[3], hi[3];
  for (int k = 0; k < 3; ++k) {
    ccd_vec3_t dir{{0, 0, 0}}, out;
    dir.v[k] = 1;
    tileSupport(&tile, &dir, &out);
    hi[k] = out.v[k];
    dir.v[k] = -1;
    tileSupport(&tile, &dir, &out);
    lo[k] = out.v[k];
  }
  const mjtNum zmin = lo[2];
  if (lo[0] - margin > size[0] || hi[0] + margin < -size[0] || lo[1] - margin > size[1] ||
      hi[1] + margin < -size[1] || lo[2] - margin > size[2] || hi[2] + margin < -size[3])
    return 0;
  const int cmin = std::max(0, int(std::floor((lo[0] + size[0]) / (2 * size[0]) * (ncol - 1))));
  const int cmax = std::min(ncol - 1, int(std::ceil((hi[0] + size[0]) / (2 * size[0]) * (ncol - 1))));
  const int rmin = std::max(0, int(std::floor((lo[1] + size[1]) / (2 * size[1]) * (nrow - 1))));
  const int rmax = std::min(nrow - 1, int(std::ceil((hi[1] + size[1]) / (2 * size[1]) * (nrow - 1))));

  ccd_t ccd{};
  ccd.first_dir = prismFirstDir;
  ccd.center1 = prismCenter;
  ccd.center2 = tileCenter;
  ccd.support1 = prismSupport;
  ccd.support2 = tileSupport;
  ccd.max_iterations = static_cast<unsigned long>(m->opt.mpr_iterations);
  ccd.mpr_tolerance = m->opt.mpr_tolerance;
  tile.margin = margin;
  const mjtNum dx = (2.0 * size[0]) / (ncol - 1), dy = (2.0 * size[1]) / (nrow - 1);

  const Culler culler(tile, active->planes[tile.mesh], margin, dx, dy, lo, hi);

  Prism prism;
  prism.v[0][2] = prism.v[1][2] = prism.v[2][2] = -size[3];
  const int dr[2] = {1, 0};
  int cnt = 0;
  for (int r = rmin; r < rmax; ++r) {
    int nvert = 0;
    for (int c = cmin; c <= cmax; ++c)
      for (int i = 0; i < 2; ++i) {
        // The sliding window of the last three grid points: the prisms of the row's triangles.
        mju_copy3(prism.v[0], prism.v[1]);
        mju_copy3(prism.v[1], prism.v[2]);
        mju_copy3(prism.v[3], prism.v[4]);
        mju_copy3(prism.v[4], prism.v[5]);
        prism.v[2][0] = prism.v[5][0] = dx * c - size[0];
        prism.v[2][1] = prism.v[5][1] = dy * (r + dr[i]) - size[1];
        prism.v[5][2] = data[(r + dr[i]) * ncol + c] * size[2] + margin;
        if (++nvert <= 2) continue;
        if (prism.v[3][2] < zmin && prism.v[4][2] < zmin && prism.v[5][2] < zmin) continue;
        if (culler.on && culler.separated(prism)) continue;
        double depth;
        ccd_vec3_t dir, pos;
        if (ccdMPRPenetration(&prism, &tile, &ccd, &depth, &dir, &pos) != 0 || nearOrigin(dir)) continue;
        con[cnt].dist = -depth;
        mju_rotVecMat(con[cnt].frame, dir.v, mat1);
        mju_rotVecMat(con[cnt].pos, pos.v, mat1);
        mju_addTo3(con[cnt].pos, pos1);
        mju_zero3(con[cnt].frame + 3);
        if (++cnt >= mjMAXCONPAIR) return cnt;
      }
  }
  // MuJoCo then fixes the normals of spheres, capsules, ellipsoids and cylinders: neither geom here.
  return cnt;
}

}  // namespace

bool install() {
  static std::once_flag once;
  std::call_once(once, [] {
    State& s = state();
    s.original = mjCOLLISIONFUNC[mjGEOM_HFIELD][mjGEOM_MESH];
    if (s.original) mjCOLLISIONFUNC[mjGEOM_HFIELD][mjGEOM_MESH] = collide;
  });
  return state().original != nullptr;
}

Scope::Scope(const mjModel* m, bool on) : was_(active) {
  if (!on || !install()) return;
  context_ = std::make_unique<Context>();
  context_->model = m;
  // The meshes that can meet a heightfield: those of moving bodies (the foot's tiles), not the
  // world's rocks, which MuJoCo never collides with the world's heightfield.
  context_->planes.resize(m->nmesh);
  for (int g = 0; g < m->ngeom; ++g)
    if (const int k = m->geom_dataid[g]; m->geom_type[g] == mjGEOM_MESH && m->geom_bodyid[g] != 0 &&
                                         context_->planes[k].empty())
      context_->planes[k] = facePlanes(m, k);
  active = context_.get();
}

Scope::~Scope() { active = static_cast<const Context*>(was_); }

}  // namespace ambler::sim::hfield
