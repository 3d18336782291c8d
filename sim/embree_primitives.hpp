#pragma once
// Analytic Embree user geometries for MuJoCo's primitive geoms (internal to sim/).
// Each intersects exactly as MuJoCo 2.2.2's mj_ray does (the same faces, the same front-face-only
// plane), computed in double precision.
#include <Eigen/Core>
#include <optional>

struct RTCDeviceTy;
struct RTCSceneTy;

namespace ambler::sim::detail {

enum class PrimitiveType { Plane, Sphere, Capsule, Ellipsoid, Cylinder, Box };

struct Primitive {
  PrimitiveType type = PrimitiveType::Sphere;
  Eigen::Vector3d pos = Eigen::Vector3d::Zero();       // geom_xpos
  Eigen::Matrix3d rot = Eigen::Matrix3d::Identity();   // geom_xmat (columns: local axes in world)
  Eigen::Vector3d size = Eigen::Vector3d::Zero();      // geom_size, as MuJoCo stores it
  unsigned geom_id = 0;
};

// Half-extent (m) an infinite plane (size <= 0) gets in Embree: rays meeting it farther out miss.
inline constexpr double kInfinitePlaneHalfExtent = 1e5;

// Attaches `p` to `scene` as a user geometry with geomID = p.geom_id and commits the geometry.
// `p` must outlive the scene (Embree keeps a pointer to it). Throws std::invalid_argument for a
// non-finite pose or a size MuJoCo would reject, std::runtime_error if Embree refuses the geometry.
void attachPrimitive(RTCDeviceTy* device, RTCSceneTy* scene, const Primitive* p);

// The nearest non-negative distance at which the double-precision ray o + t·d meets `p`, as
// mj_ray computes it; nullopt on a miss.
std::optional<double> primitiveDistance(const Primitive& p, const Eigen::Vector3d& o, const Eigen::Vector3d& d);

}  // namespace ambler::sim::detail
