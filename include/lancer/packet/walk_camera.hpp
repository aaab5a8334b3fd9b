// The camera blocks' walk: several camera tiles' packets walk the hierarchy's inner nodes
// together by their intervals (tile_intervals.hpp), each tile tests each leaf's box (or its
// cone, cones.hpp) with its own lanes. The same lexicographic minimum of (t, id) as every walk
// makes it exact. Include only from code built for the batch's ISA.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <limits>
#include <optional>
#include <type_traits>
#include <xsimd/xsimd.hpp>

#include "lancer/packet/cones.hpp"
#include "lancer/packet/tile_intervals.hpp"
#include "lancer/prepared.hpp"

namespace lancer::packet {

// What the camera blocks' walk tells a counter (lancer profile's camera blocks): the default
// counts nothing and compiles to nothing.
struct NoWalkCount {
  void block(bool /*together*/) const noexcept {}
  void node() const noexcept {}
  void leaf_pop() const noexcept {}
  void tile_test() const noexcept {}
  void leaf_call(unsigned /*lanes*/) const noexcept {}
  void tile_alone() const noexcept {}
  void cones(int /*pairs*/, int /*kept*/) const noexcept {}
};

template <class Arch, class T>
struct CameraWalk : TileIntervals<Arch, T> {
  using Base = TileIntervals<Arch, T>;
  using typename Base::B;
  using typename Base::F4;
  using typename Base::M;
  using typename Base::Node;
  using typename Base::PacketsOnly;
  using typename Base::Ray;
  using typename Base::Slab;
  using typename Base::V;
  template <int kN>
  using Block4 = typename Base::template Block4<kN>;
  template <int kG, bool kFull>
  using Tiles16 = typename Base::template Tiles16<kG, kFull>;
  template <int kG, bool kFull>
  using Tiles8 = typename Base::template Tiles8<kG, kFull>;
  using Base::add_signs;
  using Base::closest_from;
  using Base::closest_with;
  using Base::kMixedSigns;
  using Base::same_signs;
  using Base::set_signs;
  using Base::sign_code;
  using Base::signed_hit;
  using Base::slab_ray;

  template <int kN>
  static constexpr bool kTiles16 = kN % 4 == 0 && kAvx512<Arch>;
  template <int kN>
  static constexpr bool kTiles8 = B::size == 8 && kN % 2 == 0 && kFusedFmsub<Arch>;
  // Tile cones (cones.hpp): float blocks of whole registers of tiles, one tile a lane.
  static constexpr bool kConesFit =
      std::is_same_v<T, float> && (B::size == 16 || B::size == 8 || B::size == 4);
  template <int kN>
  static constexpr bool kTileCones = kConesFit&& kN % int(B::size) == 0 && kN <= 32;
  template <int kN>
  using Cones = TileCones<Arch, kN>;

  // kN camera packets at once (tiles side by side): leaf(i, first, count, mask) tests leaf-order
  // spheres [first, first + count) for the lanes `mask` of packet i, lowering best_t[i].
  // Packets whose live lanes agree in sign on every axis walk the hierarchy together
  // (closest_tiles): a node costs one interval test for several tiles; a packet whose lanes
  // do not walks alone. Packets without live lanes take no part.
  // count: a NoWalkCount's interface, told of each block (whether any of its packets walked
  // together), node test, leaf pop, tile-by-leaf box test and leaf call.
  template <int kN, class Leaf, class Count = NoWalkCount>
  static void closest_coherent(const Bvh<T>& h, const EyeSphere<T>& eye, const M* valid, const V* o,
                               const V* d, const B* best_t, Leaf&& leaf,
                               Count count = {}) noexcept {
    Ray r[kN];
    unsigned live[kN], neg[3] = {}, pos[3] = {};
    int first = -1;
    unsigned packets = 0;  // the live ones
    for (int i = 0; i < kN; ++i) {
      live[i] = lane_bits(valid[i]);
      if (!live[i]) continue;
      if (first < 0) first = i;
      packets |= 1u << i;
      Base::template slab_ray<false>(r[i], o[i], d[i]);
      add_signs(r[i], live[i], neg, pos);
    }
    if (first < 0) return;
    unsigned alone = packets;  // the packets that walk by themselves
    if constexpr (std::is_same_v<T, float>) {
      // Each tile's cone (cones.hpp: a tile a lane), where the eye's table is there (float
      // pinhole cameras).
      std::conditional_t<kTileCones<kN>, std::optional<Cones<kN>>, char> cones_of{};
      const Cones<kN>* cones = nullptr;
      // Width 4's (four registers a sphere, after each tile's box test) pay only with a large
      // scene's large leaves (Bvh::max_leaf): 1.2x the time at 1024 spheres.
      if constexpr (kTileCones<kN>)
        if (!eye.reach.empty() && (B::size > 4 || h.max_leaf > 4))
          cones = &cones_of.emplace(d, valid, eye);
      // A packet without live lanes takes the first one's ray: its lanes, all outside `valid`,
      // then take part in no bound and no leaf (closest_tiles does not branch on liveness).
      for (int i = 0; i < kN; ++i)
        if (!live[i]) r[i] = r[first];
      if (const unsigned code = sign_code(neg, pos); code != kMixedSigns) {
        // One sign per axis over the block: one slab form for every packet.
        set_signs(r[first], code);  // every packet's (closest_tiles reads only the first's)
        bool full = true;
        for (int i = 0; i < kN; ++i) full = full && live[i] == (1u << B::size) - 1;
        count.block(true);
        return closest_block<kN>(h, valid, r, first, packets, full, best_t, leaf, count, cones);
      }
      // A block on the image's centre lines. With each tile's own interval (widths 16 and 8)
      // the tiles on each side of the lines walk together, a tile a line crosses alone; the
      // block's one interval (width 4) is loose there (the reciprocals of near-zero directions
      // spread widely: 8% slower at 65536 spheres), so every packet walks alone.
      if constexpr (kTiles16<kN> || kTiles8<kN>)
        alone = walk_sides<kN>(h, valid, r, packets, best_t, leaf, count, cones);
    }
    count.block(alone != packets);  // some of its packets walked together
    for (unsigned t = alone; t; t &= t - 1) {
      const int i = __builtin_ctz(t);
      auto one = [&](std::int32_t f, std::int32_t c, const M& m) { leaf(i, f, c, m); };
      if (same_signs(r[i], valid[i]))
        Base::template closest_with<Slab::signed_>(h, valid[i], r[i], d[i], best_t[i], one);
      else
        Base::template closest_with<Slab::generic>(h, valid[i], r[i], d[i], best_t[i], one);
    }
  }

 private:
  // The live packets of a block whose lanes differ in sign on some axis, by their own signs:
  // those of one sign per axis walk together, one walk per combination of signs (per side of
  // the image's centre lines). Returns the packets whose own lanes differ in sign, which are
  // left to walk alone.
  template <int kN, class Leaf, class Count>
  static unsigned walk_sides(const Bvh<T>& h, const M* valid, Ray* r, unsigned packets,
                             const B* best_t, Leaf& leaf, Count count,
                             const Cones<kN>* cones) noexcept {
    unsigned code[kN], alone = 0;
    for (unsigned t = packets; t; t &= t - 1) {
      const int i = __builtin_ctz(t);
      unsigned neg[3] = {}, pos[3] = {};
      add_signs(r[i], lane_bits(valid[i]), neg, pos);
      code[i] = sign_code(neg, pos);
      if (code[i] == kMixedSigns) alone |= 1u << i;
    }
    for (unsigned todo = packets & ~alone; todo;) {
      const int f = __builtin_ctz(todo);
      unsigned side = 0;  // the packets of f's signs
      for (unsigned t = todo; t; t &= t - 1)
        if (code[__builtin_ctz(t)] == code[f]) side |= 1u << __builtin_ctz(t);
      todo &= ~side;
      set_signs(r[f], code[f]);  // closest_tiles reads only the first packet's planes
      M in_side[kN];             // the other packets take part in no bound
      for (int i = 0; i < kN; ++i) in_side[i] = side >> i & 1u ? valid[i] : M(false);
      closest_block<kN>(h, in_side, r, f, side, false, best_t, leaf, count, cones);
    }
    return alone;
  }

  // The tiles `packets` (one sign per axis, the planes of packet `first`) walk together; full:
  // every lane of every packet live.
  // cones: the tiles' cones (null: none), each walk instantiated with and without them.
  template <int kN, class Leaf, class Count>
  static void closest_block(const Bvh<T>& h, const M* valid, const Ray* r, int first,
                            unsigned packets, bool full, const B* best_t, Leaf& leaf, Count count,
                            const Cones<kN>* cones) noexcept {
    constexpr bool k16 = kTiles16<kN>, k8 = kTiles8<kN>;
    auto walk = [&](auto layout) {
      using Tiles = typename decltype(layout)::type;
      if constexpr (kTileCones<kN>)
        if (cones)
          return closest_tiles<Tiles, true>(h, valid, r, first, packets, best_t, leaf, count,
                                            cones);
      return closest_tiles<Tiles, false>(h, valid, r, first, packets, best_t, leaf, count, cones);
    };
    if constexpr (k16 || k8) {
      using Full = std::conditional_t<k16, Tiles16<kN / 4, true>, Tiles8<kN / 2, true>>;
      using Cut = std::conditional_t<k16, Tiles16<kN / 4, false>, Tiles8<kN / 2, false>>;
      if (full) return walk(std::common_type<Full>{});
      return walk(std::common_type<Cut>{});
    }
    return walk(std::common_type<Block4<kN>>{});
  }

  // With the tiles' cones, a leaf's spheres go to the tile only where its cone may meet them.
  template <class Leaf, class Count, class Cn>
  [[gnu::always_inline]] static void tile_alone(const Bvh<T>& h, const M& valid, const Ray& tile,
                                                unsigned code, std::int32_t start, const B& best_t,
                                                int i, Leaf& leaf, const Cn* cones,
                                                Count count) noexcept {
    Ray r = tile;
    set_signs(r, ~code & 7u);
    auto one = [&](std::int32_t f, std::int32_t c, const M& lanes) {
      if constexpr (kConesFit) {
        if (cones) {
          alignas(64) std::uint32_t which[32];
          const unsigned tiles = cones->keep(f, c, which);
          count.cones(c, __builtin_popcount(which[i]));
          if (tiles >> i & 1u) leaf(i, f, c, lanes, which[i]);
          return;
        }
      }
      leaf(i, f, c, lanes);
    };
    PacketsOnly none;
    Base::template closest_from<Slab::signed_>(h, valid, r, code, start, best_t, one, none);
  }

  // Inner nodes by the layout's interval test (Tiles16, Tiles8, Block4); a leaf by each lane's
  // own test of its box, so the spheres see only the lanes that meet it. The stack holds boxes
  // (node index * kWidth + slot: the child's reference and box are read from its parent when
  // popped), where the rays may enter them and the packets that met them (bit i: packet i).
  // Without branches on which children were met: a node's children go onto the stack as one
  // shuffled, compacted vector (PushTables), last in order first, the stack growing by the met
  // ones only; which children a block meets is what a branch predictor cannot learn (at 65536
  // spheres mispredictions, not instructions, grew most with the scene).
  // With cones, a leaf's spheres [first, first + n) go to the tiles of `in` by their cones, each
  // tile then testing the spheres its cone may meet with all its live lanes (no per-lane box
  // test). Width 4's block interval has no tiles per child: there each tile first tests the box
  // of (parent, k) with its lanes, and only the registers of the tiles that meet it test cones.
  // Out of line, as GCC chose before the walk took a counter (which changed its choice).
  template <class Tiles, bool kCones, class Leaf, class Count>
  [[gnu::noinline]] static void closest_tiles(const Bvh<T>& h, const M* valid, const Ray* r,
                                              int first, unsigned packets, const B* best_t,
                                              Leaf&& leaf, Count count,
                                              const Cones<Tiles::kTiles>* cones) noexcept {
    constexpr int kW = Bvh<T>::kWidth;
    static_assert(kW == 4 && sizeof(typename Bvh<T>::Order) == 1);
    Tiles tiles(r, valid);
    tiles.bounds(valid, best_t);
    const std::size_t* near = r[first].near;
    const std::size_t* far = r[first].far;
    const unsigned code = unsigned(!r[first].neg[0]) | unsigned(!r[first].neg[1]) << 1 |
                          unsigned(!r[first].neg[2]) << 2;
    constexpr int kSize = Bvh<T>::kStack + kW;  // + kW: a full vector stored at the top
    alignas(16) std::int32_t box[kSize], who[kSize];
    alignas(16) T tnear[kSize];
    int sp = 0;
    const __m128i iota = _mm_setr_epi32(0, 1, 2, 3);
    std::int32_t node = 0;
    unsigned in = packets;  // the tiles that met the node's box
    // cone_leaf: the tiles of `in` against a leaf's spheres by their cones (below).
    auto cone_leaf = [&](std::int32_t first_sphere, std::int32_t n, const Node& parent, int k) {
      alignas(64) std::uint32_t which[Tiles::kTiles];
      unsigned tested = in, regs = ~0u;
      M lanes[Tiles::kPerTile ? 1 : Tiles::kTiles];
      if constexpr (!Tiles::kPerTile) {
        tested = 0, regs = 0;
        for (unsigned ps = in; ps; ps &= ps - 1) {
          const int i = __builtin_ctz(ps);
          B tn_leaf;
          lanes[i] = signed_hit(parent, k, near, far, r[i], valid[i], best_t[i], tn_leaf);
          if (xsimd::any(lanes[i])) tested |= 1u << i, regs |= 1u << (i / int(B::size));
        }
      }
      const unsigned meet = tested & cones->keep(first_sphere, n, which, regs);
      for (unsigned ps = tested; ps; ps &= ps - 1) {
        count.tile_test();
        count.cones(n, __builtin_popcount(which[__builtin_ctz(ps)]));
      }
      for (unsigned ps = meet; ps; ps &= ps - 1) {
        const int i = __builtin_ctz(ps);
        const M& m = Tiles::kPerTile ? valid[i] : lanes[Tiles::kPerTile ? 0 : i];
        count.leaf_call(lane_bits(m));
        leaf(i, first_sphere, n, m, which[i]);
      }
      if (meet) tiles.bounds(valid, best_t);
    };
    for (;;) {
      count.node();
      const Node& n = h.nodes[std::size_t(node)];
      // The bounds read from memory at each node (their loads fold into the fused operations):
      // hoisted into registers, GCC spilled and reloaded all of them around every leaf call.
      const Tiles* tp = &tiles;
      asm("" : "+r"(tp));
      __m128i who4 = _mm_setzero_si128();
      F4 tn4;
      const unsigned met = tp->test(n, near, far, in, who4, tn4);
      const __m128i order =
          _mm_load_si128(reinterpret_cast<const __m128i*>(kPush.reverse[n.order[code]]));
      const int m = kPush.reorder[n.order[code]][met];  // the met slots in the order's lanes
      const __m128i pack = _mm_load_si128(reinterpret_cast<const __m128i*>(kPush.compress[m]));
      auto push = [&](__m128i v) { return _mm_shuffle_epi8(_mm_shuffle_epi8(v, order), pack); };
      const __m128i boxes = _mm_add_epi32(_mm_set1_epi32(node * kW), iota);
      _mm_storeu_si128(reinterpret_cast<__m128i*>(box + sp), push(boxes));
      if constexpr (Tiles::kPerTile)
        _mm_storeu_si128(reinterpret_cast<__m128i*>(who + sp), push(who4));
      _mm_storeu_si128(reinterpret_cast<__m128i*>(tnear + sp), push(_mm_castps_si128(tn4)));
      sp += kPush.count[m];
      for (;;) {  // the next subtree some lane may still find a nearer hit in
        if (sp == 0) return;
        --sp;
        if (tnear[sp] > tp->tmax_all) continue;
        const Node& parent = h.nodes[std::size_t(unsigned(box[sp]) / kW)];
        const int k = int(unsigned(box[sp]) % kW);
        if constexpr (Tiles::kPerTile) in = unsigned(who[sp]);
        if (parent.count[k] < 0) {
          node = parent.child[k];
          if constexpr (kCones) {
            // A node of leaves only: its spheres (consecutive in leaf order) as one leaf, the
            // node itself not read.
            if (parent.count[k] < -1) {
              count.leaf_pop();
              cone_leaf(h.first_sphere[std::size_t(node)], -2 - parent.count[k], parent, k);
              continue;
            }
          }
          // A subtree one tile alone goes on into: the tile walks it as its own packet, each
          // lane tested against each child, the descent a branch (closest_with), rather than
          // with the block's bounds and registers.
          if (Tiles::kPerTile && !(in & (in - 1))) {
            const int i = __builtin_ctz(in);
            count.tile_alone();
            tile_alone(h, valid[i], r[i], code, node, best_t[i], i, leaf, kCones ? cones : nullptr,
                       count);
            tiles.bounds(valid, best_t);
            continue;
          }
          break;
        }
        bool tested = false;
        count.leaf_pop();
        const std::int32_t first_sphere = parent.child[k], spheres = parent.count[k];
        if constexpr (kCones) {
          cone_leaf(first_sphere, spheres, parent, k);
          continue;
        }
        for (unsigned ps = in; ps; ps &= ps - 1) {
          const int i = __builtin_ctz(ps);
          B tn_leaf;
          count.tile_test();
          const M lanes = signed_hit(parent, k, near, far, r[i], valid[i], best_t[i], tn_leaf);
          if (xsimd::any(lanes)) {
            count.leaf_call(lane_bits(lanes));
            leaf(i, first_sphere, spheres, lanes);
            tested = true;
          }
        }
        if (tested) tiles.bounds(valid, best_t);
      }
    }
  }
};

}  // namespace lancer::packet
