// The counters a profiled packet kernel fills (ProfiledMode, lancer profile): per stage, TSC
// cycles, packets, active lanes and their histogram, and the camera blocks' walks. Part of the
// engine (the kernels write it); what the profile tool makes of it is in lancer/profile.hpp.
#pragma once

#include <array>
#include <cstdint>

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
  // Secondary packets in a scene whose secondary rays go one at a time (WalkSettings::
  // one_ray_lanes or clustered_lanes): those that walked whole (their rays stay together, or
  // apart where only clustered packets' lanes go alone), as a packet down to their common leaf
  // (clustered: their origins within one leaf box) and those that went lane by lane.
  std::array<std::uint64_t, kStageCount> walked_whole{}, walked_clustered{}, walked_apart{};
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
  // The shapes' camera groups (ShapePackets::closest_group, the same path): groups of tiles
  // with a live lane, their walks together (one per set of tiles sharing direction signs: two
  // or four on the image's centre lines), tiles of mixed signs walked alone (their own packet's
  // walk, not in the counts after), and in the walks together: nodes entered, per-lane box tests
  // of a tile against a child, leaves reached, tile-leaf calls and the lanes live in them.
  // group_w x group_h: a group's pixels.
  struct ShapeGroups {
    std::uint64_t groups = 0, walks = 0, tiles_alone = 0, nodes = 0, box_tests = 0, leaves = 0,
                  leaf_calls = 0, leaf_lanes = 0;
    int group_w = 0, group_h = 0;
  } shape_groups;
};

}  // namespace lancer
