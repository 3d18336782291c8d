#pragma once
// An Embree 3 scene built from a MuJoCo world's geoms, so the scanner, the ground truth and
// MuJoCo's collisions see the same surface: the hfield with MuJoCo's triangulation (and the
// walls and base of its box), every mesh, and the primitives as exact analytic user geometries.
// Embree stays behind this interface: no header of sim/ includes rtcore.h.
#include <Eigen/Geometry>
#include <limits>
#include <memory>
#include <optional>
#include <vector>

struct RTCSceneTy;

namespace ambler::sim {

class World;

// 16 rays, structure of arrays, 64-byte aligned (the layout of a coherent packet).
struct alignas(64) RayPacket16 {
  float ox[16], oy[16], oz[16];
  float dx[16], dy[16], dz[16];  // unit directions
  float tnear[16], tfar[16];
  int valid[16];                 // -1 cast, 0 skip
};

struct alignas(64) HitPacket16 {
  float t[16];        // distance along the ray (float32, as Embree found it); +inf on a miss
  int geom[16];       // MuJoCo geom id; -1 on a miss
  unsigned prim[16];  // triangle index within the geom (0 for primitives)
};

struct RayHit {
  double t = 0.0;
  int geom = -1;
};

class RayScene {
 public:
  // Builds and commits the scene. Throws std::runtime_error for a geom type it cannot represent
  // or an Embree error.
  explicit RayScene(const World& world);
  RayScene(RayScene&&) noexcept;
  RayScene& operator=(RayScene&&) noexcept;
  ~RayScene();

  // Casts one coherent packet in float32. Thread-safe.
  void intersect16(const RayPacket16& rays, HitPacket16& hits) const;

  // The distance to a hit that intersect16 found, recomputed in double precision for the double
  // ray (o, d): the plane of the hit triangle, or the primitive's analytic surface. Embree works
  // in float32 (about 1e-6 relative); this matches mj_ray to ~1e-9 m. Returns `t` if the double
  // computation disagrees (a ray grazing an edge).
  double exactDistance(int geom, unsigned prim, const Eigen::Vector3d& o, const Eigen::Vector3d& d,
                       double t) const;

  // One ray, refined to double precision; `dir` need not be unit (t is then in units of |dir|,
  // as mj_ray). Thread-safe.
  std::optional<RayHit> intersect(const Eigen::Vector3d& origin, const Eigen::Vector3d& dir,
                                  double tfar = std::numeric_limits<double>::infinity()) const;

  // Many rays at once, in parallel packets over all cores, refined to double precision. `t` gets
  // +inf on a miss.
  void intersectMany(const std::vector<Eigen::Vector3d>& origins,
                     const std::vector<Eigen::Vector3d>& dirs, std::vector<double>& t,
                     std::vector<int>* geom = nullptr) const;

  // Axis-aligned bounds of everything in the scene (world frame).
  Eigen::AlignedBox3d bounds() const;

  // The committed Embree scene, for benchmarks that cast bare Embree packets against it.
  RTCSceneTy* embreeScene() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace ambler::sim
