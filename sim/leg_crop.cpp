// sim::Leg's crop of the world: see sim/leg_crop.hpp.
#include "sim/leg_crop.hpp"

#include <mujoco/mujoco.h>

#include <algorithm>
#include <cstdio>
#include <sstream>

namespace ambler::sim {

namespace {

// Every digit of a double or float: the crop's MJCF must reproduce the compiled world's numbers.
std::string exact(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  return buf;
}

const char* geomTypeName(int type) {
  switch (type) {
    case mjGEOM_PLANE: return "plane";
    case mjGEOM_HFIELD: return "hfield";
    case mjGEOM_SPHERE: return "sphere";
    case mjGEOM_CAPSULE: return "capsule";
    case mjGEOM_ELLIPSOID: return "ellipsoid";
    case mjGEOM_CYLINDER: return "cylinder";
    case mjGEOM_BOX: return "box";
    case mjGEOM_MESH: return "mesh";
    default: return nullptr;
  }
}

std::string objectName(const mjModel* m, mjtObj type, int id, const char* prefix) {
  const char* n = mj_id2name(m, type, id);
  return n ? std::string(n) : std::string(prefix) + std::to_string(id);
}

}  // namespace

std::optional<LegCrop> cropWorld(const mjModel* m, double x0, double x1, double y0, double y1) {
  // The circle of radius r about (x, y) reaches the box.
  const auto reaches = [&](double x, double y, double r) {
    const double dx = std::max({x0 - x, 0.0, x - x1}), dy = std::max({y0 - y, 0.0, y - y1});
    return dx * dx + dy * dy <= r * r;
  };
  if (m->nbody != 3 || m->neq || m->ntendon || m->npair || m->nexclude || m->nmocap) return std::nullopt;
  for (int g = 0; g < m->ngeom; ++g)
    if (m->geom_bodyid[g] == 0 && !geomTypeName(m->geom_type[g])) return std::nullopt;
  LegCrop crop;
  std::ostringstream assets, bodies;
  for (int g = 0; g < m->ngeom; ++g) {
    if (m->geom_bodyid[g] != 0) continue;
    const int type = m->geom_type[g];
    const double* p = m->geom_pos + 3 * g;
    const double* q = m->geom_quat + 4 * g;
    if (type != mjGEOM_HFIELD && type != mjGEOM_PLANE && !reaches(p[0], p[1], m->geom_rbound[g])) {
      ++crop.dropped;
      continue;
    }
    std::ostringstream attr;
    attr << " type=\"" << geomTypeName(type) << "\"";
    if (const char* n = mj_id2name(m, mjOBJ_GEOM, g)) attr << " name=\"" << n << "\"";
    if (type == mjGEOM_HFIELD) {
      const int h = m->geom_dataid[g];
      const std::string hfield = objectName(m, mjOBJ_HFIELD, h, "hfield_");
      const double* size = m->hfield_size + 4 * h;
      assets << "    <hfield name=\"" << hfield << "\" nrow=\"" << m->hfield_nrow[h] << "\" ncol=\""
             << m->hfield_ncol[h] << "\" size=\"" << exact(size[0]) << ' ' << exact(size[1]) << ' '
             << exact(size[2]) << ' ' << exact(size[3]) << "\"/>\n";
      attr << " hfield=\"" << hfield << "\"";
    } else if (type == mjGEOM_MESH) {
      // The compiled mesh: vertices in its own frame (centred, on its principal axes), which the
      // geom's pos and quat place, and its faces.
      const int k = m->geom_dataid[g];
      const std::string mesh = objectName(m, mjOBJ_MESH, k, "mesh_");
      assets << "    <mesh name=\"" << mesh << "\" vertex=\"";
      const float* v = m->mesh_vert + 3 * m->mesh_vertadr[k];
      for (int i = 0; i < 3 * m->mesh_vertnum[k]; ++i) assets << (i ? " " : "") << exact(v[i]);
      assets << "\" face=\"";
      const int* f = m->mesh_face + 3 * m->mesh_faceadr[k];
      for (int i = 0; i < 3 * m->mesh_facenum[k]; ++i) assets << (i ? " " : "") << f[i];
      assets << "\"/>\n";
      attr << " mesh=\"" << mesh << "\"";
    } else {
      const double* sz = m->geom_size + 3 * g;
      attr << " size=\"" << exact(sz[0]) << ' ' << exact(sz[1]) << ' ' << exact(sz[2]) << "\"";
    }
    const double* fr = m->geom_friction + 3 * g;
    const double* sr = m->geom_solref + mjNREF * g;
    const double* si = m->geom_solimp + mjNIMP * g;
    attr << " pos=\"" << exact(p[0]) << ' ' << exact(p[1]) << ' ' << exact(p[2]) << "\" quat=\"" << exact(q[0])
         << ' ' << exact(q[1]) << ' ' << exact(q[2]) << ' ' << exact(q[3]) << "\" contype=\"" << m->geom_contype[g]
         << "\" conaffinity=\"" << m->geom_conaffinity[g] << "\" condim=\"" << m->geom_condim[g] << "\" group=\""
         << m->geom_group[g] << "\" priority=\"" << m->geom_priority[g] << "\" friction=\"" << exact(fr[0]) << ' '
         << exact(fr[1]) << ' ' << exact(fr[2]) << "\" solmix=\"" << exact(m->geom_solmix[g]) << "\" solref=\""
         << exact(sr[0]) << ' ' << exact(sr[1]) << "\" solimp=\"";
    for (int i = 0; i < mjNIMP; ++i) attr << (i ? " " : "") << exact(si[i]);
    attr << "\" margin=\"" << exact(m->geom_margin[g]) << "\" gap=\"" << exact(m->geom_gap[g]) << "\"";
    bodies << "    <geom" << attr.str() << "/>\n";
    crop.kept.push_back(g);
  }
  crop.xml = "<mujoco model=\"cropped_world\">\n  <compiler angle=\"radian\"/>\n  <asset>\n" + assets.str() +
             "  </asset>\n  <worldbody>\n" + bodies.str() + "  </worldbody>\n</mujoco>\n";
  return crop;
}

namespace {

// Ints of a mesh's convex graph (MuJoCo 2.2.2: numvert, numface, then 3·numvert + 6·numface).
int graphSize(const mjModel* m, int mesh) {
  const int adr = m->mesh_graphadr[mesh];
  return adr < 0 ? 0 : 2 + 3 * m->mesh_graph[adr] + 6 * m->mesh_graph[adr + 1];
}

}  // namespace

bool copyWorldGeoms(const mjModel* whole, const std::vector<int>& kept, mjModel* crop) {
  for (std::size_t i = 0; i < kept.size(); ++i) {
    const int from = kept[i], to = int(i);  // the world body's geoms come first, in order
    if (whole->geom_type[from] == mjGEOM_HFIELD) {
      const int h = whole->geom_dataid[from], hc = crop->geom_dataid[to];
      std::copy_n(whole->hfield_data + whole->hfield_adr[h], std::size_t(whole->hfield_nrow[h]) * whole->hfield_ncol[h],
                  crop->hfield_data + crop->hfield_adr[hc]);
      continue;
    }
    std::copy_n(whole->geom_pos + 3 * from, 3, crop->geom_pos + 3 * to);
    std::copy_n(whole->geom_quat + 4 * from, 4, crop->geom_quat + 4 * to);
    std::copy_n(whole->geom_size + 3 * from, 3, crop->geom_size + 3 * to);
    crop->geom_rbound[to] = whole->geom_rbound[from];
    crop->geom_sameframe[to] = whole->geom_sameframe[from];
    if (whole->geom_type[from] != mjGEOM_MESH) continue;
    const int k = whole->geom_dataid[from], kc = crop->geom_dataid[to];
    if (whole->mesh_vertnum[k] != crop->mesh_vertnum[kc] || whole->mesh_facenum[k] != crop->mesh_facenum[kc] ||
        graphSize(whole, k) != graphSize(crop, kc))
      return false;
    std::copy_n(whole->mesh_vert + 3 * whole->mesh_vertadr[k], 3 * whole->mesh_vertnum[k],
                crop->mesh_vert + 3 * crop->mesh_vertadr[kc]);
    std::copy_n(whole->mesh_normal + 3 * whole->mesh_vertadr[k], 3 * whole->mesh_vertnum[k],
                crop->mesh_normal + 3 * crop->mesh_vertadr[kc]);
    std::copy_n(whole->mesh_face + 3 * whole->mesh_faceadr[k], 3 * whole->mesh_facenum[k],
                crop->mesh_face + 3 * crop->mesh_faceadr[kc]);
    if (whole->mesh_graphadr[k] >= 0)
      std::copy_n(whole->mesh_graph + whole->mesh_graphadr[k], graphSize(whole, k),
                  crop->mesh_graph + crop->mesh_graphadr[kc]);
  }
  return true;
}

}  // namespace ambler::sim
