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

#include "perception/range_image.hpp"


namespace ambler::sim {

class World;

// 16 rays and their hits, structure of arrays, laid out exactly as Embree's RTCRayHit16 (checked
// at compile time in ray_scene.cpp), so a packet goes to Embree without a copy.
struct alignas(64) RayHitPacket16 {
  static constexpr unsigned kMiss = 0xFFFFFFFFu;
  // The rays: set origin, direction (unit), tnear and tfar before casting.
  float ox[16], oy[16], oz[16], tnear[16];
  float dx[16], dy[16], dz[16], time[16];
  float tfar[16];  // in: the farthest distance to look; out: the distance of the hit
  unsigned mask[16], id[16], flags[16];
  // The hits: geom is the MuJoCo geom id (kMiss on a miss), prim the triangle within it.
  float ng_x[16], ng_y[16], ng_z[16], u[16], v[16];
  unsigned prim[16], geom[16], inst[16];

  bool hit(int i) const { return geom[i] != kMiss; }
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

  // Casts one coherent packet in float32 (lanes with valid[i] == -1; 64-byte aligned). Thread-safe.
  void intersect16(const int* valid, RayHitPacket16& packet) const;

  // The distance to a hit that intersect16 found, recomputed in double precision for the double
  // ray (o, d): the plane of the hit triangle, or the primitive's analytic surface. Embree works
  // in float32 (about 1e-6 relative); this matches mj_ray to ~1e-9 m. Returns `t` if the double
  // computation disagrees (a ray grazing an edge).
  double exactDistance(int geom, unsigned prim, const Eigen::Vector3d& o, const Eigen::Vector3d& d,
                       double t) const;

  // exactDistance for the hits of a whole packet at once (the scanner's hot path): refines
  // packet.tfar in place; the rays share the origin `o` and have directions (dx, dy, dz)[i] in
  // double. Lanes with valid[i] == 0 or no hit are left alone.
  void refine16(const int* valid, const Eigen::Vector3d& o, const double* dx, const double* dy,
                const double* dz, RayHitPacket16& packet) const;

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

  // The benchmark's reference: every pixel ray of `image` from pose T (the image's own pose is not
  // used), cast in 4×4 tiles of bare Embree packets as the emulator casts them, over all cores;
  // only the float hit distance is kept (+inf: miss), row-major in t. No refinement, no noise.
  void referenceCast(const perception::RangeImage& image, const Eigen::Isometry3d& T, std::vector<float>& t) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace ambler::sim
