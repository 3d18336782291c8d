#include "eval/peers/open3d_peers.hpp"

#include <omp.h>

#include <cmath>
#include <memory>
#include <mutex>
#include <stdexcept>
#include <string>

#include "open3d/geometry/KDTreeSearchParam.h"
#include "open3d/geometry/PointCloud.h"
#include "open3d/pipelines/registration/FastGlobalRegistration.h"
#include "open3d/pipelines/registration/Feature.h"
#include "open3d/pipelines/registration/GeneralizedICP.h"
#include "open3d/pipelines/registration/Registration.h"
#include "open3d/pipelines/registration/TransformationEstimation.h"
#include "open3d/utility/Random.h"

namespace ambler::peers {

namespace reg = open3d::pipelines::registration;
using open3d::geometry::KDTreeSearchParamHybrid;
using open3d::geometry::PointCloud;

const char* peerMethodName(PeerMethod method) {
  switch (method) {
    case PeerMethod::IcpPointToPlane: return "icp_point_to_plane";
    case PeerMethod::Gicp: return "gicp";
    case PeerMethod::Fgr: return "fgr";
  }
  return "unknown";
}

std::vector<Eigen::Vector3d> returns(const perception::RangeImage& image) {
  std::vector<Eigen::Vector3d> points;
  points.reserve(std::size_t(image.validCount()));
  for (int r = 0; r < image.rows(); ++r)
    for (int c = 0; c < image.cols(); ++c)
      if (image.valid(r, c)) points.push_back(image.pointWorld(r, c));
  return points;
}

namespace {

// Open3D 0.16's RegistrationResult has no iteration count; RegistrationICP calls its estimation's
// ComputeTransformation once per iteration, so these count the calls.
class CountingPointToPlane : public reg::TransformationEstimationPointToPlane {
 public:
  mutable int calls = 0;
  Eigen::Matrix4d ComputeTransformation(const PointCloud& source, const PointCloud& target,
                                        const reg::CorrespondenceSet& corres) const override {
    ++calls;
    return TransformationEstimationPointToPlane::ComputeTransformation(source, target, corres);
  }
};

class CountingGicp : public reg::TransformationEstimationForGeneralizedICP {
 public:
  explicit CountingGicp(double epsilon) : TransformationEstimationForGeneralizedICP(epsilon) {}
  mutable int calls = 0;
  Eigen::Matrix4d ComputeTransformation(const PointCloud& source, const PointCloud& target,
                                        const reg::CorrespondenceSet& corres) const override {
    ++calls;
    return TransformationEstimationForGeneralizedICP::ComputeTransformation(source, target, corres);
  }
};

// One OpenMP thread for the parallel regions that take the default thread count (Open3D's
// reductions and correspondence lists, whose combining order would otherwise vary), for the
// lifetime of this object, on the calling thread; the previous setting comes back after.
class SingleThreadedOpenMP {
 public:
  SingleThreadedOpenMP() : saved_(omp_get_max_threads()) { omp_set_num_threads(1); }
  ~SingleThreadedOpenMP() { omp_set_num_threads(saved_); }
  SingleThreadedOpenMP(const SingleThreadedOpenMP&) = delete;
  SingleThreadedOpenMP& operator=(const SingleThreadedOpenMP&) = delete;

 private:
  int saved_;
};

std::mutex& peerMutex() {
  static std::mutex m;
  return m;
}

void require(bool ok, const std::string& message) {
  if (!ok) throw std::invalid_argument("registerPeer: " + message);
}

void checkCloud(const std::vector<Eigen::Vector3d>& points, const char* name) {
  require(!points.empty(), std::string(name) + " cloud is empty");
  for (const Eigen::Vector3d& p : points)
    require(p.allFinite(), std::string(name) + " cloud holds a non-finite point");
}

// Downsampled, with normals oriented toward the sensor.
std::shared_ptr<PointCloud> prepare(const std::vector<Eigen::Vector3d>& points,
                                    const Eigen::Vector3d& sensor, const PeerConfig& cfg,
                                    const char* name) {
  const PointCloud full(points);
  std::shared_ptr<PointCloud> down = full.VoxelDownSample(cfg.voxel_m);
  require(int(down->points_.size()) >= cfg.min_points,
          std::string(name) + " cloud has " + std::to_string(down->points_.size()) +
              " points after " + std::to_string(cfg.voxel_m) + " m voxel downsampling, fewer than " +
              std::to_string(cfg.min_points));
  down->EstimateNormals(KDTreeSearchParamHybrid(cfg.normal_radius_m, cfg.normal_max_nn));
  down->OrientNormalsTowardsCameraLocation(sensor);
  return down;
}

reg::ICPConvergenceCriteria criteria(const PeerConfig& cfg) {
  return reg::ICPConvergenceCriteria(cfg.relative_fitness, cfg.relative_rmse, cfg.max_iterations);
}

PeerResult fromOpen3D(const reg::RegistrationResult& r, int iterations, const PointCloud& source,
                      const PointCloud& target) {
  PeerResult out;
  out.T.matrix() = r.transformation_;
  out.iterations = iterations;
  out.fitness = r.fitness_;
  out.inlier_rmse_m = r.inlier_rmse_;
  out.source_points = int(source.points_.size());
  out.target_points = int(target.points_.size());
  return out;
}

}  // namespace

PeerResult registerPeer(const std::vector<Eigen::Vector3d>& target,
                        const Eigen::Vector3d& target_sensor_W,
                        const std::vector<Eigen::Vector3d>& source,
                        const Eigen::Vector3d& source_sensor_W, PeerMethod method,
                        const PeerConfig& cfg) {
  checkCloud(target, "target");
  checkCloud(source, "source");
  require(target_sensor_W.allFinite() && source_sensor_W.allFinite(),
          "sensor position is not finite");
  require(cfg.voxel_m > 0 && cfg.normal_radius_m > 0 && cfg.fpfh_radius_m > 0 &&
              cfg.max_correspondence_m > 0 && cfg.fgr_max_correspondence_m > 0,
          "config radii and distances must be positive");
  require(cfg.max_iterations > 0 && cfg.normal_max_nn > 0 && cfg.fpfh_max_nn > 0 &&
              cfg.fgr_iterations > 0 && cfg.fgr_max_tuples > 0 && cfg.min_points > 0,
          "config counts must be positive");

  const std::lock_guard<std::mutex> lock(peerMutex());
  const SingleThreadedOpenMP one_thread;

  const auto tgt = prepare(target, target_sensor_W, cfg, "target");
  const auto src = prepare(source, source_sensor_W, cfg, "source");

  switch (method) {
    case PeerMethod::IcpPointToPlane: {
      const CountingPointToPlane estimation;
      const auto r = reg::RegistrationICP(*src, *tgt, cfg.max_correspondence_m,
                                          Eigen::Matrix4d::Identity(), estimation, criteria(cfg));
      return fromOpen3D(r, estimation.calls, *src, *tgt);
    }
    case PeerMethod::Gicp: {
      const CountingGicp estimation(cfg.gicp_epsilon);
      const auto r = reg::RegistrationGeneralizedICP(
          *src, *tgt, cfg.max_correspondence_m, Eigen::Matrix4d::Identity(), estimation,
          criteria(cfg));
      return fromOpen3D(r, estimation.calls, *src, *tgt);
    }
    case PeerMethod::Fgr: {
      const KDTreeSearchParamHybrid fpfh_search(cfg.fpfh_radius_m, cfg.fpfh_max_nn);
      const auto src_fpfh = reg::ComputeFPFHFeature(*src, fpfh_search);
      const auto tgt_fpfh = reg::ComputeFPFHFeature(*tgt, fpfh_search);
      const reg::FastGlobalRegistrationOption option(
          cfg.fgr_division_factor, /*use_absolute_scale=*/true, /*decrease_mu=*/true,
          cfg.fgr_max_correspondence_m, cfg.fgr_iterations, cfg.fgr_tuple_scale,
          cfg.fgr_max_tuples, /*tuple_test=*/true);
      open3d::utility::random::Seed(0);
      const auto global = reg::FastGlobalRegistrationBasedOnFeatureMatching(
          *src, *tgt, *src_fpfh, *tgt_fpfh, option);
      const CountingPointToPlane estimation;
      const auto r = reg::RegistrationICP(*src, *tgt, cfg.max_correspondence_m,
                                          global.transformation_, estimation, criteria(cfg));
      return fromOpen3D(r, estimation.calls, *src, *tgt);
    }
  }
  throw std::invalid_argument("registerPeer: unknown method");
}

}  // namespace ambler::peers
