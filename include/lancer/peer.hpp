// Peers: other ray tracers fed the same scene and the same camera rays, so that lancer's speed
// can be read against them (`lancer bench --peer embree`). One peer for now: Intel Embree 3.
//
// Embree is optional (CMake option LANCER_WITH_EMBREE, on by default, and the package must be
// found). Without it this header still compiles and links: embree_available() is false and
// making an EmbreeScene throws InputError.
//
// The Embree scene, built from lancer::prepare<float>, so from the very floats lancer renders
// with (its library API's queries, where the camera looks off the world's axes, run on a
// second preparation in the queries' frame, FrameKind::query; ray sets reach both engines as
// the same world-space rays, and their answers agree to a tolerance):
//  - all spheres in one RTC_GEOMETRY_TYPE_SPHERE_POINT geometry (RTC_FORMAT_FLOAT4 x, y, z, r);
//    Embree's own sphere test, not lancer's;
//  - planes, by default, as one user geometry (rtcSetGeometryIntersectFunction) whose callbacks
//    compute lancer's formula t = dot(Q - o, N) / dot(d, N): exact, the infinite plane. Its
//    bounds are a box about Q of half-size kPlaneExtent x the scene's size (Embree's BVH needs
//    finite bounds), so a hit farther than that from Q is missed: only rays within about
//    1/kPlaneExtent radian of grazing the plane can be affected.
//  - or, with PlaneMode::quad, as one large quad per plane (RTC_GEOMETRY_TYPE_QUAD) over the
//    same square: Embree's own (hardware-friendlier) triangle test, but the corners are floats
//    of magnitude kPlaneExtent x the scene's size, so a plane that is not axis-aligned is off by
//    up to a float ulp there (1e-2 for a scene of size 10), which is enough for shadow acne; and,
//    measured on the shipped scenes, the quad's two triangles leak along their shared diagonal
//    at this size: 7 to 75 camera rays per scene (0.01-0.05%) miss the plane through that
//    crack, against none with the user geometry. Speed, measured side by side on
//    lorenzi-reflections: user geometry within +-10% of the quad at widths 4-16, ~15% slower
//    at width 1. So the default is the user geometry; quads are kept for comparison.
//  - triangles: each mesh (a lone triangle is a mesh of one) as one RTC_GEOMETRY_TYPE_TRIANGLE
//    geometry, all of them over one shared vertex buffer (lancer's prepared float vertices, each
//    once) with the mesh's slice of lancer's index buffer: Embree's own triangle test, not
//    lancer's (with RTC_SCENE_FLAG_ROBUST, Embree's robust traversal and tests, which avoid
//    optimisations that lose accuracy);
//  - cylinders, by default, as one user geometry whose callback computes the capped (or open)
//    cylinder, the peer's own formula; or, with EmbreeConfig::curves, as Embree's
//    RTC_GEOMETRY_TYPE_ROUND_LINEAR_CURVE, one segment per cylinder. A round linear segment is a
//    capsule: a sphere of the cylinder's radius closes each end, where lancer's capped cylinder
//    has a flat disc (and an open one nothing). Rays that meet lancer's cylinder on its side
//    meet the capsule at the same point (the tube is convex and holds both half-spheres), but
//    the half-spheres stick out by the radius past each end: cap hits are farther, and rays
//    passing just beyond an end hit where lancer misses. A speed stand-in, not a model of the
//    same surface: the user geometry is the one checked against lancer.
// Rays: tnear = the scene's epsilon, tfar = infinity (primary and reflected) or the distance to
// the light (shadow). Embree accepts hits with tnear <= t <= tfar where lancer wants
// epsilon < t < tfar: the two differ only on exact ties.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "lancer/ray_sets.hpp"
#include "lancer/render.hpp"
#include "lancer/scene.hpp"
#include "lancer/stats.hpp"

namespace lancer::peer {

// True when this lancer was built with Embree.
bool embree_available();
// "3.13.5", or "" without Embree.
std::string embree_version();

// Checks an Embree device configuration ("isa=avx2,threads=1": LANCER_EMBREE_CONFIG) before
// rtcNewDevice, which ignores what it does not know: an unknown key or value throws InputError
// naming `name`. Works without Embree too.
void check_embree_config(const std::string& config,
                         const std::string& name = "LANCER_EMBREE_CONFIG");

enum class PlaneMode { user, quad };

// The environment variable LANCER_EMBREE_PLANES: "user" (or unset) or "quad"; lancer bench and
// the benchmarks read it to compare the two models. Throws InputError on anything else.
PlaneMode plane_mode_from_env();

// Half-size of the square that stands for an infinite plane, in units of the scene's size (the
// largest distance from the camera's position of the lights, the sphere surfaces and the
// planes' points; prepared scenes are camera-relative).
inline constexpr float kPlaneExtent = 1e4f;

// The hit of one ray, for tests: t (infinity on a miss) and lancer's object id (-1 on a miss).
struct PeerHit {
  float t;
  int id;
};

// How the peer builds and traces, to find Embree's fastest setup on these rays (issue 12):
// spheres as RTC_GEOMETRY_TYPE_SPHERE_POINT (Embree 3.13 tests their leaves one lane at a
// time) or as a user geometry whose callback takes a whole packet; build quality MEDIUM
// (Embree's default) or HIGH (spatial splits: a better tree, a slower build);
// RTC_SCENE_FLAG_ROBUST (robust traversal, no optimisations that lose accuracy);
// cylinders as user geometry or round linear curves; camera packets of W as a row's W columns
// or as squares (4x4, 4x2, 2x2 pixels, as lancer's), or, at any width, rtcIntersect1M streams
// of 64 camera rays (four 4x4 squares) that Embree regroups itself; RTC_SCENE_FLAG_COMPACT.
struct EmbreeConfig {
  bool user_spheres = false;
  bool high_quality = false;
  bool tiles = false;
  bool compact = false;
  bool streams = false;
  bool robust = false;
  bool curves = false;
  // What name() mentions: the sphere model (scenes with spheres, or none of the shapes) and the
  // cylinder model (scenes with cylinders).
  bool name_spheres = true, name_cylinders = false;
  std::string name() const;  // "user spheres, build high, square packets"
  // Setups that differ in tracing only (tiles, streams) share one Embree scene.
  bool same_build(const EmbreeConfig& o) const;
};
// From LANCER_EMBREE_SETUP, comma-separated words: user-spheres, high, tiles, compact, streams,
// robust, curves (unset: the defaults). Throws InputError on an unknown word.
EmbreeConfig embree_config_from_env();
// The setups lancer bench tries, each a row of its own, keeping the fastest per row: only
// LANCER_EMBREE_SETUP's when it is set, else sphere points and user spheres, each at build
// quality MEDIUM and HIGH, and user spheres with square packets (4x4, 4x2, 2x2 pixels) and with
// streams.
std::vector<EmbreeConfig> embree_setups();
// The same for these scenes: with no triangle, mesh or cylinder in any, the setups above; else
// build quality MEDIUM and HIGH, each without and with RTC_SCENE_FLAG_ROBUST, each with row
// packets, square packets and streams, and, when a scene has cylinders, each of those with
// cylinders as user geometry and as round linear curves (spheres, if any, as sphere points).
std::vector<EmbreeConfig> embree_setups(const std::vector<const Scene*>& scenes);

class EmbreeScene {
 public:
  // Builds the Embree device and scene (BVH) once; throws InputError naming --peer when lancer
  // was built without Embree. `config` goes to rtcNewDevice (e.g. "isa=avx2"); the environment
  // variable LANCER_EMBREE_CONFIG is used when it is empty.
  explicit EmbreeScene(const Scene& scene, PlaneMode planes = PlaneMode::user,
                       const std::string& config = "", const EmbreeConfig& how = {});
  // Another setup over `built`'s Embree scene: allowed when how.same_build(built.config()).
  EmbreeScene(const EmbreeScene& built, const EmbreeConfig& how);
  // Seconds the constructor took to build Embree's device, geometry and BVH.
  double build_seconds() const;
  const EmbreeConfig& config() const;
  ~EmbreeScene();
  EmbreeScene(const EmbreeScene&) = delete;
  EmbreeScene& operator=(const EmbreeScene&) = delete;

  // Camera rays only, closest hit: the peer of lancer::render_primary. `width` 1, 4, 8 or 16
  // picks rtcIntersect1/4/8/16 (Embree then runs its own ISA inside); packets are a row's
  // columns i0 .. i0+width-1, the last one partial with a valid mask, as lancer's. Rows are
  // split into tiles of 4 over `threads` threads (TBB), each thread making single-threaded
  // Embree calls. Per pixel, the sum of its samples' hit distances (infinity if any missed).
  // The timing covers the rays only: the BVH was built by the constructor.
  PrimaryResult primary(int width, int threads) const;

  // Every ray lancer's full render traces, and nothing else: camera rays (rtcIntersectN), at
  // each hit a shadow ray to each light (rtcOccludedN; counted where the light is not at the
  // hit point, as lancer does) and, below max_depth on a material with reflect > 0, the mirror
  // ray (rtcIntersectN again). No shading: Embree does not shade, so this is lancer's "full"
  // ray traffic without its shading arithmetic. The hit point, normal, new directions and the
  // secondary rays' origin offset (formulas.hpp offset_origin) are lancer's formulas, computed
  // lane by lane in scalar code between Embree calls. The counts are comparable with render()'s
  // (equal camera rays; shadow and mirror rays within a few, where hits differ at silhouettes).
  struct RaysResult {
    RayCounts rays;
    double seconds = 0;
  };
  RaysResult trace_all(int width, int threads) const;

  // Closest hit of each camera ray of the scene, sample (a, b) of pixel (i, j) at
  // [((b * s + a) * ny + j) * nx + i] (s samples per axis), through rtcIntersect<width>, packets
  // grouped as in primary(). For tests.
  std::vector<PeerHit> camera_hits(int width) const;

  // Rays one at a time through rtcIntersect1 (occluded false: `found` counts the hits) or
  // rtcOccluded1 (the blocked rays), single-threaded: the peer of the library API's one-ray
  // queries. Rays in the scene's prepared frame (PreparedScene::frame), 8 floats each: origin,
  // unit direction, tnear, tfar. Returns the seconds the calls took.
  double one_rays(const float* rays, std::size_t n, bool occluded, std::size_t& found) const;

  // A ray set (lancer/ray_sets.hpp) moved into the peer's frame, as the library API moves a
  // world-space ray (in double, rounded once to float), before anything is timed: both engines
  // then trace the same floats. tnear is the scene's epsilon, as for the camera rays.
  struct Rays;
  std::shared_ptr<const Rays> load_rays(const rays::RaySet& set) const;
  // Traces every ray of `rays` on `threads` threads (tiles of 256 rays, in set order):
  // rtcOccluded (AO sets) or rtcIntersect (diffuse) with the incoherent flag, in packets of
  // `width` consecutive rays (1: rtcIntersect1), or, with the streams setup, rtcIntersect1M /
  // rtcOccluded1M over 64 rays at a time. With `answers`, fills it (lancer's object ids).
  // Returns the seconds.
  double trace_rays(const Rays& rays, int width, int threads, rays::Answers* answers) const;

  // How the planes are modelled.
  PlaneMode plane_mode() const;

 private:
  struct Impl;
  std::shared_ptr<const Impl> impl_;
  EmbreeConfig how_;
};

// Widths the embree peer offers on this machine: those of `requested` that are 1 or a packet
// width this CPU runs (packet::kernels_for), in the order given.
std::vector<int> embree_widths(const std::vector<int>& requested);

}  // namespace lancer::peer
