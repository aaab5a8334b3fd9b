// One ray over the wide nodes, the hybrid's step below a packet's thinned lanes (Benthin et al.):
// a packet's lanes that go on alone walk a subtree each by itself, their steps interleaved.
// Include only from code built for the batch's ISA.
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

#include "lancer/packet/push_tables.hpp"
#include "lancer/packet/walk_packet.hpp"

namespace lancer::packet {

// The x86 register of kBytes bytes of T, named here rather than passed as a template argument,
// which would drop the vector type's attributes (GCC's -Wignored-attributes).
template <class T, int kBytes>
struct VecReg;
template <>
struct VecReg<float, 16> {
  using type = __m128;
};
template <>
struct VecReg<double, 16> {
  using type = __m128d;
};
template <>
struct VecReg<float, 32> {
  using type = __m256;
};
template <>
struct VecReg<double, 32> {
  using type = __m256d;
};
template <>
struct VecReg<float, 64> {
  using type = __m512;
};

template <class Arch, class T>
struct OneRayWalk : PacketWalk<Arch, T> {
  using Base = PacketWalk<Arch, T>;
  using typename Base::Node;

  // One ray walks the subtree (child, count) alone: a node's four children tested at once (float:
  // an xmm; double: a ymm where the ISA has AVX, else two xmm), slab values
  // lo * inv - o * inv, as the reference's, padded by pad per axis; the met ones taken in the
  // node's order for the ray's own direction code, nearest first, depth first; a popped entry
  // is culled where it starts beyond the ray's best t.
  static constexpr bool kFloat = std::is_same_v<T, float>;
#if defined(__AVX__)
  static constexpr bool kWide = !kFloat;  // four doubles in one ymm
#else
  static constexpr bool kWide = false;
#endif
  static constexpr int kHalves = kFloat || kWide ? 1 : 2;  // registers per four children
  using Reg = typename VecReg<T, kWide ? 32 : 16>::type;
  static Reg set1(T x) noexcept {
    if constexpr (kFloat) return _mm_set1_ps(x);
#if defined(__AVX__)
    else if constexpr (kWide)
      return _mm256_set1_pd(x);
#endif
    else
      return _mm_set1_pd(x);
  }
  struct OneRay4 {
    Reg inv[3], oi[3], pad[3];
    std::size_t near[3], far[3];  // byte offsets in a Node of each axis' entry and exit planes
    unsigned code;
  };
  static OneRay4 one_ray(const T* o, const T* d, bool padded) noexcept {
    static_assert(Bvh<T>::kWidth == 4);
    const std::size_t lo[3] = {offsetof(Node, lo_x), offsetof(Node, lo_y), offsetof(Node, lo_z)};
    constexpr std::size_t kFlip = 4 * sizeof(T);  // a node's hi plane is its lo plane's ^ kFlip
    static_assert(offsetof(Node, hi_x) == (offsetof(Node, lo_x) ^ kFlip) &&
                      offsetof(Node, hi_y) == (offsetof(Node, lo_y) ^ kFlip) &&
                      offsetof(Node, hi_z) == (offsetof(Node, lo_z) ^ kFlip),
                  "the entry plane is chosen by flipping one bit of the offset");
    OneRay4 r;
    const T m = std::max({std::fabs(o[0]), std::fabs(o[1]), std::fabs(o[2])});
    for (int a = 0; a < 3; ++a) {
      // As slab_ray: a zero direction component becomes 2^-64.
      const T inv = T(1) / (std::fabs(d[a]) < T(0x1p-64) ? T(0x1p-64) : d[a]);
      r.inv[a] = set1(inv);
      r.oi[a] = set1(o[a] * inv);
      r.pad[a] = set1(padded ? m * T(Bvh<T>::kOriginPad) * std::fabs(inv) : T(0));
      // lo * inv <= hi * inv for inv > 0 (monotonic rounding): the entry plane is known. It is
      // hi where inv < 0, chosen by arithmetic: the compiler makes a branch of the choice, which
      // incoherent directions mispredict half the time.
      r.near[a] = lo[a] ^ (std::size_t(std::signbit(inv)) * kFlip);
      r.far[a] = r.near[a] ^ kFlip;
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
  // Tests node n's children for ray r and pushes the met ones but the one to visit first (the
  // nearest; kAny: slot order), whose slot it returns (-1: none met). That one is taken from the
  // node, not popped: a pop would read back the entry just stored and wait on store-to-load
  // forwarding. It needs no cull: met, it starts within best_t, which nothing lowers before it.
  template <bool kPadded, bool kAny>
  static int push_met(const Node& n, const OneRay4& r, T best_t, OneStack& st) noexcept {
    Reg tn[kHalves], tf[kHalves];
    const unsigned met = met_children<kPadded>(n, r, best_t, tn, tf);
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
    if constexpr (!kAny) {
      if constexpr (kFloat) {
        _mm_storeu_si128(reinterpret_cast<__m128i*>(st.tnear + st.sp),
                         push(_mm_castps_si128(tn[0])));
      } else {  // eight-byte lanes: the same permutation, entry by entry
        alignas(32) T t[4];
        store(t, tn);
        for (int q = 0; q < kPush.count[m]; ++q)
          st.tnear[st.sp + q] = t[kPush.reverse[order_byte][kPush.compress[m][4 * q]] >> 2];
      }
    }
    if (m == 0) return -1;
    st.sp += kPush.count[m] - 1;
    // The top is the highest met lane; lane i of the order holds the slot visited (3 - i)th.
    const int top = 31 - __builtin_clz(unsigned(m));
    return int(order_byte >> (2 * (3 - top))) & 3;
  }
  // Double entry distances to t[0..3].
  static void store(T* t, const Reg* tn) noexcept {
    if constexpr (!kFloat) {
#if defined(__AVX__)
      if constexpr (kWide) {
        _mm256_store_pd(t, tn[0]);
        return;
      }
#endif
      if constexpr (!kWide) _mm_store_pd(t, tn[0]), _mm_store_pd(t + 2, tn[1]);
    }
  }
  // The children of n that ray r meets within [0, best_t], as slot bits; tn: their entry t.
  template <bool kPadded>
  [[gnu::always_inline]] static unsigned met_children(const Node& n, const OneRay4& r, T best_t,
                                                      Reg* tn, Reg* tf) noexcept {
    const char* base = reinterpret_cast<const char*>(&n);
    if constexpr (kFloat) {
      auto plane = [&](std::size_t off) {
        return _mm_load_ps(reinterpret_cast<const T*>(base + off));
      };
      tn[0] = _mm_setzero_ps(), tf[0] = _mm_set1_ps(best_t);
      for (int a = 0; a < 3; ++a) {
        __m128 t0 = _mm_sub_ps(_mm_mul_ps(plane(r.near[a]), r.inv[a]), r.oi[a]);
        __m128 t1 = _mm_sub_ps(_mm_mul_ps(plane(r.far[a]), r.inv[a]), r.oi[a]);
        if constexpr (kPadded) t0 = _mm_sub_ps(t0, r.pad[a]), t1 = _mm_add_ps(t1, r.pad[a]);
        tn[0] = _mm_max_ps(tn[0], t0);
        tf[0] = _mm_min_ps(tf[0], t1);
      }
      return unsigned(_mm_movemask_ps(
          _mm_and_ps(_mm_cmple_ps(tn[0], tf[0]),
                     _mm_castsi128_ps(
                         _mm_load_si128(reinterpret_cast<const __m128i*>(kPush.arity[n.arity]))))));
    } else if constexpr (kWide) {
#if defined(__AVX__)
      auto plane = [&](std::size_t off) {
        return _mm256_load_pd(reinterpret_cast<const T*>(base + off));
      };
      tn[0] = _mm256_setzero_pd(), tf[0] = _mm256_set1_pd(best_t);
      for (int a = 0; a < 3; ++a) {
        __m256d t0 = _mm256_sub_pd(_mm256_mul_pd(plane(r.near[a]), r.inv[a]), r.oi[a]);
        __m256d t1 = _mm256_sub_pd(_mm256_mul_pd(plane(r.far[a]), r.inv[a]), r.oi[a]);
        if constexpr (kPadded) t0 = _mm256_sub_pd(t0, r.pad[a]), t1 = _mm256_add_pd(t1, r.pad[a]);
        tn[0] = _mm256_max_pd(tn[0], t0);
        tf[0] = _mm256_min_pd(tf[0], t1);
      }
      return unsigned(_mm256_movemask_pd(_mm256_cmp_pd(tn[0], tf[0], _CMP_LE_OQ))) &
             ((1u << n.arity) - 1);
#endif
    } else {
      auto plane = [&](std::size_t off, int h) {
        return _mm_load_pd(reinterpret_cast<const T*>(base + off) + 2 * h);
      };
      unsigned met = 0;
      for (int h = 0; h < 2; ++h) {
        tn[h] = _mm_setzero_pd(), tf[h] = _mm_set1_pd(best_t);
        for (int a = 0; a < 3; ++a) {
          __m128d t0 = _mm_sub_pd(_mm_mul_pd(plane(r.near[a], h), r.inv[a]), r.oi[a]);
          __m128d t1 = _mm_sub_pd(_mm_mul_pd(plane(r.far[a], h), r.inv[a]), r.oi[a]);
          if constexpr (kPadded) t0 = _mm_sub_pd(t0, r.pad[a]), t1 = _mm_add_pd(t1, r.pad[a]);
          tn[h] = _mm_max_pd(tn[h], t0);
          tf[h] = _mm_min_pd(tf[h], t1);
        }
        met |= unsigned(_mm_movemask_pd(_mm_cmple_pd(tn[h], tf[h]))) << (2 * h);
      }
      return met & ((1u << n.arity) - 1);
    }
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
        const Node& nd = h.nodes[std::size_t(s.node)];
        const int top = push_met<kPadded, kAny>(nd, r[i], *best_t[i], s);
        if (top >= 0) {
          if (nd.count[top] < 0) {
            s.node = nd.child[top];
            continue;
          }
          if (leaf(i, nd.child[top], std::int32_t(nd.count[top]))) {
            live &= ~(1u << i);
            continue;
          }
        }
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
};

}  // namespace lancer::packet
