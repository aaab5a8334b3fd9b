// lancer's library API: a scene prepared once, then closest-hit and occlusion queries on packets
// of world-space rays (after Embree's rtcIntersect4/8/16 and rtcOccluded4/8/16) and renders of
// row ranges into the caller's buffer. Needs no ISA flags and shows no SIMD type: the kernels
// are chosen at run time inside the library. See docs/api.md.
//
//   #include <lancer/lancer.hpp>
//   lancer::api::Scene scene = lancer::api::Scene::load("scene.json");
//   lancer::api::Ray16 rays = ...;  // world-space origins, unit directions, tnear, tfar, mask
//   lancer::api::Hit16 hits;
//   scene.intersect(nullptr, rays, hits);  // hits.id[k]: object id, -1 for a miss
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "lancer/error.hpp"      // InputError: bad input (a file, a description, an argument)
#include "lancer/precision.hpp"  // Precision
#include "lancer/scene.hpp"      // Scene, the description: a loaded file or built in code

namespace lancer::api {

// A scene description (lancer/scene.hpp): what load_scene() reads, or built in code.
using SceneDescription = ::lancer::Scene;

// How a scene is prepared. Decided once: every query and render of the scene uses it.
struct Options {
  // exact: IEEE float, identical at every width to the float reference. dbl: IEEE double.
  // fast: float with FMA and approximate reciprocals (packets only). automatic: exact where the
  // scene lies inside float's measured envelope, else double (what `lancer render` does).
  Precision precision = Precision::automatic;
  // The widest kernel the scene may use, in lanes: 0 = the widest this CPU and OS run; 1 = the
  // scalar reference; else 4, 8, 16 (float) or 2, 4, 8 (double).
  int width = 0;
  // Threads of render_rows and primary_hits: 0 = all cores, at most 4096 (as `lancer render
  // --threads`); more than the cores runs on the cores (Info::threads says what runs). Ray
  // queries run in the calling thread: call them from as many threads as you like (a Scene is
  // immutable once made).
  int threads = 0;
};

// What a scene chose, as resolved: never "auto".
struct Info {
  Precision precision = Precision::exact;
  std::string precision_reason;  // why, when Options::precision was automatic
  int width = 1;                 // widest kernel, in lanes of `precision`
  std::string isa;               // "avx512f", "avx2", "sse4.2", "scalar", ...
  // What answers the one-ray queries (intersect<1>, occluded<1>, and a packet's lanes with a
  // tnear beyond epsilon), exact and double precision: the one-ray kernels on "avx512f" or
  // "avx2", equal to the reference bit for bit (in a scene with triangles, meshes or
  // cylinders, a packet's lanes with their own tnear take the reference); without them (SSE4.2
  // alone), in a scene with shapes, the narrowest packet kernel, its one lane walking alone
  // ("sse4.2 packet": intersect<1> and occluded<1> from epsilon; the same bits; a ray with its
  // own tnear takes the reference); or "scalar", the reference itself (width 1, no AVX2). Fast
  // mode answers them in packets.
  std::string one_ray = "scalar";
  int threads = 1;                      // what render_rows and primary_hits run on
  int nx = 0, ny = 0, supersample = 1;  // the camera's image
  // Ids 0 .. objects-1: the spheres, then the planes, then the triangles, meshes and cylinders
  // (SceneDescription::shapes), each kind in file order.
  int objects = 0;
};

// Every object's mask: a ray's mask selects the objects it may hit, as Embree's geometry masks
// (objects have none of their own yet, so a mask with any bit set sees every object).
inline constexpr unsigned kAllObjects = ~0u;

// N rays, structure-of-arrays, laid out as Embree's RTCRayN (64-byte aligned). World-space
// origins, UNIT directions (|d|^2 within 1e-5 of 1, else InputError: t is the distance along
// them), and per lane:
//   tnear, tfar: a hit counts when max(tnear, epsilon) < t < tfar, epsilon being the scene's
//     (rounded to its precision). tnear = 0 (or anything up to epsilon) is every ray lancer
//     traces itself; tfar may be infinity; NaN in either is an InputError.
//   mask: a lane hits (and is blocked by) the objects whose mask shares a bit with it; every
//     object's is kAllObjects, so 0 hits nothing and anything else everything.
template <int N>
struct alignas(64) RayPacket {
  static_assert(N == 1 || N == 4 || N == 8 || N == 16, "packets of 1, 4, 8 or 16 rays");
  float org_x[N], org_y[N], org_z[N];
  float tnear[N];
  float dir_x[N], dir_y[N], dir_z[N];
  float tfar[N];
  unsigned mask[N];
};

// Closest hits of N rays, as Embree's RTCHitN plus the distance (64-byte aligned).
//   id: the object hit (Info::objects, Embree's geomID), -1 for a miss (then t is infinity, ng,
//     u and v zero, prim_id -1).
//   prim_id: the primitive within the object (Embree's primID): on a mesh, the triangle's index
//     in its file's order, as in SceneDescription's Mesh::indices (zero-area triangles, dropped
//     when the mesh is loaded, not counted; a face of n corners is its n - 2 fan triangles); 0 for
//     a sphere, a plane, a lone triangle or a cylinder, each one primitive.
//   u, v: on a triangle (v0, v1, v2), Embree's barycentric coordinates: the hit lies at
//     (1 - u - v) v0 + u v1 + v v2, with u, v >= 0 and u + v <= 1 up to rounding. 0 on spheres,
//     planes and cylinders, which have none.
//   ng: the unit geometric normal at the hit, not turned towards the ray (spheres: outward;
//     planes: as described, normalised; triangles: along (v1 - v0) x (v2 - v0), Embree's Ng
//     normalised: towards the side from which v0, v1, v2 run counter-clockwise; cylinders:
//     outward from the axis on the side, along the axis (base to top) on the top cap and against
//     it on the base).
template <int N>
struct alignas(64) HitPacket {
  float t[N];
  float ng_x[N], ng_y[N], ng_z[N];
  float u[N], v[N];
  int prim_id[N];
  int id[N];
};

using Ray1 = RayPacket<1>;
using Ray4 = RayPacket<4>;
using Ray8 = RayPacket<8>;
using Ray16 = RayPacket<16>;
using Hit1 = HitPacket<1>;
using Hit4 = HitPacket<4>;
using Hit8 = HitPacket<8>;
using Hit16 = HitPacket<16>;

// Rays traced by kind, and the wall time of a render.
struct RenderStats {
  std::uint64_t camera = 0, shadow = 0, reflected = 0;
  double seconds = 0;
};

// Per pixel, row-major from the top: the sum over its sub-samples of the camera rays' nearest
// distances (infinity where a ray missed), and the object first hit by sub-sample (0, 0), -1
// for none. What `lancer bench --mode primary` computes.
struct PrimaryHits {
  int nx = 0, ny = 0;
  std::vector<float> t;
  std::vector<int> id;
};

// A scene prepared once for a precision and width: structures built at construction and shared
// by every query and render. Movable, not copyable; const methods are safe to call concurrently.
class LANCER_API Scene {
 public:
  // InputError for a bad file (one line naming the place: "s.json: objects[2].radius: must be
  // > 0"), a description breaking the scene rules, or options out of range (a Precision or
  // CameraType that is none of its enumerators, threads above 4096) or that this machine cannot
  // run. Options are checked before the file is read. Takes what `lancer render` takes to load
  // and prepare the same file.
  static Scene load(const std::string& path, const Options& options = {});
  // A description built in code is held to the file loader's own rules, with its messages,
  // before it is prepared (no scene file is written or read): objects are numbered spheres
  // first, then planes, then shapes, as in Info::objects, and materials by index
  // (`code: materials[2].kd: must be >= 0`, `code: objects[5].radius: must be > 0`).
  static Scene from_description(SceneDescription description, const Options& options = {});

  Scene(Scene&&) noexcept;
  Scene& operator=(Scene&&) noexcept;
  ~Scene();

  const Info& info() const;
  const SceneDescription& description() const;

  // Closest hit of each active lane (valid[k] != 0; null: every lane). Inactive lanes of `hits`
  // are left as they were. World-space rays are moved into the queries' frame (the world's axes
  // at the camera's position: the render's own where the camera looks along -z, else a second
  // preparation of the scene, made on the first query) in double, rounded once to the scene's
  // precision; normals come back in world space;
  // see docs/api.md for what float origins imply far from the world's origin. The kernel is the
  // widest this machine runs up to min(N, Info::width) lanes (N = 1: the reference), applied to
  // as many chunks as it takes: in exact and double precision every N gives the same bits.
  // Lanes whose tnear exceeds epsilon are traced one at a time by the reference's walk (the
  // packet kernels start every ray at epsilon), with the same bits as any other width.
  // InputError for a non-finite origin, a direction that is not unit or a NaN tnear or tfar in
  // an active lane; every lane is checked first, so that then nothing has been written.
  template <int N>
  void intersect(const int* valid, const RayPacket<N>& rays, HitPacket<N>& hits) const;
  // Whether anything lies on each active lane's ray with max(tnear, epsilon) < t < tfar:
  // occluded[k] is 1 or 0; inactive lanes are left as they were. Same frame, kernels and
  // errors as intersect.
  template <int N>
  void occluded(const int* valid, const RayPacket<N>& rays, int* occluded) const;

  // The camera ray of pixel (i, j) at sub-sample (a, b) (0 <= a, b < supersample) in world
  // space: the ray `lancer render` traces there, moved out of the prepared frame and rounded to
  // float. Traced through intersect, it hits what the render hits wherever the round trip is
  // exact: pinhole cameras at float-representable positions looking along -z with y up, in exact
  // precision (docs/api.md).
  void camera_ray(int i, int j, int a, int b, float org[3], float dir[3]) const;

  // Renders rows [row_begin, row_end) of the image (0 at the top) into rgb: row j at
  // rgb + (j - row_begin) * row_stride floats, nx pixels of 3 floats (linear radiance). The same
  // bits as `lancer render` with the same precision and width, for any row range and threads.
  // InputError for rows outside [0, ny] or row_stride < 3 nx.
  RenderStats render_rows(int row_begin, int row_end, float* rgb, std::size_t row_stride) const;

  // Camera rays and closest hits of the whole image (Options::threads threads).
  PrimaryHits primary_hits() const;

 private:
  struct Impl;
  explicit Scene(std::unique_ptr<Impl> impl);
  static Scene make(SceneDescription description, const Options& options);
  std::unique_ptr<Impl> impl_;
};

extern template void Scene::intersect<1>(const int*, const Ray1&, Hit1&) const;
extern template void Scene::intersect<4>(const int*, const Ray4&, Hit4&) const;
extern template void Scene::intersect<8>(const int*, const Ray8&, Hit8&) const;
extern template void Scene::intersect<16>(const int*, const Ray16&, Hit16&) const;
extern template void Scene::occluded<1>(const int*, const Ray1&, int*) const;
extern template void Scene::occluded<4>(const int*, const Ray4&, int*) const;
extern template void Scene::occluded<8>(const int*, const Ray8&, int*) const;
extern template void Scene::occluded<16>(const int*, const Ray16&, int*) const;

// The library's version, "major.minor.patch".
LANCER_API const char* version();

}  // namespace lancer::api
