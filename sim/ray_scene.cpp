#include "sim/ray_scene.hpp"

#include <embree3/rtcore.h>
// GCC 12's AVX-512 headers initialise their "undefined" vectors from themselves, which
// -Wuninitialized reports at every use.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wuninitialized"
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#include <immintrin.h>
#pragma GCC diagnostic pop
#include <mujoco/mujoco.h>
#include <tbb/blocked_range2d.h>
#include <tbb/parallel_for.h>

#include <cstddef>
#include <cstring>
#include <deque>
#include <stdexcept>
#include <string>

#include "sim/embree_primitives.hpp"
#include "sim/erim_kernel.hpp"
#include "sim/world.hpp"

namespace ambler::sim {

namespace {

void onEmbreeError(void* user, RTCError code, const char* message) {
  auto* sink = static_cast<std::string*>(user);
  if (sink->empty()) *sink = "Embree error " + std::to_string(int(code)) + ": " + (message ? message : "");
}

Eigen::Matrix3d geomRotation(const mjData* d, int g) {
  Eigen::Matrix3d R;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) R(i, j) = d->geom_xmat[9 * g + 3 * i + j];
  return R;
}

Eigen::Vector3d geomPosition(const mjData* d, int g) {
  return {d->geom_xpos[3 * g], d->geom_xpos[3 * g + 1], d->geom_xpos[3 * g + 2]};
}

// mj_ray skips geoms that are invisible (alpha 0 in their rgba or material); so does the scene.
bool rayVisible(const mjModel* m, int g) {
  const int mat = m->geom_matid[g];
  return mat < 0 ? m->geom_rgba[4 * g + 3] != 0 : m->mat_rgba[4 * mat + 3] != 0;
}

// A triangle mesh in world coordinates, kept in double precision for refining Embree's hits.
struct MeshBuilder {
  std::vector<double> vertices;       // x, y, z
  std::vector<unsigned> triangles;    // i, j, k
  unsigned add(const Eigen::Vector3d& p) {
    vertices.insert(vertices.end(), {p.x(), p.y(), p.z()});
    return unsigned(vertices.size() / 3 - 1);
  }
  Eigen::Vector3d vertex(unsigned i) const {
    return {vertices[3 * i], vertices[3 * i + 1], vertices[3 * i + 2]};
  }
  void tri(unsigned a, unsigned b, unsigned c) { triangles.insert(triangles.end(), {a, b, c}); }
};

// MuJoCo's hfield as mj_rayHfield sees it: the top surface split along (r,c)–(r+1,c+1), the four
// walls from the edge profile down to the base (mj_ray hits the box sides below the profile and
// the base box), the bottom, and the base box's top face.
MeshBuilder hfieldMesh(const mjModel* m, const mjData* d, int g) {
  const int h = m->geom_dataid[g];
  const int nrow = m->hfield_nrow[h], ncol = m->hfield_ncol[h];
  const mjtNum* size = m->hfield_size + 4 * h;
  const float* data = m->hfield_data + m->hfield_adr[h];
  const Eigen::Matrix3d R = geomRotation(d, g);
  const Eigen::Vector3d p = geomPosition(d, g);
  const double dx = 2.0 * size[0] / (ncol - 1), dy = 2.0 * size[1] / (nrow - 1);
  auto local = [&](int r, int c, double z) {
    return Eigen::Vector3d(dx * c - size[0], dy * r - size[1], z);
  };
  MeshBuilder mb;
  mb.vertices.reserve(3 * (std::size_t(nrow) * ncol + 2 * (nrow + ncol)));
  for (int r = 0; r < nrow; ++r)
    for (int c = 0; c < ncol; ++c) mb.add(p + R * local(r, c, data[r * ncol + c] * size[2]));
  auto top = [ncol](int r, int c) { return unsigned(r * ncol + c); };
  for (int r = 0; r + 1 < nrow; ++r)
    for (int c = 0; c + 1 < ncol; ++c) {
      mb.tri(top(r, c), top(r + 1, c + 1), top(r, c + 1));
      mb.tri(top(r, c), top(r + 1, c + 1), top(r + 1, c));
    }
  // Walls: walk the border; each border sample gets a partner on the base plane z = -size[3].
  // mj_rayHfield (2.2.2) reads the profile of the two walls normal to x at data[r·nrow + c]
  // (sic: nrow, not ncol). Where that index is inside the data we reproduce it, so the walls
  // agree with mj_ray on non-square fields too; for square fields it is the true edge profile.
  auto wallHeight = [&](int r, int c, bool x_side) {
    const long quirk = long(r) * nrow + c;
    const long idx = x_side && quirk < long(nrow) * ncol ? quirk : long(r) * ncol + c;
    return data[idx] * size[2];
  };
  std::vector<std::pair<int, int>> ring;
  for (int c = 0; c < ncol; ++c) ring.emplace_back(0, c);
  for (int r = 1; r < nrow; ++r) ring.emplace_back(r, ncol - 1);
  for (int c = ncol - 2; c >= 0; --c) ring.emplace_back(nrow - 1, c);
  for (int r = nrow - 2; r >= 1; --r) ring.emplace_back(r, 0);
  std::vector<unsigned> bottom;
  for (auto [r, c] : ring) bottom.push_back(mb.add(p + R * local(r, c, -size[3])));
  for (std::size_t i = 0; i < ring.size(); ++i) {
    const std::size_t j = (i + 1) % ring.size();
    const auto [ri, ci] = ring[i];
    const auto [rj, cj] = ring[j];
    const bool x_side = ci == cj && (ci == 0 || ci == ncol - 1);
    const unsigned a = mb.add(p + R * local(ri, ci, wallHeight(ri, ci, x_side)));
    const unsigned b = mb.add(p + R * local(rj, cj, wallHeight(rj, cj, x_side)));
    mb.tri(a, b, bottom[j]);
    mb.tri(a, bottom[j], bottom[i]);
  }
  const unsigned c0 = bottom[0], c1 = bottom[ncol - 1], c2 = bottom[ncol - 1 + nrow - 1],
                 c3 = bottom[2 * (ncol - 1) + nrow - 1];
  mb.tri(c0, c1, c2);
  mb.tri(c0, c2, c3);
  // mj_ray also hits the top of the base box (z = 0, under the surface), which a ray that slipped
  // under the surface through a side reaches.
  const unsigned d0 = mb.add(p + R * local(0, 0, 0)), d1 = mb.add(p + R * local(0, ncol - 1, 0)),
                 d2 = mb.add(p + R * local(nrow - 1, ncol - 1, 0)), d3 = mb.add(p + R * local(nrow - 1, 0, 0));
  mb.tri(d0, d1, d2);
  mb.tri(d0, d2, d3);
  return mb;
}

MeshBuilder meshMesh(const mjModel* m, const mjData* d, int g) {
  const int id = m->geom_dataid[g];
  const Eigen::Matrix3d R = geomRotation(d, g);
  const Eigen::Vector3d p = geomPosition(d, g);
  MeshBuilder mb;
  const float* v = m->mesh_vert + 3 * m->mesh_vertadr[id];
  for (int i = 0; i < m->mesh_vertnum[id]; ++i)
    mb.add(p + R * Eigen::Vector3d(v[3 * i], v[3 * i + 1], v[3 * i + 2]));
  const int* f = m->mesh_face + 3 * m->mesh_faceadr[id];
  for (int i = 0; i < m->mesh_facenum[id]; ++i) mb.tri(f[3 * i], f[3 * i + 1], f[3 * i + 2]);
  return mb;
}

void attachMesh(RTCDevice device, RTCScene scene, const MeshBuilder& mb, unsigned id) {
  RTCGeometry geom = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_TRIANGLE);
  auto* v = static_cast<float*>(rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_VERTEX, 0,
                                                        RTC_FORMAT_FLOAT3, 3 * sizeof(float),
                                                        mb.vertices.size() / 3));
  auto* t = static_cast<unsigned*>(rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_INDEX, 0,
                                                           RTC_FORMAT_UINT3, 3 * sizeof(unsigned),
                                                           mb.triangles.size() / 3));
  if (!v || !t) throw std::runtime_error("Embree: could not allocate a geometry buffer");
  for (std::size_t i = 0; i < mb.vertices.size(); ++i) v[i] = float(mb.vertices[i]);
  std::memcpy(t, mb.triangles.data(), mb.triangles.size() * sizeof(unsigned));
  rtcCommitGeometry(geom);
  rtcAttachGeometryByID(scene, geom, id);
  rtcReleaseGeometry(geom);
}

detail::PrimitiveType primitiveType(int mj_type) {
  switch (mj_type) {
    case mjGEOM_PLANE: return detail::PrimitiveType::Plane;
    case mjGEOM_SPHERE: return detail::PrimitiveType::Sphere;
    case mjGEOM_CAPSULE: return detail::PrimitiveType::Capsule;
    case mjGEOM_ELLIPSOID: return detail::PrimitiveType::Ellipsoid;
    case mjGEOM_CYLINDER: return detail::PrimitiveType::Cylinder;
    case mjGEOM_BOX: return detail::PrimitiveType::Box;
    default: throw std::runtime_error("RayScene: unsupported geom type " + std::to_string(mj_type));
  }
}

// RayHitPacket16 is RTCRayHit16, field for field.
static_assert(sizeof(RayHitPacket16) == sizeof(RTCRayHit16));
static_assert(alignof(RayHitPacket16) == alignof(RTCRayHit16));
static_assert(offsetof(RayHitPacket16, tfar) == offsetof(RTCRayHit16, ray.tfar));
static_assert(offsetof(RayHitPacket16, flags) == offsetof(RTCRayHit16, ray.flags));
static_assert(offsetof(RayHitPacket16, ng_x) == offsetof(RTCRayHit16, hit.Ng_x));
static_assert(offsetof(RayHitPacket16, prim) == offsetof(RTCRayHit16, hit.primID));
static_assert(offsetof(RayHitPacket16, geom) == offsetof(RTCRayHit16, hit.geomID));
static_assert(offsetof(RayHitPacket16, inst) == offsetof(RTCRayHit16, hit.instID));
static_assert(RTC_MAX_INSTANCE_LEVEL_COUNT == 1);

}  // namespace

// The plane of one triangle for refining hits: the unit normal in float and the offset in double,
// taken through the centroid, so the plane passes exactly through a point of the triangle and
// tilts from the true one by at most a float rounding (~1e-7 rad): a few nm across a cell.
// One cache line per ray instead of an index and three vertices.
struct TrianglePlane {
  float n[3];
  double c;
};

std::vector<TrianglePlane> trianglePlanes(const MeshBuilder& mb) {
  std::vector<TrianglePlane> planes(mb.triangles.size() / 3);
  for (std::size_t i = 0; i < planes.size(); ++i) {
    const Eigen::Vector3d a = mb.vertex(mb.triangles[3 * i]), b = mb.vertex(mb.triangles[3 * i + 1]),
                          c = mb.vertex(mb.triangles[3 * i + 2]);
    const Eigen::Vector3d n = (b - a).cross(c - a).normalized();
    const Eigen::Vector3f nf = n.allFinite() ? Eigen::Vector3f(n.cast<float>()) : Eigen::Vector3f::Zero();
    planes[i] = {{nf.x(), nf.y(), nf.z()}, nf.cast<double>().dot((a + b + c) / 3.0)};
  }
  return planes;
}

struct RayScene::Impl {
  RTCDevice device = nullptr;
  RTCScene scene = nullptr;
  std::string error;
  std::deque<detail::Primitive> primitives;  // Embree keeps pointers to these
  std::vector<const detail::Primitive*> primitive_of;  // by geom id
  std::vector<std::vector<TrianglePlane>> planes_of;   // by geom id; empty for primitives
  std::vector<const TrianglePlane*> plane_table;       // planes_of[g].data(), null if none
  Eigen::AlignedBox3d bounds;

  ~Impl() {
    if (scene) rtcReleaseScene(scene);
    if (device) rtcReleaseDevice(device);
  }
  void check(const char* what) const {
    if (!error.empty()) throw std::runtime_error(std::string("RayScene: ") + what + ": " + error);
  }
};

RayScene::RayScene(const World& world) : impl_(std::make_unique<Impl>()) {
  const mjModel* m = world.model();
  const mjData* d = world.data();
  impl_->device = rtcNewDevice(nullptr);
  if (!impl_->device) throw std::runtime_error("RayScene: could not create an Embree device");
  rtcSetDeviceErrorFunction(impl_->device, onEmbreeError, &impl_->error);
  impl_->scene = rtcNewScene(impl_->device);
  rtcSetSceneBuildQuality(impl_->scene, RTC_BUILD_QUALITY_HIGH);
  // Watertight: a ray through a shared edge or vertex of the hfield (every vertical ground-truth
  // ray through a cell centre on the terrain grid) must not slip through the crack.
  rtcSetSceneFlags(impl_->scene, RTC_SCENE_FLAG_ROBUST);
  impl_->primitive_of.assign(m->ngeom, nullptr);
  impl_->planes_of.resize(m->ngeom);
  for (int g = 0; g < m->ngeom; ++g) {
    if (!rayVisible(m, g)) continue;
    const int type = m->geom_type[g];
    if (type == mjGEOM_HFIELD || type == mjGEOM_MESH) {
      const MeshBuilder mesh = type == mjGEOM_HFIELD ? hfieldMesh(m, d, g) : meshMesh(m, d, g);
      impl_->planes_of[g] = trianglePlanes(mesh);
      attachMesh(impl_->device, impl_->scene, mesh, unsigned(g));
    } else {
      detail::Primitive& p = impl_->primitives.emplace_back();
      p.type = primitiveType(type);
      p.pos = geomPosition(d, g);
      p.rot = geomRotation(d, g);
      p.size = Eigen::Vector3d(m->geom_size[3 * g], m->geom_size[3 * g + 1], m->geom_size[3 * g + 2]);
      p.geom_id = unsigned(g);
      impl_->primitive_of[g] = &p;
      detail::attachPrimitive(impl_->device, impl_->scene, &p);
    }
    impl_->check("building geometry");
  }
  for (const auto& planes : impl_->planes_of) impl_->plane_table.push_back(planes.empty() ? nullptr : planes.data());
  rtcCommitScene(impl_->scene);
  impl_->check("committing the scene");
  RTCBounds b;
  rtcGetSceneBounds(impl_->scene, &b);
  impl_->bounds = Eigen::AlignedBox3d(Eigen::Vector3d(b.lower_x, b.lower_y, b.lower_z),
                                      Eigen::Vector3d(b.upper_x, b.upper_y, b.upper_z));
}

RayScene::RayScene(RayScene&&) noexcept = default;
RayScene& RayScene::operator=(RayScene&&) noexcept = default;
RayScene::~RayScene() = default;

void RayScene::intersect16(const int* valid, RayHitPacket16& p) const {
  for (int i = 0; i < 16; ++i) {
    p.time[i] = 0.0f;
    p.mask[i] = 0xFFFFFFFFu;  // Debian's Embree has ray masks on
    p.id[i] = unsigned(i);
    p.flags[i] = 0;
    p.geom[i] = RTC_INVALID_GEOMETRY_ID;
    p.inst[i] = RTC_INVALID_GEOMETRY_ID;
  }
  RTCIntersectContext ctx;
  rtcInitIntersectContext(&ctx);
  ctx.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
  rtcIntersect16(valid, impl_->scene, &ctx, reinterpret_cast<RTCRayHit16*>(&p));
}

double RayScene::exactDistance(int geom, unsigned prim, const Eigen::Vector3d& o,
                               const Eigen::Vector3d& d, double t) const {
  if (geom < 0 || geom >= int(impl_->planes_of.size())) return t;
  if (const detail::Primitive* p = impl_->primitive_of[geom])
    return detail::primitiveDistance(*p, o, d).value_or(t);
  const auto& planes = impl_->planes_of[geom];
  if (prim >= planes.size()) return t;
  const TrianglePlane& pl = planes[prim];
  const double nx = pl.n[0], ny = pl.n[1], nz = pl.n[2];
  const double den = nx * d.x() + ny * d.y() + nz * d.z();
  if (den == 0.0) return t;
  const double exact = (pl.c - (nx * o.x() + ny * o.y() + nz * o.z())) / den;
  // A float hit is within ~1e-6 relative of the plane's; anything farther is not this plane.
  return std::abs(exact - t) <= 1e-4 * (1.0 + std::abs(t)) ? exact : t;
}

namespace {

// The plane refinement of 16 lanes in one pass (the lanes' loads and divisions overlap). Returns
// the lanes (bit i: lane i) that hit something other than a triangle, for the primitive path.
unsigned refinePlanes16(
    const TrianglePlane* const* table, const unsigned* geom, const unsigned* prim, const int* valid,
    double ox, double oy, double oz, const double* dx, const double* dy, const double* dz, float* t) {
  unsigned other = 0;
  for (int i = 0; i < 16; ++i) {
    const bool hit = valid[i] && geom[i] != RayHitPacket16::kMiss;
    const TrianglePlane* planes = hit ? table[geom[i]] : nullptr;
    other |= unsigned(hit && !planes) << i;
    if (!planes) continue;
    const TrianglePlane& pl = planes[prim[i]];
    const double nx = pl.n[0], ny = pl.n[1], nz = pl.n[2];
    const double den = nx * dx[i] + ny * dy[i] + nz * dz[i];
    const double exact = (pl.c - (nx * ox + ny * oy + nz * oz)) / den;
    const double tf = t[i];
    t[i] = std::abs(exact - tf) <= 1e-4 * (1.0 + tf) ? float(exact) : t[i];
  }
  return other;
}

// The same on AVX-512, 8 lanes at a time, operation for operation (same bits). Lanes whose geom
// has no planes are flagged for the primitive path, as above.
__attribute__((target("avx512f,avx512dq"))) unsigned refinePlanes16Avx512(
    const TrianglePlane* const* table, const unsigned* geom, const unsigned* prim, const int* valid,
    double ox, double oy, double oz, const double* dx, const double* dy, const double* dz, float* t) {
  unsigned other = 0;
  static_assert(offsetof(TrianglePlane, n) == 0 && sizeof(TrianglePlane) == 24);
  constexpr long long kOffsetC = offsetof(TrianglePlane, c);
  for (int h = 0; h < 2; ++h) {
    const __m512i g = _mm512_cvtepu32_epi64(_mm256_loadu_si256(reinterpret_cast<const __m256i*>(geom + 8 * h)));
    const __m512i v = _mm512_cvtepi32_epi64(_mm256_loadu_si256(reinterpret_cast<const __m256i*>(valid + 8 * h)));
    const __mmask8 hit = _mm512_test_epi64_mask(v, v) &
                         _mm512_cmpneq_epi64_mask(g, _mm512_set1_epi64(RayHitPacket16::kMiss));
    const __m512i planes = _mm512_mask_i64gather_epi64(_mm512_setzero_si512(), hit, g, table, 8);
    const __mmask8 tri = _mm512_test_epi64_mask(planes, planes) & hit;
    const __m512i p64 = _mm512_cvtepu32_epi64(_mm256_loadu_si256(reinterpret_cast<const __m256i*>(prim + 8 * h)));
    const __m512i addr = _mm512_add_epi64(planes, _mm512_mullo_epi64(p64, _mm512_set1_epi64(sizeof(TrianglePlane))));
    const __m256 zero = _mm256_setzero_ps();
    const __m512d nx = _mm512_cvtps_pd(_mm512_mask_i64gather_ps(zero, tri, addr, nullptr, 1));
    const __m512d ny = _mm512_cvtps_pd(_mm512_mask_i64gather_ps(zero, tri, _mm512_add_epi64(addr, _mm512_set1_epi64(4)), nullptr, 1));
    const __m512d nz = _mm512_cvtps_pd(_mm512_mask_i64gather_ps(zero, tri, _mm512_add_epi64(addr, _mm512_set1_epi64(8)), nullptr, 1));
    const __m512d c = _mm512_mask_i64gather_pd(_mm512_setzero_pd(), tri, _mm512_add_epi64(addr, _mm512_set1_epi64(kOffsetC)), nullptr, 1);
    const __m512d den = _mm512_add_pd(_mm512_add_pd(_mm512_mul_pd(nx, _mm512_loadu_pd(dx + 8 * h)),
                                                    _mm512_mul_pd(ny, _mm512_loadu_pd(dy + 8 * h))),
                                      _mm512_mul_pd(nz, _mm512_loadu_pd(dz + 8 * h)));
    const __m512d dot_o = _mm512_add_pd(_mm512_add_pd(_mm512_mul_pd(nx, _mm512_set1_pd(ox)), _mm512_mul_pd(ny, _mm512_set1_pd(oy))),
                                        _mm512_mul_pd(nz, _mm512_set1_pd(oz)));
    const __m512d exact = _mm512_div_pd(_mm512_sub_pd(c, dot_o), den);
    const __m512d tf = _mm512_cvtps_pd(_mm256_loadu_ps(t + 8 * h));
    const __mmask8 close = _mm512_cmp_pd_mask(_mm512_abs_pd(_mm512_sub_pd(exact, tf)),
                                              _mm512_mul_pd(_mm512_set1_pd(1e-4), _mm512_add_pd(_mm512_set1_pd(1.0), tf)),
                                              _CMP_LE_OQ) & tri;
    // A lane that keeps its float distance converts back to exactly the same float.
    _mm256_storeu_ps(t + 8 * h, _mm512_cvtpd_ps(_mm512_mask_blend_pd(close, tf, exact)));
    other |= unsigned(hit & ~tri) << 8 * h;
  }
  return other;
}

}  // namespace

void RayScene::refine16(const int* valid, const Eigen::Vector3d& o, const double* dx, const double* dy,
                        const double* dz, RayHitPacket16& p) const {
  const TrianglePlane* const* table = impl_->plane_table.data();
  unsigned other = kernel::activeIsa() == kernel::Isa::Avx512
                       ? refinePlanes16Avx512(table, p.geom, p.prim, valid, o.x(), o.y(), o.z(), dx, dy, dz, p.tfar)
                       : refinePlanes16(table, p.geom, p.prim, valid, o.x(), o.y(), o.z(), dx, dy, dz, p.tfar);
  for (; other; other &= other - 1) {
    const int i = __builtin_ctz(other);
    p.tfar[i] = float(exactDistance(int(p.geom[i]), p.prim[i], o, {dx[i], dy[i], dz[i]}, p.tfar[i]));
  }
}

std::optional<RayHit> RayScene::intersect(const Eigen::Vector3d& origin, const Eigen::Vector3d& dir,
                                          double tfar) const {
  RTCRayHit rh{};
  rh.ray.org_x = float(origin.x());
  rh.ray.org_y = float(origin.y());
  rh.ray.org_z = float(origin.z());
  rh.ray.dir_x = float(dir.x());
  rh.ray.dir_y = float(dir.y());
  rh.ray.dir_z = float(dir.z());
  rh.ray.tnear = 0.0f;
  rh.ray.tfar = tfar < 3.0e38 ? float(tfar) : std::numeric_limits<float>::infinity();
  rh.ray.mask = 0xFFFFFFFFu;
  rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
  rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
  RTCIntersectContext ctx;
  rtcInitIntersectContext(&ctx);
  rtcIntersect1(impl_->scene, &ctx, &rh);
  if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) return std::nullopt;
  const int geom = int(rh.hit.geomID);
  return RayHit{exactDistance(geom, rh.hit.primID, origin, dir, rh.ray.tfar), geom};
}

void RayScene::intersectMany(const std::vector<Eigen::Vector3d>& origins,
                             const std::vector<Eigen::Vector3d>& dirs, std::vector<double>& t,
                             std::vector<int>* geom) const {
  if (origins.size() != dirs.size())
    throw std::invalid_argument("RayScene::intersectMany: origins and dirs differ in size");
  const std::size_t n = origins.size();
  t.assign(n, std::numeric_limits<double>::infinity());
  if (geom) geom->assign(n, -1);
  const std::size_t packets = (n + 15) / 16;
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, packets, 16), [&](const auto& range) {
    RayHitPacket16 p;
    alignas(64) int valid[16];
    for (std::size_t q = range.begin(); q != range.end(); ++q) {
      for (int i = 0; i < 16; ++i) {
        const std::size_t k = std::min(q * 16 + i, n - 1);
        p.ox[i] = float(origins[k].x());
        p.oy[i] = float(origins[k].y());
        p.oz[i] = float(origins[k].z());
        p.dx[i] = float(dirs[k].x());
        p.dy[i] = float(dirs[k].y());
        p.dz[i] = float(dirs[k].z());
        p.tnear[i] = 0.0f;
        p.tfar[i] = std::numeric_limits<float>::infinity();
        valid[i] = q * 16 + i < n ? -1 : 0;
      }
      intersect16(valid, p);
      for (int i = 0; i < 16 && q * 16 + i < n; ++i) {
        const std::size_t k = q * 16 + i;
        if (!p.hit(i)) continue;
        t[k] = exactDistance(int(p.geom[i]), p.prim[i], origins[k], dirs[k], p.tfar[i]);
        if (geom) (*geom)[k] = int(p.geom[i]);
      }
    }
  });
}

Eigen::AlignedBox3d RayScene::bounds() const { return impl_->bounds; }

void RayScene::referenceCast(const perception::RangeImage& img, const Eigen::Isometry3d& T,
                             std::vector<float>& t_out) const {
  RTCScene scene = impl_->scene;
  const int rows = img.rows(), cols = img.cols();
  std::vector<double> sp(rows), cp(rows), st(cols), ct(cols);
  for (int r = 0; r < rows; ++r) sp[r] = std::sin(img.phi[r]), cp[r] = std::cos(img.phi[r]);
  for (int c = 0; c < cols; ++c) st[c] = std::sin(img.theta[c]), ct[c] = std::cos(img.theta[c]);
  const Eigen::Matrix3d R = T.linear();
  const Eigen::Vector3d o = T.translation();
  t_out.resize(std::size_t(rows) * cols);
  tbb::parallel_for(tbb::blocked_range2d<int>(0, (rows + 3) / 4, 0, (cols + 3) / 4), [&](const auto& range) {
    RTCRayHit16 rh;
    alignas(64) int valid[16];
    RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    ctx.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
    for (int tr = range.rows().begin(); tr != range.rows().end(); ++tr)
      for (int tc = range.cols().begin(); tc != range.cols().end(); ++tc) {
        for (int i = 0; i < 16; ++i) {
          const int r = std::min(tr * 4 + i / 4, rows - 1), c = std::min(tc * 4 + i % 4, cols - 1);
          valid[i] = (tr * 4 + i / 4 < rows && tc * 4 + i % 4 < cols) ? -1 : 0;
          const Eigen::Vector3d d = R * Eigen::Vector3d(st[c], cp[r] * ct[c], sp[r] * ct[c]);
          rh.ray.org_x[i] = float(o.x()), rh.ray.org_y[i] = float(o.y()), rh.ray.org_z[i] = float(o.z());
          rh.ray.dir_x[i] = float(d.x()), rh.ray.dir_y[i] = float(d.y()), rh.ray.dir_z[i] = float(d.z());
          rh.ray.tnear[i] = 0.0f;
          rh.ray.tfar[i] = std::numeric_limits<float>::infinity();
          rh.ray.mask[i] = 0xFFFFFFFFu;
          rh.ray.time[i] = 0.0f;
          rh.ray.flags[i] = 0;
          rh.hit.geomID[i] = RTC_INVALID_GEOMETRY_ID;
          rh.hit.instID[0][i] = RTC_INVALID_GEOMETRY_ID;
        }
        rtcIntersect16(valid, scene, &ctx, &rh);
        for (int i = 0; i < 16; ++i)
          if (valid[i]) t_out[std::size_t(tr * 4 + i / 4) * cols + tc * 4 + i % 4] = rh.ray.tfar[i];
      }
  });
}


}  // namespace ambler::sim
