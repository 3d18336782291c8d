// MuJoCo's primitive geoms as Embree user geometries. The shape tests repeat the formulas, the
// order of operations and the mjMINVAL thresholds of MuJoCo 2.2.2's engine_ray.c (ray_plane,
// ray_sphere, ...) in double precision, so a ray hits or misses exactly when mj_ray says so.
// The one generalisation: mj_ray takes the nearest surface point at x >= 0, here it is the
// nearest at tnear <= x < tfar (Embree's ray interval), which is the same for tnear = 0.
#include "sim/embree_primitives.hpp"

#include <embree3/rtcore.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <stdexcept>
#include <string>

namespace ambler::sim::detail {
namespace {

using Vec3 = Eigen::Vector3d;

constexpr double kMinVal = 1e-15;  // mjMINVAL: the same threshold gives the same grazing misses

struct Hit {
  double t;
  Vec3 normal;  // outward, not normalised
};

// The nearest surface point offered so far within [tnear, tfar).
struct Nearest {
  double tnear;
  double tfar;
  std::optional<Hit> hit;

  void offer(double x, const Vec3& normal) {
    if (x >= tnear && x < tfar && (!hit || x < hit->t)) hit = Hit{x, normal};
  }
};

// Roots of a x² + 2b x + c = 0, smaller first (a >= 0); false below MuJoCo's determinant
// threshold (ray_quad), which is what decides a grazing miss.
bool quadRoots(double a, double b, double c, double x[2]) {
  double det = b * b - a * c;
  if (det < kMinVal) return false;
  det = std::sqrt(det);
  x[0] = (-b - det) / a;
  x[1] = (-b + det) / a;
  return true;
}

// MuJoCo's bounding-sphere pre-test (ray_sphere about pos), in the world frame: false when the
// ray misses the ball, or the ball lies wholly before tnear.
bool reachesBall(const Vec3& pos, double radius, const Vec3& pnt, const Vec3& vec, double tnear) {
  const double dif[3] = {pnt[0] - pos[0], pnt[1] - pos[1], pnt[2] - pos[2]};
  const double a = vec[0] * vec[0] + vec[1] * vec[1] + vec[2] * vec[2];
  const double b = vec[0] * dif[0] + vec[1] * dif[1] + vec[2] * dif[2];
  const double c = dif[0] * dif[0] + dif[1] * dif[1] + dif[2] * dif[2] - radius * radius;
  double x[2];
  return quadRoots(a, b, c, x) && x[1] >= tnear;
}

// The ray in the geom frame, as ray_map: lpnt = rotᵀ (pnt − pos), lvec = rotᵀ vec.
void toLocal(const Primitive& p, const Vec3& pnt, const Vec3& vec, Vec3& lpnt, Vec3& lvec) {
  const double dif[3] = {pnt[0] - p.pos[0], pnt[1] - p.pos[1], pnt[2] - p.pos[2]};
  const Eigen::Matrix3d& m = p.rot;
  for (int i = 0; i < 3; ++i) {
    lpnt[i] = m(0, i) * dif[0] + m(1, i) * dif[1] + m(2, i) * dif[2];
    lvec[i] = m(0, i) * vec[0] + m(1, i) * vec[1] + m(2, i) * vec[2];
  }
}

// The shapes below take the ray in the geom frame and offer local normals.

void plane(const Vec3& size, const Vec3& lpnt, const Vec3& lvec, Nearest& out) {
  if (lvec[2] > -kMinVal) return;  // front face only: the ray must come from +z
  const double x = -lpnt[2] / lvec[2];
  const double p0 = lpnt[0] + x * lvec[0];
  const double p1 = lpnt[1] + x * lvec[1];
  if ((size[0] <= 0 || std::abs(p0) <= size[0]) && (size[1] <= 0 || std::abs(p1) <= size[1])) {
    out.offer(x, Vec3::UnitZ());
  }
}

// Sphere, in the world frame as MuJoCo's ray_sphere (a sphere needs no rotation).
void sphere(const Vec3& pos, double radius, const Vec3& pnt, const Vec3& vec, Nearest& out) {
  const Vec3 dif(pnt[0] - pos[0], pnt[1] - pos[1], pnt[2] - pos[2]);
  const double a = vec[0] * vec[0] + vec[1] * vec[1] + vec[2] * vec[2];
  const double b = vec[0] * dif[0] + vec[1] * dif[1] + vec[2] * dif[2];
  const double c = dif[0] * dif[0] + dif[1] * dif[1] + dif[2] * dif[2] - radius * radius;
  double xx[2];
  if (!quadRoots(a, b, c, xx)) return;
  for (double x : xx) out.offer(x, dif + x * vec);
}

// Round side of a z-axis cylinder, accepted for |z| <= half_height. As MuJoCo, only the first
// root at or past tnear is tried: when it is rejected the second could only be nearest through
// rounding (in exact arithmetic the ray has then crossed a cap plane inside the radius first).
void roundSide(double radius, double half_height, const Vec3& lpnt, const Vec3& lvec,
               Nearest& out) {
  const double a = lvec[0] * lvec[0] + lvec[1] * lvec[1];
  const double b = lvec[0] * lpnt[0] + lvec[1] * lpnt[1];
  const double c = lpnt[0] * lpnt[0] + lpnt[1] * lpnt[1] - radius * radius;
  double xx[2];
  if (!quadRoots(a, b, c, xx)) return;
  const double x = xx[0] >= out.tnear ? xx[0] : xx[1];
  if (std::abs(lpnt[2] + x * lvec[2]) <= half_height) {
    out.offer(x, Vec3(lpnt[0] + x * lvec[0], lpnt[1] + x * lvec[1], 0.0));
  }
}

void capsule(const Vec3& size, const Vec3& lpnt, const Vec3& lvec, Nearest& out) {
  roundSide(size[0], size[1], lpnt, lvec, out);
  const double a = lvec[0] * lvec[0] + lvec[1] * lvec[1] + lvec[2] * lvec[2];
  for (int side = 1; side >= -1; side -= 2) {  // top, then bottom hemisphere
    const Vec3 ldif(lpnt[0], lpnt[1], lpnt[2] - side * size[1]);
    const double b = lvec[0] * ldif[0] + lvec[1] * ldif[1] + lvec[2] * ldif[2];
    const double c = ldif[0] * ldif[0] + ldif[1] * ldif[1] + ldif[2] * ldif[2] - size[0] * size[0];
    double xx[2];
    if (!quadRoots(a, b, c, xx)) continue;
    for (double x : xx) {
      const double z = lpnt[2] + x * lvec[2];
      if (side > 0 ? z >= size[1] : z <= -size[1]) out.offer(x, ldif + x * lvec);
    }
  }
}

void ellipsoid(const Vec3& size, const Vec3& lpnt, const Vec3& lvec, Nearest& out) {
  const double s[3] = {1 / (size[0] * size[0]), 1 / (size[1] * size[1]), 1 / (size[2] * size[2])};
  const double a = s[0] * lvec[0] * lvec[0] + s[1] * lvec[1] * lvec[1] + s[2] * lvec[2] * lvec[2];
  const double b = s[0] * lvec[0] * lpnt[0] + s[1] * lvec[1] * lpnt[1] + s[2] * lvec[2] * lpnt[2];
  const double c =
      s[0] * lpnt[0] * lpnt[0] + s[1] * lpnt[1] * lpnt[1] + s[2] * lpnt[2] * lpnt[2] - 1;
  double xx[2];
  if (!quadRoots(a, b, c, xx)) return;
  for (double x : xx) {
    const Vec3 q = lpnt + x * lvec;
    out.offer(x, Vec3(s[0] * q[0], s[1] * q[1], s[2] * q[2]));
  }
}

void cylinder(const Vec3& size, const Vec3& lpnt, const Vec3& lvec, Nearest& out) {
  if (std::abs(lvec[2]) > kMinVal) {
    for (int side = -1; side <= 1; side += 2) {
      const double x = (side * size[1] - lpnt[2]) / lvec[2];
      const double p0 = lpnt[0] + x * lvec[0];
      const double p1 = lpnt[1] + x * lvec[1];
      if (p0 * p0 + p1 * p1 <= size[0] * size[0]) out.offer(x, Vec3(0.0, 0.0, side));
    }
  }
  roundSide(size[0], size[1], lpnt, lvec, out);
}

void box(const Vec3& size, const Vec3& lpnt, const Vec3& lvec, Nearest& out) {
  constexpr int kFace[3][2] = {{1, 2}, {0, 2}, {0, 1}};
  for (int i = 0; i < 3; ++i) {
    if (std::abs(lvec[i]) <= kMinVal) continue;
    for (int side = -1; side <= 1; side += 2) {
      const double x = (side * size[i] - lpnt[i]) / lvec[i];
      const int j0 = kFace[i][0];
      const int j1 = kFace[i][1];
      const double p0 = lpnt[j0] + x * lvec[j0];
      const double p1 = lpnt[j1] + x * lvec[j1];
      if (std::abs(p0) <= size[j0] && std::abs(p1) <= size[j1]) {
        out.offer(x, side * Vec3::Unit(i));
      }
    }
  }
}

// Nearest hit in [tnear, tfar) with its world-frame normal, as mj_ray would find it.
std::optional<Hit> intersect(const Primitive& p, const Vec3& pnt, const Vec3& vec, double tnear,
                             double tfar) {
  Nearest out{tnear, tfar, std::nullopt};
  if (p.type == PrimitiveType::Sphere) {
    sphere(p.pos, p.size[0], pnt, vec, out);
    return out.hit;  // already in the world frame
  }
  // The bounding spheres MuJoCo tests first: they decide the same grazing cases it does.
  switch (p.type) {
    case PrimitiveType::Capsule:
      if (!reachesBall(p.pos, p.size[0] + p.size[1], pnt, vec, tnear)) return std::nullopt;
      break;
    case PrimitiveType::Cylinder:
      if (!reachesBall(p.pos, std::sqrt(p.size[0] * p.size[0] + p.size[1] * p.size[1]), pnt, vec,
                       tnear)) {
        return std::nullopt;
      }
      break;
    case PrimitiveType::Box:
      if (!reachesBall(p.pos,
                       std::sqrt(p.size[0] * p.size[0] + p.size[1] * p.size[1] +
                                 p.size[2] * p.size[2]),
                       pnt, vec, tnear)) {
        return std::nullopt;
      }
      break;
    default:
      break;
  }
  Vec3 lpnt;
  Vec3 lvec;
  toLocal(p, pnt, vec, lpnt, lvec);
  switch (p.type) {
    case PrimitiveType::Plane: plane(p.size, lpnt, lvec, out); break;
    case PrimitiveType::Capsule: capsule(p.size, lpnt, lvec, out); break;
    case PrimitiveType::Ellipsoid: ellipsoid(p.size, lpnt, lvec, out); break;
    case PrimitiveType::Cylinder: cylinder(p.size, lpnt, lvec, out); break;
    case PrimitiveType::Box: box(p.size, lpnt, lvec, out); break;
    case PrimitiveType::Sphere: break;
  }
  if (out.hit) out.hit->normal = p.rot * out.hit->normal;
  return out.hit;
}

// Half-extents of the world AABB about p.pos.
Vec3 worldHalfExtent(const Primitive& p) {
  const Eigen::Matrix3d a = p.rot.cwiseAbs();
  const Vec3& s = p.size;
  switch (p.type) {
    case PrimitiveType::Plane: {
      const double e0 = s[0] > 0 ? s[0] : kInfinitePlaneHalfExtent;
      const double e1 = s[1] > 0 ? s[1] : kInfinitePlaneHalfExtent;
      return a.col(0) * e0 + a.col(1) * e1;
    }
    case PrimitiveType::Sphere: return Vec3::Constant(s[0]);
    case PrimitiveType::Capsule: return a.col(2) * s[1] + Vec3::Constant(s[0]);
    case PrimitiveType::Ellipsoid:
      return (p.rot * s.asDiagonal()).rowwise().norm();
    case PrimitiveType::Cylinder: {
      // A disc of radius r with axis k spans r·sqrt(1 − k_i²) along world axis i.
      const Vec3 disc = (Vec3::Ones() - p.rot.col(2).cwiseAbs2()).cwiseMax(0.0).cwiseSqrt();
      return a.col(2) * s[1] + disc * s[0];
    }
    case PrimitiveType::Box: return a * s;
  }
  return Vec3::Zero();
}

void bounds(const RTCBoundsFunctionArguments* args) {
  const auto& p = *static_cast<const Primitive*>(args->geometryUserPtr);
  const Vec3 ext = worldHalfExtent(p);
  // Embree culls with float boxes and float slab tests. The pad (0.1 mm plus 1e-6 of the
  // coordinate, ~16 float ulps) keeps rounding from culling a ray that meets the surface, and
  // gives an axis-aligned plane, whose box is flat, a thickness. It only costs a few more calls.
  RTCBounds& b = *args->bounds_o;
  float lower[3];
  float upper[3];
  for (int i = 0; i < 3; ++i) {
    const double lo = p.pos[i] - ext[i];
    const double hi = p.pos[i] + ext[i];
    const double pad = 1e-4 + 1e-6 * std::max(std::abs(lo), std::abs(hi));
    lower[i] = std::nextafter(static_cast<float>(lo - pad), -std::numeric_limits<float>::max());
    upper[i] = std::nextafter(static_cast<float>(hi + pad), std::numeric_limits<float>::max());
  }
  b.lower_x = lower[0];
  b.lower_y = lower[1];
  b.lower_z = lower[2];
  b.upper_x = upper[0];
  b.upper_y = upper[1];
  b.upper_z = upper[2];
}

Vec3 origin(RTCRayN* ray, unsigned n, unsigned i) {
  return {RTCRayN_org_x(ray, n, i), RTCRayN_org_y(ray, n, i), RTCRayN_org_z(ray, n, i)};
}

Vec3 direction(RTCRayN* ray, unsigned n, unsigned i) {
  return {RTCRayN_dir_x(ray, n, i), RTCRayN_dir_y(ray, n, i), RTCRayN_dir_z(ray, n, i)};
}

// Handles any packet width Embree calls with (1 for rtcIntersect1, up to 16), lane by lane.
// No filter functions are invoked: the ray scene installs none.
void intersectN(const RTCIntersectFunctionNArguments* args) {
  const auto& p = *static_cast<const Primitive*>(args->geometryUserPtr);
  const unsigned n = args->N;
  RTCRayN* ray = RTCRayHitN_RayN(args->rayhit, n);
  RTCHitN* hit = RTCRayHitN_HitN(args->rayhit, n);
  for (unsigned i = 0; i < n; ++i) {
    if (args->valid[i] == 0) continue;
    const std::optional<Hit> h = intersect(p, origin(ray, n, i), direction(ray, n, i),
                                           RTCRayN_tnear(ray, n, i), RTCRayN_tfar(ray, n, i));
    if (!h) continue;
    // h->t < tfar, and rounding to float is monotone, so tfar never grows.
    RTCRayN_tfar(ray, n, i) = static_cast<float>(h->t);
    RTCHitN_Ng_x(hit, n, i) = static_cast<float>(h->normal.x());
    RTCHitN_Ng_y(hit, n, i) = static_cast<float>(h->normal.y());
    RTCHitN_Ng_z(hit, n, i) = static_cast<float>(h->normal.z());
    RTCHitN_u(hit, n, i) = 0.0f;
    RTCHitN_v(hit, n, i) = 0.0f;
    RTCHitN_primID(hit, n, i) = args->primID;
    RTCHitN_geomID(hit, n, i) = p.geom_id;
    // RTC_INVALID_GEOMETRY_ID unless the scene is instanced.
    for (unsigned l = 0; l < RTC_MAX_INSTANCE_LEVEL_COUNT; ++l) {
      RTCHitN_instID(hit, n, i, l) = args->context->instID[l];
    }
  }
}

void occludedN(const RTCOccludedFunctionNArguments* args) {
  const auto& p = *static_cast<const Primitive*>(args->geometryUserPtr);
  const unsigned n = args->N;
  for (unsigned i = 0; i < n; ++i) {
    if (args->valid[i] == 0) continue;
    if (intersect(p, origin(args->ray, n, i), direction(args->ray, n, i),
                  RTCRayN_tnear(args->ray, n, i), RTCRayN_tfar(args->ray, n, i))) {
      RTCRayN_tfar(args->ray, n, i) = -std::numeric_limits<float>::infinity();
    }
  }
}

bool valid(const Primitive& p) {
  if (!p.pos.allFinite() || !p.rot.allFinite() || !p.size.allFinite()) return false;
  switch (p.type) {
    case PrimitiveType::Plane: return true;  // size <= 0 means infinite
    case PrimitiveType::Sphere: return p.size[0] > 0;
    case PrimitiveType::Capsule:
    case PrimitiveType::Cylinder: return p.size[0] > 0 && p.size[1] >= 0;
    case PrimitiveType::Ellipsoid: return (p.size.array() > 0).all();
    case PrimitiveType::Box: return (p.size.array() > 0).all();
  }
  return false;
}

}  // namespace

std::optional<double> primitiveDistance(const Primitive& p, const Eigen::Vector3d& o,
                                        const Eigen::Vector3d& d) {
  const std::optional<Hit> h = intersect(p, o, d, 0.0, std::numeric_limits<double>::infinity());
  if (!h) return std::nullopt;
  return h->t;
}

void attachPrimitive(RTCDeviceTy* device, RTCSceneTy* scene, const Primitive* p) {
  if (p == nullptr || !valid(*p)) {
    throw std::invalid_argument("attachPrimitive: geom " +
                                (p ? std::to_string(p->geom_id) : std::string("(null)")) +
                                " has a non-finite pose or a size MuJoCo would reject");
  }
  RTCGeometry geom = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_USER);
  if (geom == nullptr) {
    throw std::runtime_error("attachPrimitive: Embree could not create a user geometry for geom " +
                             std::to_string(p->geom_id));
  }
  rtcSetGeometryUserPrimitiveCount(geom, 1);
  rtcSetGeometryUserData(geom, const_cast<Primitive*>(p));  // the callbacks only read it
  rtcSetGeometryBoundsFunction(geom, bounds, nullptr);
  rtcSetGeometryIntersectFunction(geom, intersectN);
  rtcSetGeometryOccludedFunction(geom, occludedN);
  rtcCommitGeometry(geom);
  rtcAttachGeometryByID(scene, geom, p->geom_id);
  rtcReleaseGeometry(geom);
}

}  // namespace ambler::sim::detail
