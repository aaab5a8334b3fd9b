// The one-ray kernels (one_ray_api.hpp): a single ray's closest hit and occlusion over the
// sphere hierarchy and the planes, for the library API's one-ray queries. Kept apart from the
// reference (traverse.hpp, reference.cpp), which stays the definition and which they equal bit
// for bit. As Embree's single-ray BVH8 traversal: the 4-wide hierarchy collapsed into 8-wide
// float nodes (one_ray_scene), a node's eight children tested against the ray in one ymm per
// plane, the met ones visited nearest entry first (occlusion: in slot order), a popped subtree
// culled where it starts beyond the best t; a leaf's spheres with the reference's sphere formulas
// (formulas.hpp), float's eight in one ymm, double's four at a time. The closest hit keeps the
// lexicographic minimum of (t, object id), so the visiting order cannot change it; occlusion
// stops at the first object met within (tmin, tfar). The boxes are the hierarchy's, padded for
// the sphere test's rounding and, beyond origin_limit, for the origin's, as the reference pads
// them (double's rounded outward to float and padded for the float slab test, one_ray_scene.cpp).
// Include only from src/isa/one_ray_*.cpp.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <type_traits>

#include "lancer/bvh.hpp"
#include "lancer/formulas.hpp"
#include "lancer/packet/intrin.hpp"
#include "lancer/packet/lanes.hpp"
#include "lancer/packet/one_ray_api.hpp"
#include "lancer/packet/prim/shapes_lone.hpp"
#include "lancer/prepared.hpp"
#include "lancer/prim/triangle.hpp"
#include "lancer/vec3.hpp"

namespace lancer::packet {

// For each set of an 8-wide node's slots (bit k: slot k), its slots in order, a byte each: the
// lanes a permutation packs to the front (the unsorted walk's pushes).
struct Compress8 {
  std::uint64_t slots[256];
};
constexpr Compress8 compress8() {
  Compress8 t{};
  for (unsigned m = 0; m < 256; ++m) {
    int q = 0;
    for (unsigned k = 0; k < 8; ++k)
      if (m >> k & 1u) t.slots[m] |= std::uint64_t(k) << (8 * q++);
  }
  return t;
}
inline constexpr Compress8 kCompress8 = compress8();

// Arch names the translation unit (its flags). An 8-wide node's eight float children and a float
// leaf's eight spheres run on one ymm, a double leaf's four spheres on one: all of it in every
// x86 ISA from AVX2 up.
template <class Arch, class T>
struct OneRayKernel {
  using A = std::conditional_t<std::is_same_v<T, float>, Arch4, xsimd::avx2>;
  using B = xsimd::batch<T, A>;
  static_assert(B::size == 4, "four spheres in one vector");

  // The walk over the 8-wide float nodes (OneRayNode8), for float and double rays alike: a
  // node's eight children tested against the ray in one ymm per plane, the met ones visited
  // nearest entry first (sorted on the stack, the nearest taken at once), as Embree's BVH8
  // single-ray traversal. The ray's slab form, as the reference's (RayTraversal): a zero
  // direction component becomes 2^-64; beyond origin_limit the boxes grow by float's
  // kOriginPad |origin| (max-norm; twice that for double rays, whose float form rounds once
  // more). near: byte offsets in a node of each axis' entry plane; its exit plane is the other
  // of the pair (Embree's near/far offsets), which keeps two of the walk's registers free.
  struct Slab8 {
    __m256 inv[3], oi[3], pad[3];
    std::size_t near[3];  // an axis' exit plane: near ^ 32 (lo and hi adjacent, 32 bytes each)
  };
  static Slab8 slab8(const T* o, const T* d, bool padded) noexcept {
    using N8 = OneRayNode8;
    const std::size_t lo[3] = {offsetof(N8, lo_x), offsetof(N8, lo_y), offsetof(N8, lo_z)};
    static_assert(offsetof(N8, hi_x) == (offsetof(N8, lo_x) ^ 32u) &&
                      offsetof(N8, hi_y) == (offsetof(N8, lo_y) ^ 32u) &&
                      offsetof(N8, hi_z) == (offsetof(N8, lo_z) ^ 32u),
                  "each axis' planes 32 bytes apart, the pair 64-byte aligned");
    Slab8 r;
    const T m = std::max({std::fabs(o[0]), std::fabs(o[1]), std::fabs(o[2])});
    const T pad = T(Bvh<float>::kOriginPad) * T(std::is_same_v<T, float> ? 1 : 2);
    const T far = padded ? m * pad : T(0);
    for (int a = 0; a < 3; ++a) {
      const T inv = T(1) / (std::fabs(d[a]) < T(0x1p-64) ? T(0x1p-64) : d[a]);
      // lo * inv <= hi * inv for inv > 0 (monotonic rounding): the entry plane is known. It is
      // hi (lo ^ 32) where inv < 0, chosen by arithmetic: the compiler makes a branch of the
      // choice, which random directions mispredict half the time.
      r.inv[a] = _mm256_set1_ps(float(inv));
      r.oi[a] = _mm256_set1_ps(float(o[a] * inv));
      r.pad[a] = _mm256_set1_ps(float(far * std::fabs(inv)));
      r.near[a] = lo[a] ^ (std::size_t(std::signbit(inv)) << 5);
    }
    return r;
  }
  // The met children of n (bits of met) packed to the front of its child and count vectors,
  // interleaved as (child, count) entries, eight stored at once at out (those past the met ones
  // are overwritten or never read).
  [[gnu::always_inline]] static void store_met8(const OneRayNode8& n, unsigned met,
                                                void* out) noexcept {
    const __m256i at =
        _mm256_cvtepu8_epi32(_mm_cvtsi64_si128(static_cast<long long>(kCompress8.slots[met])));
    const __m256i c = _mm256_permutevar8x32_epi32(
        _mm256_load_si256(reinterpret_cast<const __m256i*>(n.child)), at);
    const __m256i k = _mm256_permutevar8x32_epi32(
        _mm256_load_si256(reinterpret_cast<const __m256i*>(n.count)), at);
    const __m256i lo = _mm256_unpacklo_epi32(c, k), hi = _mm256_unpackhi_epi32(c, k);
    __m256i* v = static_cast<__m256i*>(out);
    _mm256_storeu_si256(v, _mm256_permute2x128_si256(lo, hi, 0x20));
    _mm256_storeu_si256(v + 1, _mm256_permute2x128_si256(lo, hi, 0x31));
  }
  template <bool kPadded, bool kSort, class Leaf, class LeafAt>
  static bool walk8(const OneRayNode8* nodes, const Slab8& r, const T& tmax, Leaf&& leaf,
                    LeafAt&& leaf_at) noexcept {
    struct SortEntry {
      std::int32_t child, count;
      float tnear;
    };
    struct AnyEntry {  // unsorted: no distance, two to a vector lane pair
      std::int32_t child, count;
    };
    using Entry = std::conditional_t<kSort, SortEntry, AnyEntry>;
    // tmax (read afresh: a closest-hit leaf lowers it) as a float not below it: double's too
    // cuts no box it meets.
    auto tmax_up = [&] {
      const float f = float(tmax);
      return T(f) < tmax ? std::nextafter(f, std::numeric_limits<float>::infinity()) : f;
    };
    // Every 8-wide level stands for one 4-wide level or more: at most seven entries each; and
    // room for the unsorted walk's whole vectors of eight.
    Entry stack[7 * (Bvh<T>::kMaxTreeDepth / 2) + 2 + 8];
    int sp = 0;
    std::int32_t node = 0;
    for (;;) {
      const OneRayNode8& n = nodes[std::size_t(node)];
      const char* base = reinterpret_cast<const char*>(&n);
      auto plane = [&](std::size_t off) {
        return _mm256_load_ps(reinterpret_cast<const float*>(base + off));
      };
      __m256 tn = _mm256_setzero_ps(), tf = _mm256_set1_ps(tmax_up());
      for (int a = 0; a < 3; ++a) {
        __m256 t0 = _mm256_sub_ps(_mm256_mul_ps(plane(r.near[a]), r.inv[a]), r.oi[a]);
        __m256 t1 = _mm256_sub_ps(_mm256_mul_ps(plane(r.near[a] ^ 32u), r.inv[a]), r.oi[a]);
        if constexpr (kPadded) t0 = _mm256_sub_ps(t0, r.pad[a]), t1 = _mm256_add_ps(t1, r.pad[a]);
        tn = _mm256_max_ps(tn, t0);
        tf = _mm256_min_ps(tf, t1);
      }
      unsigned met = unsigned(_mm256_movemask_ps(_mm256_cmp_ps(tn, tf, _CMP_LE_OQ)));
      if (met) {
        Entry e;
        if ((met & (met - 1)) == 0) {  // one child met: straight on
          const int k = __builtin_ctz(met);
          if constexpr (kSort)
            e = {n.child[k], n.count[k], 0.0f};
          else
            e = {n.child[k], n.count[k]};
        } else if constexpr (!kSort) {
          // Slot order, nothing prefetched: the pushed entries' lines, prefetched, measured no
          // faster at 65536 spheres and a million (docs/notebook/2026-11-incoherent-rays.md).
          store_met8(n, met, stack + sp);
          // The top entry, the last met slot, taken from the node rather than read back from
          // the vector just stored (no store-to-load forwarding to wait on).
          const int top = 31 - __builtin_clz(met);
          sp += __builtin_popcount(met) - 1;
          e = {n.child[top], n.count[top]};
        } else {
          // Each met child straight to its place, the nearest on top: below it the met children
          // farther away (ties: the lower slot below). No branch on the distances, which a
          // single ray's walk mispredicts. A child's distance is taken from the register by a
          // permutation, not from a copy just stored (a load from within a vector store waits
          // on its forwarding).
          for (unsigned m = met; m; m &= m - 1) {
            const int k = __builtin_ctz(m);
            const __m256 dk = _mm256_permutevar8x32_ps(tn, _mm256_set1_epi32(k));
            const unsigned farther =
                unsigned(_mm256_movemask_ps(_mm256_cmp_ps(tn, dk, _CMP_GT_OQ)));
            const unsigned same = unsigned(_mm256_movemask_ps(_mm256_cmp_ps(tn, dk, _CMP_EQ_OQ)));
            const unsigned below = (1u << k) - 1u;
            const int rank = __builtin_popcount(met & (farther | (same & below)));
            Entry& x = stack[sp + rank];
            x.child = n.child[k], x.count = n.count[k], x.tnear = _mm256_cvtss_f32(dk);
            // The pushed child's lines on their way meanwhile (a node's four; a leaf block's two,
            // its first line twice).
            const bool inner = x.count < 0;
            const char* p =
                inner ? reinterpret_cast<const char*>(nodes + x.child) : leaf_at(x.child);
            const char* q = inner ? p + 128 : p;
            _mm_prefetch(p, _MM_HINT_T0), _mm_prefetch(p + 64, _MM_HINT_T0);
            _mm_prefetch(q, _MM_HINT_T0), _mm_prefetch(q + 64, _MM_HINT_T0);
          }
          sp += __builtin_popcount(met);
          e = stack[--sp];
        }
        if (e.count < 0) {
          node = e.child;
          continue;
        }
        if (leaf(e.child, e.count)) return true;
      }
      for (;;) {
        if (sp == 0) return false;
        // The entry's fields read where they are, not through a copy of the entry (which GCC
        // makes on the stack and reads back, its distance as a float from integer stores).
        const Entry& e = stack[--sp];
        // Unsorted (occlusion): tmax stays tfar, which every pushed entry starts before.
        if constexpr (kSort)
          if (e.tnear > tmax) continue;
        const std::int32_t child = e.child, count = e.count;
        if (count < 0) {
          node = child;
          break;
        }
        if (leaf(child, count)) return true;
      }
    }
  }

  // Spheres [first, first + n) of arrays of `total` entries, four at a time, for one ray:
  // hit(j, t) for each sphere j met at eps < t <= tmax, in index order within each four; true
  // from hit stops.
  struct SphereArrays {
    const T *cx, *cy, *cz, *r2;
    int total;
  };
  template <class Hit>
  static bool spheres(const SphereArrays& sp, int first, int n, const Vec3<B>& o, const Vec3<B>& d,
                      const B& eps, const T& tmax, Hit&& hit) noexcept {
    alignas(32) static constexpr T kLane[4] = {0, 1, 2, 3};
    const B lane = B::load_aligned(kLane);
    for (int j = first; j < first + n; j += 4) {
      const int m = std::min(4, first + n - j);
      B cx, cy, cz, r2;
      if (j + 4 <= sp.total) {
        cx = B::load_unaligned(sp.cx + j), cy = B::load_unaligned(sp.cy + j);
        cz = B::load_unaligned(sp.cz + j), r2 = B::load_unaligned(sp.r2 + j);
      } else {  // the arrays' last spheres: no reads past them
        alignas(32) T v[4][4] = {};
        for (int q = 0; q < m; ++q)
          v[0][q] = sp.cx[j + q], v[1][q] = sp.cy[j + q], v[2][q] = sp.cz[j + q],
          v[3][q] = sp.r2[j + q];
        cx = B::load_aligned(v[0]), cy = B::load_aligned(v[1]);
        cz = B::load_aligned(v[2]), r2 = B::load_aligned(v[3]);
      }
      const Vec3<B> f = o - Vec3<B>{cx, cy, cz};
      const SphereDisc<B> sd = sphere_disc(f, d, r2);
      // No branch on the discriminant: the roots of four spheres cost less than its mispredictions.
      const auto live = (sd.disc >= B(T(0))) & (lane < B(T(m)));
      const B t = sphere_first_root(sphere_roots(sd, sphere_c(f, r2)), eps);
      unsigned met = lane_bits(live & (t > eps) & (t <= B(tmax)));
      if (!met) continue;
      alignas(32) T tt[4];
      t.store_aligned(tt);
      for (; met; met &= met - 1) {
        const int q = __builtin_ctz(met);
        if (hit(j + q, tt[q])) return true;
      }
    }
    return false;
  }

  // An object id read only when asked: a closest-hit walk needs a met sphere's id only where
  // it ties the best t, or for the final hit, and the ids' line is then often not loaded.
  struct LazyId {
    const std::int32_t* at;
    operator std::int32_t() const noexcept { return *at; }
  };

  // A leaf's blocks (OneRayLeaf) from `block`, each in one vector a field (float: eight
  // spheres in a ymm; double: four), as spheres() tests four: hit(LazyId, t) for each sphere
  // met at eps < t <= tmax.
  using BL = std::conditional_t<std::is_same_v<T, float>, xsimd::batch<float, xsimd::avx2>, B>;
  static constexpr int kLanes = OneRayLeaf<T>::kLanes;
  static_assert(BL::size == kLanes && sizeof(OneRayLeaf<T>) == 128, "a block: two lines");
  template <class Hit>
  static bool leaf(const OneRayScene<T>& one, std::int32_t block, std::int32_t count,
                   const T* ray_o, const T* ray_d, T tmin, const T& tmax, Hit&& hit) noexcept {
    // The ray broadcast here, from memory, not held in registers the node tests need.
    const Vec3<BL> o{BL(ray_o[0]), BL(ray_o[1]), BL(ray_o[2])};
    const Vec3<BL> d{BL(ray_d[0]), BL(ray_d[1]), BL(ray_d[2])};
    const BL eps(tmin);
    for (; count > 0; ++block, count -= kLanes) {
      const OneRayLeaf<T>& l = one.leaves[std::size_t(block)];
      const BL r2 = BL::load_aligned(l.r2);
      const Vec3<BL> f =
          o - Vec3<BL>{BL::load_aligned(l.cx), BL::load_aligned(l.cy), BL::load_aligned(l.cz)};
      const SphereDisc<BL> sd = sphere_disc(f, d, r2);
      // Unused lanes: NaN centres, a NaN discriminant.
      const BL t = sphere_first_root(sphere_roots(sd, sphere_c(f, r2)), eps);
      unsigned met = lane_bits((sd.disc >= BL(T(0))) & (t > eps) & (t <= BL(tmax)));
      if (!met) continue;
      alignas(32) T tt[kLanes];
      t.store_aligned(tt);
      for (; met; met &= met - 1) {
        const int q = __builtin_ctz(met);
        const std::int32_t* id =
            &one.ids[std::size_t(kLanes) * std::size_t(block) + std::size_t(q)];
        if (hit(LazyId{id}, tt[q])) return true;
      }
    }
    return false;
  }

  // Over the hierarchy, or every sphere in id order where there is none or the ray starts
  // beyond kFarLimit (as the reference): hit(id, t) for the spheres met at t > tmin (id an
  // std::int32_t or a LazyId). kAny (occlusion): any hit stops the walk, whose met children are
  // then taken in slot order, unsorted (as Embree's any-hit traversal).
  template <bool kAny = false, class Hit>
  static bool all_spheres(const PreparedScene<T>& s, const OneRayScene<T>& one, const T* o,
                          const T* d, T tmin, const T& tmax, Hit&& hit) noexcept {
    const Vec3<B> ov{B(o[0]), B(o[1]), B(o[2])}, dv{B(d[0]), B(d[1]), B(d[2])};
    const B eps(tmin);
    const Bvh<T>& h = s.bvh;
    const T m = std::max({std::fabs(o[0]), std::fabs(o[1]), std::fabs(o[2])});
    if (!h.active() || m > T(Bvh<T>::kFarLimit)) {
      const SphereArrays sp{s.spheres.cx.data(), s.spheres.cy.data(), s.spheres.cz.data(),
                            s.spheres.r2.data(), s.num_spheres};
      return spheres(sp, 0, s.num_spheres, ov, dv, eps, tmax,
                     [&](int j, T t) { return hit(j, t); });
    }
    const bool padded = m > h.origin_limit;
    const Slab8 r = slab8(o, d, padded);
    auto go = [&](auto&& leaf, auto&& leaf_at) {
      return padded ? walk8<true, !kAny>(one.nodes8.data(), r, tmax, leaf, leaf_at)
                    : walk8<false, !kAny>(one.nodes8.data(), r, tmax, leaf, leaf_at);
    };
    return go([&](std::int32_t block,
                  std::int32_t count) { return leaf(one, block, count, o, d, tmin, tmax, hit); },
              [&](std::int32_t block) {
                return reinterpret_cast<const char*>(one.leaves.data() + block);
              });
  }

  // The planes in id order, as the reference: hit(id, t) for each met at t > tmin.
  template <class Hit>
  static bool planes(const PreparedScene<T>& s, const T* o, const T* d, T tmin, Hit&& hit) {
    const Vec3<T> origin{o[0], o[1], o[2]}, dir{d[0], d[1], d[2]};
    const PlaneBlock<T>& p = s.planes;
    for (int k = 0; k < s.num_planes; ++k) {
      const Vec3<T> normal{p.nx[k], p.ny[k], p.nz[k]};
      const T denom = dot(dir, normal);
      if (denom == T(0)) continue;
      const T t = dot(Vec3<T>{p.px[k], p.py[k], p.pz[k]} - origin, normal) / denom;
      if (t > tmin && hit(s.num_spheres + k, t)) return true;
    }
    return false;
  }

  // The triangles, meshes and cylinders: ShapeLone's walk over their hierarchy (the walk a
  // packet's lone lanes take), the ray set up as a packet's lane is (ShapeWalk::Ray): the
  // reference's shear, and 1 / d (1 where d is 0) for the boxes.
  using Lone = ShapeLone<Arch, T>;
  static typename Lone::Ray lone_ray(const T* o, const T* d) noexcept {
    return typename Lone::Ray(o, d);
  }

  static bool closest(const PreparedScene<T>& s, const OneRayScene<T>& one, const T* o, const T* d,
                      T tmin, T tfar, T& t_out, std::int32_t& id_out,
                      std::int32_t* prim_out) noexcept {
    // Only hits before tfar count: starting from it, nothing at or beyond it is taken (an equal
    // t would need an id below -1), and what is nearer is the reference's minimum.
    T best_t = tfar;
    std::int32_t best_id = -1;
    // The planes first (their hit bounds the walk): in id order, a strictly nearer t wins; then
    // the spheres, whose ids are lower, win ties with them.
    planes(s, o, d, tmin, [&](std::int32_t id, T t) {
      if (t < best_t) best_t = t, best_id = id;
      return false;
    });
    const std::int32_t* best_at = nullptr;  // where best_id is, once a LazyId is the best
    all_spheres(s, one, o, d, tmin, best_t, [&](auto id, T t) {
      if (t < best_t || (t == best_t && std::int32_t(id) < (best_at ? *best_at : best_id))) {
        best_t = t;
        if constexpr (std::is_same_v<decltype(id), LazyId>) {
          best_at = id.at;
          // The caller's normal reads the sphere by id next: its lines on their way while
          // the walk goes on (out of its path: nothing waits on this load).
          const std::size_t j = std::size_t(*id.at);
          for (const T* a :
               {s.spheres.cx.data(), s.spheres.cy.data(), s.spheres.cz.data(), s.spheres.r2.data()})
            _mm_prefetch(reinterpret_cast<const char*>(a + j), _MM_HINT_T0);
        } else
          best_id = id, best_at = nullptr;
      }
      return false;
    });
    if (best_at) best_id = *best_at;
    std::int32_t prim = -1;
    if (s.shapes) {
      // Shapes' hit ids follow every sphere's and plane's id, so an equal t stays with those
      // (the reference's lower id); among shapes, primitives are numbered in object-id order.
      const std::int64_t first = s.num_spheres + s.num_planes;
      std::int64_t hit = best_id;
      Lone::closest(*s.shapes, lone_ray(o, d), tmin, first, best_t, hit);
      if (hit >= first) {
        prim = std::int32_t(hit - first);
        best_id = s.shapes->prim_object(prim);
      } else {
        best_id = std::int32_t(hit);  // a sphere item of one hierarchy: its own id
      }
    }
    if (best_id < 0) return false;
    t_out = best_t, id_out = best_id;
    if (prim_out) *prim_out = prim;
    return true;
  }

  static bool occluded(const PreparedScene<T>& s, const OneRayScene<T>& one, const T* o, const T* d,
                       T tmin, T tfar) noexcept {
    auto before = [&](auto, T t) { return t < tfar; };
    // The planes first: a few tests, and an unbounded plane blocks most rays that meet it.
    return planes(s, o, d, tmin, before) || all_spheres<true>(s, one, o, d, tmin, tfar, before) ||
           (s.shapes && Lone::any(*s.shapes, lone_ray(o, d), tmin, tfar));
  }
};

template <class Arch, class Real>
const OneRayTable<Real>* one_ray_table() {
  using K = OneRayKernel<Arch, Real>;
  static const OneRayTable<Real> t{Arch::name(), &K::closest, &K::occluded};
  return &t;
}

}  // namespace lancer::packet
