// The sphere, a primitive module of the packets: its ray test for the lanes of a `valid` mask
// (the discriminant and nearest root of formulas.hpp, as the reference computes them), the
// loops over a run of spheres (the scene's in id order, or a hierarchy leaf's), and one ray
// against a leaf's spheres four at a time (the hybrid's lanes alone).
// Include only from code built for the batch's ISA (packet/kernel.hpp).
#pragma once

#include <algorithm>
#include <cstdint>

#include "lancer/packet/lane_traits.hpp"

namespace lancer::packet {

template <class Arch, class Real, class Mode>
struct SpherePackets : Lanes<Arch, Real, Mode> {
  using L = Lanes<Arch, Real, Mode>;
  using L::gather;
  using L::kFast;
  using L::select3;
  using L::tests;
  using L::to_m;
  using L::to_mi;
  using typename L::B;
  using typename L::I;
  using typename L::Id;
  using typename L::M;
  using typename L::Mth;
  using typename L::Prepared;
  using typename L::T;
  using typename L::V;

  // The discriminant of sphere i, f = origin - centre. Exact: Ray Tracing Gems ch. 7's
  // r^2 - |f - b d|^2, as the reference. Fast: the textbook b^2 - c, b^2 fused, with c from the
  // eye's table for camera rays: a third of the operations, at the price of b^2 - c's
  // cancellation when a sphere is small against its distance, so only in scenes where no sphere
  // is (PreparedScene::naive_spheres_hold; docs/precision.md).
  static bool textbook(const Prepared& s) noexcept { return kFast && s.naive_spheres_hold; }
  // eye_c: the eye's c of the sphere (read only for camera rays).
  [[gnu::always_inline]] static SphereDisc<B> disc_of(const Prepared& s, const V& f, const V& d,
                                                      const B& r2, bool from_eye,
                                                      T eye_c) noexcept {
    if (textbook(s)) {
      const B b = Mth::dot(f, d);
      // c = |f|^2 - r^2 with r^2 folded into the first multiply-add.
      const B c = from_eye ? B(eye_c) : fmadd(f.z, f.z, fmadd(f.y, f.y, fmsub(f.x, f.x, r2)));
      return {b, fmsub(b, b, c)};
    } else {
      return sphere_disc<Mth>(f, d, r2);
    }
  }
  // The nearest root beyond epsilon. Exact: c/q and q (RTG ch. 7), as the reference. Fast, with
  // the textbook discriminant: -b -+ sqrt(disc), no division; its near root loses ulps of |b|
  // where the ray starts near the sphere, which the offset origins and epsilon absorb.
  static B first_root(const Prepared& s, const SphereDisc<B>& sd, const V& f, const B& r2,
                      bool from_eye, T eye_c, const B& eps) noexcept {
    if (textbook(s)) {
      const B root = xsimd::sqrt(sd.disc);
      return sphere_first_root(SphereRoots<B>{-(sd.b + root), root - sd.b}, eps);
    }
    const B c = from_eye ? B(eye_c) : sphere_c<Mth>(f, r2);
    return sphere_first_root(sphere_roots<Mth>(sd, c), eps);
  }

  // Fast: a ray that leaves a sphere from outside cannot meet it again (spheres are convex),
  // so its lanes skip that sphere's roots, which would only find the point it leaves. Exact
  // tests it, as the reference does; camera rays (kFromEye) leave no sphere.
  template <bool kFromEye = false>
  static M skip(const M& m, const I& leaving, Id sphere) noexcept {
    if constexpr (kFast && !kFromEye)
      return m & to_m(leaving != I(sphere));
    else
      return m;
  }

  // The spheres a loop walks: the scene's, in id order, or the hierarchy's copy in leaf order
  // with their object ids.
  struct Spheres {
    const T *cx, *cy, *cz, *r2, *efx, *efy, *efz, *ec;
    const std::int32_t* id;  // null: the position is the id
    Id object(int j) const noexcept { return id ? Id(id[j]) : Id(j); }
  };
  static Spheres all_spheres(const Prepared& s) noexcept {
    return {s.spheres.cx.data(), s.spheres.cy.data(), s.spheres.cz.data(),
            s.spheres.r2.data(), s.eye.fx.data(),     s.eye.fy.data(),
            s.eye.fz.data(),     s.eye.c.data(),      nullptr};
  }
  static Spheres leaf_spheres(const Prepared& s) noexcept {
    const Bvh<T>& h = s.bvh;
    const EyeSphere<T>& e = s.leaf_eye;
    return {h.cx.data(), h.cy.data(), h.cz.data(), h.r2.data(), e.fx.data(),
            e.fy.data(), e.fz.data(), e.c.data(),  h.id.data()};
  }

  // Closest hit over spheres [begin, end) of `sp` for the lanes of `valid`; updates t and id
  // where a hit wins. kIdOrder: the spheres come in id order, so a nearer t alone decides (the
  // sequential loop's result); else, in any order, the lexicographic minimum of (t, id).
  // kFromEye: every ray leaves the pinhole eye, so f and c per sphere come precomputed.
  // kSome: only the spheres begin + j of which's bits j (a camera tile's cone, cones.hpp).
  template <bool kFromEye, bool kIdOrder, bool kSome = false>
  [[gnu::always_inline]] static void spheres_closest(const Prepared& s, const Spheres& sp,
                                                     int begin, int end, M valid, const V& o,
                                                     const V& d, B& best_t, I& best_id,
                                                     RayCounts& counts, const I& leaving,
                                                     std::uint32_t which = 0) noexcept {
    const B eps(s.epsilon);
    const T no_c(0);
    // The tests of sphere j, given its discriminant: the nearest root beyond epsilon, kept
    // where it wins.
    // Inlined (as disc_of): left to GCC, whether it inlined them into the ray tree's loops
    // changed with unrelated code in the same file (lorenzi-glass, width 16: 0.95x).
    auto update = [&](int j, const V& f, const B& r2, const SphereDisc<B>& sd, M m)
        __attribute__((always_inline)) {
      const B t = first_root(s, sd, f, r2, kFromEye, kFromEye ? sp.ec[j] : no_c, eps);
      const Id id = sp.object(j);
      if constexpr (kIdOrder)
        m = m & (t > eps) & (t < best_t);
      else
        m = m & (t > eps) & ((t < best_t) | ((t == best_t) & to_m(I(id) < best_id)));
      best_t = xsimd::select(m, t, best_t);
      best_id = xsimd::select(to_mi(m), I(id), best_id);
    };
    auto offset = [&](int j) {
      return kFromEye ? V{B(sp.efx[j]), B(sp.efy[j]), B(sp.efz[j])}
                      : o - V{B(sp.cx[j]), B(sp.cy[j]), B(sp.cz[j])};
    };
    auto one = [&](int j) __attribute__((always_inline)) {
      tests(counts, valid, true);
      const B r2(sp.r2[j]);
      const V f = offset(j);
      const SphereDisc<B> sd = disc_of(s, f, d, r2, kFromEye, kFromEye ? sp.ec[j] : no_c);
      const M m = skip<kFromEye>(valid & (sd.disc >= B(0)), leaving, sp.object(j));
      if (xsimd::any(m)) update(j, f, r2, sd, m);
    };
    if constexpr (kSome) {  // few spheres, most of which some lane meets: no group test
      for (; which; which &= which - 1) one(begin + __builtin_ctz(which));
      return;
    }
    // kGroup spheres per early-out test: most rays miss most spheres, and one branch then
    // skips the group. Hits are still taken in sphere order: the sequential loop's result.
    constexpr int kGroup = 4;
    int j = begin;
    for (; j + kGroup <= end; j += kGroup) {
      V f[kGroup];
      SphereDisc<B> sd[kGroup];
      for (int g = 0; g < kGroup; ++g) {
        tests(counts, valid, true);
        f[g] = offset(j + g);
        sd[g] = disc_of(s, f[g], d, B(sp.r2[j + g]), kFromEye, kFromEye ? sp.ec[j + g] : no_c);
      }
      // Some disc >= 0 exactly where the largest is: one compare for the group. (The
      // discriminants of a loaded scene are never NaN: its coordinates are bounded.)
      static_assert(kGroup == 4);
      const B largest =
          xsimd::max(xsimd::max(sd[0].disc, sd[1].disc), xsimd::max(sd[2].disc, sd[3].disc));
      if (!xsimd::any(valid & (largest >= B(0)))) continue;
      for (int g = 0; g < kGroup; ++g) {
        const M m = skip<kFromEye>(valid & (sd[g].disc >= B(0)), leaving, sp.object(j + g));
        if (xsimd::any(m)) update(j + g, f[g], B(sp.r2[j + g]), sd[g], m);
      }
    }
    for (; j < end; ++j) one(j);
  }

  // The one-ray leaf tests' registers: four floats, or four doubles in a ymm where the ISA has
  // AVX2 (else two in an xmm). The closest hit's leaf of more than four float spheres
  // (Bvh::max_leaf 8) takes eight floats in a ymm there, one pass over the leaf instead of two;
  // the any hit keeps four: it stops at its first blocker, often before a leaf's second four
  // (docs/notebook/2026-11-incoherent-rays.md).
#if LANCER_X86 && defined(__AVX2__)
  using LeafArch = std::conditional_t<std::is_same_v<T, float>, Arch4, xsimd::avx2>;
  using WideLeafArch = xsimd::avx2;
#else
  using LeafArch = Arch4;
  using WideLeafArch = Arch4;
#endif
  // One ray (o, d) against leaf-order spheres [first, first + n), a register of spheres at a
  // time (the lanes are spheres: four or eight floats, or doubles as LeafArch holds): each lane
  // computes the reference's formulas for its sphere, IEEE operation by operation, so its t is
  // the reference's. hit(q, t) for each sphere met beyond epsilon, in leaf order, -> true to
  // stop; returns whether one did.
  template <bool kWideLeaf = false, class Hit>
  static bool spheres_one(const Prepared& s, int first, int n, const T* o, const T* d,
                          Hit&& hit) noexcept {
    // Only where the wide register holds more (float on AVX2: eight against four).
    constexpr int kNarrow = int(xsimd::batch<T, LeafArch>::size);
    if constexpr (kWideLeaf && int(xsimd::batch<T, WideLeafArch>::size) > kNarrow)
      if (n > kNarrow) return spheres_run<WideLeafArch>(s, first, n, o, d, hit);
    return spheres_run<LeafArch>(s, first, n, o, d, hit);
  }
  template <class RegArch, class Hit>
  static bool spheres_run(const Prepared& s, int first, int n, const T* o, const T* d,
                          Hit& hit) noexcept {
    using R = xsimd::batch<T, RegArch>;
    constexpr int K = int(R::size);
    const Bvh<T>& h = s.bvh;
    const int total = int(h.cx.size());
    const Vec3<R> ov{R(o[0]), R(o[1]), R(o[2])}, dv{R(d[0]), R(d[1]), R(d[2])};
    const R eps(s.epsilon);
    alignas(32) static constexpr T kLane[8] = {0, 1, 2, 3, 4, 5, 6, 7};
    const R lane = R::load_unaligned(kLane);
    for (int j = first; j < first + n; j += K) {
      const int m = std::min(K, first + n - j);
      R cx, cy, cz, r2;
      if (j + K <= total) {
        cx = R::load_unaligned(&h.cx[j]), cy = R::load_unaligned(&h.cy[j]);
        cz = R::load_unaligned(&h.cz[j]), r2 = R::load_unaligned(&h.r2[j]);
      } else {  // the last leaf's last spheres: no reads past the arrays
        alignas(sizeof(R)) T v[4][K] = {};
        for (int q = 0; q < m; ++q)
          v[0][q] = h.cx[j + q], v[1][q] = h.cy[j + q], v[2][q] = h.cz[j + q],
          v[3][q] = h.r2[j + q];
        cx = R::load_aligned(v[0]), cy = R::load_aligned(v[1]);
        cz = R::load_aligned(v[2]), r2 = R::load_aligned(v[3]);
      }
      const Vec3<R> f = ov - Vec3<R>{cx, cy, cz};
      const SphereDisc<R> sd = sphere_disc(f, dv, r2);
      const auto live = (sd.disc >= R(T(0))) & (lane < R(T(m)));
      if (!xsimd::any(live)) continue;
      const R t = sphere_first_root(sphere_roots(sd, sphere_c(f, r2)), eps);
      unsigned met = lane_bits(live & (t > eps));
      if (!met) continue;
      alignas(sizeof(R)) T tt[K];
      t.store_aligned(tt);
      for (; met; met &= met - 1) {
        const int q = __builtin_ctz(met);
        if (hit(j + q, tt[q])) return true;
      }
    }
    return false;
  }
  // The lexicographic minimum of (t, id) over those spheres and the ray's best.
  static void spheres_closest_one(const Prepared& s, int first, int n, const T* o, const T* d,
                                  T& best_t, Id& best_id) noexcept {
    spheres_one</*kWideLeaf=*/true>(s, first, n, o, d, [&](int j, T t) {
      const Id id = Id(s.bvh.id[std::size_t(j)]);
      if (t < best_t || (t == best_t && id < best_id)) best_t = t, best_id = id;
      return false;
    });
  }

  // Whether the scene has spheres (a scene pays only for the kinds it has).
  static bool present(const Prepared& s) noexcept { return s.features.spheres; }

  // Any hit over spheres [begin, end) of `sp` for the lanes of `mask` still pending, from p along
  // unit l before `dist`: step(id, lanes, pending) for each sphere the lanes meet beyond eps (the
  // scene's epsilon, broadcast once by the caller), in the run's order, until none is pending.
  // `leaving` as for skip().
  template <class Step>
  [[gnu::always_inline]] static M spheres_any(const Prepared& s, const Spheres& sp, int begin,
                                              int end, const M& mask, M pending, const V& p,
                                              const V& l, const B& dist, const B& eps,
                                              const I& leaving, RayCounts& counts,
                                              Step& step) noexcept {
    for (int j = begin; j < end; ++j) {
      const M live = mask & pending;
      tests(counts, live, true);
      const V f = p - V{B(sp.cx[j]), B(sp.cy[j]), B(sp.cz[j])};
      const B r2(sp.r2[j]);
      const SphereDisc<B> sd = disc_of(s, f, l, r2, false, T(0));
      M m = skip(live & (sd.disc >= B(0)), leaving, sp.object(j));
      if (!xsimd::any(m)) continue;
      const B t = first_root(s, sd, f, r2, false, T(0), eps);
      m = m & (t > eps) & (t < dist);
      if (!xsimd::any(m)) continue;
      pending = step(sp.object(j), m, pending);
      if (!xsimd::any(pending)) break;
    }
    return pending;
  }

  // The surface at the hits (contract step 3): the geometric normal (p - c) / r, computed as
  // the reference computes it: p relative to the sphere where it is small against the hit's
  // magnitude, t recomputed where it is huge (formulas.hpp). The first kind in id order: it
  // writes every lane (its normal from sphere min(id, last)); later kinds overwrite theirs.
  [[gnu::always_inline]] static void surface(const Prepared& s, const M& hit, const I& best_id,
                                             const I& id, const V& o, const V& d, const B& best_t,
                                             const B& magnitude, V& p, V& n, B& delta) noexcept {
    const I sid = xsimd::min(id, I(Id(s.num_spheres - 1)));
    const int ns = s.num_spheres;
    const V c{gather(s.spheres.cx, sid, ns), gather(s.spheres.cy, sid, ns),
              gather(s.spheres.cz, sid, ns)};
    if constexpr (kFast) {  // (p - c) / r, the contract's normal, by a multiplication
      n = (p - c) * gather(s.spheres.inv_r, sid, ns);
    } else {
      n = sphere_normal<Mth>(p, c);
      const B r2 = gather(s.spheres.r2, sid, ns);
      const M small = hit & to_m(best_id < I(Id(ns))) & sphere_is_small(r2, magnitude);
      if (xsimd::any(small)) {
        const SurfacePoint<B> at = sphere_point_local<T, Mth>(o, d, best_t, c, r2);
        p = select3(small, at.p, p);
        n = select3(small, at.normal, n);
        delta = xsimd::select(small, at.delta, delta);
      }
      const M large = hit & to_m(best_id < I(Id(ns))) & sphere_is_large(r2, magnitude);
      if (xsimd::any(large)) {
        const SurfacePoint<B> at = sphere_point_large<T, Mth>(o, d, best_t, c, r2, magnitude);
        p = select3(large, at.p, p);
        n = select3(large, at.normal, n);
      }
    }
  }

  // Fast mode: the sphere each lane of `outside` hit from outside (-1: none or not a sphere),
  // which that level's shadow rays and reflections leave and so skip (skip()).
  static I left_from_outside(const Prepared& s, const M& outside, const I& best_id) noexcept {
    return xsimd::select(to_mi(outside) & (best_id < I(Id(s.num_spheres))), best_id, I(Id(-1)));
  }
};

}  // namespace lancer::packet
