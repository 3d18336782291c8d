// The analytic Embree primitives against MuJoCo's own ray casts (mju_rayGeom, the per-geom core
// of mj_ray) and against an independent ground truth: the first zero of the shape's signed
// distance along the ray.
#include "sim/embree_primitives.hpp"

#include <embree3/rtcore.h>
#include <gtest/gtest.h>
#include <mujoco/mujoco.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <memory>
#include <numbers>
#include <optional>
#include <random>
#include <vector>

namespace ambler::sim::detail {
namespace {

using Vec3 = Eigen::Vector3d;
using Rng = std::mt19937_64;

constexpr double kInf = std::numeric_limits<double>::infinity();

struct TypeInfo {
  PrimitiveType type;
  const char* name;
  int mj_type;
};
constexpr TypeInfo kTypes[] = {{PrimitiveType::Plane, "plane", mjGEOM_PLANE},
                               {PrimitiveType::Sphere, "sphere", mjGEOM_SPHERE},
                               {PrimitiveType::Capsule, "capsule", mjGEOM_CAPSULE},
                               {PrimitiveType::Ellipsoid, "ellipsoid", mjGEOM_ELLIPSOID},
                               {PrimitiveType::Cylinder, "cylinder", mjGEOM_CYLINDER},
                               {PrimitiveType::Box, "box", mjGEOM_BOX}};
const TypeInfo& info(PrimitiveType type) { return kTypes[static_cast<int>(type)]; }

// Rays within this distance (m) of a tangency, an edge, or with the origin this close to the
// surface, may flip between hit and miss under one rounding; they are not compared.
constexpr double kDegenerate = 1e-9;

// Embree stores t as a float: for t <= 20 a float ulp is at most 2^-19 ≈ 1.9e-6, so 1e-5 is ~5
// ulps. Longer (grazing plane) hits get the same relative bound.
double tTolerance(double t) { return 1e-5 * std::max(1.0, t / 20.0); }
// Sharper, where the double t is MuJoCo's own: rounding it to the nearest float moves it by at
// most 2^-24·t.
constexpr double kHalfFloatUlp = 0x1p-24;

// MuJoCo's answer: t >= 0, or -1 on a miss.
double mujocoRay(const Primitive& p, const Vec3& pnt, const Vec3& vec) {
  double mat[9];
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) mat[3 * r + c] = p.rot(r, c);  // geom_xmat is row-major
  }
  return mju_rayGeom(p.pos.data(), mat, p.size.data(), pnt.data(), vec.data(),
                     info(p.type).mj_type);
}

// ---- Embree ----------------------------------------------------------------------------------

void failOnEmbreeError(void*, RTCError code, const char* message) {
  ADD_FAILURE() << "Embree error " << code << ": " << (message ? message : "");
}

struct DeviceDeleter {
  void operator()(RTCDeviceTy* d) const { rtcReleaseDevice(d); }
};
struct SceneDeleter {
  void operator()(RTCSceneTy* s) const { rtcReleaseScene(s); }
};

RTCDevice device() {
  static const std::unique_ptr<RTCDeviceTy, DeviceDeleter> d = [] {
    RTCDevice dev = rtcNewDevice(nullptr);
    rtcSetDeviceErrorFunction(dev, failOnEmbreeError, nullptr);
    return std::unique_ptr<RTCDeviceTy, DeviceDeleter>(dev);
  }();
  return d.get();
}

// A committed scene owning its primitives (Embree keeps pointers to them).
class Scene {
 public:
  explicit Scene(std::vector<Primitive> prims)
      : prims_(std::move(prims)), scene_(rtcNewScene(device())) {
    for (const Primitive& p : prims_) attachPrimitive(device(), scene_.get(), &p);
    rtcCommitScene(scene_.get());
  }
  RTCScene get() const { return scene_.get(); }
  const std::vector<Primitive>& prims() const { return prims_; }

 private:
  std::vector<Primitive> prims_;
  std::unique_ptr<RTCSceneTy, SceneDeleter> scene_;
};

struct Ray {
  Vec3 o;  // float-representable, so MuJoCo and Embree see the same ray
  Vec3 d;
};

RTCRayHit rayHit(const Ray& ray, float tnear, float tfar) {
  RTCRayHit rh{};
  rh.ray.org_x = static_cast<float>(ray.o.x());
  rh.ray.org_y = static_cast<float>(ray.o.y());
  rh.ray.org_z = static_cast<float>(ray.o.z());
  rh.ray.dir_x = static_cast<float>(ray.d.x());
  rh.ray.dir_y = static_cast<float>(ray.d.y());
  rh.ray.dir_z = static_cast<float>(ray.d.z());
  rh.ray.tnear = tnear;
  rh.ray.tfar = tfar;
  rh.ray.mask = 0xFFFFFFFFu;
  rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
  rh.hit.primID = RTC_INVALID_GEOMETRY_ID;
  rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
  return rh;
}

RTCRayHit intersect1(RTCScene scene, const Ray& ray, float tnear = 0.0f,
                     float tfar = std::numeric_limits<float>::infinity()) {
  RTCIntersectContext context;
  rtcInitIntersectContext(&context);
  RTCRayHit rh = rayHit(ray, tnear, tfar);
  rtcIntersect1(scene, &context, &rh);
  return rh;
}

bool occluded1(RTCScene scene, const Ray& ray) {
  RTCIntersectContext context;
  rtcInitIntersectContext(&context);
  RTCRay r = rayHit(ray, 0.0f, std::numeric_limits<float>::infinity()).ray;
  rtcOccluded1(scene, &context, &r);
  return r.tfar == -std::numeric_limits<float>::infinity();
}

bool isHit(const RTCRayHit& rh) { return rh.hit.geomID != RTC_INVALID_GEOMETRY_ID; }

// ---- Geometry ground truth -------------------------------------------------------------------

Vec3 toLocal(const Primitive& p, const Vec3& world) { return p.rot.transpose() * (world - p.pos); }

// Signed distance to a solid (negative inside); exact but for the ellipsoid, where
// min(s)·(|q/s| − 1) has the right zero set and never exceeds the true distance in magnitude.
// Convex in space, so convex along a ray.
double sdf(const Primitive& p, const Vec3& world) {
  const Vec3 q = toLocal(p, world);
  const Vec3& s = p.size;
  switch (p.type) {
    case PrimitiveType::Sphere: return q.norm() - s[0];
    case PrimitiveType::Capsule:
      return (q - Vec3(0, 0, std::clamp(q.z(), -s[1], s[1]))).norm() - s[0];
    case PrimitiveType::Ellipsoid: return s.minCoeff() * (q.cwiseQuotient(s).norm() - 1.0);
    case PrimitiveType::Cylinder: {
      const Eigen::Vector2d d(q.head<2>().norm() - s[0], std::abs(q.z()) - s[1]);
      return d.cwiseMax(0.0).norm() + std::min(d.maxCoeff(), 0.0);
    }
    case PrimitiveType::Box: {
      const Vec3 d = q.cwiseAbs() - s;
      return d.cwiseMax(0.0).norm() + std::min(d.maxCoeff(), 0.0);
    }
    case PrimitiveType::Plane: break;
  }
  return kInf;
}

// Largest distance of a surface point from the geom centre.
double boundingRadius(const Primitive& p) {
  const Vec3& s = p.size;
  switch (p.type) {
    case PrimitiveType::Sphere: return s[0];
    case PrimitiveType::Capsule: return s[0] + s[1];
    case PrimitiveType::Cylinder: return std::hypot(s[0], s[1]);
    case PrimitiveType::Ellipsoid: return s.maxCoeff();
    case PrimitiveType::Box: return s.norm();
    case PrimitiveType::Plane: break;
  }
  return kInf;
}

// A ray parameter past every surface point and past the minimum of sdf along the ray. With D =
// |o − pos| and R the bounding radius: sdf at the closest approach to pos is at most D, and sdf
// exceeds D once |x − pos| > D + R, i.e. past t|d| = 2D + R. The ellipsoid's stand-in sdf is
// stretched by at most k = max(s)/min(s).
double rayRange(const Primitive& p, const Ray& ray) {
  const double k =
      p.type == PrimitiveType::Ellipsoid ? p.size.maxCoeff() / p.size.minCoeff() : 1.0;
  return ((2.0 * (ray.o - p.pos).norm() + boundingRadius(p)) * k + 1.0) / ray.d.norm();
}

struct Clearance {
  double min_sdf;  // min over t >= 0 of sdf(o + t d)
  double t_min;    // where
};

// Golden-section search: sdf is convex along the ray.
Clearance clearance(const Primitive& p, const Ray& ray) {
  const double g = (std::sqrt(5.0) - 1.0) / 2.0;
  double a = 0.0;
  double b = rayRange(p, ray);
  double c = b - g * (b - a);
  double d = a + g * (b - a);
  double fc = sdf(p, ray.o + c * ray.d);
  double fd = sdf(p, ray.o + d * ray.d);
  for (int it = 0; it < 200 && b - a > 1e-15 * b; ++it) {
    if (fc < fd) {
      b = d, d = c, fd = fc;
      c = b - g * (b - a);
      fc = sdf(p, ray.o + c * ray.d);
    } else {
      a = c, c = d, fc = fd;
      d = a + g * (b - a);
      fd = sdf(p, ray.o + d * ray.d);
    }
  }
  const double f0 = sdf(p, ray.o);
  const double tm = 0.5 * (a + b);
  const double fm = sdf(p, ray.o + tm * ray.d);
  return f0 <= fm ? Clearance{f0, 0.0} : Clearance{fm, tm};
}

// The unique sign change of sdf in [lo, hi], by bisection.
double bisect(const Primitive& p, const Ray& ray, double lo, double hi) {
  const bool lo_inside = sdf(p, ray.o + lo * ray.d) < 0;
  for (int it = 0; it < 200; ++it) {
    const double mid = 0.5 * (lo + hi);
    if (mid <= lo || mid >= hi) break;
    ((sdf(p, ray.o + mid * ray.d) < 0) == lo_inside ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

// Ground truth for a solid: the first surface point at t >= 0 (from inside, the exit).
double groundTruth(const Primitive& p, const Ray& ray, const Clearance& cl) {
  if (sdf(p, ray.o) < 0) return bisect(p, ray, 0.0, rayRange(p, ray));
  if (cl.min_sdf > 0) return -1;
  return bisect(p, ray, 0.0, cl.t_min);
}

// Outward normal at a surface point (local frame); nearest face for box and cylinder.
Vec3 localNormal(const Primitive& p, const Vec3& q) {
  const Vec3& s = p.size;
  switch (p.type) {
    case PrimitiveType::Plane: return Vec3::UnitZ();
    case PrimitiveType::Sphere: return q;
    case PrimitiveType::Capsule: return q - Vec3(0, 0, std::clamp(q.z(), -s[1], s[1]));
    case PrimitiveType::Ellipsoid: return q.cwiseQuotient(s.cwiseAbs2());
    case PrimitiveType::Cylinder:
      if (std::abs(q.z()) - s[1] > q.head<2>().norm() - s[0]) return Vec3(0, 0, q.z() > 0 ? 1 : -1);
      return Vec3(q.x(), q.y(), 0);
    case PrimitiveType::Box: {
      int i = 0;
      (q.cwiseAbs() - s).maxCoeff(&i);
      return (q[i] > 0 ? 1.0 : -1.0) * Vec3::Unit(i);
    }
  }
  return Vec3::Zero();
}

// Local point within kDegenerate of an edge where two acceptance tests meet.
bool nearEdge(const Primitive& p, const Vec3& q) {
  const Vec3& s = p.size;
  auto near = [](double a, double b) { return std::abs(a - b) < kDegenerate; };
  switch (p.type) {
    case PrimitiveType::Box: {
      int on = 0;
      for (int i = 0; i < 3; ++i) on += near(std::abs(q[i]), s[i]) ? 1 : 0;
      return on >= 2;
    }
    case PrimitiveType::Cylinder:
      return near(std::abs(q.z()), s[1]) && near(q.head<2>().norm(), s[0]);
    case PrimitiveType::Capsule: return near(std::abs(q.z()), s[1]);  // side meets hemisphere
    default: return false;
  }
}

// Why a ray is not compared, or nullptr. The criterion is geometric, exact to ~1e-15:
//  solids: the origin within kDegenerate of the surface; the ray's deepest point within
//    kDegenerate of the surface (a tangent, or grazing an edge or corner); the true hit point
//    within kDegenerate of an edge (box edges, cylinder rims, capsule side/hemisphere seams).
//  plane: the origin within kDegenerate of the plane; the crossing point within kDegenerate of
//    a rectangle edge; the crossing beyond the ±kInfinitePlaneHalfExtent Embree represents.
const char* degenerate(const Primitive& p, const Ray& ray) {
  if (p.type == PrimitiveType::Plane) {
    const Vec3 lo = toLocal(p, ray.o);
    const Vec3 ld = p.rot.transpose() * ray.d;
    if (std::abs(lo.z()) < kDegenerate) return "origin on plane";
    const double x = -lo.z() / ld.z();
    if (!(x >= 0) || std::isinf(x)) return nullptr;  // never crosses: both must miss
    const Vec3 c = lo + x * ld;
    for (int i = 0; i < 2; ++i) {
      if (p.size[i] > 0 && std::abs(std::abs(c[i]) - p.size[i]) < kDegenerate) return "rim";
      if (p.size[i] <= 0 && std::abs(c[i]) >= kInfinitePlaneHalfExtent) return "beyond extent";
    }
    return nullptr;
  }
  if (std::abs(sdf(p, ray.o)) < kDegenerate) return "origin on surface";
  const Clearance cl = clearance(p, ray);
  if (std::abs(cl.min_sdf) < kDegenerate) return "tangent";
  const double t = groundTruth(p, ray, cl);
  if (t >= 0 && nearEdge(p, toLocal(p, ray.o + t * ray.d))) return "edge";
  return nullptr;
}

// ---- Random shapes and rays ------------------------------------------------------------------

// Rounds to float precision through a volatile: GCC 12.2 at -O2 (SLP vectorizer) drops a
// double -> float -> double round trip of vectorised lanes, silently keeping the double.
Vec3 toFloatPrecision(const Vec3& v) {
  Vec3 r;
  for (int i = 0; i < 3; ++i) {
    volatile float f = static_cast<float>(v[i]);
    r[i] = f;
  }
  return r;
}

Eigen::Matrix3d randomRotation(Rng& rng) {
  std::normal_distribution<double> n;
  return Eigen::Quaterniond(n(rng), n(rng), n(rng), n(rng)).normalized().toRotationMatrix();
}

Vec3 randomUnit(Rng& rng) {
  std::normal_distribution<double> n;
  return Vec3(n(rng), n(rng), n(rng)).normalized();
}

Primitive randomPrimitive(PrimitiveType type, Rng& rng, unsigned id, double spread) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::uniform_real_distribution<double> size(0.05, 1.5);
  Primitive p;
  p.type = type;
  p.geom_id = id;
  p.pos = spread * Vec3(u(rng), u(rng), u(rng));
  p.rot = randomRotation(rng);
  switch (type) {
    case PrimitiveType::Plane: {
      std::uniform_real_distribution<double> half(0.2, 3.0);
      std::uniform_int_distribution<int> kind(0, 2);  // one in three directions infinite
      for (int i = 0; i < 2; ++i) p.size[i] = kind(rng) == 0 ? 0.0 : half(rng);
      p.size[2] = 0.1;  // MuJoCo's grid spacing, unused by rays
      break;
    }
    case PrimitiveType::Sphere: p.size = Vec3(size(rng), 0, 0); break;
    case PrimitiveType::Capsule:
    case PrimitiveType::Cylinder: p.size = Vec3(size(rng), size(rng), 0); break;
    case PrimitiveType::Ellipsoid:
    case PrimitiveType::Box: p.size = Vec3(size(rng), size(rng), size(rng)); break;
  }
  return p;
}

// Half-extents in the geom frame to aim at (an infinite plane direction: 4 m).
Vec3 aimExtent(const Primitive& p) {
  const Vec3& s = p.size;
  switch (p.type) {
    case PrimitiveType::Plane: return Vec3(s[0] > 0 ? s[0] : 4.0, s[1] > 0 ? s[1] : 4.0, 0.0);
    case PrimitiveType::Sphere: return Vec3::Constant(s[0]);
    case PrimitiveType::Capsule: return Vec3(s[0], s[0], s[0] + s[1]);
    case PrimitiveType::Cylinder: return Vec3(s[0], s[0], s[1]);
    case PrimitiveType::Ellipsoid:
    case PrimitiveType::Box: return s;
  }
  return s;
}

// Origins up to 8 m from the geom (some inside it); three in four aimed at a point of its
// extent box, the rest in random directions; lengths |d| in [0.5, 2] (t is in units of |d|).
Ray randomRay(const Primitive& p, Rng& rng) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::uniform_real_distribution<double> dist(0.0, 8.0);
  std::uniform_real_distribution<double> len(0.5, 2.0);
  std::uniform_int_distribution<int> aim(0, 3);
  const Vec3 o = p.pos + dist(rng) * randomUnit(rng);
  Vec3 d = randomUnit(rng);
  if (aim(rng) != 0) {
    const Vec3 target = p.pos + p.rot * aimExtent(p).cwiseProduct(Vec3(u(rng), u(rng), u(rng)));
    if ((target - o).norm() > 1e-6) d = (target - o).normalized();
  }
  d *= len(rng);
  // Round to float: the exact ray Embree casts is the one MuJoCo gets.
  return {toFloatPrecision(o), toFloatPrecision(d)};
}

Vec3 ng(const RTCRayHit& rh) { return Vec3(rh.hit.Ng_x, rh.hit.Ng_y, rh.hit.Ng_z); }

// ---- Tests -----------------------------------------------------------------------------------

TEST(EmbreePrimitives, HandPickedRaysFollowMujocoSemantics) {
  auto prim = [](PrimitiveType type, Vec3 size) {
    Primitive p;
    p.type = type;
    p.size = size;
    p.geom_id = 0;
    return p;
  };
  struct Case {
    const char* what;
    Primitive p;
    Ray ray;
    double t;  // analytic; -1 for a miss
  };
  Primitive turned_box = prim(PrimitiveType::Box, Vec3(1, 2, 3));
  turned_box.rot = Eigen::AngleAxisd(std::numbers::pi / 2, Vec3::UnitZ()).toRotationMatrix();
  const Case cases[] = {
      {"sphere from its centre: the far side", prim(PrimitiveType::Sphere, Vec3(1, 0, 0)),
       {Vec3(0, 0, 0), Vec3(1, 0, 0)}, 1.0},
      {"sphere, t in units of |d|", prim(PrimitiveType::Sphere, Vec3(1, 0, 0)),
       {Vec3(5, 0, 0), Vec3(-2, 0, 0)}, 2.0},
      {"infinite plane from above", prim(PrimitiveType::Plane, Vec3(0, 0, 1)),
       {Vec3(3, -7, 1), Vec3(0, 0, -1)}, 1.0},
      {"axis-aligned plane (a flat box), grazing", prim(PrimitiveType::Plane, Vec3(0, 0, 1)),
       {Vec3(0, 0, 1), Vec3(1, 0, -0.0078125)}, 128.0},
      {"plane from below: back face, a miss", prim(PrimitiveType::Plane, Vec3(0, 0, 1)),
       {Vec3(0, 0, -1), Vec3(0, 0, 1)}, -1.0},
      {"finite plane, outside its rectangle", prim(PrimitiveType::Plane, Vec3(1, 1, 1)),
       {Vec3(2, 0, 1), Vec3(0, 0, -1)}, -1.0},
      {"capsule hemisphere", prim(PrimitiveType::Capsule, Vec3(0.5, 1, 0)),
       {Vec3(0, 0, 5), Vec3(0, 0, -1)}, 3.5},
      {"capsule side", prim(PrimitiveType::Capsule, Vec3(0.5, 1, 0)),
       {Vec3(5, 0, 0.9), Vec3(-1, 0, 0)}, 4.5},
      {"cylinder cap", prim(PrimitiveType::Cylinder, Vec3(0.5, 1, 0)),
       {Vec3(0, 0.2, 5), Vec3(0, 0, -1)}, 4.0},
      {"cylinder side", prim(PrimitiveType::Cylinder, Vec3(0.5, 1, 0)),
       {Vec3(5, 0, 0.9), Vec3(-1, 0, 0)}, 4.5},
      {"box face", prim(PrimitiveType::Box, Vec3(1, 2, 3)), {Vec3(5, 0, 0), Vec3(-1, 0, 0)}, 4.0},
      {"box turned 90° about z", turned_box, {Vec3(5, 0, 0), Vec3(-1, 0, 0)}, 3.0},
      {"box from inside: the exit", prim(PrimitiveType::Box, Vec3(1, 2, 3)),
       {Vec3(0, 0, 0), Vec3(0, 0, 1)}, 3.0},
      {"ellipsoid", prim(PrimitiveType::Ellipsoid, Vec3(1, 2, 3)),
       {Vec3(0, 5, 0), Vec3(0, -1, 0)}, 3.0},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.what);
    EXPECT_DOUBLE_EQ(mujocoRay(c.p, c.ray.o, c.ray.d), c.t);
    const Scene scene({c.p});
    const RTCRayHit rh = intersect1(scene.get(), c.ray);
    ASSERT_EQ(isHit(rh), c.t >= 0);
    if (c.t >= 0) {
      EXPECT_FLOAT_EQ(rh.ray.tfar, static_cast<float>(c.t));
    }
  }
}

struct Stats {
  int compared = 0;
  int skipped = 0;
  int hits = 0;
  double max_dt = 0.0;      // Embree (float t) vs MuJoCo
  double t_at_max = 0.0;    // where
  double max_rel = 0.0;     // max |dt| / t
  double max_dt_dbl = 0.0;  // primitiveDistance (double t) vs MuJoCo
  double max_dt_gt = 0.0;   // MuJoCo vs the sdf ground truth (solids)
};

TEST(EmbreePrimitives, MatchesMujocoRayGeomOnRandomRays) {
  constexpr int kShapes = 100;
  constexpr int kRaysPerShape = 200;
  Rng rng(20240611);
  for (const TypeInfo& ti : kTypes) {
    const PrimitiveType type = ti.type;
    SCOPED_TRACE(ti.name);
    Stats st;
    for (int s = 0; s < kShapes; ++s) {
      const Scene scene({randomPrimitive(type, rng, 7, 2.0)});
      const Primitive& p = scene.prims()[0];
      for (int r = 0; r < kRaysPerShape; ++r) {
        const Ray ray = randomRay(p, rng);
        if (degenerate(p, ray) != nullptr) {
          ++st.skipped;
          continue;
        }
        ++st.compared;
        const double t_mj = mujocoRay(p, ray.o, ray.d);
        const RTCRayHit rh = intersect1(scene.get(), ray);
        ASSERT_EQ(isHit(rh), t_mj >= 0)
            << "shape " << s << " ray " << r << " t_mj " << t_mj << " t_embree " << rh.ray.tfar;
        EXPECT_EQ(occluded1(scene.get(), ray), t_mj >= 0);
        if (p.type != PrimitiveType::Plane) {
          const double t_gt = groundTruth(p, ray, clearance(p, ray));
          ASSERT_EQ(t_gt >= 0, t_mj >= 0);
          if (t_mj >= 0) st.max_dt_gt = std::max(st.max_dt_gt, std::abs(t_gt - t_mj));
        }
        const std::optional<double> t_dbl = primitiveDistance(p, ray.o, ray.d);
        ASSERT_EQ(t_dbl.has_value(), t_mj >= 0);
        if (t_mj < 0) continue;
        ++st.hits;
        // The same formulas in the same order: equal up to the last bits.
        st.max_dt_dbl = std::max(st.max_dt_dbl, std::abs(*t_dbl - t_mj));
        EXPECT_LE(std::abs(*t_dbl - t_mj), 1e-12 * std::max(1.0, t_mj));
        const double dt = std::abs(rh.ray.tfar - t_mj);
        if (dt > st.max_dt) st.max_dt = dt, st.t_at_max = t_mj;
        if (t_mj > 0) st.max_rel = std::max(st.max_rel, dt / t_mj);
        EXPECT_LE(dt, tTolerance(t_mj)) << "shape " << s << " ray " << r << " t_mj " << t_mj;
        // Sharper: the double t is MuJoCo's, so only the rounding to float remains.
        EXPECT_LE(dt, kHalfFloatUlp * t_mj) << "shape " << s << " ray " << r;
        EXPECT_EQ(rh.hit.geomID, 7u);
        EXPECT_EQ(rh.hit.primID, 0u);
        EXPECT_EQ(rh.hit.instID[0], RTC_INVALID_GEOMETRY_ID);
        EXPECT_EQ(rh.hit.u, 0.0f);
        EXPECT_EQ(rh.hit.v, 0.0f);
        // The normal at MuJoCo's (double) hit point: float rounding of Ng only.
        const Vec3 n = p.rot * localNormal(p, toLocal(p, ray.o + t_mj * ray.d));
        EXPECT_GT(ng(rh).normalized().dot(n.normalized()), 1.0 - 1e-6)
            << "shape " << s << " ray " << r;
      }
    }
    std::printf(
        "%-9s compared %d (hits %d), skipped %d; max |dt| %.3g at t %.3g, max |dt|/t %.3g; "
        "double: max |dt| %.3g; max |t_mj - t_sdf| %.3g\n",
        ti.name, st.compared, st.hits, st.skipped, st.max_dt, st.t_at_max, st.max_rel,
        st.max_dt_dbl, st.max_dt_gt);
    // The rays are aimed: most hit, or the comparison says little.
    EXPECT_GT(st.hits, st.compared / 3);
    EXPECT_LT(st.skipped, st.compared / 1000 + 1);
  }
}

// Numerical gradient of sdf (unit outside the solid; the ellipsoid's stand-in is not unit).
Vec3 sdfGradient(const Primitive& p, const Vec3& x) {
  constexpr double h = 1e-6;
  Vec3 g;
  for (int i = 0; i < 3; ++i) {
    const Vec3 e = h * Vec3::Unit(i);
    g[i] = (sdf(p, x + e) - sdf(p, x - e)) / (2 * h);
  }
  return g;
}

// Rays placed a chosen distance from a tangency (or from grazing an edge or corner), from 1e-11
// to 1e-4 m on either side: the shape, whose pose is double, is slid towards the (float) ray.
// Those outside the skip band must still agree with MuJoCo and with the sign of the clearance.
TEST(EmbreePrimitives, GrazingRaysAgreeOutsideTheSkipBand) {
  Rng rng(31);
  std::uniform_real_distribution<double> decade(-11.0, -4.0);
  std::uniform_int_distribution<int> sign(0, 1);
  for (const TypeInfo& ti : kTypes) {
    const PrimitiveType type = ti.type;
    if (type == PrimitiveType::Plane) continue;  // a plane has no silhouette
    SCOPED_TRACE(ti.name);
    int compared = 0;
    int skipped = 0;
    int close = 0;  // compared, and within 1e-6 of the tangency
    for (int r = 0; r < 1500; ++r) {
      Primitive p = randomPrimitive(type, rng, 2, 2.0);
      const Ray ray = randomRay(p, rng);
      if (sdf(p, ray.o) < 1e-3) continue;  // an origin inside sees no silhouette
      const double target = (sign(rng) ? 1.0 : -1.0) * std::pow(10.0, decade(rng));
      const Vec3 pos0 = p.pos;
      Clearance cl = clearance(p, ray);
      for (int it = 0; it < 4; ++it) {
        // Sliding the solid by v changes sdf at the deepest point by −∇sdf·v.
        const Vec3 g = sdfGradient(p, ray.o + cl.t_min * ray.d);
        p.pos += (cl.min_sdf - target) * g / g.squaredNorm();
        cl = clearance(p, ray);
      }
      // Keep only placements that worked: the solid slid a little, ahead of the origin.
      if (!((p.pos - pos0).norm() <= 1.0) || cl.t_min <= 0.0 || !(sdf(p, ray.o) >= 1e-3) ||
          !(std::abs(cl.min_sdf - target) <= 1e-3 * std::abs(target))) {
        continue;
      }
      if (degenerate(p, ray) != nullptr || std::abs(cl.min_sdf) < kDegenerate) {
        ++skipped;
        continue;
      }
      ++compared;
      if (std::abs(cl.min_sdf) < 1e-6) ++close;
      const bool truth = cl.min_sdf < 0;
      const double t_mj = mujocoRay(p, ray.o, ray.d);
      ASSERT_EQ(t_mj >= 0, truth) << "clearance " << cl.min_sdf;
      const Scene scene({p});
      const RTCRayHit rh = intersect1(scene.get(), ray);
      ASSERT_EQ(isHit(rh), truth) << "clearance " << cl.min_sdf;
      if (truth) {
        EXPECT_LE(std::abs(rh.ray.tfar - t_mj), kHalfFloatUlp * t_mj);
      }
    }
    std::printf("%-9s grazing: compared %d (%d within 1e-6 of tangency), skipped %d\n",
                ti.name, compared, close, skipped);
    EXPECT_GT(close, 200);
  }
}

// A ray interval [tnear, tfar) is MuJoCo's answer for the ray started at o + tnear·d, cut at tfar.
TEST(EmbreePrimitives, HonoursTnearAndTfar) {
  Rng rng(7);
  std::uniform_real_distribution<double> start(0.0, 4.0);
  for (const TypeInfo& ti : kTypes) {
    const PrimitiveType type = ti.type;
    SCOPED_TRACE(ti.name);
    int compared = 0;
    for (int s = 0; s < 20; ++s) {
      const Scene scene({randomPrimitive(type, rng, 1, 2.0)});
      const Primitive& p = scene.prims()[0];
      for (int r = 0; r < 100; ++r) {
        const Ray ray = randomRay(p, rng);
        const float tnear = static_cast<float>(start(rng));
        const Ray later{ray.o + double{tnear} * ray.d, ray.d};
        if (degenerate(p, ray) != nullptr || degenerate(p, later) != nullptr) continue;
        ++compared;
        const double t_later = mujocoRay(p, later.o, later.d);
        const RTCRayHit rh = intersect1(scene.get(), ray, tnear);
        ASSERT_EQ(isHit(rh), t_later >= 0);
        if (t_later >= 0) {
          const double t_expected = tnear + t_later;
          EXPECT_LE(std::abs(rh.ray.tfar - t_expected), tTolerance(t_expected));
        }

        const double t = mujocoRay(p, ray.o, ray.d);
        if (t < 1e-3) continue;
        EXPECT_FALSE(isHit(intersect1(scene.get(), ray, 0.0f, static_cast<float>(t * 0.999))));
        EXPECT_TRUE(isHit(intersect1(scene.get(), ray, 0.0f, static_cast<float>(t * 1.001))));
      }
    }
    EXPECT_GT(compared, 1900);
  }
}

// Several overlapping primitives: the nearest surface and its geom id.
std::vector<Primitive> randomWorld(Rng& rng) {
  std::vector<Primitive> prims;
  unsigned id = 3;
  for (const TypeInfo& ti : kTypes) {
    prims.push_back(randomPrimitive(ti.type, rng, id, 3.0));
    id += 4;  // sparse ids, as MuJoCo's are once meshes and hfields sit between
  }
  for (int i = 0; i < 4; ++i) {
    prims.push_back(randomPrimitive(kTypes[1 + i % 5].type, rng, id, 3.0));
    id += 4;
  }
  return prims;
}

struct Reference {
  double t = -1;
  unsigned geom = RTC_INVALID_GEOMETRY_ID;
  bool ambiguous = false;
};

// Nearest MuJoCo hit over all primitives; ambiguous when a ray is degenerate for one of them or
// two surfaces are hit within the float resolution of t (they cross there: ties).
Reference nearestByMujoco(const std::vector<Primitive>& prims, const Ray& ray) {
  Reference ref;
  double second = kInf;
  for (const Primitive& p : prims) {
    if (degenerate(p, ray) != nullptr) ref.ambiguous = true;
    const double t = mujocoRay(p, ray.o, ray.d);
    if (t < 0) continue;
    if (ref.t < 0 || t < ref.t) {
      second = ref.t < 0 ? kInf : ref.t;
      ref.t = t;
      ref.geom = p.geom_id;
    } else {
      second = std::min(second, t);
    }
  }
  if (ref.t >= 0 && second - ref.t < tTolerance(second)) ref.ambiguous = true;
  return ref;
}

Ray rayIntoWorld(const std::vector<Primitive>& prims, Rng& rng) {
  std::uniform_int_distribution<size_t> pick(0, prims.size() - 1);
  Ray ray = randomRay(prims[pick(rng)], rng);
  return ray;
}

TEST(EmbreePrimitives, SeveralPrimitivesGiveTheNearestAndItsGeomId) {
  Rng rng(99);
  int compared = 0;
  int skipped = 0;
  int hits = 0;
  double max_dt = 0.0;
  double t_at_max = 0.0;
  for (int w = 0; w < 20; ++w) {
    const Scene scene(randomWorld(rng));
    for (int r = 0; r < 1000; ++r) {
      const Ray ray = rayIntoWorld(scene.prims(), rng);
      const Reference ref = nearestByMujoco(scene.prims(), ray);
      if (ref.ambiguous) {
        ++skipped;
        continue;
      }
      ++compared;
      const RTCRayHit rh = intersect1(scene.get(), ray);
      ASSERT_EQ(isHit(rh), ref.t >= 0) << "world " << w << " ray " << r;
      EXPECT_EQ(occluded1(scene.get(), ray), ref.t >= 0);
      if (ref.t < 0) continue;
      ++hits;
      EXPECT_EQ(rh.hit.geomID, ref.geom) << "world " << w << " ray " << r;
      const double dt = std::abs(rh.ray.tfar - ref.t);
      if (dt > max_dt) max_dt = dt, t_at_max = ref.t;
      EXPECT_LE(dt, tTolerance(ref.t));
      EXPECT_LE(dt, kHalfFloatUlp * ref.t);
    }
  }
  std::printf("several: compared %d (hits %d), skipped %d, max |dt| %.3g at t %.3g\n", compared,
              hits, skipped, max_dt, t_at_max);
  EXPECT_GT(hits, compared / 2);
  EXPECT_LT(skipped, compared / 100);
}

TEST(EmbreePrimitives, Packet16MatchesSingleRays) {
  Rng rng(5);
  std::uniform_int_distribution<int> lane_off(0, 7);
  int lanes = 0;
  for (int w = 0; w < 10; ++w) {
    const Scene scene(randomWorld(rng));
    for (int k = 0; k < 50; ++k) {
      Ray rays[16];
      alignas(64) int valid[16];
      RTCRayHit16 packet;
      for (int i = 0; i < 16; ++i) {
        rays[i] = rayIntoWorld(scene.prims(), rng);
        valid[i] = lane_off(rng) == 0 ? 0 : -1;
        const RTCRayHit one = rayHit(rays[i], 0.0f, std::numeric_limits<float>::infinity());
        packet.ray.org_x[i] = one.ray.org_x;
        packet.ray.org_y[i] = one.ray.org_y;
        packet.ray.org_z[i] = one.ray.org_z;
        packet.ray.dir_x[i] = one.ray.dir_x;
        packet.ray.dir_y[i] = one.ray.dir_y;
        packet.ray.dir_z[i] = one.ray.dir_z;
        packet.ray.tnear[i] = 0.0f;
        packet.ray.tfar[i] = one.ray.tfar;
        packet.ray.time[i] = 0.0f;
        packet.ray.mask[i] = 0xFFFFFFFFu;
        packet.ray.id[i] = static_cast<unsigned>(i);
        packet.ray.flags[i] = 0;
        packet.hit.geomID[i] = RTC_INVALID_GEOMETRY_ID;
        packet.hit.primID[i] = RTC_INVALID_GEOMETRY_ID;
        packet.hit.instID[0][i] = RTC_INVALID_GEOMETRY_ID;
      }
      RTCIntersectContext context;
      rtcInitIntersectContext(&context);
      context.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
      RTCRay16 shadow = packet.ray;
      rtcIntersect16(valid, scene.get(), &context, &packet);
      rtcOccluded16(valid, scene.get(), &context, &shadow);
      for (int i = 0; i < 16; ++i) {
        if (valid[i] == 0) {
          EXPECT_EQ(packet.ray.tfar[i], std::numeric_limits<float>::infinity());
          EXPECT_EQ(packet.hit.geomID[i], RTC_INVALID_GEOMETRY_ID);
          EXPECT_EQ(shadow.tfar[i], std::numeric_limits<float>::infinity());
          continue;
        }
        ++lanes;
        const RTCRayHit one = intersect1(scene.get(), rays[i]);
        EXPECT_EQ(shadow.tfar[i] == -std::numeric_limits<float>::infinity(), isHit(one));
        EXPECT_EQ(packet.ray.tfar[i], one.ray.tfar);
        EXPECT_EQ(packet.hit.geomID[i], one.hit.geomID);
        if (!isHit(one)) continue;
        EXPECT_EQ(packet.hit.primID[i], 0u);
        EXPECT_EQ(packet.hit.instID[0][i], RTC_INVALID_GEOMETRY_ID);
        EXPECT_EQ(packet.hit.Ng_x[i], one.hit.Ng_x);
        EXPECT_EQ(packet.hit.Ng_y[i], one.hit.Ng_y);
        EXPECT_EQ(packet.hit.Ng_z[i], one.hit.Ng_z);
      }
    }
  }
  EXPECT_GT(lanes, 6000);
}

}  // namespace
}  // namespace ambler::sim::detail
