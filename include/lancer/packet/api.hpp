// The packet path's entry points, declared without any SIMD type so that code built for the
// baseline ISA can call them. The kernels are defined in packet/kernel.hpp and instantiated only
// in src/isa/<isa>.cpp, which alone is built with that ISA's flags.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "lancer/image.hpp"
#include "lancer/packet/api_rays.hpp"
#include "lancer/precision.hpp"
#include "lancer/prepared.hpp"
#include "lancer/stats.hpp"

namespace lancer::packet {

// Arithmetic modes of a kernel: ExactMode computes exactly what the reference computes; FastMode
// fuses multiply-adds and refines approximate reciprocals (float only).
struct ExactMode {};
struct FastMode {};
// Exact arithmetic plus per-stage timing and counters (lancer profile); never used to render.
struct ProfiledMode {};
// A mode's kernels built for spheres and planes alone: the same arithmetic, without the
// triangle, mesh and cylinder module, so that a scene without them runs the code it ran before
// that module existed. Chosen per scene (float_kernels' `shapes`).
template <class Mode>
struct SpheresAndPlanes {};
// A mode's arithmetic (ExactMode, FastMode or ProfiledMode) and whether its kernels model shapes.
template <class Mode>
struct ModeTraits {
  using Arithmetic = Mode;
  static constexpr bool kShapes = true;
};
template <class Mode>
struct ModeTraits<SpheresAndPlanes<Mode>> {
  using Arithmetic = Mode;
  static constexpr bool kShapes = false;
};

// Where a packet's hit fields go (lancer.hpp's HitPacket, from some lane on): one array each.
struct HitLanes {
  float *t, *ng_x, *ng_y, *ng_z, *u, *v;
  int *prim_id, *id;
  // The lanes from lane c on.
  HitLanes from(int c) const noexcept {
    return {t + c, ng_x + c, ng_y + c, ng_z + c, u + c, v + c, prim_id + c, id + c};
  }
};

// Where intersect_lanes leaves, for a scene with triangles, meshes or cylinders, what the API
// needs to rewrite the lanes that hit one (their fields come from the primitive, not from the
// kernel's ISA): the n lanes' rays in the prepared frame, W at a time (six rows of W: origin x,
// y, z, direction x, y, z), aligned to 64 bytes; each lane's t (its tfar where it missed); and
// each lane's shape primitive number (PreparedShapes::prim's index), -1 where it hit none.
template <class Real>
struct ShapeLanes {
  Real* rays;
  Real* t;
  std::int32_t* prim;
};

// One kernel instantiation's entry points.
template <class Real>
struct KernelTable {
  int width;          // lanes of Real per packet
  const char* isa;    // "sse4.2", "avx2", "avx512f" (fast AVX2 reports "fma3<avx2>")
  const char* kinds;  // what it was compiled for: "spheres and planes alone" or every kind
  // Whole render of rows [row_begin, row_end); in exact mode bit-identical to
  // reference::render_rows.
  void (*render_rows)(const PreparedScene<Real>&, Image&, int row_begin, int row_end, RayCounts&);
  // Camera rays and closest hit only, as reference::primary_rows.
  void (*primary_rows)(const PreparedScene<Real>&, float* t_out, std::int32_t* id_out,
                       int row_begin, int row_end, RayCounts&);
  // The primary intersection kernel alone (lancer bench --mode kernel). camera_packets makes
  // the camera rays of rows [row_begin, row_end) once (row_begin a multiple of kTileRows),
  // camera_packet_count(row_begin, row_end) packets in the order primary_rows traces them (the
  // camera blocks or tiles through a hierarchy, else rows), each 6 x width values (origin then
  // direction, SoA), its live lanes as bits in lanes[p], and in where[] per lane the index of
  // its camera ray, (row * samples^2 + sub-sample) * nx + column, or kNoCameraRay (dead lane).
  // intersect_camera_packets runs primary_rows' closest-hit kernel over `count` of them (the
  // count of whole rows of tiles), width nearest t per packet into t_out (infinity where missed).
  std::size_t (*camera_packet_count)(const PreparedScene<Real>&, int row_begin, int row_end);
  void (*camera_packets)(const PreparedScene<Real>&, int row_begin, int row_end, Real* rays,
                         int* lanes, std::uint32_t* where);
  void (*intersect_camera_packets)(const PreparedScene<Real>&, const Real* rays, const int* lanes,
                                   std::size_t count, Real* t_out, RayCounts&);
  // One packet through the closest-hit kernel, for tests and the library API (src/engine/api.cpp,
  // which moves world-space rays into the prepared frame first): rays in SoA arrays of `width`
  // lanes (origin x, y, z then direction x, y, z), lanes with valid[k] false come back untouched in
  // t and id. hit_out gets the lanes hit; prim_out, unless null, each valid lane's shape
  // primitive number (PreparedShapes::prim's index, ShapeHit::prim) where it hit a triangle,
  // mesh or cylinder, else -1.
  void (*closest_hit_packet)(const PreparedScene<Real>&, const bool* valid, const Real* rays,
                             Real* t, std::int32_t* id, bool* hit_out, std::int32_t* prim_out);
  // One packet through the any-hit kernel (shadow rays), for the library API (lancer.hpp):
  // rays as closest_hit_packet, blocked_out[k] true where valid[k] and some object lies at
  // epsilon < t < tfar[k]; false elsewhere.
  void (*occluded_packet)(const PreparedScene<Real>&, const bool* valid, const Real* rays,
                          const Real* tfar, bool* blocked_out);
  // A caller's packet of n lanes, a multiple of `width`, straight from its arrays
  // (packet/api_rays.hpp RayLanes), checked, moved, traced and written out in one call where it
  // is plain; returns 2 when done, else scan_rays' bits having written nothing
  // (packet/kernel.hpp). With `shapes` (non-null), also what ShapeLanes says.
  int (*intersect_lanes)(const PreparedScene<Real>&, const RayLanes&, int n, const HitLanes& out,
                         const ShapeLanes<Real>* shapes);
  int (*occluded_lanes)(const PreparedScene<Real>&, const RayLanes&, int n, int* blocked_out);
  // n world-space rays (float origin x, y, z, direction x, y, z) moved into the prepared frame,
  // into six arrays (packet/api_rays.hpp): the library API's packets, in this ISA's vectors.
  void (*frame_rays)(const Frame&, int n, const float* ox, const float* oy, const float* oz,
                     const float* dx, const float* dy, const float* dz, Real* o0, Real* o1,
                     Real* o2, Real* o3, Real* o4, Real* o5);
  // Checks of n such rays (packet/api_rays.hpp scan_rays): bit 0, some lane with on[l] fails
  // them; bit 1, every lane plain.
  int (*scan_rays)(int n, const float* ox, const float* oy, const float* oz, const float* dx,
                   const float* dy, const float* dz, const float* tnear, const float* tfar,
                   const unsigned* mask, const int* on, unsigned all_objects, Real eps);
  // Every hit field of one packet's lanes (packet/api_hits.hpp): rays, t and id as
  // closest_hit_packet's, into the first `width` lanes of out's arrays; a lane that hit a
  // triangle, mesh or cylinder gets a zero normal.
  void (*hit_fields)(const PreparedScene<Real>&, const Real* rays, const Real* t,
                     const std::int32_t* id, const HitLanes& out);
};

// camera_packets' where[] for a lane that holds no camera ray.
inline constexpr std::uint32_t kNoCameraRay = ~std::uint32_t(0);

// Defined in packet/kernel.hpp; instantiated per ISA in src/isa/*.cpp. Call only after the
// CPU check (dispatch.cpp): it runs that ISA's instructions.
template <class Arch, class Real, class Mode>
const KernelTable<Real>* table();

// The kernels of a precision (exact, dbl or fast) at a width in lanes, if this CPU and OS run
// them, else nullptr. Float widths are 4, 8, 16; double widths 2, 4, 8.
// `shapes` false: the exact kernels built for spheres and planes alone (SpheresAndPlanes), for
// scenes without triangles, meshes or cylinders (a scene with them needs `shapes` true).
const KernelTable<float>* float_kernels(int width, Precision precision, bool shapes = true);
const KernelTable<double>* double_kernels(int width, bool shapes = true);

// Profiled exact float kernels, for lancer profile.
const KernelTable<float>* profiled_kernels(int width);

// Exact float kernels, the ones validate proves identical to the reference.
using Kernels = KernelTable<float>;
inline const Kernels* kernels_for(int width) { return float_kernels(width, Precision::exact); }

// Packet widths of a precision this machine runs, widest first, then 1 where the reference
// runs that precision (exact, double).
std::vector<int> supported_widths(Precision precision = Precision::exact);

// The ISA name of a width for a precision ("scalar" for 1), whether or not this machine runs it.
std::string isa_name(int width, Precision precision = Precision::exact);

}  // namespace lancer::packet
