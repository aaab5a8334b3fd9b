// Packet traversal of the sphere hierarchy (lancer/bvh.hpp), apart from the primitive tests: the
// caller's leaf functor tests the spheres of a leaf for the lanes whose ray meets its box.
// Include only from packet/kernel.hpp (code built for the batch's ISA).
//
// Closest hit: the packet visits a wide node's children in the order of the binary splits it was
// collapsed from, the nearer side first by its summed direction's sign on each split's axis, and
// re-culls popped subtrees against the lanes' best t. The result does not depend on the order:
// the leaf functor keeps the lexicographic minimum of (t, object id).
// Camera blocks (closest_coherent): several tiles' packets walk the inner nodes as one interval
// ray, and each tile tests each leaf's box with its own lanes; the same rule makes it exact.
// Any hit: children in their FIXED slot order, depth first, for every packet and ray,
// so each lane meets the objects along its segment in one order on every path (a product of
// transmittances over them is then the same bits everywhere). Stops once no lane is pending.
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

#include "lancer/bvh.hpp"
#include "lancer/packet/cones.hpp"
#include "lancer/packet/fused.hpp"
#include "lancer/packet/lanes.hpp"
#include "lancer/vec3.hpp"

namespace lancer::packet {

// pshufb controls for pushing a 4-wide node's met children as one vector (closest_tiles).
struct PushTables {
  alignas(16) std::uint8_t reverse[256][16];  // per order byte: lane i = slot visited (3-i)th
  alignas(16) std::uint8_t compress[16][16];  // per 4-bit mask: its set lanes first, in order
  alignas(16) std::int32_t arity[5][4];       // lanes < arity set
  std::uint8_t reorder[256][16];  // per order byte and 4-bit mask by slot: that mask by lane
  std::int8_t count[16];          // set bits of a 4-bit mask
};
constexpr PushTables push_tables() {
  PushTables t{};
  for (int o = 0; o < 256; ++o)
    for (int i = 0; i < 4; ++i)
      for (int b = 0; b < 4; ++b)
        t.reverse[o][4 * i + b] = std::uint8_t(4 * ((o >> (2 * (3 - i))) & 3) + b);
  for (int m = 0; m < 16; ++m) {
    int n = 0;
    for (int i = 0; i < 4; ++i)
      if (m >> i & 1) {
        for (int b = 0; b < 4; ++b) t.compress[m][4 * n + b] = std::uint8_t(4 * i + b);
        ++n;
      }
    for (int i = n; i < 4; ++i)
      for (int b = 0; b < 4; ++b) t.compress[m][4 * i + b] = 0x80;  // zero
    t.count[m] = std::int8_t(n);
  }
  for (int a = 0; a <= 4; ++a)
    for (int i = 0; i < 4; ++i) t.arity[a][i] = i < a ? -1 : 0;
  for (int o = 0; o < 256; ++o)
    for (int m = 0; m < 16; ++m)
      for (int i = 0; i < 4; ++i)
        t.reorder[o][m] |= std::uint8_t((m >> ((o >> (2 * (3 - i))) & 3) & 1) << i);
  return t;
}
inline constexpr PushTables kPush = push_tables();

// The camera tiles' register of kBytes bytes (Traversal::TileBounds), named here rather than as
// a template argument, which would drop the vector type's attributes (-Wignored-attributes).
template <int kBytes>
struct TileReg;
template <>
struct TileReg<32> {
  using type = __m256;
};
template <>
struct TileReg<64> {
  using type = __m512;
};

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
struct Traversal {
  using B = xsimd::batch<T, Arch>;
  using M = xsimd::batch_bool<T, Arch>;
  using V = Vec3<B>;
  using Node = typename Bvh<T>::Node;

  // The slab test's form of a ray: t = lo * inv - o * inv, one fused operation per plane. A zero
  // (or tiny) direction component becomes 2^-64: the reciprocal stays finite, so no 0 * inf NaN,
  // and every product stays below FLT_MAX for the loader's coordinates (|x| <= 1e18).
  // pad: per axis, how far (in t) each slab widens for this ray (kPadded traversals only).
  // neg[a]: every live lane's reciprocal on axis a is negative (meaningful only where
  // same_signs() says every live lane agrees on every axis).
  struct Ray {
    V inv, oi, pad;
    bool neg[3];
    std::size_t near[3], far[3];  // signed: byte offsets in a Node of each axis' lo or hi array
  };
  // Sets r's slab form of the ray (o, d), and its pad if kPad (only padded traversals read it;
  // the per-packet walks compute it anyway: without it GCC's any-hit code for width 8 changed
  // and tripped qemu 7.2's AVX2 emulation on random scene 109 of .ci/qemu.sh, as noted in
  // docs/precision.md).
  template <bool kPad>
  static void slab_ray(Ray& r, const V& o, const V& d) noexcept {
    const B tiny(T(0x1p-64));
    auto rcp = [&](const B& x) { return B(T(1)) / xsimd::select(xsimd::abs(x) < tiny, tiny, x); };
    r.inv = V{rcp(d.x), rcp(d.y), rcp(d.z)};
    r.oi = V{o.x * r.inv.x, o.y * r.inv.y, o.z * r.inv.z};
    if constexpr (kPad) {
      // Rays from beyond the origin limit (hits on a far plane): the sphere test's rounding
      // grows with |origin|, so the boxes grow by Bvh::kOriginPad |origin| for them.
      const B far = xsimd::max(xsimd::max(xsimd::abs(o.x), xsimd::abs(o.y)), xsimd::abs(o.z)) *
                    B(T(Bvh<T>::kOriginPad));
      r.pad = V{far * xsimd::abs(r.inv.x), far * xsimd::abs(r.inv.y), far * xsimd::abs(r.inv.z)};
    }
  }

  // Whether the live lanes' reciprocals agree in sign on every axis (coherent packets: camera
  // tiles off the image's centre lines); sets r.neg then.
  static bool same_signs(Ray& r, const M& valid) noexcept {
    const B zero(T(0));
    const B* inv[3] = {&r.inv.x, &r.inv.y, &r.inv.z};
    for (int a = 0; a < 3; ++a) {
      const M neg = *inv[a] < zero;
      if (xsimd::all(neg | !valid))
        r.neg[a] = true;
      else if (!xsimd::any(neg & valid))
        r.neg[a] = false;
      else
        return false;
    }
    set_planes(r);
    return true;
  }
  // r.near and r.far from r.neg.
  static void set_planes(Ray& r) noexcept {
    const std::size_t lo[3] = {offsetof(Node, lo_x), offsetof(Node, lo_y), offsetof(Node, lo_z)};
    const std::size_t hi[3] = {offsetof(Node, hi_x), offsetof(Node, hi_y), offsetof(Node, hi_z)};
    for (int a = 0; a < 3; ++a) {
      r.near[a] = r.neg[a] ? hi[a] : lo[a];
      r.far[a] = r.neg[a] ? lo[a] : hi[a];
    }
  }
  // same_signs' test over several packets: per axis a, neg[a] collects (as lane bits) the live
  // lanes whose reciprocal is negative, pos[a] those whose is not.
  static void add_signs(const Ray& r, unsigned live, unsigned* neg, unsigned* pos) noexcept {
    const B zero(T(0));
    const unsigned x = lane_bits(r.inv.x < zero), y = lane_bits(r.inv.y < zero),
                   z = lane_bits(r.inv.z < zero);
    neg[0] |= x & live, neg[1] |= y & live, neg[2] |= z & live;
    pos[0] |= ~x & live, pos[1] |= ~y & live, pos[2] |= ~z & live;
  }

  // add_signs' result as one code: bit a set where the lanes' reciprocal is negative on axis a,
  // or kMixedSigns where some axis has lanes of both signs.
  static constexpr unsigned kMixedSigns = 8;
  static unsigned sign_code(const unsigned* neg, const unsigned* pos) noexcept {
    if ((neg[0] && pos[0]) || (neg[1] && pos[1]) || (neg[2] && pos[2])) return kMixedSigns;
    return unsigned(neg[0] != 0) | unsigned(neg[1] != 0) << 1 | unsigned(neg[2] != 0) << 2;
  }
  // r's slab form for the sign code (not kMixedSigns) `code`.
  static void set_signs(Ray& r, unsigned code) noexcept {
    for (int a = 0; a < 3; ++a) r.neg[a] = (code >> a & 1u) != 0;
    set_planes(r);
  }

  // How a traversal tests boxes: padded for rays from beyond the origin limit; signed where
  // every live lane agrees on the direction's signs: each slab's near plane is then known per
  // packet (lo * inv <= hi * inv for inv > 0, rounding being monotonic: the same values as
  // generic's min and max), so no min/max per plane.
  enum class Slab { generic, padded, signed_ };

  // The lanes of `active` whose ray meets child k's box within [0, tmax]; tnear: where it enters.
  template <Slab kSlab>
  [[gnu::always_inline]] static M child_hit(const Node& n, int k, const Ray& r, const M& active,
                                            const B& tmax, B& tnear) noexcept {
    if constexpr (kSlab == Slab::signed_)
      return signed_hit(n, k, r.near, r.far, r, active, tmax, tnear);
    const B x0 = fmsub(B(n.lo_x[k]), r.inv.x, r.oi.x), x1 = fmsub(B(n.hi_x[k]), r.inv.x, r.oi.x);
    const B y0 = fmsub(B(n.lo_y[k]), r.inv.y, r.oi.y), y1 = fmsub(B(n.hi_y[k]), r.inv.y, r.oi.y);
    const B z0 = fmsub(B(n.lo_z[k]), r.inv.z, r.oi.z), z1 = fmsub(B(n.hi_z[k]), r.inv.z, r.oi.z);
    B nx = xsimd::min(x0, x1), ny = xsimd::min(y0, y1), nz = xsimd::min(z0, z1);
    B fx = xsimd::max(x0, x1), fy = xsimd::max(y0, y1), fz = xsimd::max(z0, z1);
    if constexpr (kSlab == Slab::padded) {
      nx = nx - r.pad.x, ny = ny - r.pad.y, nz = nz - r.pad.z;
      fx = fx + r.pad.x, fy = fy + r.pad.y, fz = fz + r.pad.z;
    }
    return overlap(nx, ny, nz, fx, fy, fz, active, tmax, tnear);
  }
  // child_hit's signed form, the planes at byte offsets near and far in a Node (a Ray's, or one
  // set for every packet of a camera block).
  [[gnu::always_inline]] static M signed_hit(const Node& n, int k, const std::size_t* near,
                                             const std::size_t* far, const Ray& r, const M& active,
                                             const B& tmax, B& tnear) noexcept {
    const char* base = reinterpret_cast<const char*>(&n) + std::size_t(k) * sizeof(T);
    auto plane = [&](std::size_t off) { return B(*reinterpret_cast<const T*>(base + off)); };
    const B nx = fmsub(plane(near[0]), r.inv.x, r.oi.x), fx = fmsub(plane(far[0]), r.inv.x, r.oi.x);
    const B ny = fmsub(plane(near[1]), r.inv.y, r.oi.y), fy = fmsub(plane(far[1]), r.inv.y, r.oi.y);
    const B nz = fmsub(plane(near[2]), r.inv.z, r.oi.z), fz = fmsub(plane(far[2]), r.inv.z, r.oi.z);
    return overlap(nx, ny, nz, fx, fy, fz, active, tmax, tnear);
  }
  // The lanes of `active` whose slabs (entered at n*, left at f*) overlap within [0, tmax];
  // tnear: where they enter.
  [[gnu::always_inline]] static M overlap(const B& nx, const B& ny, const B& nz, const B& fx,
                                          const B& fy, const B& fz, const M& active, const B& tmax,
                                          B& tnear) noexcept {
    tnear = xsimd::max(xsimd::max(nx, ny), xsimd::max(nz, B(T(0))));
    const B tfar = xsimd::min(xsimd::min(fx, fy), xsimd::min(fz, tmax));
    return active & (tnear <= tfar);
  }
  // How a packet from origins o traverses: 0 as built, 1 with boxes padded per lane, 2 not at
  // all (some lane beyond Bvh::kFarLimit, where the slab products could overflow: the caller
  // loops over all spheres instead).
  static int reach(const Bvh<T>& h, const M& valid, const V& o) noexcept {
    const B m = xsimd::max(xsimd::max(xsimd::abs(o.x), xsimd::abs(o.y)), xsimd::abs(o.z));
    if (!xsimd::any(valid & (m > B(h.origin_limit)))) return 0;
    return xsimd::any(valid & (m > B(T(Bvh<T>::kFarLimit)))) ? 2 : 1;
  }

  // The direction code of a packet (docs/accel.md): bit a set where the lanes' summed
  // direction goes up axis a. It orders a closest-hit traversal's children only.
  static unsigned direction_code(const M& valid, const V& d) noexcept {
    // Pairwise sums through memory (xsimd 8.1's AVX-512 hadd needs AVX512DQ): log2(W) steps.
    alignas(64) T lanes[3][B::size];
    const B* axes[3] = {&d.x, &d.y, &d.z};
    unsigned code = 0;
    for (int a = 0; a < 3; ++a) {
      xsimd::select(valid, *axes[a], B(T(0))).store_aligned(lanes[a]);
      for (std::size_t w = B::size / 2; w > 0; w /= 2)
        for (std::size_t k = 0; k < w; ++k) lanes[a][k] += lanes[a][k + w];
      code |= unsigned(lanes[a][0] >= T(0)) << a;
    }
    return code;
  }

  // The greatest of x's live lanes less the least (valid: some lane live).
  static T live_span(const M& valid, const B& x) noexcept {
    const M v[1] = {valid};
    auto get = [&](int) { return x; };
    return _mm_cvtss_f32(lane_bound<true, 1>(v, get)) - _mm_cvtss_f32(lane_bound<false, 1>(v, get));
  }

  // The subtrees still to visit, with the lanes that met each one's box and where they entered
  // it.
  struct Stack {
    std::int32_t child[Bvh<T>::kStack], count[Bvh<T>::kStack];
    M mask[Bvh<T>::kStack];
    B tnear[Bvh<T>::kStack];
    int sp = 0;
  };

  // The children of n met by the lanes of `mask` within tmax, taken in `order` (slots,
  // Bvh::kOrderBits each): the first becomes (child, count, mask), the node to descend into; the
  // others go onto the stack, the last first, so that they pop in order. False when none is met.
  // Branches rather than masks: coherent packets meet the same children from node to node, and
  // a predicted branch lets the next node's load start before these tests end.
  //
  // Inlined into the closest-hit walk (its ray then stays in registers from node to node: 3.7%
  // more camera rays per second at 65536 spheres, median of 20 alternated runs). Out of line
  // (descend) for the any-hit walk, which `occluded` inlines into every render's shading loop:
  // inlined there too, it added 2-3% instructions to the course scenes at width 8 (out of line,
  // 0.6%). Left to GCC's choice, the counts were as before, but that code tripped qemu 7.2's AVX2
  // emulation (random scene 109 of PacketIdentity.RandomScenes under .ci/qemu.sh).
  template <Slab kSlab>
  [[gnu::always_inline]] static bool descend_inline(const Node& n, unsigned order, const Ray& r,
                                                    M& mask, const B& tmax, Stack& st,
                                                    std::int32_t& child,
                                                    std::int32_t& count) noexcept {
    constexpr int kW = Bvh<T>::kWidth;
    M m[kW];
    B tn[kW];
    int slot[kW];
    unsigned met = 0;
    for (int p = 0; p < kW; ++p) {
      slot[p] = int(order >> (Bvh<T>::kOrderBits * p)) & (kW - 1);
      m[p] = child_hit<kSlab>(n, slot[p], r, mask, tmax, tn[p]);
      met |= unsigned(xsimd::any(m[p])) << p;
    }
    met &= (1u << n.arity) - 1;  // the slots in use come first in every order
#pragma GCC unroll 8
    for (int p = 0; p < kW; ++p) {
      if (!(met >> p & 1)) continue;
#pragma GCC unroll 7
      for (int q = kW - 1; q > p; --q) {
        if (!(met >> q & 1)) continue;
        const int i = st.sp++;
        st.child[i] = n.child[slot[q]], st.count[i] = n.count[slot[q]];
        st.mask[i] = m[q], st.tnear[i] = tn[q];
      }
      child = n.child[slot[p]], count = n.count[slot[p]], mask = m[p];
      return true;
    }
    return false;
  }
  template <Slab kSlab>
  [[gnu::noinline]] static bool descend(const Node& n, unsigned order, const Ray& r, M& mask,
                                        const B& tmax, Stack& st, std::int32_t& child,
                                        std::int32_t& count) noexcept {
    return descend_inline<kSlab>(n, order, r, mask, tmax, st, child, count);
  }

  // No one-ray step: the packet walks every node with its lanes (the step is never called).
  struct PacketsOnly {
    static constexpr int kMaxLanes = 0;
  };

  // leaf(first, count, mask): tests leaf-order spheres [first, first + count) for `mask`,
  // lowering best_t (read here to cull). one(lanes, child, count): where at most
  // one.limit lanes go on into a subtree, walks it for each of them alone, lowering best_t
  // (the hybrid traversal of Benthin et al.).
  template <bool kPadded, class Leaf, class One = PacketsOnly>
  static void closest(const Bvh<T>& h, const M& valid, const V& o, const V& d, const B& best_t,
                      Leaf&& leaf, One&& one = One{}) noexcept {
    Ray r;
    slab_ray<true>(r, o, d);
    if constexpr (kPadded)
      closest_with<Slab::padded>(h, valid, r, d, best_t, leaf, one);
    else if (same_signs(r, valid))
      closest_with<Slab::signed_>(h, valid, r, d, best_t, leaf, one);
    else
      closest_with<Slab::generic>(h, valid, r, d, best_t, leaf, one);
  }

  // ---- one ray over the wide nodes: the hybrid's step below a packet's thinned lanes ----------
  // One ray (float) walks the subtree (child, count) alone: a node's four children tested at
  // once in an xmm (slab values lo * inv - o * inv, as the reference's, padded by pad per axis),
  // the met ones taken in the node's order for the ray's own direction code, nearest first,
  // depth first; a popped entry is culled where it starts beyond the ray's best t.
  struct OneRay4 {
    __m128 inv[3], oi[3], pad[3];
    std::size_t near[3], far[3];  // byte offsets in a Node of each axis' entry and exit planes
    unsigned code;
  };
  static OneRay4 one_ray(const T* o, const T* d, bool padded) noexcept {
    static_assert(std::is_same_v<T, float> && Bvh<T>::kWidth == 4);
    const std::size_t lo[3] = {offsetof(Node, lo_x), offsetof(Node, lo_y), offsetof(Node, lo_z)};
    const std::size_t hi[3] = {offsetof(Node, hi_x), offsetof(Node, hi_y), offsetof(Node, hi_z)};
    OneRay4 r;
    const T m = std::max({std::fabs(o[0]), std::fabs(o[1]), std::fabs(o[2])});
    for (int a = 0; a < 3; ++a) {
      // As slab_ray: a zero direction component becomes 2^-64.
      const T inv = T(1) / (std::fabs(d[a]) < T(0x1p-64) ? T(0x1p-64) : d[a]);
      r.inv[a] = _mm_set1_ps(inv);
      r.oi[a] = _mm_set1_ps(o[a] * inv);
      r.pad[a] = _mm_set1_ps(padded ? m * T(Bvh<T>::kOriginPad) * std::fabs(inv) : T(0));
      // lo * inv <= hi * inv for inv > 0 (monotonic rounding): the entry plane is known.
      r.near[a] = inv < T(0) ? hi[a] : lo[a];
      r.far[a] = inv < T(0) ? lo[a] : hi[a];
    }
    r.code = unsigned(d[0] >= T(0)) | unsigned(d[1] >= T(0)) << 1 | unsigned(d[2] >= T(0)) << 2;
    return r;
  }
  // n <= kN rays walk the subtree (child, count), each alone as above, their steps interleaved:
  // a step tests one ray's node and pops its stack (leaves included) down to its next inner
  // node, then the next ray's step runs while that node's lines are on their way (a lone walk
  // waits for every node it loads: at 65536 spheres and more the nodes come from L3 or memory).
  // The order of a ray's own steps is that of its lone walk, so nothing it finds changes.
  // best_t[i]: ray i's best t; leaf(i, first, count) tests leaf-order spheres
  // [first, first + count) for ray i, lowering *best_t[i].
  template <bool kPadded, int kN, class Leaf>
  static void closest_one(const Bvh<T>& h, const OneRay4* r, int n, std::int32_t child,
                          std::int32_t count, const T* const* best_t, Leaf&& leaf) noexcept {
    walk_one<kPadded, false, kN>(h, r, n, child, count, best_t,
                                 [&](int i, std::int32_t first, std::int32_t c) {
                                   leaf(i, first, c);
                                   return false;
                                 });
  }
  // The any-hit walks of up to kN rays before their tmax[i]: the nodes' fixed slot order (the
  // reference's, which a product of transmits depends on), no cull. leaf(i, first, count) ->
  // true when ray i is done.
  template <bool kPadded, int kN, class Leaf>
  static void any_one(const Bvh<T>& h, const OneRay4* r, int n, std::int32_t child,
                      std::int32_t count, const T* const* tmax, Leaf&& leaf) noexcept {
    walk_one<kPadded, true, kN>(h, r, n, child, count, tmax, leaf);
  }

 private:
  // A lone ray's stack: the met children's references and counts (as the node's child and
  // count) and their entry distances, pushed as shuffled, compacted vectors (PushTables), the
  // nearest on top; a pop reads its child from here, not from the parent node.
  struct OneStack {
    static constexpr int kSize = Bvh<T>::kStack + Bvh<T>::kWidth;
    alignas(16) std::int32_t ref[kSize], cnt[kSize];
    alignas(16) T tnear[kSize];
    int sp;
    std::int32_t node;
  };
  // Tests node n's children for ray r and pushes the met ones (nearest on top; kAny: slot order).
  template <bool kPadded, bool kAny>
  static void push_met(const Node& n, const OneRay4& r, T best_t, OneStack& st) noexcept {
    const char* base = reinterpret_cast<const char*>(&n);
    auto plane = [&](std::size_t off) {
      return _mm_load_ps(reinterpret_cast<const T*>(base + off));
    };
    __m128 tn = _mm_setzero_ps(), tf = _mm_set1_ps(best_t);
    for (int a = 0; a < 3; ++a) {
      __m128 t0 = _mm_sub_ps(_mm_mul_ps(plane(r.near[a]), r.inv[a]), r.oi[a]);
      __m128 t1 = _mm_sub_ps(_mm_mul_ps(plane(r.far[a]), r.inv[a]), r.oi[a]);
      if constexpr (kPadded) t0 = _mm_sub_ps(t0, r.pad[a]), t1 = _mm_add_ps(t1, r.pad[a]);
      tn = _mm_max_ps(tn, t0);
      tf = _mm_min_ps(tf, t1);
    }
    const unsigned met = unsigned(_mm_movemask_ps(_mm_and_ps(
        _mm_cmple_ps(tn, tf),
        _mm_castsi128_ps(_mm_load_si128(reinterpret_cast<const __m128i*>(kPush.arity[n.arity]))))));
    const unsigned order_byte = kAny ? Bvh<T>::kSlotOrder : unsigned(n.order[r.code]);
    const __m128i order =
        _mm_load_si128(reinterpret_cast<const __m128i*>(kPush.reverse[order_byte]));
    const int m = kPush.reorder[order_byte][met];
    const __m128i pack = _mm_load_si128(reinterpret_cast<const __m128i*>(kPush.compress[m]));
    auto push = [&](__m128i v) { return _mm_shuffle_epi8(_mm_shuffle_epi8(v, order), pack); };
    std::int32_t counts;
    std::memcpy(&counts, n.count, sizeof counts);
    _mm_storeu_si128(reinterpret_cast<__m128i*>(st.ref + st.sp),
                     push(_mm_load_si128(reinterpret_cast<const __m128i*>(n.child))));
    _mm_storeu_si128(reinterpret_cast<__m128i*>(st.cnt + st.sp),
                     push(_mm_cvtepi8_epi32(_mm_cvtsi32_si128(counts))));
    if constexpr (!kAny)
      _mm_storeu_si128(reinterpret_cast<__m128i*>(st.tnear + st.sp), push(_mm_castps_si128(tn)));
    st.sp += kPush.count[m];
  }
  template <bool kPadded, bool kAny, int kN, class Leaf>
  static void walk_one(const Bvh<T>& h, const OneRay4* r, int n, std::int32_t child,
                       std::int32_t count, const T* const* best_t, Leaf&& leaf) noexcept {
    if (count >= 0) {  // a leaf: nothing to walk
      for (int i = 0; i < n; ++i) leaf(i, child, count);
      return;
    }
    OneStack st[kN];
    for (int i = 0; i < n; ++i) st[i].sp = 0, st[i].node = child;
    unsigned live = (1u << n) - 1;
    while (live) {
      for (unsigned each = live; each; each &= each - 1) {
        const int i = __builtin_ctz(each);
        OneStack& s = st[i];
        push_met<kPadded, kAny>(h.nodes[std::size_t(s.node)], r[i], *best_t[i], s);
        for (;;) {
          if (s.sp == 0) {
            live &= ~(1u << i);
            break;
          }
          const int q = --s.sp;
          if (!kAny && s.tnear[q] > *best_t[i]) continue;
          if (s.cnt[q] < 0) {
            s.node = s.ref[q];
            break;
          }
          if (leaf(i, s.ref[q], s.cnt[q])) {
            live &= ~(1u << i);
            break;
          }
        }
      }
    }
  }

 public:
  // Camera blocks of kN packets: each tile's interval, several in one register (Tiles16 at
  // width 16, Tiles8 at width 8 with fused fmsub), or else the block's one interval (Block4).
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
  static void closest_coherent(const Bvh<T>& h, const M* valid, const V* o, const V* d,
                               const B* best_t, Leaf&& leaf, Count count = {}) noexcept {
    Ray r[kN];
    unsigned live[kN], neg[3] = {}, pos[3] = {};
    int first = -1;
    unsigned packets = 0;  // the live ones
    for (int i = 0; i < kN; ++i) {
      live[i] = lane_bits(valid[i]);
      if (!live[i]) continue;
      if (first < 0) first = i;
      packets |= 1u << i;
      slab_ray<false>(r[i], o[i], d[i]);
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
        if (!h.eye_reach.empty() && (B::size > 4 || h.max_leaf > 4))
          cones = &cones_of.emplace(d, valid);
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
        closest_with<Slab::signed_>(h, valid[i], r[i], d[i], best_t[i], one);
      else
        closest_with<Slab::generic>(h, valid[i], r[i], d[i], best_t[i], one);
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

 public:
  // leaf(first, count, mask) -> the lanes still pending after that leaf (of `mask`'s and the
  // others). Returns the lanes of `valid` still pending at the end. one(lanes, child, count,
  // pending) -> pending: where at most one.limit pending lanes go on into a subtree, walks it
  // for each of them alone.
  template <bool kPadded, class Leaf, class One = PacketsOnly>
  static M any(const Bvh<T>& h, const M& valid, const V& o, const V& d, const B& tmax, Leaf&& leaf,
               One&& one = One{}) noexcept {
    Ray r;
    slab_ray<true>(r, o, d);
    if constexpr (kPadded)
      return any_with<Slab::padded>(h, valid, r, tmax, leaf, one);
    else if (same_signs(r, valid))
      return any_with<Slab::signed_>(h, valid, r, tmax, leaf, one);
    else
      return any_with<Slab::generic>(h, valid, r, tmax, leaf, one);
  }

 private:
  // ---- coherent packets: one interval test per node (Wald et al.'s interval culling) -------
  // Per axis, the bounds of the live lanes' reciprocals and o * inv. A lane's slab value
  // fmsub(p, inv, oi) lies between fmsub(p, inv_lo or inv_hi, oi_hi) and fmsub(p, inv_lo or
  // inv_hi, oi_lo) exactly; rounding is monotonic, and the bounds round the way the lanes do
  // (fused where they are fused), so the computed bounds hold for the computed lane values: a
  // node's child that some lane meets within its best t passes the interval test. The walk may
  // visit more leaves than the lanes' own tests would; it never skips one a lane needs, and the
  // leaf functor's lexicographic minimum makes the extra visits harmless.
  using F4 = __m128;
  struct Frustum {
    F4 inv_lo[3], inv_hi[3], oi_lo[3], oi_hi[3];
  };
  static F4 fmsub4(F4 a, F4 b, F4 c) noexcept {
    if constexpr (kAvx512<Arch>)      // AVX-512F alone has no 128-bit FMA: a zmm whose upper lanes
      return _mm512_castps512_ps128(  // are zero
          _mm512_fmsub_ps(_mm512_zextps128_ps512(a), _mm512_zextps128_ps512(b),
                          _mm512_zextps128_ps512(c)));
    else if constexpr (kFusedFmsub<Arch>)
      return _mm_fmsub_ps(a, b, c);  // the lanes' fmsub is fused on these paths (fused.hpp)
    else
      return _mm_sub_ps(_mm_mul_ps(a, b), c);
  }
  // The least (kMax: greatest) of get(i)'s lanes over the live lanes of kN packets, in every
  // lane of a 4-float register: the packets folded lane by lane, then the register's halves,
  // then two shuffles (once per block, and after each leaf).
  template <bool kMax, int kN, class Get>
  static F4 lane_bound(const M* valid, Get get) noexcept {
    constexpr T fill =
        kMax ? -std::numeric_limits<T>::infinity() : std::numeric_limits<T>::infinity();
    B v(fill);
    for (int i = 0; i < kN; ++i) {
      const B x = xsimd::select(valid[i], get(i), B(fill));
      v = kMax ? xsimd::max(v, x) : xsimd::min(v, x);
    }
    return reduce<kMax>(v);
  }
  // The least (kMax: greatest) of v's lanes, in every lane of a 4-float register.
  template <bool kMax>
  static F4 reduce(const B& v) noexcept {
    auto op = [](F4 a, F4 b) { return kMax ? _mm_max_ps(a, b) : _mm_min_ps(a, b); };
    F4 m;
    if constexpr (B::size == 16) {
      const __m512 z = v;
      const __m256 lo = _mm512_castps512_ps256(z);
      const __m256 hi = _mm256_castpd_ps(_mm512_extractf64x4_pd(_mm512_castps_pd(z), 1));
      m = op(op(_mm256_castps256_ps128(lo), _mm256_extractf128_ps(lo, 1)),
             op(_mm256_castps256_ps128(hi), _mm256_extractf128_ps(hi, 1)));
    } else if constexpr (B::size == 8) {
      const __m256 y = v;
      m = op(_mm256_castps256_ps128(y), _mm256_extractf128_ps(y, 1));
    } else {
      m = v;
    }
    m = op(m, _mm_shuffle_ps(m, m, _MM_SHUFFLE(2, 3, 0, 1)));
    return op(m, _mm_shuffle_ps(m, m, _MM_SHUFFLE(1, 0, 3, 2)));
  }
  template <int kA>
  static const B& axis(const V& v) noexcept {
    if constexpr (kA == 0)
      return v.x;
    else if constexpr (kA == 1)
      return v.y;
    else
      return v.z;
  }
  template <int kN, int kA>
  static void frustum_axis(Frustum& f, const Ray* r, const M* valid) noexcept {
    // lane_bound's folds, the four in one pass over the packets.
    const B inf(std::numeric_limits<T>::infinity()), ninf(-std::numeric_limits<T>::infinity());
    B inv_lo = inf, inv_hi = ninf, oi_lo = inf, oi_hi = ninf;
    for (int i = 0; i < kN; ++i) {
      const B& inv = axis<kA>(r[i].inv);
      const B& oi = axis<kA>(r[i].oi);
      inv_lo = xsimd::min(inv_lo, xsimd::select(valid[i], inv, inf));
      inv_hi = xsimd::max(inv_hi, xsimd::select(valid[i], inv, ninf));
      oi_lo = xsimd::min(oi_lo, xsimd::select(valid[i], oi, inf));
      oi_hi = xsimd::max(oi_hi, xsimd::select(valid[i], oi, ninf));
    }
    f.inv_lo[kA] = reduce<false>(inv_lo), f.inv_hi[kA] = reduce<true>(inv_hi);
    f.oi_lo[kA] = reduce<false>(oi_lo), f.oi_hi[kA] = reduce<true>(oi_hi);
  }
  // The greatest best t of the live lanes of kN packets.
  template <int kN>
  static F4 far_bound(const M* valid, const B* best_t) noexcept {
    return lane_bound<true, kN>(valid, [&](int i) -> const B& { return best_t[i]; });
  }

  // The children of n the interval ray meets within [0, tmax], as a lane mask (slots < arity);
  // tnear: where it may enter each (a lower bound over the lanes).
  [[gnu::always_inline]] static F4 frustum_hit4(const Node& n, const Frustum& f,
                                                const std::size_t* near, const std::size_t* far,
                                                F4 tmax, F4& tnear) noexcept {
    static_assert(Bvh<T>::kWidth == 4);
    const char* base = reinterpret_cast<const char*>(&n);
    F4 lo = _mm_setzero_ps(), hi = tmax;
    for (int a = 0; a < 3; ++a) {
      const F4 pn = _mm_load_ps(reinterpret_cast<const float*>(base + near[a]));
      const F4 pf = _mm_load_ps(reinterpret_cast<const float*>(base + far[a]));
      // The least of pn * inv over [inv_lo, inv_hi] is at inv_lo where pn >= 0, at inv_hi where
      // pn < 0 (the sign bit picks; at -0 both products are zeros); the greatest of pf * inv
      // the other way round. One fused operation each, then, rather than both and a min or max.
      lo = _mm_max_ps(lo, fmsub4(pn, _mm_blendv_ps(f.inv_lo[a], f.inv_hi[a], pn), f.oi_hi[a]));
      hi = _mm_min_ps(hi, fmsub4(pf, _mm_blendv_ps(f.inv_hi[a], f.inv_lo[a], pf), f.oi_lo[a]));
    }
    tnear = lo;
    return _mm_and_ps(
        _mm_cmple_ps(lo, hi),
        _mm_castsi128_ps(_mm_load_si128(reinterpret_cast<const __m128i*>(kPush.arity[n.arity]))));
  }

  // Width 4 (SSE4.2): the whole block's interval (frustum_hit4), one xmm; a met child goes on
  // with every live packet (closest_tiles' layout of one part).
  template <int kN>
  struct Block4 {
    static constexpr int kTiles = kN;
    static constexpr bool kPerTile = false;  // every live packet goes on with every met child
    Frustum f;
    F4 tmax;
    float tmax_all;
    Block4(const Ray* r, const M* valid) noexcept {
      frustum_axis<kN, 0>(f, r, valid);
      frustum_axis<kN, 1>(f, r, valid);
      frustum_axis<kN, 2>(f, r, valid);
    }
    void bounds(const M* valid, const B* best_t) noexcept {
      tmax = far_bound<kN>(valid, best_t);
      tmax_all = _mm_cvtss_f32(tmax);
    }
    [[gnu::always_inline]] unsigned test(const Node& n, const std::size_t* near,
                                         const std::size_t* far, unsigned in, __m128i& who4,
                                         F4& tn4) const noexcept {
      (void)in, (void)who4;
      return unsigned(_mm_movemask_ps(frustum_hit4(n, f, near, far, tmax, tn4)));
    }
  };

  // ---- each tile's own interval, several tiles in one register ------------------------------
  // Wald et al.'s interval culling per camera tile rather than per block: a node's four boxes
  // against several tiles' intervals at once, lane 4q + k of a register holding tile q against
  // child slot k. A tile's interval bounds its 16 or 8 rays (the block interval's bounds over
  // fewer rays: tighter) for the instructions of one block interval in an xmm. A child goes
  // onto the stack with the tiles that meet it; below it only they are tested, and at a leaf
  // only they run the per-lane box test. Each tile culls with its own greatest best t.
  // Width 16 (Tiles16): four 4x4 tiles a zmm; width 8 (Tiles8, AVX2): two 4x2 tiles a ymm.

  // Packet p's rays' get(p), its dead lanes as +inf (kMax: -inf) so that they bound nothing;
  // kFull: every lane of every packet live.
  template <bool kMax, bool kFull, class Get>
  static B live_lanes(const M* valid, int p, Get get) noexcept {
    if constexpr (kFull) return get(p);
    const B fill(kMax ? -std::numeric_limits<T>::infinity() : std::numeric_limits<T>::infinity());
    return xsimd::select(valid[p], get(p), fill);
  }

  // What Tiles16 and Tiles8 (L) share: per register g (kBytes bytes: F), each tile's bounds
  // (L::bound) of its reciprocals, its o * inv and its best t, and the greatest of the best t
  // (L::greatest).
  template <class L, int kBytes, int kG>
  struct TileBounds {
    using F = typename TileReg<kBytes>::type;
    struct Axes {
      F inv_lo[3], inv_hi[3], oi_lo[3], oi_hi[3];
    } f[kG];
    F tmax[kG];
    float tmax_all;
    TileBounds(const Ray* r, const M* valid) noexcept {
      for (int g = 0; g < kG; ++g)
        for (int a = 0; a < 3; ++a) {
          auto inv = [&](int p) -> const B& {
            return a == 0 ? r[p].inv.x : a == 1 ? r[p].inv.y : r[p].inv.z;
          };
          auto oi = [&](int p) -> const B& {
            return a == 0 ? r[p].oi.x : a == 1 ? r[p].oi.y : r[p].oi.z;
          };
          f[g].inv_lo[a] = L::template bound<false>(valid, g, inv);
          f[g].inv_hi[a] = L::template bound<true>(valid, g, inv);
          f[g].oi_lo[a] = L::template bound<false>(valid, g, oi);
          f[g].oi_hi[a] = L::template bound<true>(valid, g, oi);
        }
    }
    void bounds(const M* valid, const B* best_t) noexcept {
      tmax_all = 0;  // (entry bounds are >= 0)
      for (int g = 0; g < kG; ++g) {
        tmax[g] = L::template bound<true>(valid, g, [&](int p) -> const B& { return best_t[p]; });
        tmax_all = std::max(tmax_all, L::greatest(tmax[g]));
      }
    }
  };

  // Width 16: kG zmm of four 4x4 tiles each.
  template <int kG, bool kFull>
  struct Tiles16 : TileBounds<Tiles16<kG, kFull>, 64, kG> {
    static constexpr int kTiles = 4 * kG;
    using F16 = __m512;
    using TileBounds<Tiles16, 64, kG>::TileBounds;
    using TileBounds<Tiles16, 64, kG>::f;
    using TileBounds<Tiles16, 64, kG>::tmax;
    static constexpr bool kPerTile = true;  // a child goes on with the tiles that meet it
    // The least (kMax: greatest) lane of x[p], in lanes 4p to 4p + 3 (lanes.hpp).
    template <bool kMax>
    static F16 reduce(const F16* x) noexcept {
      return fold_quarters<kMax>(x);
    }
    template <bool kMax, class Get>
    static F16 bound(const M* valid, int g, Get get) noexcept {
      F16 x[4];
      for (int p = 0; p < 4; ++p) x[p] = live_lanes<kMax, kFull>(valid, 4 * g + p, get);
      return reduce<kMax>(x);
    }
    // Each tile's four lanes are equal: the greatest of lanes 0, 4, 8 and 12.
    static float greatest(F16 t) noexcept {
      const F16 m = _mm512_max_ps(t, _mm512_shuffle_f32x4(t, t, _MM_SHUFFLE(1, 0, 3, 2)));
      return _mm512_cvtss_f32(
          _mm512_max_ps(m, _mm512_shuffle_f32x4(m, m, _MM_SHUFFLE(2, 3, 0, 1))));
    }
    // The children (bits by slot) some tile of `in` meets within its t; per child (lane k) the
    // tiles that meet it and the least entry bound of those.
    [[gnu::always_inline]] unsigned test(const Node& n, const std::size_t* near,
                                         const std::size_t* far, unsigned in, __m128i& who4,
                                         F4& tn4) const noexcept {
      static constexpr std::uint16_t kLanes[16] = {0x0000, 0x000F, 0x00F0, 0x00FF, 0x0F00, 0x0F0F,
                                                   0x0FF0, 0x0FFF, 0xF000, 0xF00F, 0xF0F0, 0xF0FF,
                                                   0xFF00, 0xFF0F, 0xFFF0, 0xFFFF};
      const char* base = reinterpret_cast<const char*>(&n);
      const unsigned slots = 0x1111u * ((1u << n.arity) - 1);
      const __m512i zero = _mm512_setzero_si512();
      const __m512i bit = _mm512_setr_epi32(1, 1, 1, 1, 2, 2, 2, 2, 4, 4, 4, 4, 8, 8, 8, 8);
      const F16 inf = _mm512_set1_ps(std::numeric_limits<float>::infinity());
      unsigned met = 0;
      __m512i who = _mm512_setzero_si512();
      F16 tn = inf;
      for (int g = 0; g < kG; ++g) {
        F16 lo = _mm512_setzero_ps(), hi = tmax[g];
        for (int a = 0; a < 3; ++a) {
          const F16 pn =
              _mm512_broadcast_f32x4(_mm_load_ps(reinterpret_cast<const float*>(base + near[a])));
          const F16 pf =
              _mm512_broadcast_f32x4(_mm_load_ps(reinterpret_cast<const float*>(base + far[a])));
          // The bound the plane's sign bit picks, as frustum_hit4's blendv.
          const __mmask16 nneg = _mm512_cmplt_epi32_mask(_mm512_castps_si512(pn), zero);
          const __mmask16 fneg = _mm512_cmplt_epi32_mask(_mm512_castps_si512(pf), zero);
          lo = _mm512_max_ps(
              lo, _mm512_fmsub_ps(pn, _mm512_mask_blend_ps(nneg, f[g].inv_lo[a], f[g].inv_hi[a]),
                                  f[g].oi_hi[a]));
          hi = _mm512_min_ps(
              hi, _mm512_fmsub_ps(pf, _mm512_mask_blend_ps(fneg, f[g].inv_hi[a], f[g].inv_lo[a]),
                                  f[g].oi_lo[a]));
        }
        const __mmask16 m = _mm512_mask_cmp_ps_mask(__mmask16(kLanes[in >> (4 * g) & 0xF] & slots),
                                                    lo, hi, _CMP_LE_OQ);
        met |= m;
        who = _mm512_or_si512(who,
                              _mm512_maskz_mov_epi32(m, _mm512_slli_epi32(bit, unsigned(4 * g))));
        tn = _mm512_min_ps(tn, _mm512_mask_mov_ps(inf, m, lo));
      }
      who = _mm512_or_si512(who, _mm512_shuffle_i32x4(who, who, _MM_SHUFFLE(1, 0, 3, 2)));
      who = _mm512_or_si512(who, _mm512_shuffle_i32x4(who, who, _MM_SHUFFLE(2, 3, 0, 1)));
      tn = _mm512_min_ps(tn, _mm512_shuffle_f32x4(tn, tn, _MM_SHUFFLE(1, 0, 3, 2)));
      tn = _mm512_min_ps(tn, _mm512_shuffle_f32x4(tn, tn, _MM_SHUFFLE(2, 3, 0, 1)));
      who4 = _mm512_castsi512_si128(who), tn4 = _mm512_castps512_ps128(tn);
      met |= met >> 8, met |= met >> 4;  // from the masks: a shorter chain than through who
      return met & 0xF;
    }
  };

  // Width 8 (AVX2): kG ymm of two 4x2 tiles each.
  template <int kG, bool kFull>
  struct Tiles8 : TileBounds<Tiles8<kG, kFull>, 32, kG> {
    static constexpr int kTiles = 2 * kG;
    using F8 = __m256;
    using TileBounds<Tiles8, 32, kG>::TileBounds;
    using TileBounds<Tiles8, 32, kG>::f;
    using TileBounds<Tiles8, 32, kG>::tmax;
    static constexpr bool kPerTile = true;
    // Of tiles 2g and 2g + 1: the least (kMax: greatest) in lanes 0-3 and 4-7.
    template <bool kMax, class Get>
    static F8 bound(const M* valid, int g, Get get) noexcept {
      auto op = [](F8 a, F8 b) { return kMax ? _mm256_max_ps(a, b) : _mm256_min_ps(a, b); };
      const F8 a = live_lanes<kMax, kFull>(valid, 2 * g, get);
      const F8 b = live_lanes<kMax, kFull>(valid, 2 * g + 1, get);
      F8 u = op(_mm256_permute2f128_ps(a, b, 0x20), _mm256_permute2f128_ps(a, b, 0x31));
      u = op(u, _mm256_permute_ps(u, _MM_SHUFFLE(2, 3, 0, 1)));
      return op(u, _mm256_permute_ps(u, _MM_SHUFFLE(1, 0, 3, 2)));
    }
    // Each tile's lanes are equal: the greater of lanes 0 and 4.
    static float greatest(F8 t) noexcept {
      return _mm_cvtss_f32(_mm_max_ps(_mm256_castps256_ps128(t), _mm256_extractf128_ps(t, 1)));
    }
    [[gnu::always_inline]] unsigned test(const Node& n, const std::size_t* near,
                                         const std::size_t* far, unsigned in, __m128i& who4,
                                         F4& tn4) const noexcept {
      const char* base = reinterpret_cast<const char*>(&n);
      const unsigned slots = 0x11u * ((1u << n.arity) - 1);
      const __m256i lane_bit = _mm256_setr_epi32(1, 2, 4, 8, 16, 32, 64, 128);
      const F8 inf = _mm256_set1_ps(std::numeric_limits<float>::infinity());
      unsigned met = 0;
      __m128i who = _mm_setzero_si128();
      F8 tn = inf;
      for (int g = 0; g < kG; ++g) {
        F8 lo = _mm256_setzero_ps(), hi = tmax[g];
        for (int a = 0; a < 3; ++a) {
          const F8 pn = _mm256_broadcast_ps(reinterpret_cast<const __m128*>(base + near[a]));
          const F8 pf = _mm256_broadcast_ps(reinterpret_cast<const __m128*>(base + far[a]));
          lo = _mm256_max_ps(
              lo, _mm256_fmsub_ps(pn, _mm256_blendv_ps(f[g].inv_lo[a], f[g].inv_hi[a], pn),
                                  f[g].oi_hi[a]));
          hi = _mm256_min_ps(
              hi, _mm256_fmsub_ps(pf, _mm256_blendv_ps(f[g].inv_hi[a], f[g].inv_lo[a], pf),
                                  f[g].oi_lo[a]));
        }
        const unsigned q = in >> (2 * g);
        const unsigned active = ((q & 1u) * 0x0Fu | (q >> 1 & 1u) * 0xF0u) & slots;
        const F8 hit = _mm256_and_ps(_mm256_cmp_ps(lo, hi, _CMP_LE_OQ),
                                     _mm256_castsi256_ps(_mm256_cmpgt_epi32(
                                         _mm256_and_si256(_mm256_set1_epi32(int(active)), lane_bit),
                                         _mm256_setzero_si256())));
        met |= unsigned(_mm256_movemask_ps(hit));
        const __m128i h0 = _mm_castps_si128(_mm256_castps256_ps128(hit));
        const __m128i h1 = _mm_castps_si128(_mm256_extractf128_ps(hit, 1));
        who = _mm_or_si128(who, _mm_or_si128(_mm_and_si128(h0, _mm_set1_epi32(1 << (2 * g))),
                                             _mm_and_si128(h1, _mm_set1_epi32(2 << (2 * g)))));
        tn = _mm256_min_ps(tn, _mm256_blendv_ps(inf, lo, hit));
      }
      who4 = who;
      tn4 = _mm_min_ps(_mm256_castps256_ps128(tn), _mm256_extractf128_ps(tn, 1));
      return (met | met >> 4) & 0xF;
    }
  };

  // Tile i of a camera block walks the subtree of inner node `start` alone, with its own lanes
  // and best t and the block's slab form, from the block's direction code (bit a set where the
  // rays go up axis a: the complement of its sign code). Inlined into the block walk: out of
  // line measured 1-2% slower at 65536 spheres.
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
          const unsigned tiles = cones->keep(h.eye_fx.data(), h.eye_fy.data(), h.eye_fz.data(),
                                             h.eye_reach.data(), f, c, which);
          count.cones(c, __builtin_popcount(which[i]));
          if (tiles >> i & 1u) leaf(i, f, c, lanes, which[i]);
          return;
        }
      }
      leaf(i, f, c, lanes);
    };
    PacketsOnly none;
    closest_from<Slab::signed_>(h, valid, r, code, start, best_t, one, none);
  }

  // Inner nodes by the layout's interval test (Tiles16, Tiles8, Block4); a leaf by each lane's
  // own test of its box, so the spheres see only the lanes that meet it. The stack holds boxes
  // (node index * kWidth + slot: the child's reference and box are read from its parent when
  // popped), where the rays may enter them and the packets that met them (bit i: packet i).
  // Without branches on which children were met: a node's children go onto the stack as one
  // shuffled, compacted vector (PushTables), last in order first, the stack growing by the met
  // ones only; which children a block meets is what a branch predictor cannot learn (at 65536
  // spheres mispredictions, not instructions, grew most with the scene).
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
    // The tiles of `in` against leaf-order spheres [first, first + n) by their cones, each tile
    // then testing the spheres its cone may meet with all its live lanes (no per-lane box test).
    // Width 4's block interval has no tiles per child: there each tile first tests the box of
    // (parent, k) with its lanes, and only the registers of the tiles that meet it test cones.
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
      const unsigned meet = tested & cones->keep(h.eye_fx.data(), h.eye_fy.data(), h.eye_fz.data(),
                                                 h.eye_reach.data(), first_sphere, n, which, regs);
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

  template <Slab kSlab, class Leaf>
  static void closest_with(const Bvh<T>& h, const M& valid, const Ray& r, const V& d,
                           const B& best_t, Leaf& leaf) noexcept {
    PacketsOnly none;
    closest_with<kSlab>(h, valid, r, d, best_t, leaf, none);
  }
  template <Slab kSlab, class Leaf, class One>
  static void closest_with(const Bvh<T>& h, const M& valid, const Ray& r, const V& d,
                           const B& best_t, Leaf& leaf, One& one) noexcept {
    // Signed: every lane goes the same way along each axis; else the lanes' summed direction.
    const unsigned code = kSlab == Slab::signed_ ? unsigned(!r.neg[0]) | unsigned(!r.neg[1]) << 1 |
                                                       unsigned(!r.neg[2]) << 2
                                                 : direction_code(valid, d);
    closest_from<kSlab>(h, valid, r, code, 0, best_t, leaf, one);
  }
  // closest_with's walk of the subtree of inner node `start` (0: the whole hierarchy), children
  // in the order of direction code `code`.
  template <Slab kSlab, class Leaf, class One>
  static void closest_from(const Bvh<T>& h, const M& valid, const Ray& r, unsigned code,
                           std::int32_t start, const B& best_t, Leaf& leaf, One& one) noexcept {
    Stack st;
    std::int32_t child = start, count = -1;
    M mask = valid;
    for (;;) {
      if constexpr (One::kMaxLanes > 0) {
        if (const unsigned lanes = lane_bits(mask); __builtin_popcount(lanes) <= one.limit) {
          one(lanes, child, count);
          goto next;
        }
      } else if (false) {
        goto next;  // packets only: the label stays used (no -Wunused-label), the code is dead
      }
      if (count < 0) {
        const Node& n = h.nodes[std::size_t(child)];
        if (descend_inline<kSlab>(n, unsigned(n.order[code]), r, mask, best_t, st, child, count))
          continue;
      } else {
        leaf(child, count, mask);
      }
    next:
      for (;;) {  // the next subtree some lane may still find a nearer hit in
        if (st.sp == 0) return;
        const int i = --st.sp;
        mask = st.mask[i] & (st.tnear[i] <= best_t);
        if (xsimd::any(mask)) {
          child = st.child[i], count = st.count[i];
          break;
        }
      }
    }
  }

  template <Slab kSlab, class Leaf, class One>
  static M any_with(const Bvh<T>& h, const M& valid, const Ray& r, const B& tmax, Leaf& leaf,
                    One& one) noexcept {
    Stack st;
    std::int32_t child = 0, count = -1;
    M pending = valid, mask = valid;
    for (;;) {
      if constexpr (One::kMaxLanes > 0) {
        if (const unsigned lanes = lane_bits(mask); __builtin_popcount(lanes) <= one.limit) {
          pending = one(lanes, child, count, pending);
          if (!xsimd::any(pending)) return pending;
          goto next;
        }
      } else if (false) {
        goto next;  // as in closest_with
      }
      if (count < 0) {
        if (descend<kSlab>(h.nodes[std::size_t(child)], Bvh<T>::kSlotOrder, r, mask, tmax, st,
                           child, count))
          continue;
      } else {
        pending = leaf(child, count, mask, pending);
        if (!xsimd::any(pending)) return pending;
      }
    next:
      for (;;) {
        if (st.sp == 0) return pending;
        const int i = --st.sp;
        mask = st.mask[i] & pending;
        if (xsimd::any(mask)) {
          child = st.child[i], count = st.count[i];
          break;
        }
      }
    }
  }
};

}  // namespace lancer::packet
