// Where a packet render's time goes: per stage, TSC cycles, rays, intersection tests and how full
// the lanes were. Filled only by the profiled kernel instantiation (ProfiledMode): render and
// bench run kernels compiled without any of it.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "lancer/bvh.hpp"
#include "lancer/scene.hpp"

namespace lancer {

enum Stage : int {
  kRayGeneration,
  kPrimaryIntersection,
  kShading,
  kShadowRays,           // from camera hits (packets)
  kSecondaryShadowRays,  // from reflection and refraction points (one ray at a time at scale)
  kReflection,
  kRefraction,
  kOutput,
  kStageCount
};
const char* stage_name(int stage);

inline constexpr int kMaxHistogramLanes = 16;

struct StageProfile {
  std::array<std::uint64_t, kStageCount> cycles{};
  std::array<std::uint64_t, kStageCount> packets{};       // packets through the stage
  std::array<std::uint64_t, kStageCount> active_lanes{};  // lanes active in them
  // packets by how many lanes were active, 0 .. 16
  std::array<std::array<std::uint64_t, kMaxHistogramLanes + 1>, kStageCount> histogram{};
  std::uint64_t sphere_tests = 0, plane_tests = 0;  // ray-object tests, lanes counted one by one
  std::uint64_t last_tsc = 0;                       // the chain of laps; see Kernel::lap
  // Hierarchy leaves visited per stage and the lanes active in them (traversal occupancy).
  std::array<std::uint64_t, kStageCount> leaf_packets{}, leaf_lanes{};
  // Secondary packets in a scene whose secondary rays go one at a time (Bvh::one_ray_lanes):
  // those that walked whole (their rays stay together) and those that went lane by lane.
  std::array<std::uint64_t, kStageCount> walked_whole{}, walked_apart{};
  int current = 0;  // the stage whose rays are being traced (set by Kernel::occupancy)
  // The camera blocks' walk (primary mode's path, Traversal::closest_coherent): blocks whose
  // tiles walked the hierarchy together (on the image's centre lines, one walk per side, a tile
  // a line crosses alone) or packet by packet (width 4's blocks on the centre lines, double
  // precision), and in the walks together: inner nodes tested, leaves popped, tile-by-leaf
  // tests (each lane against the leaf's box at width 4, the tile's cone against each sphere at
  // widths 16 and 8), leaf calls and the lanes live in them. block_w x block_h: the blocks'
  // pixels.
  struct Blocks {
    std::uint64_t together = 0, alone = 0, nodes = 0, leaf_pops = 0, tile_tests = 0, leaf_calls = 0,
                  leaf_lanes = 0;
    // Subtrees that one tile alone went on into, walked by that tile as its own packet (their
    // nodes and leaves are not in the counts above).
    std::uint64_t tiles_alone = 0;
    // Widths 16 and 8: at the leaves (the lone tiles' too), tile-sphere pairs whose cone test
    // ran, and those whose cone may meet the sphere, which alone go on to the per-lane tests.
    std::uint64_t cone_pairs = 0, cone_kept = 0;
    int block_w = 0, block_h = 0;
  } blocks;
};

struct ProfileResult {
  struct StageRow {
    std::string name;
    double seconds = 0;
    std::uint64_t rays = 0;                // rays of the kind the stage handles
    double lane_occupancy = 0;             // mean active lanes / width over its packets
    double leaf_occupancy = 0;             // the same at the hierarchy's leaves (0: none)
    std::uint64_t leaves = 0;              // leaf visits by its packets
    std::vector<std::uint64_t> histogram;  // packets by active lanes
    // Where its scene sends secondary rays one at a time: packets that walked the hierarchy
    // whole (their rays stay together) and packets that went lane by lane (0 and 0 elsewhere).
    std::uint64_t walked_whole = 0, walked_apart = 0;
  };
  int width = 0;
  std::string isa;
  double total_seconds = 0;
  std::uint64_t camera_rays = 0, shadow_rays = 0, reflected_rays = 0, refracted_rays = 0;
  double tests_per_ray = 0;  // ray-object intersection tests per ray, all kinds
  std::vector<StageRow> stages;
  // A second profiled run: camera rays and closest hits alone (bench --mode primary's path),
  // whose camera blocks walk the hierarchy together; their counts per block walked together.
  struct CameraBlocks {
    double seconds = 0;  // the profiled run, counters included
    std::uint64_t rays = 0;
    StageProfile::Blocks totals;
    // per block walked together
    double nodes = 0, leaf_pops = 0, tile_tests = 0, leaf_calls = 0, tiles_alone = 0;
    double cone_kept = 0;       // the share of tile-sphere pairs the cones kept (0: no cones)
    double leaf_occupancy = 0;  // live lanes / width over the leaf calls (0: none)
  } camera_blocks;
};

// Renders once, single-threaded, with the profiled exact kernels of `width` (4, 8 or 16; 0 for
// the widest), then traces the camera rays' closest hits once more as primary mode does
// (camera_blocks). Throws InputError for a width this machine does not run.
ProfileResult profile_render(const Scene& scene, int width, Accel accel = Accel::automatic);

}  // namespace lancer
