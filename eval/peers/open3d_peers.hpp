#pragma once
// The registration methods a researcher would compare the paper's matchers against, from Open3D
// 0.16: point-to-plane ICP, generalized ICP, and FPFH features + Fast Global Registration refined
// by point-to-plane ICP. They take point clouds (a range image's returns, see returns()) where the
// paper's matchers take elevation maps, and return the same kind of answer: the rigid transform
// that carries scan J's believed world onto scan I's world, starting from the rover's estimate.
// Open3D stays behind this header: nothing here includes it.
//
// Determinism: registerPeer gives bit-identical results for identical inputs, call after call,
// whatever the machine's thread count (checked: 1 and 2 OpenMP threads give the same bits). Open3D sums its ICP/GICP normal equations and its correspondence
// lists in OpenMP parallel regions whose per-thread partial results are combined in whatever
// order the threads arrive, so without the measure below the last bits of T changed from run to
// run (measured: ICP, GICP and FGR each failed the bitwise test on 2 threads). registerPeer runs those
// regions on one thread (omp_set_num_threads(1) for the call, restored after); Open3D's per-point
// loops (normals, covariances, FPFH) keep their threads, since each writes only its own point.
// FGR's tuple test draws from Open3D's global random engine; it is seeded (0) before every FGR
// call. Calls are serialised by a process-wide mutex, because both the seed and the OpenMP
// setting are shared state. Tests: tests/peers/test_open3d_peers.cpp (two calls compared
// bitwise, per method).
#include <Eigen/Geometry>
#include <vector>

#include "perception/range_image.hpp"

namespace ambler::peers {

enum class PeerMethod { IcpPointToPlane, Gicp, Fgr };

// "icp_point_to_plane", "gicp", "fgr".
const char* peerMethodName(PeerMethod method);

// How the defaults were chosen. Our scans: ERIM 64 × 256 pixels over 30° × 80°, sensor ~3 m high,
// ranges 3–15 m, map cells 10 cm, the demo's maps ~10 × 11 m. The voxel is the map cell (0.10 m):
// it leaves ~7 000 of a scan's 16 384 returns (the near field thinned, the far field, rows
// 0.3–0.6 m apart, untouched). Open3D's FGR guidance keeps voxel : normal radius : FPFH radius
// near 1 : 2 : 5 (0.20 and 0.50 m), for clouds sampled about evenly. A scanner's are not: on the
// ground its rows are 0.3–0.6 m apart in the far field, so a 0.20 m ball holds one row, its points
// nearly collinear, and the normal is ill-posed. On the pipeline's noise-free Mars-like pair
// (tests/integration/test_matching.cpp, 0.3 m and 3° off) a 0.20 m radius left every peer 1.0 cm
// and 0.07° off, a 0.40 m radius 1.5–1.8 mm and 0.012–0.018° (and ICP then came home from 2 m and
// 30° too); so 0.40 m for normals, and the FPFH radius at 2.5 × that, 1.00 m, keeping the guide's
// normal : FPFH ratio. Measured on the test's noise-free ray-cast scans of
// the demo's two views (tests/peers; view J 0.36 m and 3.2° off, as the demo's initial error):
//   - the correspondence gate decides the accuracy. Pairs up to the gate include wrong ones across
//     the edges of the overlap and of rock shadows, and they bias the fit: point-to-plane ICP
//     ended 0.85 mm / 0.007° off at a 0.10 m gate, 2.5 mm / 0.015° at 0.15, 6.6 mm / 0.043° at
//     0.20, 1.9 cm / 0.13° at 0.30 (60 iterations, not converged), 6.7 cm / 0.49° at 1.0; GICP
//     0.1–0.4 mm up to 0.20, 2.1 mm at 0.30. At 0.15 a 0.5 m + 10° start still comes home. So
//     0.15 m (1.5 voxels): the Done-when's 1 cm / 0.1° with margin on noise-free scans. On noisy
//     scans (σ_ρ = kρ², 3–7 cm at 10–15 m, plus 7.6 cm range quantization) a wider gate keeps
//     more true pairs at the price of that bias; widen it there and say so.
//   - voxel 0.05 m (gate 0.15) doubled the points for the same 2.4 mm; voxel 0.20 m (gate 0.60)
//     left ICP 5.7 cm off. (On those dense synthetic scans the normal radius mattered < 1 mm.)
//   - convergence thresholds 1e-9 (Open3D's 1e-6 gave the same T to < 0.1 mm here, a few
//     iterations sooner); they cost little and make "converged" mean a still transform.
//   - FGR with use_absolute_scale = true (metres): its own answer was 6 mm / 0.02° off from the
//     paper's 2 m + 30° start at fgr_max_correspondence_m 0.025–0.10 (relative scale: 8–13 mm);
//     the point-to-plane refinement then lands where ICP lands.
struct PeerConfig {
  double voxel_m = 0.10;               // voxel-grid downsampling of both clouds
  double normal_radius_m = 0.40;       // hybrid KD search radius for normals (4 × voxel: two scan rows)
  int normal_max_nn = 30;              // ... and its neighbour cap
  double fpfh_radius_m = 1.00;         // hybrid KD search radius for FPFH (2.5 × the normal radius)
  int fpfh_max_nn = 100;               // ... and its neighbour cap
  double max_correspondence_m = 0.15;  // ICP / GICP / FGR-refinement pair gate (1.5 × voxel)
  int max_iterations = 60;             // ICP / GICP / FGR-refinement iteration cap
  double relative_fitness = 1e-9;      // ICP stops when fitness and rmse both change less
  double relative_rmse = 1e-9;
  double gicp_epsilon = 1e-3;          // GICP's covariance of a plane: diag(ε, 1, 1) in its frame
  // FGR, distances in metres (use_absolute_scale = true). Its graduated non-convexity divides the
  // robust scale μ (compared with squared distances) by fgr_division_factor every 4 of its
  // fgr_iterations while μ > fgr_max_correspondence_m; Open3D 0.16 starts μ at 1 in absolute
  // scale (it passes scale_global, 1, where the FGR paper starts at the cloud's size).
  double fgr_max_correspondence_m = 0.05;  // 0.5 × voxel, as Open3D's FGR example
  int fgr_iterations = 64;
  double fgr_division_factor = 1.4;
  double fgr_tuple_scale = 0.95;
  int fgr_max_tuples = 1000;
  int min_points = 30;  // fewer points than this in either cloud after downsampling: refused
};

struct PeerResult {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();  // maps source points onto target points
  int iterations = 0;        // ICP iterations (for FGR: the refinement's; FGR adds fgr_iterations)
  double fitness = 0;        // Open3D's: share of downsampled source points with a pair ≤ gate
  double inlier_rmse_m = 0;  // Open3D's: RMS point-to-point distance of those pairs (all methods)
  int source_points = 0;     // after downsampling
  int target_points = 0;
};

// The returns of a range image in the frame its T_WS names (world, or the rover's believed
// world): every valid pixel, row by row.
std::vector<Eigen::Vector3d> returns(const perception::RangeImage& image);

// Registers `source` (scan J's returns in J's believed world, sensor J at source_sensor_W) onto
// `target` (scan I's returns in world, sensor I at target_sensor_W), starting from the identity:
// the believed pose is the initial estimate T_0, exactly as the iconic matchers start. Both clouds
// are voxel-downsampled; normals are estimated by Open3D (hybrid KD search at normal_radius_m)
// and oriented toward each scan's sensor position.
//   IcpPointToPlane: RegistrationICP with TransformationEstimationPointToPlane.
//   Gicp: RegistrationGeneralizedICP; its per-point covariances come from those normals.
//   Fgr: FPFH features, FastGlobalRegistrationBasedOnFeatureMatching, then point-to-plane ICP from
//        FGR's answer. FGR is global: it ignores the initial estimate (the identity start) and
//        works from feature matches alone, so its answer does not depend on how wrong T_0 is.
// Throws std::invalid_argument when a cloud is empty, holds a non-finite point, or has fewer than
// config.min_points points after downsampling, or when the config is not positive where it must be.
PeerResult registerPeer(const std::vector<Eigen::Vector3d>& target,
                        const Eigen::Vector3d& target_sensor_W,
                        const std::vector<Eigen::Vector3d>& source,
                        const Eigen::Vector3d& source_sensor_W, PeerMethod method,
                        const PeerConfig& config = {});

}  // namespace ambler::peers
