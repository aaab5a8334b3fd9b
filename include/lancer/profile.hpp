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
#include "lancer/stage_profile.hpp"

namespace lancer {

// The stage's name in tables ("primary intersection").
const char* stage_name(int stage);

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
    // whole (their rays stay together), as a packet down to their common leaf (clustered: their
    // origins within one leaf box) and packets that went lane by lane (all 0 elsewhere).
    std::uint64_t walked_whole = 0, walked_clustered = 0, walked_apart = 0;
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
    // The shapes' camera groups in the same run (all zero without shapes or camera blocks), and
    // the live lanes / width over their tile-leaf calls (0: none).
    StageProfile::ShapeGroups shape_groups;
    double shape_leaf_occupancy = 0;
  } camera_blocks;
};

// Renders once, single-threaded, with the profiled exact kernels of `width` (4, 8 or 16; 0 for
// the widest), then traces the camera rays' closest hits once more as primary mode does
// (camera_blocks). Throws InputError for a width this machine does not run.
ProfileResult profile_render(const Scene& scene, int width, Accel accel = Accel::automatic);

}  // namespace lancer
