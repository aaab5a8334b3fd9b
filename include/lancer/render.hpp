// Rendering a scene: choosing the path (reference or a packet width), splitting the image into
// row tiles over threads, counting rays and timing.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <string>

#include "lancer/bvh.hpp"
#include "lancer/image.hpp"
#include "lancer/precision.hpp"
#include "lancer/scene.hpp"
#include "lancer/stats.hpp"

namespace lancer {

// What `auto` picks for a scene, and why, in a sentence. Where rays can bounce twice or more it
// prepares the scene in both precisions and renders a sample of rows in each (docs/precision.md).
struct PrecisionChoice {
  Precision precision;
  std::string reason;
};
PrecisionChoice choose_precision(const Scene& scene);

// The acceleration structure a render used, as built.
struct StructureInfo {
  std::string kind = "none";  // "bvh" or "none" (the plain loop)
  int spheres = 0;            // objects in it
  std::size_t nodes = 0, bytes = 0;
  double build_seconds = 0;
  // Secondary rays' closest hits, as they ran: a lane went on alone into a subtree at most this
  // many lanes of its packet entered (0: packets only; the width or more: every ray alone).
  int one_ray_lanes = 0;
  int clustered_lanes = 0;       // the same for packets whose rays leave from within one leaf box
  int shadow_one_ray_lanes = 0;  // the same for the shadow rays from secondary hits
  // Triangles, meshes and cylinders: their own hierarchy (lancer/shapes.hpp), when any.
  std::size_t shape_primitives = 0, shape_nodes = 0, shape_bytes = 0;
  double shape_build_seconds = 0;
  // Spheres that are leaves of the shapes' hierarchy too (one hierarchy over every bounded kind,
  // which the packets walk; the reference keeps the spheres' own structure).
  int shape_spheres = 0;
  // The primitive kinds the kernels test for this scene, in id order ("spheres, planes,
  // triangles (smooth normals), cylinders"): a kind the scene lacks runs none of its code.
  std::string kinds;
  // The kinds the kernels that ran were compiled for (packet::KernelTable::kinds): spheres and
  // planes alone for a scene without triangles, meshes or cylinders, else every kind.
  std::string built_for;
};
// One line for both: "closest hits one ray at a time; shadow rays packets, one ray alone at 1
// lane" (each "packets", "one ray at a time" or "packets, one ray alone at N lanes or fewer").
std::string secondary_walk(const StructureInfo& st, int width);

template <class T>
struct PreparedScene;
// What a prepared scene built over its spheres (float and double instantiated in render.cpp).
template <class T>
StructureInfo structure_of(const PreparedScene<T>& p);

struct RenderOptions {
  int width = 0;                   // 0: the widest this machine runs (auto); 1: the reference
  Accel accel = Accel::automatic;  // the spheres' structure (auto: by their count)
  Precision precision = Precision::exact;
  int threads = 0;  // 0: all cores
  bool progress = false;
  // Model every shading term (specular, shadow rays, the reflection loop) even where the scene
  // needs none, to measure what modelling only what a scene requires saves. Same image.
  bool model_everything = false;
  // Called with rows done and rows in all, from whichever thread finished a tile.
  std::function<void(int, int)> on_progress;
};

struct RenderResult {
  Image image;
  RayCounts rays;
  double seconds = 0;
  int width = 1;
  int threads = 1;
  std::string isa;
  Precision precision = Precision::exact;  // as resolved: never automatic
  std::string precision_reason;            // why, when automatic chose it
  StructureInfo structure;
};

// Throws InputError if the options ask for something this machine cannot do (a width this CPU
// lacks, fast mode at width 1).
RenderResult render(const Scene& scene, const RenderOptions& options);

// Camera rays and closest hit only (lancer bench's `primary` mode): per pixel the sum of the
// hit distances of its samples.
struct PrimaryResult {
  std::vector<float> t;
  std::vector<std::int32_t> id;  // object first hit by each pixel's first sample, -1 for none
  RayCounts rays;
  double seconds = 0;
  int width = 1;
  int threads = 1;
  StructureInfo structure;
};
PrimaryResult render_primary(const Scene& scene, const RenderOptions& options);

// A scene prepared once (its precision resolved, its structure built), then rendered, or traced
// for its camera rays' closest hits, as often as asked, at any width and thread count of that
// precision. lancer bench times frames so, as it times the Embree peer's over a scene it built
// once: a frame that follows its own build runs beside the build's parallel workers and in the
// caches it left (measured: primary Mrays/s 11% lower at 65536 spheres on 2 vCPUs; docs/accel.md).
// The build is reported apart (StructureInfo::build_seconds). render(), render_primary() and
// render_primary_with_ids() each make one for one frame.
class PreparedRun {
 public:
  // Prepares for options.precision (automatic resolved as render() does), .accel and
  // .model_everything; .on_progress is called by every frame. InputError for a width or thread
  // count the options cannot have, before any preparing.
  PreparedRun(const Scene& scene, const RenderOptions& options);
  ~PreparedRun();
  PreparedRun(const PreparedRun&) = delete;
  PreparedRun& operator=(const PreparedRun&) = delete;
  // One frame at this width and thread count (0: auto), InputError as render().
  RenderResult render(int width, int threads) const;
  PrimaryResult primary(int width, int threads, bool ids = false) const;
  StructureInfo structure() const;  // what the frames report, without running one

 private:
  struct State;
  std::unique_ptr<State> state_;
  template <class Result, class Body>
  void frame(Result& res, int width, int threads, Body body) const;  // render.cpp only
};

// The scene prepared as a render with these options computes in (options.accel; with
// model_everything, every shading term forced on).
template <class T>
PreparedScene<T> prepare_for(const Scene& scene, const RenderOptions& options);

// The width `requested` resolves to (0 = auto) for a precision (not automatic), or InputError
// naming `option`.
int resolve_width(int requested, Precision precision, const std::string& option = "--width");

// Primary mode with the closest-hit ids too (for lancer trade's hit mismatch); slower.
PrimaryResult render_primary_with_ids(const Scene& scene, const RenderOptions& options);

// The CPUs this process may run on (TBB's default concurrency: affinity and cgroup quota).
int hardware_threads();

// More threads than this is a typing error, not a machine (docs/limits.md).
inline constexpr int kMaxThreads = 4096;
// The threads a render asked for `requested` runs on: 0 is every core; more than the cores is
// capped at the cores (TBB runs no more at once, and a summary reports what ran); negative or
// above kMaxThreads is an InputError naming `option`.
int resolve_threads(int requested, const std::string& option = "--threads");

}  // namespace lancer
