// The Embree peer's scene (EmbreeScene::Impl): lancer's scene in Embree 3, with planes and
// spheres as user geometry or Embree's own, shapes as peer_embree_shapes.hpp makes them, and its
// camera rays traced by packets, rows, tiles and streams. Included by peer_embree.cpp alone, inside
// LANCER_HAVE_EMBREE.
#pragma once

#include <embree3/rtcore.h>
#include <pmmintrin.h>
#include <xmmintrin.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <type_traits>

#include "lancer/formulas.hpp"
#include "lancer/prepared.hpp"
#include "lancer/shapes.hpp"
#include "lancer/tiles.hpp"
#include "peer_embree_shapes.hpp"
#include "peer_embree_spheres.hpp"

namespace lancer::peer {

namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();
using Clock = std::chrono::steady_clock;

// The packet calls of one width, over Embree's own packet types. Every Embree ray type is laid
// out as RTCRayHitN with N = its width (N = 1 included), so lanes are reached through the
// RTCRayN_* / RTCHitN_* accessors whatever the width.
template <int W>
struct Api;
template <>
struct Api<1> {
  using RayHit = RTCRayHit;
  using Ray = RTCRay;
  static void intersect(const int* valid, RTCScene s, RTCIntersectContext* c, RayHit& r) {
    if (valid[0]) rtcIntersect1(s, c, &r);
  }
  static void occluded(const int* valid, RTCScene s, RTCIntersectContext* c, Ray& r) {
    if (valid[0]) rtcOccluded1(s, c, &r);
  }
};
// Widths 4, 8 and 16 differ only in their types and entry points.
template <class RayHitT, class RayT,
          void (*Intersect)(const int*, RTCScene, RTCIntersectContext*, RayHitT*),
          void (*Occluded)(const int*, RTCScene, RTCIntersectContext*, RayT*)>
struct PacketApi {
  using RayHit = RayHitT;
  using Ray = RayT;
  static void intersect(const int* v, RTCScene s, RTCIntersectContext* c, RayHit& r) {
    Intersect(v, s, c, &r);
  }
  static void occluded(const int* v, RTCScene s, RTCIntersectContext* c, Ray& r) {
    Occluded(v, s, c, &r);
  }
};
template <>
struct Api<4> : PacketApi<RTCRayHit4, RTCRay4, rtcIntersect4, rtcOccluded4> {};
template <>
struct Api<8> : PacketApi<RTCRayHit8, RTCRay8, rtcIntersect8, rtcOccluded8> {};
template <>
struct Api<16> : PacketApi<RTCRayHit16, RTCRay16, rtcIntersect16, rtcOccluded16> {};

// Sets lane k of a ray (of an RTCRayN laid out for W lanes).
template <int W>
inline void set_ray(RTCRayN* r, int k, const Vec3<float>& o, const Vec3<float>& d, float tnear,
                    float tfar) {
  RTCRayN_org_x(r, W, k) = o.x;
  RTCRayN_org_y(r, W, k) = o.y;
  RTCRayN_org_z(r, W, k) = o.z;
  RTCRayN_tnear(r, W, k) = tnear;
  RTCRayN_dir_x(r, W, k) = d.x;
  RTCRayN_dir_y(r, W, k) = d.y;
  RTCRayN_dir_z(r, W, k) = d.z;
  RTCRayN_time(r, W, k) = 0.0f;
  RTCRayN_tfar(r, W, k) = tfar;
  RTCRayN_mask(r, W, k) = ~0u;
  RTCRayN_id(r, W, k) = unsigned(k);
  RTCRayN_flags(r, W, k) = 0;
}

template <int W>
inline void clear_hit(RTCHitN* h, int k) {
  RTCHitN_geomID(h, W, k) = RTC_INVALID_GEOMETRY_ID;
  RTCHitN_primID(h, W, k) = RTC_INVALID_GEOMETRY_ID;
  RTCHitN_instID(h, W, k, 0) = RTC_INVALID_GEOMETRY_ID;
}

// Embree asks for flush-to-zero and denormals-are-zero on every thread that calls it (it warns
// of a "severe performance impact" otherwise). They change float results, so they are set only
// around the peer's own work and the caller's MXCSR is restored after: lancer's kernels never
// run under them.
class FlushDenormals {
 public:
  FlushDenormals() : saved_(_mm_getcsr()) {
    _MM_SET_FLUSH_ZERO_MODE(_MM_FLUSH_ZERO_ON);
    _MM_SET_DENORMALS_ZERO_MODE(_MM_DENORMALS_ZERO_ON);
  }
  ~FlushDenormals() { _mm_setcsr(saved_); }
  FlushDenormals(const FlushDenormals&) = delete;
  FlushDenormals& operator=(const FlushDenormals&) = delete;

 private:
  unsigned saved_;
};

// Tiles as lancer's render splits them (lancer/tiles.hpp), each under Embree's flush-to-zero
// and denormals-are-zero, restored afterwards so that lancer's kernels never run with them.
template <class Body>
RayCounts embree_tiles(int ny, int threads, Body body) {
  return run_tiles(ny, threads, [&](int r0, int r1, RayCounts& counts) {
    const FlushDenormals ftz_daz;
    body(r0, r1, counts);
  });
}

// The scene's size: the largest distance from the camera's position (the origin of the
// prepared, camera-relative coordinates) of anything a ray starts from or hits at a finite
// place, at least 1.
float scene_size(const Scene& scene) {
  const CameraSpec& c = scene.camera;
  double r = 1;
  auto grow = [&](const Vec3<double>& p, double pad) {
    r = std::max(r, length(p - c.position) + pad);
  };
  // Orthographic rays start anywhere on the screen rectangle about the camera's position.
  grow(c.position, std::hypot(std::max(std::abs(c.xmin), std::abs(c.xmax)),
                              std::max(std::abs(c.ymin), std::abs(c.ymax))));
  for (const Light& l : scene.lights) grow(l.position, 0);
  for (const Sphere& s : scene.spheres) grow(s.center, s.radius);
  for (const Plane& p : scene.planes) grow(p.point, 0);
  return float(r);
}

// Two unit vectors spanning the plane of unit normal n.
void plane_basis(const Vec3<double>& n, Vec3<double>& t1, Vec3<double>& t2) {
  const Vec3<double> axis = std::abs(n.x) < 0.5 ? Vec3<double>{1, 0, 0} : Vec3<double>{0, 1, 0};
  t1 = normalize(cross(n, axis));
  t2 = cross(n, t1);
}

}  // namespace

struct EmbreeScene::Impl {
  PreparedScene<float> s;
  PlaneMode mode = PlaneMode::user;
  float plane_half = 0;  // half-size of the square standing for each plane
  RTCDevice device = nullptr;
  RTCScene scene = nullptr;
  unsigned sphere_geom = RTC_INVALID_GEOMETRY_ID, plane_geom = RTC_INVALID_GEOMETRY_ID;
  EmbreeShapes shapes;
  std::vector<GeomIds> geoms;  // by geometry id
  EmbreeConfig config;
  double build_seconds = 0;

  ~Impl() {
    if (scene) rtcReleaseScene(scene);
    if (device) rtcReleaseDevice(device);
  }

  void check(const char* what) const {
    const RTCError e = rtcGetDeviceError(device);
    if (e != RTC_ERROR_NONE)
      throw std::runtime_error(std::string("embree: ") + what + " failed (error " +
                               std::to_string(int(e)) + ")");
  }

  // lancer's object id of an Embree hit, -1 for none.
  int object_id(unsigned geom, unsigned prim) const {
    if (geom == RTC_INVALID_GEOMETRY_ID) return -1;
    return geoms[geom].of(prim);
  }

  // ---- planes as user geometry: lancer's formula, exactly --------------------------------
  static void plane_bounds(const RTCBoundsFunctionArguments* args) {
    const Impl& im = *static_cast<const Impl*>(args->geometryUserPtr);
    const PreparedScene<float>& s = im.s;
    const unsigned k = args->primID;
    const float n[3] = {s.planes.nx[k], s.planes.ny[k], s.planes.nz[k]};
    const float q[3] = {s.planes.px[k], s.planes.py[k], s.planes.pz[k]};
    float lo[3], hi[3];
    for (int a = 0; a < 3; ++a) {
      // A disc of radius R in the plane reaches R * sqrt(1 - n_a^2) along axis a; padded so
      // that an axis-aligned plane's box has some thickness to round into.
      const float reach = im.plane_half * std::sqrt(std::max(0.0f, 1.0f - n[a] * n[a]));
      const float pad = 1e-5f * (std::abs(q[a]) + 1.0f) + 1e-6f * reach;
      lo[a] = q[a] - reach - pad;
      hi[a] = q[a] + reach + pad;
    }
    RTCBounds* b = args->bounds_o;
    b->lower_x = lo[0], b->lower_y = lo[1], b->lower_z = lo[2];
    b->upper_x = hi[0], b->upper_y = hi[1], b->upper_z = hi[2];
  }

  // Whether ray i hits plane k within (tnear, tfar), by lancer's formula; t is set when it does.
  static bool plane_t(const PreparedScene<float>& s, unsigned k, RTCRayN* ray, unsigned N,
                      unsigned i, float& t) {
    const Vec3<float> n{s.planes.nx[k], s.planes.ny[k], s.planes.nz[k]};
    const Vec3<float> o{RTCRayN_org_x(ray, N, i), RTCRayN_org_y(ray, N, i),
                        RTCRayN_org_z(ray, N, i)};
    const Vec3<float> d{RTCRayN_dir_x(ray, N, i), RTCRayN_dir_y(ray, N, i),
                        RTCRayN_dir_z(ray, N, i)};
    const float denom = dot(d, n);
    if (denom == 0.0f) return false;
    t = dot(Vec3<float>{s.planes.px[k], s.planes.py[k], s.planes.pz[k]} - o, n) / denom;
    return t > RTCRayN_tnear(ray, N, i) && t < RTCRayN_tfar(ray, N, i);
  }

  static Vec3<float> plane_normal(const PreparedScene<float>& s, unsigned k) {
    return {s.planes.nx[k], s.planes.ny[k], s.planes.nz[k]};
  }

  // ---- spheres as user geometry: one callback for a whole packet of N rays ---------------
  // SPHERE_POINT leaves are tested one lane at a time in Embree 3.13; this callback gets the N
  // rays of a packet against one sphere in one call, a loop the compiler vectorises.
  static void sphere_bounds(const RTCBoundsFunctionArguments* args) {
    const PreparedScene<float>& s = static_cast<const Impl*>(args->geometryUserPtr)->s;
    const unsigned k = args->primID;
    const float r = s.spheres.r[k];
    RTCBounds* b = args->bounds_o;
    b->lower_x = s.spheres.cx[k] - r, b->lower_y = s.spheres.cy[k] - r;
    b->lower_z = s.spheres.cz[k] - r;
    b->upper_x = s.spheres.cx[k] + r, b->upper_y = s.spheres.cy[k] + r;
    b->upper_z = s.spheres.cz[k] + r;
  }

  // ---- the planes' user-geometry callbacks, over their hit test and normal -------------
  using HitTest = bool (*)(const PreparedScene<float>&, unsigned, RTCRayN*, unsigned, unsigned,
                           float&);
  using Normal = Vec3<float> (*)(const PreparedScene<float>&, unsigned);
  template <HitTest Test, Normal Ng>
  static void intersect_n(const RTCIntersectFunctionNArguments* args) {
    const Impl& im = *static_cast<const Impl*>(args->geometryUserPtr);
    const unsigned N = args->N, k = args->primID;
    RTCRayN* ray = RTCRayHitN_RayN(args->rayhit, N);
    RTCHitN* hit = RTCRayHitN_HitN(args->rayhit, N);
    for (unsigned i = 0; i < N; ++i) {
      float t;
      if (args->valid[i] != -1 || !Test(im.s, k, ray, N, i, t)) continue;
      const Vec3<float> n = Ng(im.s, k);
      RTCRayN_tfar(ray, N, i) = t;
      RTCHitN_Ng_x(hit, N, i) = n.x;
      RTCHitN_Ng_y(hit, N, i) = n.y;
      RTCHitN_Ng_z(hit, N, i) = n.z;
      RTCHitN_u(hit, N, i) = 0.0f;
      RTCHitN_v(hit, N, i) = 0.0f;
      RTCHitN_primID(hit, N, i) = k;
      RTCHitN_geomID(hit, N, i) = args->geomID;
      RTCHitN_instID(hit, N, i, 0) = args->context->instID[0];
    }
  }
  template <HitTest Test>
  static void occluded_n(const RTCOccludedFunctionNArguments* args) {
    const Impl& im = *static_cast<const Impl*>(args->geometryUserPtr);
    const unsigned N = args->N, k = args->primID;
    for (unsigned i = 0; i < N; ++i) {
      float t;
      if (args->valid[i] != -1 || !Test(im.s, k, args->ray, N, i, t)) continue;
      RTCRayN_tfar(args->ray, N, i) = -kInf;
    }
  }
  // A user geometry of count primitives with the given callbacks, attached to the scene.
  unsigned attach_user(int count, RTCBoundsFunction bounds, RTCIntersectFunctionN intersect,
                       RTCOccludedFunctionN occluded) {
    RTCGeometry g = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_USER);
    rtcSetGeometryUserPrimitiveCount(g, unsigned(count));
    rtcSetGeometryUserData(g, this);
    rtcSetGeometryBoundsFunction(g, bounds, this);
    rtcSetGeometryIntersectFunction(g, intersect);
    rtcSetGeometryOccludedFunction(g, occluded);
    if (config.high_quality) rtcSetGeometryBuildQuality(g, RTC_BUILD_QUALITY_HIGH);
    rtcCommitGeometry(g);
    const unsigned id = rtcAttachGeometry(scene, g);
    rtcReleaseGeometry(g);
    return id;
  }

  void build(const Scene& src, const std::string& device_config) {
    s = prepare<float>(src);
    shapes.set(s.shapes.get());
    plane_half = kPlaneExtent * shapes.size(scene_size(src));
    std::string cfg = device_config;
    if (cfg.empty())
      if (const char* env = std::getenv("LANCER_EMBREE_CONFIG")) cfg = env;
    check_embree_config(cfg, device_config.empty() ? "LANCER_EMBREE_CONFIG" : "Embree config");
    device = rtcNewDevice(cfg.empty() ? nullptr : cfg.c_str());
    if (!device)
      throw std::runtime_error("embree: rtcNewDevice failed (error " +
                               std::to_string(int(rtcGetDeviceError(nullptr))) + ")");
    // Build time: the geometry and the BVH, not the device (its threads start once per process).
    // The faster of two builds, the first released: the second reuses the memory the first
    // touched (Embree's allocator and the C library keep some), as a process that has built
    // before would. A fresh process's first build pays its page faults (docs/accel.md,
    // fourteenth round): the peer at its best.
    build_seconds = make_scene();
    rtcReleaseScene(scene);
    scene = nullptr;
    build_seconds = std::min(build_seconds, make_scene());
  }

  // The scene of the spheres, planes and shapes, committed: returns the seconds it took.
  double make_scene() {
    const auto start = Clock::now();
    sphere_geom = plane_geom = RTC_INVALID_GEOMETRY_ID;
    geoms.clear();
    scene = rtcNewScene(device);
    check("rtcNewScene");
    rtcSetSceneBuildQuality(
        scene, config.high_quality ? RTC_BUILD_QUALITY_HIGH : RTC_BUILD_QUALITY_MEDIUM);
    rtcSetSceneFlags(scene, RTCSceneFlags((config.compact ? RTC_SCENE_FLAG_COMPACT : 0) |
                                          (config.robust ? RTC_SCENE_FLAG_ROBUST : 0)));

    if (s.num_spheres > 0 && config.user_spheres) {
      sphere_geom = attach_user(s.num_spheres, &Impl::sphere_bounds, &UserSpheres<Impl>::intersect,
                                &UserSpheres<Impl>::occluded);
      check("spheres");
    } else if (s.num_spheres > 0) {
      RTCGeometry g = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_SPHERE_POINT);
      auto* v = static_cast<float*>(rtcSetNewGeometryBuffer(
          g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT4, 4 * sizeof(float), s.num_spheres));
      check("sphere vertex buffer");
      for (int i = 0; i < s.num_spheres; ++i) {
        v[4 * i + 0] = s.spheres.cx[i];
        v[4 * i + 1] = s.spheres.cy[i];
        v[4 * i + 2] = s.spheres.cz[i];
        v[4 * i + 3] = s.spheres.r[i];
      }
      if (config.high_quality) rtcSetGeometryBuildQuality(g, RTC_BUILD_QUALITY_HIGH);
      rtcCommitGeometry(g);
      sphere_geom = rtcAttachGeometry(scene, g);
      rtcReleaseGeometry(g);
      check("spheres");
    }
    if (sphere_geom != RTC_INVALID_GEOMETRY_ID) {
      geoms.resize(std::max<std::size_t>(geoms.size(), sphere_geom + 1));
      geoms[sphere_geom] = {0, 1, nullptr};
    }
    if (s.num_planes > 0) {
      if (mode == PlaneMode::user) {
        plane_geom = attach_user(s.num_planes, &Impl::plane_bounds,
                                 &Impl::intersect_n<&Impl::plane_t, &Impl::plane_normal>,
                                 &Impl::occluded_n<&Impl::plane_t>);
      } else {
        // A square of half-size plane_half about the plane's point: rays from within the scene
        // miss it only when they run within about 1/kPlaneExtent radian of parallel to it.
        RTCGeometry g = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_QUAD);
        auto* v = static_cast<float*>(rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0,
                                                              RTC_FORMAT_FLOAT3, 3 * sizeof(float),
                                                              4 * std::size_t(s.num_planes)));
        auto* idx = static_cast<unsigned*>(
            rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT4,
                                    4 * sizeof(unsigned), std::size_t(s.num_planes)));
        check("plane buffers");
        for (int k = 0; k < s.num_planes; ++k) {
          const Vec3<double> n{s.planes.nx[k], s.planes.ny[k], s.planes.nz[k]};
          const Vec3<double> q{s.planes.px[k], s.planes.py[k], s.planes.pz[k]};
          Vec3<double> t1, t2;
          plane_basis(n, t1, t2);
          const double h = plane_half;
          const Vec3<double> corners[4] = {q - t1 * h - t2 * h, q + t1 * h - t2 * h,
                                           q + t1 * h + t2 * h, q - t1 * h + t2 * h};
          for (int c = 0; c < 4; ++c) {
            v[3 * (4 * k + c) + 0] = float(corners[c].x);
            v[3 * (4 * k + c) + 1] = float(corners[c].y);
            v[3 * (4 * k + c) + 2] = float(corners[c].z);
            idx[4 * k + c] = unsigned(4 * k + c);
          }
        }
        rtcCommitGeometry(g);
        plane_geom = rtcAttachGeometry(scene, g);
        rtcReleaseGeometry(g);
      }
      check("planes");
      geoms.resize(std::max<std::size_t>(geoms.size(), plane_geom + 1));
      geoms[plane_geom] = {s.num_spheres, 1, nullptr};
    }
    shapes.attach(device, scene, config, geoms);
    check("shapes");
    rtcCommitScene(scene);
    check("rtcCommitScene");
    return std::chrono::duration<double>(Clock::now() - start).count();
  }

  // ---- camera rays -----------------------------------------------------------------------
  // Lane k of packet (i0, j, a, b): lancer's camera ray from its screen tables.
  void camera_ray_of(int i, int j, int a, int b, Vec3<float>& o, Vec3<float>& d) const {
    const PreparedCamera<float>& cam = s.camera;
    camera_ray(cam, cam.screen_x[std::size_t(a) * cam.nx + i],
               cam.screen_y[std::size_t(b) * cam.ny + j], o, d);
  }

  // Fills a camera packet; lanes >= `lanes` get a copy of lane 0 and valid 0.
  template <int W>
  void camera_packet(typename Api<W>::RayHit& rh, int* valid, int i0, int j, int a, int b,
                     int lanes) const {
    RTCRayHitN* rhn = reinterpret_cast<RTCRayHitN*>(&rh);
    RTCRayN* ray = RTCRayHitN_RayN(rhn, W);
    RTCHitN* hit = RTCRayHitN_HitN(rhn, W);
    Vec3<float> o, d, o0, d0;
    for (int k = 0; k < W; ++k) {
      if (k < lanes) camera_ray_of(i0 + k, j, a, b, o, d);
      if (k == 0) o0 = o, d0 = d;
      valid[k] = k < lanes ? -1 : 0;
      set_ray<W>(ray, k, k < lanes ? o : o0, k < lanes ? d : d0, s.epsilon, kInf);
      clear_hit<W>(hit, k);
    }
  }

  // rtcIntersect1M streams: the camera rays of a block of 4 rows by 16 columns, ordered as four
  // 4x4 squares, in one call with the coherent flag; Embree regroups the stream into its own
  // packets (the "rtcIntersect1M streams").
  void primary_streams(float* t_out, int r0, int r1, RayCounts& counts) const {
    const PreparedCamera<float>& cam = s.camera;
    constexpr int kBlock = 64;
    alignas(64) RTCRayHit rh[kBlock];
    int px[kBlock], py[kBlock];
    float sum[kBlock];
    RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    ctx.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
    for (int j0 = r0; j0 < r1; j0 += 4)
      for (int i0 = 0; i0 < cam.nx; i0 += 16) {
        int n = 0;
        for (int q = 0; q < 4; ++q)
          for (int k = 0; k < 16; ++k) {
            const int i = i0 + 4 * q + k % 4, j = j0 + k / 4;
            if (i < cam.nx && j < r1) px[n] = i, py[n] = j, sum[n] = 0.0f, ++n;
          }
        for (int b = 0; b < cam.samples; ++b)
          for (int a = 0; a < cam.samples; ++a) {
            for (int m = 0; m < n; ++m) {
              Vec3<float> o, d;
              camera_ray_of(px[m], py[m], a, b, o, d);
              set_ray<1>(reinterpret_cast<RTCRayN*>(&rh[m].ray), 0, o, d, s.epsilon, kInf);
              clear_hit<1>(reinterpret_cast<RTCHitN*>(&rh[m].hit), 0);
            }
            counts.camera += unsigned(n);
            rtcIntersect1M(scene, &ctx, rh, unsigned(n), sizeof(RTCRayHit));
            for (int m = 0; m < n; ++m) sum[m] = sum[m] + rh[m].ray.tfar;
          }
        for (int m = 0; m < n; ++m) t_out[std::size_t(py[m]) * cam.nx + px[m]] = sum[m];
      }
  }

  template <int W>
  void primary_rows(float* t_out, int r0, int r1, RayCounts& counts) const {
    const PreparedCamera<float>& cam = s.camera;
    alignas(64) typename Api<W>::RayHit rh;
    alignas(64) int valid[W];
    RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    ctx.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
    RTCRayN* ray = RTCRayHitN_RayN(reinterpret_cast<RTCRayHitN*>(&rh), W);
    float sum[W];
    for (int j = r0; j < r1; ++j) {
      for (int i0 = 0; i0 < cam.nx; i0 += W) {
        const int lanes = std::min(W, cam.nx - i0);
        for (int k = 0; k < W; ++k) sum[k] = 0.0f;
        for (int b = 0; b < cam.samples; ++b)
          for (int a = 0; a < cam.samples; ++a) {
            camera_packet<W>(rh, valid, i0, j, a, b, lanes);
            counts.camera += lanes;
            Api<W>::intersect(valid, scene, &ctx, rh);
            for (int k = 0; k < lanes; ++k) sum[k] = sum[k] + RTCRayN_tfar(ray, W, k);
          }
        float* row = t_out + std::size_t(j) * cam.nx + i0;
        for (int k = 0; k < lanes; ++k) row[k] = sum[k];
      }
    }
  }

  // Packets of W as squares, as lancer's camera packets (16: 4x4, 8: 4x2, 4: 2x2 pixels; rows
  // r0..r1 come in tiles of 8 rows): rays of a square diverge less than those of a row, so
  // Embree's packet traversal keeps more lanes together.
  template <int W>
  void primary_tiles(float* t_out, int r0, int r1, RayCounts& counts) const {
    constexpr int kTw = W >= 8 ? 4 : 2, kTh = W / kTw;
    const PreparedCamera<float>& cam = s.camera;
    alignas(64) typename Api<W>::RayHit rh;
    alignas(64) int valid[W];
    RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    ctx.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
    RTCRayHitN* rhn = reinterpret_cast<RTCRayHitN*>(&rh);
    RTCRayN* ray = RTCRayHitN_RayN(rhn, W);
    RTCHitN* hit = RTCRayHitN_HitN(rhn, W);
    float sum[W];
    for (int j0 = r0; j0 < r1; j0 += kTh)
      for (int i0 = 0; i0 < cam.nx; i0 += kTw) {
        for (float& v : sum) v = 0.0f;
        for (int b = 0; b < cam.samples; ++b)
          for (int a = 0; a < cam.samples; ++a) {
            Vec3<float> o, d, o0, d0;
            int lanes = 0;
            for (int k = 0; k < W; ++k) {
              const int i = i0 + k % kTw, j = j0 + k / kTw;
              const bool in = i < cam.nx && j < r1;
              if (in) camera_ray_of(i, j, a, b, o, d), ++lanes;
              if (k == 0) o0 = o, d0 = d;
              valid[k] = in ? -1 : 0;
              set_ray<W>(ray, k, in ? o : o0, in ? d : d0, s.epsilon, kInf);
              clear_hit<W>(hit, k);
            }
            counts.camera += lanes;
            Api<W>::intersect(valid, scene, &ctx, rh);
            for (int k = 0; k < W; ++k) sum[k] = sum[k] + RTCRayN_tfar(ray, W, k);
          }
        for (int k = 0; k < W; ++k) {
          const int i = i0 + k % kTw, j = j0 + k / kTw;
          if (i < cam.nx && j < r1) t_out[std::size_t(j) * cam.nx + i] = sum[k];
        }
      }
  }

  template <int W>
  void camera_hits(PeerHit* out) const {
    const PreparedCamera<float>& cam = s.camera;
    alignas(64) typename Api<W>::RayHit rh;
    alignas(64) int valid[W];
    RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    RTCRayHitN* rhn = reinterpret_cast<RTCRayHitN*>(&rh);
    RTCRayN* ray = RTCRayHitN_RayN(rhn, W);
    RTCHitN* hit = RTCRayHitN_HitN(rhn, W);
    for (int b = 0; b < cam.samples; ++b)
      for (int a = 0; a < cam.samples; ++a)
        for (int j = 0; j < cam.ny; ++j)
          for (int i0 = 0; i0 < cam.nx; i0 += W) {
            const int lanes = std::min(W, cam.nx - i0);
            camera_packet<W>(rh, valid, i0, j, a, b, lanes);
            Api<W>::intersect(valid, scene, &ctx, rh);
            PeerHit* row = out + (std::size_t(b * cam.samples + a) * cam.ny + j) * cam.nx + i0;
            for (int k = 0; k < lanes; ++k) {
              const int id = object_id(RTCHitN_geomID(hit, W, k), RTCHitN_primID(hit, W, k));
              row[k] = {id < 0 ? kInf : RTCRayN_tfar(ray, W, k), id};
            }
          }
  }

  // ---- every ray of a render, without shading ------------------------------------------
  template <int W>
  void trace_rows(int r0, int r1, RayCounts& counts) const {
    const PreparedCamera<float>& cam = s.camera;
    alignas(64) typename Api<W>::RayHit rh;
    alignas(64) typename Api<W>::Ray shadow;
    alignas(64) int active[W], lit[W];
    RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    RTCRayHitN* rhn = reinterpret_cast<RTCRayHitN*>(&rh);
    RTCRayN* ray = RTCRayHitN_RayN(rhn, W);
    RTCHitN* hit = RTCRayHitN_HitN(rhn, W);
    RTCRayN* sray = reinterpret_cast<RTCRayN*>(&shadow);
    Vec3<float> o[W], d[W], p[W], n[W];
    float t[W];
    int id[W];
    for (int j = r0; j < r1; ++j) {
      for (int i0 = 0; i0 < cam.nx; i0 += W) {
        const int lanes = std::min(W, cam.nx - i0);
        for (int b = 0; b < cam.samples; ++b)
          for (int a = 0; a < cam.samples; ++a) {
            for (int k = 0; k < W; ++k) {
              active[k] = k < lanes ? -1 : 0;
              if (k < lanes)
                camera_ray_of(i0 + k, j, a, b, o[k], d[k]);
              else
                o[k] = o[0], d[k] = d[0];
            }
            counts.camera += lanes;
            for (int depth = 0;; ++depth) {
              // Closest hits of the active lanes.
              ctx.flags = depth == 0 ? RTC_INTERSECT_CONTEXT_FLAG_COHERENT
                                     : RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT;
              for (int k = 0; k < W; ++k) {
                set_ray<W>(ray, k, o[k], d[k], s.epsilon, kInf);
                clear_hit<W>(hit, k);
              }
              Api<W>::intersect(active, scene, &ctx, rh);
              bool any_hit = false;
              for (int k = 0; k < W; ++k) {
                id[k] = active[k] ? object_id(RTCHitN_geomID(hit, W, k), RTCHitN_primID(hit, W, k))
                                  : -1;
                if (id[k] < 0) continue;
                any_hit = true;
                // The hit point and the normal facing the ray, as lancer computes them.
                t[k] = RTCRayN_tfar(ray, W, k);
                p[k] = along(o[k], d[k], t[k]);
                const int m = id[k];
                if (m >= s.num_spheres + s.num_planes) {
                  // Shapes: the normal Embree reports (its triangle test's, the cylinder
                  // callback's or the curve's), unit.
                  n[k] = normalize(Vec3<float>{RTCHitN_Ng_x(hit, W, k), RTCHitN_Ng_y(hit, W, k),
                                               RTCHitN_Ng_z(hit, W, k)});
                } else if (m < s.num_spheres) {
                  const float r = s.spheres.r[m];
                  n[k] = Vec3<float>{(p[k].x - s.spheres.cx[m]) / r, (p[k].y - s.spheres.cy[m]) / r,
                                     (p[k].z - s.spheres.cz[m]) / r};
                } else {
                  const int q = m - s.num_spheres;
                  n[k] = Vec3<float>{s.planes.nx[q], s.planes.ny[q], s.planes.nz[q]};
                }
                if (dot(n[k], d[k]) > 0.0f) n[k] = -n[k];
              }
              if (!any_hit) break;
              // A shadow ray to each light from each hit lane.
              ctx.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
              for (int l = 0; l < s.num_lights; ++l) {
                const Vec3<float> light{s.lights.x[l], s.lights.y[l], s.lights.z[l]};
                int nlit = 0;
                for (int k = 0; k < W; ++k) {
                  lit[k] = 0;
                  Vec3<float> dir = d[0];
                  float dist = 1.0f;
                  if (id[k] >= 0) {
                    const Vec3<float> to_light = light - p[k];
                    dist = length(to_light);
                    if (dist > 0.0f) {
                      lit[k] = -1, ++nlit;
                      dir = to_light / dist;
                    } else {
                      dist = 1.0f;
                    }
                  }
                  // Leaving the surface as lancer does: offset along the normal (formulas.hpp).
                  const Vec3<float> from = id[k] >= 0 ? offset_origin<float, float>(
                                                            p[k], n[k], dot(dir, n[k]), o[k], t[k])
                                                      : o[0];
                  set_ray<W>(sray, k, from, dir, s.epsilon, dist);
                }
                counts.shadow += nlit;
                if (nlit) Api<W>::occluded(lit, scene, &ctx, shadow);
              }
              // Mirror rays where the material reflects and depth allows.
              if (!s.features.reflection || depth >= s.max_depth) break;
              bool any_reflected = false;
              for (int k = 0; k < W; ++k) {
                active[k] = id[k] >= 0 && s.materials.reflect[id[k]] > 0.0f ? -1 : 0;
                if (!active[k]) continue;
                any_reflected = true;
                ++counts.reflected;
                d[k] = normalize(reflect(d[k], n[k]));
                o[k] = offset_origin<float, float>(p[k], n[k], dot(d[k], n[k]), o[k], t[k]);
              }
              if (!any_reflected) break;
            }
          }
      }
    }
  }
};

}  // namespace lancer::peer
