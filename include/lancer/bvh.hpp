// A bounding volume hierarchy over a scene's spheres (planes are unbounded and stay outside it),
// built once per scene by prepare(). Binned SAH (as madmann91/bvh v2), collapsed into 4-wide nodes
// holding their children's boxes structure-of-arrays, so a packet tests four children per node.
// The spheres are copied in leaf order with their ORIGINAL object ids: materials and the tie
// rule (equal t goes to the lower id) stay those of the file. docs/accel.md.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <type_traits>
#include <vector>

#include "lancer/huge_pages.hpp"

namespace lancer {

// Which structure a scene gets: automatic picks the plain loop below kBvhMinSpheres spheres.
// one: as automatic for the spheres' own structure (the reference's), and in a scene with
// triangles, meshes or cylinders the packets walk one hierarchy over the spheres and those
// (PreparedShapes::spheres); automatic keeps two there, measured faster (docs/accel.md).
enum class Accel { automatic, none, bvh, one };
const char* to_string(Accel a);

// Spheres from which the hierarchy beats the plain loop (measured, docs/accel.md).
inline constexpr int kBvhMinSpheres = 16;

// Secondary rays' closest hits (reflected, refracted; exact float and double packets): from
// kOneRayMinSpheres spheres every lane walks alone from the root, a packet's walks interleaved
// (Benthin et al.'s hybrid; threshold measured on random clouds: docs/accel.md, "Secondary rays
// one at a time" and "Lone walks interleaved").
inline constexpr int kOneRayMinSpheres = 8192;
// ... except a packet whose rays stay within about this many leaves of each other over the whole
// structure (a flat mirror's reflections, camera-like rays through the library API): it walks
// as a packet (Bvh::coherent_spread; measured 4 to 16 alike, docs/accel.md thirteenth round).
inline constexpr int kCoherentLeaves = 8;
// ... and a packet whose live lanes leave from within one leaf box of each other (the median
// leaf's diagonal: several rays from each hit point, as ambient occlusion and diffuse bounces
// are cast) walks as a packet until at most kClusteredLanes of its lanes enter a subtree, which
// then go on alone: their walks share the path down to their common leaf. From
// kClusteredMinSpheres (below kOneRayMinSpheres too, where the other secondary packets stay
// packets; in smaller hierarchies packets measured faster) and below kClusteredMaxSpheres: above
// it, every lane alone from the root keeps more node loads in flight at once, which wins when the
// hierarchy lies beyond the caches (docs/accel.md, "Packets that leave from one leaf walk
// clustered").
inline constexpr int kClusteredLanes = 4;
inline constexpr int kClusteredMinSpheres = 1024;
inline constexpr int kClusteredMaxSpheres = 262144;
// The shadow rays of secondary hits (exact float and double packets): from
// kOneRayShadowMinSpheres, a lane goes on alone into a subtree no other lane of its packet enters
// (docs/accel.md, tenth round).
// The camera hits' shadow rays, coherent, stay packets.
inline constexpr int kOneRayShadowMinSpheres = 1024;
inline constexpr int kOneRayShadowLanes = 1;
// Leaves of up to 8 spheres rather than 4 from this many spheres (Bvh::max_leaf; docs/accel.md,
// seventeenth round): with the camera tiles' cones, which test a leaf's spheres for every tile
// at once, and the bottom nodes taken as leaves, 0.90x the time of camera rays at 65536 spheres
// (width 16) and 0.93x of full renders; at 1024 spheres, 1.05x at width 4.
inline constexpr int kLargeLeafMinSpheres = 8192;

template <class T>
struct Bvh {
  // A kWidth-wide node: a binary SAH tree collapsed (docs/accel.md). Child slot k < arity:
  // count[k] < 0: child[k] is an inner node (-1; -2 - n where its own children are leaves only,
  // of n spheres in all: a bottom node, whose first sphere is first_sphere[child[k]]); else a
  // leaf of count[k] spheres from leaf-order index child[k]. Slots hold the binary tree's
  // depth-first order, so children visited in slot order meet the leaves in the binary tree's fixed
  // order. order[u], per packet direction code u (bit a set: the rays go up along axis a): the
  // slots nearest first (kOrderBits each, the first lowest; the binary splits' near-first rule),
  // the slots >= arity last. Aligned to 64-byte cache lines.
  static constexpr int kWidth = 4;  // 8 measured: no faster at 65536 spheres, slower at 16384
  static constexpr int kOrderBits = kWidth == 4 ? 2 : 3;
  using Order = std::conditional_t<kWidth == 4, std::uint8_t, std::uint32_t>;
  struct alignas(64) Node {
    T lo_x[kWidth], hi_x[kWidth], lo_y[kWidth], hi_y[kWidth], lo_z[kWidth], hi_z[kWidth];
    std::int32_t child[kWidth];
    Order order[8];
    std::int8_t count[kWidth];
    std::int32_t arity;  // children in use: 1 (a one-sphere tree) to kWidth
  };
  // The any-hit traversal's order: the slots in their order.
  static constexpr unsigned slot_order() {
    unsigned o = 0;
    for (int p = 0; p < kWidth; ++p) o |= unsigned(p) << (kOrderBits * p);
    return o;
  }
  static constexpr unsigned kSlotOrder = slot_order();
  BigVector<Node> nodes;  // nodes[0] is the root; empty: no hierarchy (plain loop)
  // Per node: where its children are leaves only, its spheres' first leaf-order index (they are
  // consecutive: the leaves keep the depth-first order); else -1. The camera tiles' walk takes
  // such a node as one leaf (packet/cones.hpp) without reading it.
  std::vector<std::int32_t> first_sphere;
  // The spheres in leaf order: centre, r^2 and object id (the camera's tables in that order are
  // the prepared scene's leaf_eye: the hierarchy knows nothing of the camera).
  // (Plain vectors, their pages prepared by prepare(): with BigVector's type here GCC compiled
  // the course scenes' AVX2 shading loop differently, 2% more instructions.)
  std::vector<T> cx, cy, cz, r2;
  std::vector<std::int32_t> id;
  // id's inverse: sphere k's position in leaf order. The library API reads a hit sphere's centre
  // from the leaf copy the walk has just tested, in the cache where the id-order arrays are not.
  std::vector<std::int32_t> leaf_of;
  // Boxes are padded for the rounding of the sphere test of rays whose origin lies within this
  // max-norm of the camera: a packet with a lane beyond it uses the plain loop (exact either way).
  T origin_limit = T(0);
  int depth = 0;     // deepest wide node (root: 1); at most kMaxTreeDepth / 2
  int max_leaf = 4;  // a leaf's spheres at most (build_bvh, by kLargeLeafMinSpheres)
  // Where secondary rays go one at a time, a packet whose live lanes stay together walks whole:
  // the spread of their origins plus `diagonal` (the root box's) times the spread of their
  // directions (the sides of the boxes around each) at most coherent_spread, kCoherentLeaves
  // times the median leaf box's diagonal, leaf_diagonal.
  T diagonal = T(0), coherent_spread = T(0), leaf_diagonal = T(0);
  double build_seconds = 0;

  // The binary tree's depth bound; every inner child of a wide node lies two binary levels down,
  // so a traversal stack (at most kWidth - 1 entries per wide level, + 1) holds kStack entries.
  static constexpr int kMaxTreeDepth = 96;
  static constexpr int kStack = (kWidth - 1) * (kMaxTreeDepth / 2) + 2;
  // Rays from beyond origin_limit traverse boxes grown by kOriginPad |origin| (max-norm), up to
  // kFarLimit; beyond that they loop over all spheres. The slab products stay finite below it.
  static constexpr double kOriginPad = 1024.0 * (sizeof(T) == 4 ? 0x1p-24 : 0x1p-53);
  static constexpr double kFarLimit = 1e18;
  bool active() const { return !nodes.empty(); }
  std::size_t bytes() const;
};

// The hierarchy of spheres (centre, radius) in the camera's frame: nodes, origin_limit and
// `order` (leaf-order position -> sphere index). eye_reach: the camera's max-norm distance from
// the frame's origin (Frame::depth). Deterministic: a function of the input only.
template <class T>
Bvh<T> build_bvh(const std::vector<T>& cx, const std::vector<T>& cy, const std::vector<T>& cz,
                 const std::vector<T>& r, int n, std::vector<std::int32_t>& order,
                 double eye_reach = 0);

extern template Bvh<float> build_bvh<float>(const std::vector<float>&, const std::vector<float>&,
                                            const std::vector<float>&, const std::vector<float>&,
                                            int, std::vector<std::int32_t>&, double);
extern template Bvh<double> build_bvh<double>(const std::vector<double>&,
                                              const std::vector<double>&,
                                              const std::vector<double>&,
                                              const std::vector<double>&, int,
                                              std::vector<std::int32_t>&, double);

}  // namespace lancer
