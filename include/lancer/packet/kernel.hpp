// The packet kernels, one source for every width and precision: Kernel<Arch, Real, Mode> works
// on the lanes of one xsimd::batch<Real, Arch> at once, structure-of-arrays. Include only from
// src/isa/*.cpp (built with that ISA's flags) and instantiate there through table<>().
//
// Conventions (after Embree's intersectors): a kernel takes a `valid` mask, narrows it test by
// test, and never writes a lane outside it. Kernels are noexcept; they report through masks.
// Exact mode: every formula comes from formulas.hpp with ExactMath, as in the reference, in the
// same order, so every lane computes the reference's bits.
#pragma once

#include <immintrin.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <limits>
#include <type_traits>
#include <vector>
#include <xsimd/xsimd.hpp>

#include "lancer/formulas.hpp"
#include "lancer/packet/api.hpp"
#include "lancer/packet/fused.hpp"
#include "lancer/packet/lanes.hpp"
#include "lancer/packet/traversal.hpp"
#include "lancer/profile.hpp"

namespace lancer::packet {

// Fast arithmetic for float batches: fused multiply-adds (fused.hpp), and reciprocals / reciprocal
// square roots from the hardware's approximations (12 bits on SSE/AVX, 14 on AVX-512) refined by
// one Newton step to about 22 bits. Which of these pay is measured by `lancer trade`.
template <class Arch>
struct FastMath {
  using B = xsimd::batch<float, Arch>;
  static constexpr bool kAvx512 = std::is_same_v<Arch, xsimd::avx512f>;

  static B approx_rcp(const B& x) noexcept {
    if constexpr (kAvx512)
      return _mm512_rcp14_ps(x);  // xsimd's avx512 reciprocal is an exact division
    else
      return xsimd::reciprocal(x);
  }
  static B approx_rsqrt(const B& x) noexcept {
    if constexpr (kAvx512)
      return _mm512_rsqrt14_ps(x);  // xsimd 8.1's rsqrt does not compile for avx512f
    else
      return xsimd::rsqrt(x);
  }
  // One Newton-Raphson step each: r' = r (2 - x r), y' = y (1.5 - x/2 y^2).
  static B rcp(const B& x) noexcept {
    const B r = approx_rcp(x);
    return fmadd(r, fnmadd(x, r, B(1.0f)), r);
  }
  static B rsqrt(const B& x) noexcept {
    const B y = approx_rsqrt(x);
    return y * fnmadd(B(0.5f) * x * y, y, B(1.5f));
  }

  static B dot(const Vec3<B>& a, const Vec3<B>& b) noexcept {
    return fmadd(a.z, b.z, fmadd(a.y, b.y, a.x * b.x));
  }
  static B div(const B& a, const B& b) noexcept { return a * rcp(b); }
  static Vec3<B> div(const Vec3<B>& v, const B& s) noexcept { return v * rcp(s); }
  static B length(const Vec3<B>& v) noexcept { return xsimd::sqrt(dot(v, v)); }
  static Vec3<B> normalize(const Vec3<B>& v) noexcept { return v * rsqrt(dot(v, v)); }
  static Vec3<B> sub_scaled(const Vec3<B>& a, const Vec3<B>& b, const B& s) noexcept {
    return {fnmadd(b.x, s, a.x), fnmadd(b.y, s, a.y), fnmadd(b.z, s, a.z)};
  }
  static Vec3<B> along(const Vec3<B>& o, const Vec3<B>& d, const B& t) noexcept {
    return {fmadd(t, d.x, o.x), fmadd(t, d.y, o.y), fmadd(t, d.z, o.z)};
  }
  static Vec3<B> reflect(const Vec3<B>& d, const Vec3<B>& n) noexcept {
    return sub_scaled(d, n, B(2.0f) * dot(d, n));
  }

  // c^e for c in [0, 1] and e >= 0 as 2^(e log2 c), each by a short polynomial (least-squares
  // fits on [0, 1): 2e-6 absolute in log2(1+m)/m, 1e-7 in 2^f): a fixed dozen operations where
  // binary powering loops log2(e) times. 0^e is 0 (e > 0) and c^0 is 1, as std::pow.
  static B pow01(const B& c, const B& e) noexcept {
    using I = xsimd::batch<std::int32_t, Arch>;
    const I bits = xsimd::bitwise_cast<I>(c);
    const B exponent = xsimd::batch_cast<float>((bits >> 23) - I(127));
    const B m = xsimd::bitwise_cast<B>((bits & I(0x007fffff)) | I(0x3f800000)) - B(1.0f);
    B g = B(0.0204903372f);
    g = fmadd(g, m, B(-0.0960662224f));
    g = fmadd(g, m, B(0.215588502f));
    g = fmadd(g, m, B(-0.339247757f));
    g = fmadd(g, m, B(0.477705927f));
    g = fmadd(g, m, B(-0.721162734f));
    g = fmadd(g, m, B(1.44269326f));
    const B log2c = fmadd(g, m, exponent);
    const B y = xsimd::max(e * log2c, B(-126.0f));
    const B yi = xsimd::floor(y);
    const B f = y - yi;
    B q = B(0.00189510704f);
    q = fmadd(q, f, B(0.00894621529f));
    q = fmadd(q, f, B(0.0558632821f));
    q = fmadd(q, f, B(0.24014077f));
    q = fmadd(q, f, B(0.69315462f));
    q = fmadd(q, f, B(0.999999896f));
    const I scaled = xsimd::bitwise_cast<I>(q) + (xsimd::batch_cast<std::int32_t>(yi) << 23);
    const B result = xsimd::bitwise_cast<B>(scaled);
    return xsimd::select(e == B(0.0f), B(1.0f), xsimd::select(c > B(0.0f), result, B(0.0f)));
  }
};

template <class Arch, class Real, class Mode>
struct Kernel {
  using T = Real;
  using B = xsimd::batch<T, Arch>;
  using M = xsimd::batch_bool<T, Arch>;
  using V = Vec3<B>;
  // Object ids: integers of Real's width, one per lane (exact for any count of objects).
  using Id = xsimd::as_integer_t<T>;
  using I = xsimd::batch<Id, Arch>;
  using MI = xsimd::batch_bool<Id, Arch>;
  using Tr = Traversal<Arch, T>;
  static constexpr bool kFast = std::is_same_v<Mode, FastMode>;
  static constexpr bool kProfile = std::is_same_v<Mode, ProfiledMode>;
  using Mth = std::conditional_t<kFast, FastMath<Arch>, ExactMath>;
  static constexpr int W = static_cast<int>(B::size);
  using Scene = PreparedScene<T>;
  static_assert(W <= kMaxLanes, "camera tables are padded for kMaxLanes lanes");
  static_assert(std::is_same_v<Mode, ExactMode> || std::is_same_v<T, float>,
                "fast and profiled modes are for float");

  // Profiling (ProfiledMode only; compiled out of every other instantiation). The laps form one
  // chain: each charges the cycles since the previous lap to a stage, so the stages cover the
  // kernel's whole time between them.
  static void lap(RayCounts& c, int stage) noexcept {
    if constexpr (kProfile) {
      const std::uint64_t now = __rdtsc();
      c.profile->cycles[stage] += now - c.profile->last_tsc;
      c.profile->last_tsc = now;
    }
  }
  static void occupancy(RayCounts& c, int stage, const M& m) noexcept {
    if constexpr (kProfile) {
      const int n = static_cast<int>(count(m));
      c.profile->current = stage;
      c.profile->packets[stage] += 1;
      c.profile->active_lanes[stage] += n;
      c.profile->histogram[stage][n] += 1;
    }
  }
  // A hierarchy leaf visited by the lanes of m, charged to the stage being traced.
  static void leaf_visit(RayCounts& c, const M& m) noexcept {
    if constexpr (kProfile) {
      c.profile->leaf_packets[c.profile->current] += 1;
      c.profile->leaf_lanes[c.profile->current] += count(m);
    }
  }
  // A secondary packet that walked the hierarchy whole though its scene sends such rays one at a
  // time (its rays stay together), or lane by lane.
  static void walk_choice(RayCounts& c, bool whole) noexcept {
    if constexpr (kProfile)
      (whole ? c.profile->walked_whole : c.profile->walked_apart)[c.profile->current] += 1;
  }
  static void tests(RayCounts& c, const M& m, bool sphere) noexcept {
    if constexpr (kProfile) (sphere ? c.profile->sphere_tests : c.profile->plane_tests) += count(m);
  }

  static B iota() noexcept {
    alignas(64) T v[W];
    for (int k = 0; k < W; ++k) v[k] = T(k);
    return B::load_aligned(v);
  }

  // The mask as one bit per lane (lanes.hpp).
  static unsigned bits(const M& m) noexcept { return lane_bits(m); }

  // A mask between Real's and the id's lanes (same count, same bits: xsimd 8.1 has no cast).
  static MI to_mi(const M& m) noexcept {
    using Q = typename M::register_type;
    using R = typename MI::register_type;
    const Q q = m;
    R r;
    std::memcpy(&r, &q, sizeof r);
    return MI(r);
  }
  static M to_m(const MI& m) noexcept {
    using Q = typename MI::register_type;
    using R = typename M::register_type;
    const Q q = m;
    R r;
    std::memcpy(&r, &q, sizeof r);
    return M(r);
  }

  // Ids to and from 32-bit integer arrays (the API's, trade's and the tests' outputs): every id
  // is below kMaxObjects = 2^25, so nothing rounds, unlike floats past 2^24. Lane by lane where
  // the lanes are 64-bit (double).
  static void store_ids(const I& id, std::int32_t* out, int lanes) noexcept {
    alignas(64) Id in[W];
    id.store_aligned(in);
    for (int k = 0; k < lanes; ++k) out[k] = static_cast<std::int32_t>(in[k]);
  }
  static I load_ids(const std::int32_t* in) noexcept {
    alignas(64) Id v[W];
    for (int k = 0; k < W; ++k) v[k] = static_cast<Id>(in[k]);
    return I::load_aligned(v);
  }

  // Active lanes of a mask.
  static std::uint64_t count(const M& m) noexcept {
    return static_cast<std::uint64_t>(__builtin_popcount(bits(m)));
  }

  // field[id] per lane, for a field of n entries (padded to kMaxLanes by prepare()). Up to W
  // entries the field fits one register and one permute looks every lane up; beyond, a hardware
  // gather. (xsimd 8.1's B::gather falls back to inserting lane by lane here.) SSE has neither:
  // lane by lane.
  [[gnu::always_inline]] static B gather(const std::vector<T>& field, const I& id, int n) noexcept {
    if constexpr (std::is_same_v<T, float> && W == 16) {
      if (n <= 16) return _mm512_permutexvar_ps(id, _mm512_loadu_ps(field.data()));
      return _mm512_i32gather_ps(id, field.data(), 4);
    } else if constexpr (std::is_same_v<T, double> && W == 8) {
      if (n <= 8) return _mm512_permutexvar_pd(id, _mm512_loadu_pd(field.data()));
      return _mm512_i64gather_pd(id, field.data(), 8);
    } else if constexpr (std::is_same_v<T, float> && W == 8) {
      if (n <= 8) return _mm256_permutevar8x32_ps(_mm256_loadu_ps(field.data()), id);
      return gather8(field.data(), id);
    } else {
      alignas(64) Id ids[W];
      alignas(64) T out[W];
      id.store_aligned(ids);
      for (int k = 0; k < W; ++k) out[k] = field[static_cast<std::size_t>(ids[k])];
      return B::load_aligned(out);
    }
  }
  // _mm256_i32gather_ps, its index kept out of ymm4 (the asm clobbers it). qemu 7.2 (Debian
  // 12's, which .ci/qemu.sh runs) decodes a VSIB index of ymm4 as no index at all (SIB's 100b
  // means none for general registers only), so a gather GCC gave ymm4 read field[0] in every
  // lane under emulation: wrong colours at width 8 there, appearing and going with unrelated
  // changes to GCC's register choice (docs/tools.md). Hardware reads every index register.
  static __m256 gather8(const float* base, __m256i id) noexcept {
    __m256 out = _mm256_setzero_ps();
    __m256 mask = _mm256_castsi256_ps(_mm256_set1_epi32(-1));
    asm("vgatherdps %[mask], (%[base],%[index],4), %[out]"
        : [out] "+x"(out), [mask] "+x"(mask)
        : [base] "r"(base), [index] "x"(id), "m"(*(const char(*)[])base)
        : "xmm4");
    return out;
  }
  // A field of every object (materials).
  [[gnu::always_inline]] static B gather(const Scene& s, const std::vector<T>& field,
                                         const I& id) noexcept {
    return gather(field, id, s.num_objects());
  }

  static V select3(const M& m, const V& a, const V& b) noexcept {
    return {xsimd::select(m, a.x, b.x), xsimd::select(m, a.y, b.y), xsimd::select(m, a.z, b.z)};
  }

  // The discriminant of sphere i, f = origin - centre. Exact: Ray Tracing Gems ch. 7's
  // r^2 - |f - b d|^2, as the reference. Fast: the textbook b^2 - c, b^2 fused, with c from the
  // eye's table for camera rays: a third of the operations, at the price of b^2 - c's
  // cancellation when a sphere is small against its distance, so only in scenes where no sphere
  // is (PreparedScene::naive_spheres_hold; docs/precision.md).
  static bool textbook(const Scene& s) noexcept { return kFast && s.naive_spheres_hold; }
  // eye_c: the eye's c of the sphere (read only for camera rays).
  [[gnu::always_inline]] static SphereDisc<B> disc_of(const Scene& s, const V& f, const V& d,
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
  static B first_root(const Scene& s, const SphereDisc<B>& sd, const V& f, const B& r2,
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
  static Spheres all_spheres(const Scene& s) noexcept {
    return {s.sphere_cx.data(), s.sphere_cy.data(), s.sphere_cz.data(),
            s.sphere_r2.data(), s.eye.fx.data(),    s.eye.fy.data(),
            s.eye.fz.data(),    s.eye.c.data(),     nullptr};
  }
  static Spheres leaf_spheres(const Scene& s) noexcept {
    const Bvh<T>& h = s.bvh;
    return {h.cx.data(),     h.cy.data(),     h.cz.data(),    h.r2.data(), h.eye_fx.data(),
            h.eye_fy.data(), h.eye_fz.data(), h.eye_c.data(), h.id.data()};
  }

  // Closest hit over spheres [begin, end) of `sp` for the lanes of `valid`; updates t and id
  // where a hit wins. kIdOrder: the spheres come in id order, so a nearer t alone decides (the
  // sequential loop's result); else, in any order, the lexicographic minimum of (t, id).
  // kFromEye: every ray leaves the pinhole eye, so f and c per sphere come precomputed.
  // kSome: only the spheres begin + j of which's bits j (a camera tile's cone, cones.hpp).
  template <bool kFromEye, bool kIdOrder, bool kSome = false>
  [[gnu::always_inline]] static void spheres_closest(const Scene& s, const Spheres& sp, int begin,
                                                     int end, M valid, const V& o, const V& d,
                                                     B& best_t, I& best_id, RayCounts& counts,
                                                     const I& leaving,
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

  // The spheres through the hierarchy (reach 0 or 1: Traversal::reach). Out of line: inlined
  // into closest_hit, the 4-wide traversal changed the code GCC made for the plain loop around
  // it (course scenes, no hierarchy: 2.5% more instructions at width 8, callgrind).
  // camera: camera rays (orthographic ones come here), which stay packets: they are coherent.
  template <bool kFromEye>
  [[gnu::noinline]] static void closest_in_hierarchy(const Scene& s, int reach, M valid, const V& o,
                                                     const V& d, B& best_t, I& best_id,
                                                     RayCounts& counts, const I& leaving,
                                                     bool camera) noexcept {
    const Spheres sp = leaf_spheres(s);
    auto leaf = [&](int first, int n, const M& m) {
      leaf_visit(counts, m);
      spheres_closest<kFromEye, false>(s, sp, first, first + n, m, o, d, best_t, best_id, counts,
                                       leaving);
    };
    // Exact float: where the scene says (Bvh::one_ray_lanes), secondary rays' lanes go on one
    // ray at a time, unless they stay together.
    if constexpr (!kFromEye && !kFast && std::is_same_v<T, float>) {
      if (s.bvh.one_ray_lanes > 0 && !camera) {
        const bool whole = together(s, valid, o, d);
        walk_choice(counts, whole);
        if (!whole) {
          auto walk = [&](auto padded) {
            constexpr bool kPadded = decltype(padded)::value;
            OneRay<kPadded> one{s, o, d, best_t, best_id, counts, s.bvh.one_ray_lanes, {}};
            Tr::template closest<kPadded>(s.bvh, valid, o, d, best_t, leaf, one);
          };
          reach == 0 ? walk(std::false_type{}) : walk(std::true_type{});
          return;
        }
      }
    }
    if (reach == 0)
      Tr::template closest<false>(s.bvh, valid, o, d, best_t, leaf);
    else
      Tr::template closest<true>(s.bvh, valid, o, d, best_t, leaf);
  }
  // Whether a packet's live lanes stay together through the hierarchy (Bvh::coherent_spread):
  // the spread of their origins plus that of their directions over the structure's diagonal.
  // Coherent packets (a flat mirror's, camera rays through the library API) walk 2x faster
  // whole than lane by lane at 65536 spheres; diverging ones 1.3x-1.5x slower.
  [[gnu::noinline]] static bool together(const Scene& s, const M& valid, const V& o,
                                         const V& d) noexcept {
    auto span = [&](const B& x) { return Tr::live_span(valid, x); };
    const T ox = span(o.x), oy = span(o.y), oz = span(o.z);
    const T dx = span(d.x), dy = span(d.y), dz = span(d.z);
    return std::sqrt(ox * ox + oy * oy + oz * oz) +
               s.bvh.diagonal * std::sqrt(dx * dx + dy * dy + dz * dz) <=
           s.bvh.coherent_spread;
  }
  // A packet's rays lane by lane, stored when a first lane goes on alone.
  struct LaneRays {
    alignas(64) T ox[W], oy[W], oz[W], dx[W], dy[W], dz[W];
    bool stored = false;
    void store(const V& o, const V& d) noexcept {
      if (stored) return;
      o.x.store_aligned(ox), o.y.store_aligned(oy), o.z.store_aligned(oz);
      d.x.store_aligned(dx), d.y.store_aligned(dy), d.z.store_aligned(dz);
      stored = true;
    }
    void get(int k, T* o, T* d) const noexcept {
      o[0] = ox[k], o[1] = oy[k], o[2] = oz[k], d[0] = dx[k], d[1] = dy[k], d[2] = dz[k];
    }
  };
  // The lanes `lanes` of a packet going on alone, in lane order: their rays and slab forms.
  struct LoneRays {
    typename Tr::OneRay4 slab[W];
    T o[W][3], d[W][3];
    int lane[W];
    int n = 0;
    LoneRays(const LaneRays& rays, unsigned lanes, bool padded) noexcept {
      for (; lanes; lanes &= lanes - 1, ++n) {
        const int k = lane[n] = __builtin_ctz(lanes);
        rays.get(k, o[n], d[n]);
        slab[n] = Tr::one_ray(o[n], d[n], padded);
      }
    }
  };
  // A leaf visited by one lane alone (lancer profile: one call, one lane live).
  static void one_leaf_visit(RayCounts& c, int spheres) noexcept {
    if constexpr (kProfile) {
      c.profile->leaf_packets[c.profile->current] += 1;
      c.profile->leaf_lanes[c.profile->current] += 1;
      c.profile->sphere_tests += std::uint64_t(spheres);
    }
  }
  // A secondary packet's lanes walking a subtree one ray at a time (exact float; the hybrid
  // step of Traversal::closest): each lane's ray over the wide nodes alone, the lanes' walks
  // interleaved (Traversal::closest_one), its leaves' spheres four at a time
  // (spheres_closest_one).
  template <bool kPadded>
  struct OneRay {
    static constexpr int kMaxLanes = W;
    const Scene& s;
    const V& o;
    const V& d;
    B& best_t;
    I& best_id;
    RayCounts& counts;
    int limit;  // lanes at or below which they go on alone
    LaneRays rays;
    void operator()(unsigned lanes, std::int32_t child, std::int32_t count) noexcept {
      rays.store(o, d);
      alignas(64) T bt[W];
      alignas(64) Id bi[W];
      best_t.store_aligned(bt);
      best_id.store_aligned(bi);
      // Every lane's walk at once, interleaved (Traversal::closest_one).
      const LoneRays lone(rays, lanes, kPadded);
      const T* best[W];
      for (int i = 0; i < lone.n; ++i) best[i] = &bt[lone.lane[i]];
      Tr::template closest_one<kPadded, W>(
          s.bvh, lone.slab, lone.n, child, count, best, [&](int i, int first, int m) {
            const int k = lone.lane[i];
            one_leaf_visit(counts, m);
            spheres_closest_one(s, first, m, lone.o[i], lone.d[i], bt[k], bi[k]);
          });
      best_t = B::load_aligned(bt);
      best_id = I::load_aligned(bi);
    }
  };
  // One ray (o, d) against leaf-order spheres [first, first + n), four spheres a register (the
  // lanes are spheres): each lane computes the reference's formulas for its sphere, IEEE
  // operation by operation, so its t is the reference's. hit(q, t) for each sphere met beyond
  // epsilon, in leaf order, -> true to stop; returns whether one did.
  template <class Hit>
  static bool spheres_one(const Scene& s, int first, int n, const T* o, const T* d,
                          Hit&& hit) noexcept {
    using B4 = xsimd::batch<float, xsimd::sse4_2>;
    const Bvh<T>& h = s.bvh;
    const int total = int(h.cx.size());
    const Vec3<B4> ov{B4(o[0]), B4(o[1]), B4(o[2])}, dv{B4(d[0]), B4(d[1]), B4(d[2])};
    const B4 eps(s.epsilon);
    const B4 lane(_mm_setr_ps(0.f, 1.f, 2.f, 3.f));
    for (int j = first; j < first + n; j += 4) {
      const int m = std::min(4, first + n - j);
      B4 cx, cy, cz, r2;
      if (j + 4 <= total) {
        cx = B4::load_unaligned(&h.cx[j]), cy = B4::load_unaligned(&h.cy[j]);
        cz = B4::load_unaligned(&h.cz[j]), r2 = B4::load_unaligned(&h.r2[j]);
      } else {  // the last leaf's last spheres: no reads past the arrays
        alignas(16) T v[4][4] = {};
        for (int q = 0; q < m; ++q)
          v[0][q] = h.cx[j + q], v[1][q] = h.cy[j + q], v[2][q] = h.cz[j + q],
          v[3][q] = h.r2[j + q];
        cx = B4::load_aligned(v[0]), cy = B4::load_aligned(v[1]);
        cz = B4::load_aligned(v[2]), r2 = B4::load_aligned(v[3]);
      }
      const Vec3<B4> f = ov - Vec3<B4>{cx, cy, cz};
      const SphereDisc<B4> sd = sphere_disc(f, dv, r2);
      const auto live = (sd.disc >= B4(0.f)) & (lane < B4(float(m)));
      if (!xsimd::any(live)) continue;
      const B4 t = sphere_first_root(sphere_roots(sd, sphere_c(f, r2)), eps);
      unsigned met = unsigned(_mm_movemask_ps(live & (t > eps)));
      if (!met) continue;
      alignas(16) T tt[4];
      t.store_aligned(tt);
      for (; met; met &= met - 1) {
        const int q = __builtin_ctz(met);
        if (hit(j + q, tt[q])) return true;
      }
    }
    return false;
  }
  // The lexicographic minimum of (t, id) over those spheres and the ray's best.
  static void spheres_closest_one(const Scene& s, int first, int n, const T* o, const T* d,
                                  T& best_t, Id& best_id) noexcept {
    spheres_one(s, first, n, o, d, [&](int j, T t) {
      const Id id = Id(s.bvh.id[std::size_t(j)]);
      if (t < best_t || (t == best_t && id < best_id)) best_t = t, best_id = id;
      return false;
    });
  }

  // A shadow packet's lanes walking a subtree one ray at a time (exact float; the hybrid step
  // of Traversal::any): each pending lane's segment over the wide nodes alone in the fixed slot
  // order, the lanes' walks interleaved (Traversal::any_one), its leaves' spheres four at a
  // time; step(id, lane, pending) for each sphere a lane meets before the light, in leaf order
  // for that lane, until the lane is no longer pending (steps of different lanes touch
  // different lanes only, so their interleaving changes nothing).
  template <bool kPadded, class Step>
  struct OneShadow {
    static constexpr int kMaxLanes = W;
    const Scene& s;
    const V& p;
    const V& l;
    const B& dist;
    Step& step;
    RayCounts& counts;
    int limit;  // lanes at or below which they go on alone
    LaneRays rays;
    alignas(64) T dd[W];
    M operator()(unsigned lanes, std::int32_t child, std::int32_t count, M pending) noexcept {
      if (!rays.stored) dist.store_aligned(dd);
      rays.store(p, l);
      const B index = iota();
      // Every lane's walk at once, interleaved.
      const LoneRays lone(rays, lanes, kPadded);
      const T* tmax[W];
      for (int i = 0; i < lone.n; ++i) tmax[i] = &dd[lone.lane[i]];
      auto leaf = [&](int i, int first, int m) {
        one_leaf_visit(counts, m);
        const M mine = index == B(T(lone.lane[i]));
        return spheres_one(s, first, m, lone.o[i], lone.d[i], [&](int j, T t) {
          if (!(t < *tmax[i])) return false;
          pending = step(Id(s.bvh.id[std::size_t(j)]), mine, pending);
          return !xsimd::any(pending & mine);
        });
      };
      // One lane (the usual case at limit 1) walks without the others' stacks.
      if (lone.n == 1)
        Tr::template any_one<kPadded, 1>(s.bvh, lone.slab, 1, child, count, tmax, leaf);
      else
        Tr::template any_one<kPadded, W>(s.bvh, lone.slab, lone.n, child, count, tmax, leaf);
      return pending;
    }
  };
  // The hierarchy's any-hit walk with lanes going on alone (OneShadow) where the scene says.
  template <bool kPadded, class Leaf, class Step>
  static M any_one_ray(const Scene& s, const M& valid, const V& p, const V& l, const B& dist,
                       RayCounts& counts, Leaf& leaf, Step& step) noexcept {
    OneShadow<kPadded, Step> one{s, p, l, dist, step, counts, s.bvh.shadow_one_ray_lanes, {}, {}};
    return Tr::template any<kPadded>(s.bvh, valid, p, l, dist, leaf, one);
  }

  // Closest hit over all objects for the lanes in `valid`. Updates t and id only where a nearer
  // hit is found (an equal t: a lower id); returns the lanes whose t is now finite.
  // Spheres through the hierarchy where the scene has one (and every lane starts within its
  // origin limit), else all in a loop; planes always in a loop, after the spheres (higher ids).
  // `leaving`: per lane, the sphere the ray leaves from outside (-1: none); see skip().
  // camera: the rays are camera rays (coherent: never one ray at a time).
  // Always inlined: with the ray tree's second copy of shade(), GCC stopped inlining it into
  // render_rows, and opaque scenes lost 5% to 15% at width 16.
  template <bool kFromEye = false>
  [[gnu::always_inline]] static M closest_hit(const Scene& s, M valid, const V& o, const V& d,
                                              B& best_t, I& best_id, RayCounts& counts,
                                              const I& leaving = I(Id(-1)),
                                              bool camera = false) noexcept {
    if (s.features.spheres) {
      const int reach = !s.bvh.active() ? 2 : kFromEye ? 0 : Tr::reach(s.bvh, valid, o);
      if (reach < 2) {
        closest_in_hierarchy<kFromEye>(s, reach, valid, o, d, best_t, best_id, counts, leaving,
                                       camera);
      } else {
        spheres_closest<kFromEye, true>(s, all_spheres(s), 0, s.num_spheres, valid, o, d, best_t,
                                        best_id, counts, leaving);
      }
    }

    if (s.features.planes) planes_closest(s, valid, o, d, best_t, best_id, counts);
    return valid & (best_t < B(std::numeric_limits<T>::infinity()));
  }

  // Where the ray (o, d) meets plane k; denom: d . n (0: parallel, no hit).
  [[gnu::always_inline]] static B plane_t(const Scene& s, int k, const V& o, const V& d,
                                          B& denom) noexcept {
    const V n{B(s.plane_nx[k]), B(s.plane_ny[k]), B(s.plane_nz[k])};
    denom = Mth::dot(d, n);
    return Mth::div(Mth::dot(V{B(s.plane_px[k]), B(s.plane_py[k]), B(s.plane_pz[k])} - o, n),
                    denom);
  }

  // The planes' part of closest_hit: after the spheres, in id order (their ids are higher).
  [[gnu::always_inline]] static void planes_closest(const Scene& s, const M& valid, const V& o,
                                                    const V& d, B& best_t, I& best_id,
                                                    RayCounts& counts) noexcept {
    const B eps(s.epsilon);
    for (int k = 0; k < s.num_planes; ++k) {
      tests(counts, valid, false);
      B denom;
      const B t = plane_t(s, k, o, d, denom);
      const M m = valid & (denom != B(0)) & (t > eps) & (t < best_t);
      best_t = xsimd::select(m, t, best_t);
      best_id = xsimd::select(to_mi(m), I(Id(s.num_spheres + k)), best_id);
    }
  }

  // The spheres of kN pinhole camera packets through the hierarchy at once
  // (Traversal::closest_coherent): one walk for tiles side by side.
  template <int kN>
  [[gnu::noinline]] static void closest_group_in_hierarchy(const Scene& s, const M* valid,
                                                           const V* o, const V* d, B* best_t,
                                                           I* best_id, RayCounts& counts) noexcept {
    const Spheres sp = leaf_spheres(s);
    const I none(Id(-1));
    auto leaf = [&](int i, int first, int n, const M& m) {
      leaf_visit(counts, m);
      spheres_closest<true, false>(s, sp, first, first + n, m, o[i], d[i], best_t[i], best_id[i],
                                   counts, none);
    };
    // The spheres of [first, first + n) that tile i's cone may meet (bits of which).
    auto some = [&](int i, int first, int n, const M& m, std::uint32_t which) {
      leaf_visit(counts, m);
      spheres_closest<true, false, true>(s, sp, first, first + n, m, o[i], d[i], best_t[i],
                                         best_id[i], counts, none, which);
    };
    // One functor, two calls: all of a leaf's spheres, or those of a mask.
    struct Leaves : decltype(leaf), decltype(some) {
      using decltype(leaf)::operator(), decltype(some)::operator();
    } leaves{leaf, some};
    if constexpr (kProfile)
      Tr::template closest_coherent<kN>(s.bvh, valid, o, d, best_t, leaves,
                                        WalkCount{&counts.profile->blocks});
    else
      Tr::template closest_coherent<kN>(s.bvh, valid, o, d, best_t, leaves);
  }
  // The camera blocks' walk counted into the profile (ProfiledMode only).
  struct WalkCount {
    StageProfile::Blocks* b;
    void block(bool together) const noexcept {
      ++(together ? b->together : b->alone);
      b->block_w = kGroupPx, b->block_h = kBlockRows;
    }
    void node() const noexcept { ++b->nodes; }
    void leaf_pop() const noexcept { ++b->leaf_pops; }
    void tile_test() const noexcept { ++b->tile_tests; }
    void leaf_call(unsigned lanes) const noexcept {
      ++b->leaf_calls;
      b->leaf_lanes += unsigned(__builtin_popcount(lanes));
    }
    void tile_alone() const noexcept { ++b->tiles_alone; }
    void cones(int pairs, int kept) const noexcept {
      b->cone_pairs += unsigned(pairs), b->cone_kept += unsigned(kept);
    }
  };

  // Any-hit for shadow rays from p along unit l, before `dist`: calls step(id, lanes, pending)
  // for each object the lanes' segments meet (each object once per lane, spheres in the
  // hierarchy's fixed depth-first order or id order, then planes), and returns the lanes of
  // `valid` still pending; stops as soon as none is. `leaving` as for closest_hit. The order is
  // the reference's (a float product of three or more transmits depends on it).
  template <bool kOneRay = false, class Step>
  [[gnu::always_inline]] static M any_hit(const Scene& s, const M& valid, const V& p, const V& l,
                                          const B& dist, RayCounts& counts, const I& leaving,
                                          Step&& step) noexcept {
    const B eps(s.epsilon);
    auto spheres = [&](const Spheres& sp, int begin, int end, const M& mask, M pending) {
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
    };
    M pending = valid;
    if (s.features.spheres) {
      const int reach = s.bvh.active() ? Tr::reach(s.bvh, valid, p) : 2;
      if (reach < 2) {
        const Spheres sp = leaf_spheres(s);
        auto leaf = [&](int first, int n, const M& mask, const M& pend) {
          leaf_visit(counts, mask & pend);
          return spheres(sp, first, first + n, mask, pend);
        };
        if constexpr (kOneRay)
          pending = reach == 0 ? any_one_ray<false>(s, valid, p, l, dist, counts, leaf, step)
                               : any_one_ray<true>(s, valid, p, l, dist, counts, leaf, step);
        else
          pending = reach == 0 ? Tr::template any<false>(s.bvh, valid, p, l, dist, leaf)
                               : Tr::template any<true>(s.bvh, valid, p, l, dist, leaf);
      } else {
        pending = spheres(all_spheres(s), 0, s.num_spheres, valid, valid);
      }
      if (!xsimd::any(pending)) return pending;
    }
    for (int k = 0; k < s.num_planes; ++k) {
      tests(counts, pending, false);
      B denom;
      const B t = plane_t(s, k, p, l, denom);
      const M m = pending & (denom != B(0)) & (t > eps) & (t < dist);
      if (!xsimd::any(m)) continue;
      pending = step(Id(s.num_spheres + k), m, pending);
      if (!xsimd::any(pending)) return pending;
    }
    return pending;
  }

  // A packet of shadow rays under way: the lanes still looking for what they meet, and each
  // lane's transmittance so far (contract step 4; stays 1 in scenes without transparency).
  struct Shadow {
    M pending;
    B transmittance;
  };

  // The any-hit query's per-object step: the lanes of `met` meet object `id` (nearest hit beyond
  // epsilon, nearer than the light). Their transmittance is multiplied by its transmit; a lane
  // is done once that is 0. Without transparency every object is opaque: done at once, no
  // product. kGlass false: the scene has no transparency (compiled out of the grey opaque path).
  template <bool kGlass>
  static void shadow_hit(const Scene& s, Shadow& sh, const M& met, Id id) noexcept {
    if (!kGlass || !s.features.transparency) {
      sh.pending = sh.pending & ~met;
      return;
    }
    sh.transmittance = xsimd::select(
        met, attenuate(sh.transmittance, B(s.mat_transmit[std::size_t(id)])), sh.transmittance);
    sh.pending = sh.pending & ~(met & (sh.transmittance == B(0)));
  }

  // Shadow rays from p along unit l towards lights at `dist`: each lane's transmittance over
  // the objects it meets; `pending` keeps the lanes whose transmittance is not 0 (in opaque
  // scenes, those not blocked). `leaving` as for closest_hit.
  // Always inlined: with the 4-wide traversal in any_hit, GCC stopped inlining it into
  // render_rows, and course scenes ran 6% to 9% more instructions (callgrind, widths 4 and 8).
  template <bool kGlass, bool kOneRay = true>
  [[gnu::always_inline]] static Shadow occluded(const Scene& s, M valid, const V& p, const V& l,
                                                const B& dist, RayCounts& counts, const I& leaving,
                                                bool secondary = false) noexcept {
    if constexpr (kOneRay && !kFast && std::is_same_v<T, float>)
      if (__builtin_expect(secondary && s.bvh.shadow_one_ray_lanes > 0, 0))
        return occluded_one_ray<kGlass>(s, valid, p, l, dist, counts);
    return occluded_as<kGlass, false>(s, valid, p, l, dist, counts, leaving);
  }
  template <bool kGlass, bool kOneRay>
  [[gnu::always_inline]] static Shadow occluded_as(const Scene& s, const M& valid, const V& p,
                                                   const V& l, const B& dist, RayCounts& counts,
                                                   const I& leaving) noexcept {
    Shadow sh{valid, B(T(1))};
    sh.pending = any_hit<kOneRay>(s, valid, p, l, dist, counts, leaving,
                                  [&](Id id, const M& met, const M& pending) {
                                    sh.pending = pending;
                                    shadow_hit<kGlass>(s, sh, met, id);
                                    return sh.pending;
                                  });
    return sh;
  }
  // Shadow rays of secondary hits through a hierarchy, lanes alone where the scene says (exact
  // float). Out of line and by value: the shading loops that inline `occluded` keep their
  // vectors in registers (a reference passed out would give them a home in memory; the course
  // scenes ran 2-3% more instructions in render_rows, callgrind).
  template <bool kGlass>
  [[gnu::noinline]] static Shadow occluded_one_ray(const Scene& s, M valid, V p, V l, B dist,
                                                   RayCounts& counts) noexcept {
    return occluded_as<kGlass, true>(s, valid, p, l, dist, counts, I(Id(-1)));
  }

  // max(0, c)^shininess per lane: binary powering for whole exponents; std::pow lane by lane
  // for the rare fractional ones, exactly as the reference does for that material.
  [[gnu::always_inline]] static B power(const Scene& s, const B& cos_nh, const B& shininess,
                                        const B& shininess_int) noexcept {
    // One whole exponent for every lane (one material's area, the common case): drive binary
    // powering from the exponent's bits as an integer, a chain of multiplications only.
    const T first = shininess.get(0);
    // Whole: the prepared flag (exact); fast tests the value itself and gathers no flag.
    const bool first_whole = kFast ? first == std::trunc(first) && first < T(4294967296.0)
                                   : shininess_int.get(0) != T(0);
    if (xsimd::all(shininess == B(first)) && first_whole)
      return power_uint(positive_part(cos_nh), static_cast<std::uint32_t>(first));
    if constexpr (kFast) return Mth::pow01(positive_part(cos_nh), shininess);
    const M whole = shininess_int != B(0);
    B p = specular_power(cos_nh, xsimd::select(whole, shininess, B(0)));
    if (!s.features.fractional_shininess || xsimd::all(whole)) return p;
    alignas(64) T pv[W], cv[W], sv[W], wv[W];
    p.store_aligned(pv);
    positive_part(cos_nh).store_aligned(cv);
    shininess.store_aligned(sv);
    shininess_int.store_aligned(wv);
    for (int k = 0; k < W; ++k)
      if (wv[k] == T(0)) pv[k] = std::pow(cv[k], sv[k]);
    return B::load_aligned(pv);
  }

  // v / |v|, and |v| in `length`. Exact: a square root and a division, as the reference.
  // Fast: one refined reciprocal square root for both. Where v = 0, length is 0 (exact) or NaN
  // (fast): callers test length > 0, false for both.
  static V unit(const V& v, B& length) noexcept {
    if constexpr (kFast) {
      const B len2 = Mth::dot(v, v);
      const B inv = Mth::rsqrt(len2);
      length = len2 * inv;
      return v * inv;
    } else {
      length = Mth::length(v);
      return Mth::div(v, length);
    }
  }

  // A cosine with the surface normal. Fast mode's sphere normals, (p - c) / r, are unit only as
  // far as p lies on the sphere: where float puts p far off a tiny sphere, capping at 1 keeps
  // cos^shininess and kd I cos finite.
  static B cosine(const B& c) noexcept {
    if constexpr (kFast)
      return xsimd::min(c, B(1.0f));
    else
      return c;
  }

  // One bounce level of a packet: what the recursion of the reference keeps on its stack.
  struct Level {
    B r, g, b;    // local colour (or background/environment where the ray missed)
    B reflect;    // the hit material's reflection coefficient
    M reflected;  // lanes that went on to a reflected ray
    // Scenes with refraction only: the lanes that went on to a refracted (or totally
    // reflected) ray, the material's transmit, and those rays, with `leaving` as for shade().
    M refracted;
    B transmit;
    V to, td;
    I t_leaving;
  };

  // A camera packet's closest hits found before it is shaded (render_rows' camera blocks):
  // shade() then takes them instead of tracing the packet's rays.
  struct GivenHit {
    B t;
    I id;
  };

  // Contract steps 4 and 5 for the lanes of `hit` over C channels of the lights (1: grey, the
  // colour then scales one sum; 3: coloured): shade[c] = (ambient + diffuse) + specular.
  // `here`: the sphere hit from outside (fast mode), which shadow rays leaving outwards skip.
  // kGlass false: grey opaque scenes, with no transparency code at all.
  struct Shade {
    B r, g, b;
  };
  template <int C, bool kGlass, bool kOneRay = true>
  [[gnu::always_inline]] static Shade light_sums(const Scene& s, const M& hit, const I& id,
                                                 const B& delta, const V& p, const V& n,
                                                 const V& view, const I& here, RayCounts& counts,
                                                 bool secondary) noexcept {
    const B ka = gather(s, s.mat_ka, id), kd = gather(s, s.mat_kd, id);
    B ks(0), shininess(0), shininess_int(0);
    if (s.features.specular) {
      ks = gather(s, s.mat_ks, id);
      shininess = gather(s, s.mat_shininess, id);
      if constexpr (!kFast) shininess_int = gather(s, s.mat_shininess_int, id);
    }
    // Fast mode's shortcuts for shadow rays (below) assume opaque objects.
    const bool glass = kGlass && s.features.transparency;
    const bool shortcuts = kFast && !glass;
    B ambient[C], diffuse[C], specular[C];
    for (int c = 0; c < C; ++c) ambient[c] = diffuse[c] = specular[c] = B(0);
    for (int k = 0; k < s.num_lights; ++k) {
      for (int c = 0; c < C; ++c)
        ambient[c] = ambient[c] + ka * B(C == 1 ? s.light_ambient[k] : s.light_ambient_rgb[c][k]);
      const V to_light = V{B(s.light_x[k]), B(s.light_y[k]), B(s.light_z[k])} - p;
      B dist;
      const V l = unit(to_light, dist);
      const M lit = hit & (dist > B(0));
      counts.shadow += count(lit);
      if (!xsimd::any(lit)) continue;
      const B cos_nl = Mth::dot(l, n);
      // Fast mode, opaque scenes: a light behind the surface is blocked by the surface itself
      // (the offset origin lies on the viewer's side), so its shadow ray is answered without
      // tracing; the rays traced all leave on the normal's side, and those leaving a sphere
      // from outside skip it. Through glass the surface passes part of the light: traced, and
      // only the rays leaving outwards skip their sphere.
      const M traced = shortcuts ? lit & (cos_nl > B(0)) : lit;
      const V from = offset_origin(p, n, shortcuts ? B(1) : cos_nl, delta);
      I skip_sphere = here;
      if constexpr (kFast)
        if (!shortcuts) skip_sphere = xsimd::select(to_mi(cos_nl > B(0)), here, I(Id(-1)));
      lap(counts, kShading);
      occupancy(counts, secondary ? kSecondaryShadowRays : kShadowRays, traced);
      const Shadow sh =
          occluded<kGlass, kOneRay>(s, traced, from, l, dist, counts, skip_sphere, secondary);
      const M unblocked = traced & sh.pending;
      lap(counts, secondary ? kSecondaryShadowRays : kShadowRays);
      if (!xsimd::any(unblocked)) continue;
      const B cos_term = positive_part(cosine(cos_nl));
      B spec_power(0);
      M spec_lanes(false);
      if (s.features.specular) {
        B half_len;
        const V h = unit(l + view, half_len);
        spec_lanes = unblocked & (half_len > B(0));
        spec_power = power(s, cosine(Mth::dot(n, h)), shininess, shininess_int);
      }
      for (int c = 0; c < C; ++c) {
        B intensity(C == 1 ? s.light_intensity[k] : s.light_intensity_rgb[c][k]);
        if (glass) intensity = intensity * sh.transmittance;
        diffuse[c] = xsimd::select(unblocked, diffuse[c] + (kd * intensity) * cos_term, diffuse[c]);
        if (s.features.specular)
          specular[c] =
              xsimd::select(spec_lanes, specular[c] + (ks * intensity) * spec_power, specular[c]);
      }
    }
    const B sum0 = (ambient[0] + diffuse[0]) + specular[0];
    if constexpr (C == 1)
      return {sum0, sum0, sum0};
    else
      return {sum0, (ambient[C - 2] + diffuse[C - 2]) + specular[C - 2],
              (ambient[C - 1] + diffuse[C - 1]) + specular[C - 1]};
  }

  // Coloured lights or transparency: out of line. Inlined beside the grey opaque sums they made
  // GCC stop inlining the intersection loops into render_rows, which cost grey opaque scenes
  // their speed (issue 13: a scene pays only for what it uses). Arguments by value: references
  // would give the hot path's vectors a home in memory.
  [[gnu::noinline]] static Shade general_light_sums(const Scene& s, M hit, I id, B delta, V p, V n,
                                                    V view, I here, RayCounts& counts,
                                                    bool secondary) noexcept {
    if (s.features.coloured_lights)
      return light_sums<3, true>(s, hit, id, delta, p, n, view, here, counts, secondary);
    return light_sums<1, true>(s, hit, id, delta, p, n, view, here, counts, secondary);
  }

  // Shades the lanes of `active` at one level; returns the lanes that reflect further and sets
  // o, d to their reflected rays; in scenes with refraction, out.refracted, out.to, out.td to
  // the refracted ones. `stage`: the stage the ray's intersection is charged to.
  // `leaving` (fast mode): the sphere each lane's ray leaves from outside, -1 for none; set for
  // the reflected rays (out.t_leaving for the refracted ones).
  // kTree: the ray tree's levels (scenes with refraction); the chain's have no refraction code.
  template <bool kTree, bool kOneRay = true>
  [[gnu::always_inline]] static M shade(const Scene& s, M active, int depth, int stage, V& o, V& d,
                                        I& leaving, Level& out, RayCounts& counts,
                                        const GivenHit* given = nullptr) noexcept {
    const B inf(std::numeric_limits<T>::infinity());
    B best_t = inf;
    I best_id(Id(-1));
    occupancy(counts, stage, active);
    M hit;
    if (given) {  // the camera blocks' hits: the same (t, id) as closest_hit<true> finds
      best_t = xsimd::select(active, given->t, inf);
      best_id = xsimd::select(to_mi(active), given->id, best_id);
      hit = active & (best_t < inf);
    } else {
      hit = depth == 0 && !s.camera.orthographic
                ? closest_hit<true>(s, active, o, d, best_t, best_id, counts)
                : closest_hit(s, active, o, d, best_t, best_id, counts, leaving, depth == 0);
    }
    lap(counts, stage);
    const T* miss_color = depth == 0 ? s.background : s.environment;
    out.r = B(miss_color[0]), out.g = B(miss_color[1]), out.b = B(miss_color[2]);
    out.reflected = M(false);
    out.refracted = M(false);
    if (!xsimd::any(hit)) return out.reflected;
    occupancy(counts, kShading, hit);

    // The hit point, its geometric normal and its secondary rays' offset (formulas.hpp):
    // p = o + t d, except on spheres small against |o|inf + t, where exact mode computes p
    // relative to the sphere, and huge ones, where it recomputes t accurately, as the reference.
    const B magnitude = hit_magnitude(o, best_t);
    V p = Mth::along(o, d, best_t);
    B delta = offset_delta<T>(magnitude);
    const I id = xsimd::select(to_mi(hit), best_id, I(0));
    V n{B(0), B(0), B(0)};
    if (s.features.spheres) {
      const I sid = xsimd::min(id, I(Id(s.num_spheres - 1)));
      const int ns = s.num_spheres;
      const V c{gather(s.sphere_cx, sid, ns), gather(s.sphere_cy, sid, ns),
                gather(s.sphere_cz, sid, ns)};
      if constexpr (kFast) {  // (p - c) / r, the contract's normal, by a multiplication
        n = (p - c) * gather(s.sphere_inv_r, sid, ns);
      } else {
        n = sphere_normal<Mth>(p, c);
        const B r2 = gather(s.sphere_r2, sid, ns);
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
    if (s.features.planes) {
      const I pid = xsimd::max(id - I(Id(s.num_spheres)), I(0));
      const int np = s.num_planes;
      const V pn{gather(s.plane_nx, pid, np), gather(s.plane_ny, pid, np),
                 gather(s.plane_nz, pid, np)};
      n = s.features.spheres ? select3(to_m(best_id < I(Id(s.num_spheres))), n, pn) : pn;
    }
    // The geometric normal's side: the ray enters the object where cos_in < 0 (step 7).
    const B cos_in = Mth::dot(n, d);
    const M inside = cos_in > B(0);
    n = select3(inside, -n, n);
    const V view = -d;
    // The sphere hit from outside, which this level's shadow rays and reflections leave.
    I here(Id(-1));
    if constexpr (kFast)
      if (s.features.spheres)
        here =
            xsimd::select(to_mi(hit & ~inside) & (best_id < I(Id(s.num_spheres))), best_id, here);

    const bool secondary = depth > 0;
    const Shade sum =
        s.features.coloured_lights || s.features.transparency
            ? general_light_sums(s, hit, id, delta, p, n, view, here, counts, secondary)
            : light_sums<1, false, kOneRay>(s, hit, id, delta, p, n, view, here, counts, secondary);
    out.r = xsimd::select(hit, gather(s, s.mat_r, id) * sum.r, out.r);
    out.g = xsimd::select(hit, gather(s, s.mat_g, id) * sum.g, out.g);
    out.b = xsimd::select(hit, gather(s, s.mat_b, id) * sum.b, out.b);

    if (!(kTree || s.features.reflection) || depth >= s.max_depth) {
      lap(counts, kShading);
      return out.reflected;
    }
    // Refracted rays first, while o and d are still this level's rays; their term is added
    // after the reflection's all the same (radiance_tree).
    if constexpr (kTree) {
      refract_rays(s, hit, id, d, delta, p, n, cos_in, here, out, counts);
      if (!s.features.reflection) {
        lap(counts, kShading);
        return out.reflected;
      }
    }
    out.reflect = gather(s, s.mat_reflect, id);
    out.reflected = hit & (out.reflect > B(0));
    if (xsimd::any(out.reflected)) {
      counts.reflected += count(out.reflected);
      // Normalised in fast mode too. Without it the error feeds back: the roots take |d| = 1,
      // so p lands off the sphere by about |t| (|d| - 1), (p - c) / r is off unit by as much
      // times t / r, and the next reflection's length by four times that: 1e-4 by the third
      // bounce inside a mirrored sphere, 2.4% of pixels off (FastMode.RaysInsideASphere...),
      // and 14 dB of PSNR lost on lorenzi-reflections, for 2.5% of speed.
      const V r = Mth::normalize(Mth::reflect(d, n));
      // n faces the incoming ray, so the reflected one leaves on its side: r.n = -d.n >= 0.
      // Exact computes r.n as the reference does; fast takes the sign as known.
      const V from = offset_origin(p, n, kFast ? B(1) : Mth::dot(r, n), delta);
      o = select3(out.reflected, from, o);
      d = select3(out.reflected, r, d);
      if constexpr (kFast) leaving = here;
    }
    lap(counts, kShading);
    return out.reflected;
  }

  // Contract step 7 for the lanes of `hit` whose material transmits: out.refracted and their
  // rays out.to, out.td. eta is 1 / ior entering (cos_in < 0 for the geometric normal), ior
  // leaving; where k < 0 (total internal reflection) the ray takes the mirror direction. The
  // refracted ray leaves on the far side of the surface (t.n = -sqrt(k) <= 0), so its origin
  // moves there. Fast mode: a refracted ray may meet the sphere it crosses again, so it skips
  // nothing; a totally reflected one leaves on the near side like a reflection.
  [[gnu::always_inline]] static void refract_rays(const Scene& s, const M& hit, const I& id,
                                                  const V& d, const B& delta, const V& p,
                                                  const V& n, const B& cos_in, const I& here,
                                                  Level& out, RayCounts& counts) noexcept {
    out.transmit = gather(s, s.mat_transmit, id);
    out.refracted = hit & (out.transmit > B(0));
    if (!xsimd::any(out.refracted)) return;
    lap(counts, kShading);
    counts.refracted += count(out.refracted);
    const B eta =
        xsimd::select(cos_in < B(0), gather(s, s.mat_inv_ior, id), gather(s, s.mat_ior, id));
    const Refraction<B> rf = refract<Mth>(d, n, eta);
    const M through = rf.k >= B(0);
    V t = Mth::normalize(rf.dir);
    if (!xsimd::all(through | ~out.refracted))
      t = select3(through, t, Mth::normalize(Mth::reflect(d, n)));
    const B side = kFast ? xsimd::select(through, B(T(-1)), B(T(1))) : Mth::dot(t, n);
    out.to = offset_origin(p, n, side, delta);
    out.td = t;
    out.t_leaving = xsimd::select(to_mi(through), I(Id(-1)), here);
    lap(counts, kRefraction);
  }

  // The ray tree of the lanes of `active` from `depth` on, for scenes with refraction:
  // recursion over packets with masks, depth first. Each level shades its lanes, then traces
  // the reflected packet, then the refracted one, each on the lanes that spawned it, and adds
  // local + reflect * child, then + transmit * child: the reference's order, bottom-up.
  // Recursion is at most max_depth + 1 deep; splitting materials bound it (kMaxSplitDepth).
  [[gnu::noinline]] static void radiance_tree(const Scene& s, M active, int depth, int stage, V o,
                                              V d, I leaving, B& r, B& g, B& b, RayCounts& counts,
                                              const GivenHit* given = nullptr) noexcept {
    Level lv;
    const M reflected = shade<true>(s, active, depth, stage, o, d, leaving, lv, counts, given);
    r = lv.r, g = lv.g, b = lv.b;
    if (xsimd::any(reflected)) {
      B cr, cg, cb;
      radiance_tree(s, reflected, depth + 1, kReflection, o, d, leaving, cr, cg, cb, counts);
      r = xsimd::select(reflected, r + lv.reflect * cr, r);
      g = xsimd::select(reflected, g + lv.reflect * cg, g);
      b = xsimd::select(reflected, b + lv.reflect * cb, b);
    }
    if (xsimd::any(lv.refracted)) {
      B cr, cg, cb;
      radiance_tree(s, lv.refracted, depth + 1, kRefraction, lv.to, lv.td, lv.t_leaving, cr, cg, cb,
                    counts);
      r = xsimd::select(lv.refracted, r + lv.transmit * cr, r);
      g = xsimd::select(lv.refracted, g + lv.transmit * cg, g);
      b = xsimd::select(lv.refracted, b + lv.transmit * cb, b);
    }
  }

  // The radiance of a packet of camera rays. Without refraction, reflection is an iterative
  // loop over levels with an active mask; the levels are then folded from the deepest up,
  // local + reflect * child, which is the order the reference's recursion adds in (a running
  // weight would not be). With refraction the rays form a tree: radiance_tree.
  template <bool kOneRay>
  [[gnu::always_inline]] static void radiance(const Scene& s, M active, V o, V d,
                                              std::vector<Level>& levels, B& r, B& g, B& b,
                                              RayCounts& counts,
                                              const GivenHit* given = nullptr) noexcept {
    int depth = 0;
    I leaving(Id(-1));
    if (s.features.refraction) {
      radiance_tree(s, active, 0, kPrimaryIntersection, o, d, leaving, r, g, b, counts, given);
      return;
    }
    for (;;) {
      active =
          shade<false, kOneRay>(s, active, depth, depth == 0 ? kPrimaryIntersection : kReflection,
                                o, d, leaving, levels[depth], counts, depth == 0 ? given : nullptr);
      if (!xsimd::any(active)) break;
      ++depth;
    }
    r = levels[depth].r, g = levels[depth].g, b = levels[depth].b;
    for (int k = depth - 1; k >= 0; --k) {
      const Level& lv = levels[k];
      r = xsimd::select(lv.reflected, lv.r + lv.reflect * r, lv.r);
      g = xsimd::select(lv.reflected, lv.g + lv.reflect * g, lv.g);
      b = xsimd::select(lv.reflected, lv.b + lv.reflect * b, lv.b);
    }
  }

  // Camera rays of columns i0 .. i0+W-1 of row j at sub-sample (a, b); screen coordinates come
  // from the camera's tables, computed once by the same formula.
  static void camera_packet(const Scene& s, int i0, int j, int a, int b, V& o, V& d) noexcept {
    const PreparedCamera<T>& cam = s.camera;
    const B x = B::load_unaligned(&cam.screen_x[std::size_t(a) * cam.nx + i0]);
    const B y(cam.screen_y[std::size_t(b) * cam.ny + j]);
    camera_ray<Mth>(cam, x, y, o, d);
  }

  // Stores the first `lanes` lanes of v at dst.
  static void store_lanes(const B& v, float* dst, int lanes) noexcept {
    alignas(64) T tmp[W];
    v.store_aligned(tmp);
    for (int k = 0; k < lanes; ++k) dst[k] = static_cast<float>(tmp[k]);
  }

  // 16 pixels' r, g, b into 48 interleaved floats at dst: per output register, one two-source
  // permute places r and g (indexes 0-15 pick r, 16-31 g), a masked permute adds b.
  static void store_rgb16(const B& r, const B& g, const B& b, float* dst) noexcept {
    if constexpr (std::is_same_v<T, float> && W == 16) {
      alignas(64) static constexpr std::int32_t kRg[3][16] = {
          {0, 16, 0, 1, 17, 0, 2, 18, 0, 3, 19, 0, 4, 20, 0, 5},
          {21, 0, 6, 22, 0, 7, 23, 0, 8, 24, 0, 9, 25, 0, 10, 26},
          {0, 11, 27, 0, 12, 28, 0, 13, 29, 0, 14, 30, 0, 15, 31, 0}};
      alignas(64) static constexpr std::int32_t kB[3][16] = {
          {0, 0, 0, 0, 0, 1, 0, 0, 2, 0, 0, 3, 0, 0, 4, 0},
          {0, 5, 0, 0, 6, 0, 0, 7, 0, 0, 8, 0, 0, 9, 0, 0},
          {10, 0, 0, 11, 0, 0, 12, 0, 0, 13, 0, 0, 14, 0, 0, 15}};
      constexpr __mmask16 kBLanes[3] = {0x4924, 0x2492, 0x9249};
      for (int v = 0; v < 3; ++v) {
        const __m512 t = _mm512_permutex2var_ps(r, _mm512_load_si512(kRg[v]), g);
        _mm512_storeu_ps(dst + 16 * v,
                         _mm512_mask_permutexvar_ps(t, kBLanes[v], _mm512_load_si512(kB[v]), b));
      }
    }
  }

  // Through a hierarchy, a pinhole camera's closest hits come first, kBlockRows rows at a time,
  // from the camera blocks that walk it together (bench --mode primary's path), and the rows
  // then shade them: the same (t, id) per pixel as the row packets' own walks (a lexicographic
  // minimum over the same rays), found in about half the time (docs/accel.md). Two
  // instantiations: the plain loop's scenes keep the rows' code as it was.
  static void render_rows(const Scene& s, Image& image, int row_begin, int row_end,
                          RayCounts& counts) noexcept {
    const PreparedCamera<T>& cam = s.camera;
    const bool blocks =
        kGroup > 1 && cam.samples == 1 && !cam.orthographic && s.features.spheres && s.bvh.active();
    // Shadow rays of secondary hits one ray at a time (exact float, by the scene): its own
    // instantiations, so that scenes without it keep their shading loops' code (lorenzi-diffuse,
    // width 16: 0.97x with the test in every loop).
    if constexpr (!kFast && std::is_same_v<T, float>) {
      if (s.bvh.shadow_one_ray_lanes > 0) {
        if (blocks)
          render_rows_as<kGroup != 1, true>(s, image, row_begin, row_end, counts);
        else
          render_rows_as<false, true>(s, image, row_begin, row_end, counts);
        return;
      }
    }
    if (blocks)
      render_rows_as<kGroup != 1, false>(s, image, row_begin, row_end, counts);
    else
      render_rows_as<false, false>(s, image, row_begin, row_end, counts);
  }
  template <bool kBlocks, bool kOneRay>
  static void render_rows_as(const Scene& s, Image& image, int row_begin, int row_end,
                             RayCounts& counts) noexcept {
    const PreparedCamera<T>& cam = s.camera;
    const B lane = iota();
    const B samples = B(T(cam.samples * cam.samples));
    std::vector<Level> levels(static_cast<std::size_t>(s.max_depth) + 1);
    alignas(64) T out[3][W];
    std::vector<float> band_t;
    std::vector<Id> band_id;  // Id: 32-bit, as T is float here
    if (kBlocks) {            // W more: a row's last packet loads whole registers
      band_t.resize(std::size_t(cam.nx) * kBlockRows + W);
      band_id.resize(band_t.size());
    }
    if constexpr (kProfile) counts.profile->last_tsc = __rdtsc();
    for (int j = row_begin; j < row_end; ++j) {
      [[maybe_unused]] const int band_row = (j - row_begin) % kBlockRows;
      if constexpr (kBlocks) {
        if (band_row == 0) {
          lap(counts, kOutput);
          if constexpr (kProfile) counts.profile->current = kPrimaryIntersection;
          primary_blocks<kGroupX, kGroupY>(s, band_t.data(), band_id.data(), j,
                                           std::min(row_end, j + kBlockRows), j, counts);
          lap(counts, kPrimaryIntersection);
        }
      }
      for (int i0 = 0; i0 < cam.nx; i0 += W) {
        const int lanes = std::min(W, cam.nx - i0);
        const M valid = lane < B(T(lanes));
        B sr(0), sg(0), sb(0);
        for (int b = 0; b < cam.samples; ++b) {
          for (int a = 0; a < cam.samples; ++a) {
            V o, d;
            lap(counts, kOutput);
            camera_packet(s, i0, j, a, b, o, d);
            if (!kBlocks) counts.camera += lanes;  // else counted by the blocks
            occupancy(counts, kRayGeneration, valid);
            lap(counts, kRayGeneration);
            B r, g, bl;
            if constexpr (kBlocks) {
              const std::size_t at = std::size_t(band_row) * cam.nx + i0;
              const GivenHit hit{B::load_unaligned(&band_t[at]), I::load_unaligned(&band_id[at])};
              radiance<kOneRay>(s, valid, o, d, levels, r, g, bl, counts, &hit);
            } else {
              radiance<kOneRay>(s, valid, o, d, levels, r, g, bl, counts);
            }
            sr = sr + r, sg = sg + g, sb = sb + bl;
          }
        }
        // The mean of the sub-samples (x / 1 is x: one sample needs no division).
        if (cam.samples > 1) sr = sr / samples, sg = sg / samples, sb = sb / samples;
        if constexpr (std::is_same_v<T, float> && W == 16) {
          if (lanes == W) {
            store_rgb16(sr, sg, sb, image.pixel(i0, j));
            continue;
          }
        }
        sr.store_aligned(out[0]);
        sg.store_aligned(out[1]);
        sb.store_aligned(out[2]);
        for (int k = 0; k < lanes; ++k) {
          float* px = image.pixel(i0 + k, j);
          px[0] = static_cast<float>(out[0][k]);
          px[1] = static_cast<float>(out[1][k]);
          px[2] = static_cast<float>(out[2][k]);
        }
      }
    }
    lap(counts, kOutput);
  }

  static void primary_rows(const Scene& s, float* t_out, std::int32_t* id_out, int row_begin,
                           int row_end, RayCounts& counts) noexcept {
    // Through a hierarchy, square packets: their rays diverge less than a row's, so they share
    // more of the nodes and leaves they visit. The plain loop (the course scenes) keeps rows.
    if (s.bvh.active())
      primary_tiles(s, t_out, id_out, row_begin, row_end, counts);
    else
      primary_packet_rows(s, t_out, id_out, row_begin, row_end, counts);
  }

  static void primary_packet_rows(const Scene& s, float* t_out, std::int32_t* id_out, int row_begin,
                                  int row_end, RayCounts& counts) noexcept {
    const PreparedCamera<T>& cam = s.camera;
    const B lane = iota();
    for (int j = row_begin; j < row_end; ++j) {
      for (int i0 = 0; i0 < cam.nx; i0 += W) {
        const int lanes = std::min(W, cam.nx - i0);
        const M valid = lane < B(T(lanes));
        B sum(0);
        I first_id(Id(-1));
        for (int b = 0; b < cam.samples; ++b) {
          for (int a = 0; a < cam.samples; ++a) {
            V o, d;
            camera_packet(s, i0, j, a, b, o, d);
            counts.camera += lanes;
            primary_hit(s, valid, o, d, sum, first_id, a == 0 && b == 0, counts);
          }
        }
        const std::size_t at = std::size_t(j) * cam.nx + i0;
        if constexpr (std::is_same_v<T, float>) {
          if (lanes == W) {
            sum.store_unaligned(t_out + at);
          } else {
            store_lanes(sum, t_out + at, lanes);
          }
        } else {
          store_lanes(sum, t_out + at, lanes);
        }
        if (id_out) store_ids(first_id, id_out + at, lanes);
      }
    }
  }

  // The closest hit of one camera packet: its t added to `sum`, its ids kept if `first`.
  [[gnu::always_inline]] static void primary_hit(const Scene& s, const M& valid, const V& o,
                                                 const V& d, B& sum, I& first_id, bool first,
                                                 RayCounts& counts) noexcept {
    B t(std::numeric_limits<T>::infinity());
    I id(Id(-1));
    if (s.camera.orthographic)
      closest_hit(s, valid, o, d, t, id, counts, I(Id(-1)), true);
    else
      closest_hit<true>(s, valid, o, d, t, id, counts);
    sum = sum + t;
    if (first) first_id = id;
  }

  // Packets of kTileW x kTileH pixels (16: 4x4, 8: 4x2, 4: 2x2, 2: 2x1), lane k at column
  // i0 + k % kTileW, row j0 + k / kTileW; each lane's ray is the one a row packet makes for
  // that pixel (the same table entries, the same formula), so the values do not change.
  static constexpr int kTileW = W >= 8 ? 4 : 2;
  static constexpr int kTileH = W / kTileW;

  // Lanes k = p[k % kTileW] (columns) and p[k / kTileW] (rows), from kTileW (kTileH) readable
  // values. Float: one load, broadcast or permuted (lanes filled one by one through memory cost
  // a failed store forwarding per packet); double through memory.
  static B tile_columns(const T* p) noexcept {
    if constexpr (std::is_same_v<T, float> && W == 16) {
      return _mm512_broadcast_f32x4(_mm_loadu_ps(p));
    } else if constexpr (std::is_same_v<T, float> && W == 8) {
      return _mm256_broadcast_ps(reinterpret_cast<const __m128*>(p));
    } else if constexpr (std::is_same_v<T, float> && W == 4) {
      const __m128i two = _mm_loadl_epi64(reinterpret_cast<const __m128i_u*>(p));  // p0 p1
      return _mm_castpd_ps(_mm_movedup_pd(_mm_castsi128_pd(two)));
    } else {
      alignas(64) T v[W];
      for (int k = 0; k < W; ++k) v[k] = p[k % kTileW];
      return B::load_aligned(v);
    }
  }
  static B tile_rows(const T* p) noexcept {
    if constexpr (std::is_same_v<T, float> && W == 16) {
      const __m512i quarter = _mm512_set_epi32(3, 3, 3, 3, 2, 2, 2, 2, 1, 1, 1, 1, 0, 0, 0, 0);
      return _mm512_permutexvar_ps(quarter, _mm512_castps128_ps512(_mm_loadu_ps(p)));
    } else if constexpr (std::is_same_v<T, float> && W == 8) {
      return _mm256_set_m128(_mm_set1_ps(p[1]), _mm_set1_ps(p[0]));
    } else if constexpr (std::is_same_v<T, float> && W == 4) {
      const __m128 two = _mm_castsi128_ps(_mm_loadl_epi64(reinterpret_cast<const __m128i_u*>(p)));
      return _mm_unpacklo_ps(two, two);
    } else {
      alignas(64) T v[W];
      for (int k = 0; k < W; ++k) v[k] = p[k / kTileW];
      return B::load_aligned(v);
    }
  }

  // Pinhole cameras (float): kGroup tiles side by side (a block kGroupPx wide, kBlockRows high)
  // walk the hierarchy together (closest_group_in_hierarchy), each tile's rays tested at the
  // leaves as its own packet. Measured at 65536 spheres: docs/accel.md.
  static constexpr int kGroupPx = std::is_same_v<T, float> ? (W >= 16 ? 32 : 8) : kTileW;
  static constexpr int kGroupX = kGroupPx / kTileW;
  static constexpr int kBlockRows = 8;  // within run_tiles' rows (tiles.hpp kTileRows)
  static constexpr int kGroupY = std::is_same_v<T, float> ? kBlockRows / kTileH : 1;
  static constexpr int kGroup = kGroupX * kGroupY;

  static void primary_tiles(const Scene& s, float* t_out, std::int32_t* id_out, int row_begin,
                            int row_end, RayCounts& counts) noexcept {
    if (kGroup > 1 && !s.camera.orthographic && s.features.spheres)
      primary_blocks<kGroupX, kGroupY>(s, t_out, id_out, row_begin, row_end, 0, counts);
    else
      primary_blocks<1, 1>(s, t_out, id_out, row_begin, row_end, 0, counts);
  }
  // Blocks of gx x gy tiles (the block's shape fixed at compile time: its loops unroll). Pixel
  // (i, j) goes to t_out[(j - row_base) * nx + i].
  template <int gx, int gy>
  static void primary_blocks(const Scene& s, float* t_out, std::int32_t* id_out, int row_begin,
                             int row_end, int row_base, RayCounts& counts) noexcept {
    const int nx = s.camera.nx;
    for (int j0 = row_begin; j0 < row_end; j0 += kTileH * gy)
      for (int i0 = 0; i0 < nx; i0 += kTileW * gx) {
        // Every tile whole (all but the image's last columns and rows): no edge cases.
        if (i0 + kTileW * gx <= nx && j0 + kTileH * gy <= row_end)
          primary_block<gx, gy, true>(s, i0, j0, row_end, row_base, t_out, id_out, counts);
        else
          primary_block<gx, gy, false>(s, i0, j0, row_end, row_base, t_out, id_out, counts);
      }
  }
  // The tiles of the block at (i0, j0), gx x gy tiles: tile g's columns ti[g] .., rows tj[g]
  // .., cols[g] x rows[g] of them inside the image and above row_end (0: outside), its live
  // lanes valid[g]. kWhole: every tile whole (all but the image's last columns and rows).
  template <int gx, int gy, bool kWhole>
  struct BlockTiles {
    static constexpr int n = gx * gy;
    int ti[n], tj[n], cols[n], rows[n];
    M valid[n];
    [[gnu::always_inline]] BlockTiles(const PreparedCamera<T>& cam, int i0, int j0,
                                      int row_end) noexcept {
      alignas(64) T col_of[W], row_of[W];  // each lane's column and row in its tile (edges)
      if constexpr (!kWhole)
        for (int k = 0; k < W; ++k) col_of[k] = T(k % kTileW), row_of[k] = T(k / kTileW);
      for (int g = 0; g < n; ++g) {
        ti[g] = i0 + (g % gx) * kTileW, tj[g] = j0 + (g / gx) * kTileH;
        if constexpr (kWhole) {
          cols[g] = kTileW, rows[g] = kTileH, valid[g] = M(true);
        } else {
          cols[g] = std::max(0, std::min(kTileW, cam.nx - ti[g]));
          rows[g] = std::max(0, std::min(kTileH, row_end - tj[g]));
          valid[g] =
              (B::load_aligned(col_of) < B(T(cols[g]))) & (B::load_aligned(row_of) < B(T(rows[g])));
        }
      }
    }
    // Tile g's camera rays at sub-sample (a, b); a tile at the image's edge repeats its last
    // live row or column in its dead lanes, a tile outside it takes tile 0's rays (unused).
    [[gnu::always_inline]] void rays(const PreparedCamera<T>& cam, int g, int a, int b, V* o,
                                     V* d) const noexcept {
      const T* ys = &cam.screen_y[std::size_t(b) * cam.ny + tj[g]];
      const T* xs = &cam.screen_x[std::size_t(a) * cam.nx + ti[g]];
      alignas(64) T edge_x[kTileW], edge_y[kTileH];
      if constexpr (!kWhole) {
        if (cols[g] == 0 || rows[g] == 0) {
          o[g] = o[0], d[g] = d[0];
          return;
        }
        if (rows[g] < kTileH) {
          for (int r = 0; r < kTileH; ++r) edge_y[r] = ys[std::min(r, rows[g] - 1)];
          ys = edge_y;
        }
        if (cols[g] < kTileW) {
          for (int c = 0; c < kTileW; ++c) edge_x[c] = xs[std::min(c, cols[g] - 1)];
          xs = edge_x;
        }
      }
      camera_ray<Mth>(cam, tile_columns(xs), tile_rows(ys), o[g], d[g]);
    }
  };

  template <int gx, int gy, bool kWhole>
  [[gnu::always_inline]] static void primary_block(const Scene& s, int i0, int j0, int row_end,
                                                   int row_base, float* t_out, std::int32_t* id_out,
                                                   RayCounts& counts) noexcept {
    const PreparedCamera<T>& cam = s.camera;
    constexpr int n = gx * gy;
    const BlockTiles<gx, gy, kWhole> tiles(cam, i0, j0, row_end);
    const auto& [ti, tj, cols, rows, valid] = tiles;
    B sum[n];
    I first_id[n];
    for (int g = 0; g < n; ++g) sum[g] = B(0), first_id[g] = I(Id(-1));
    for (int b = 0; b < cam.samples; ++b) {
      for (int a = 0; a < cam.samples; ++a) {
        V o[n], d[n];
        for (int g = 0; g < n; ++g) {
          tiles.rays(cam, g, a, b, o, d);
          counts.camera += std::uint64_t(cols[g] * rows[g]);
        }
        const bool first = a == 0 && b == 0;
        if constexpr (n == 1) {
          primary_hit(s, valid[0], o[0], d[0], sum[0], first_id[0], first, counts);
        } else {
          B t[n];
          I id[n];
          for (int g = 0; g < n; ++g)
            t[g] = B(std::numeric_limits<T>::infinity()), id[g] = I(Id(-1));
          closest_group_in_hierarchy<n>(s, valid, o, d, t, id, counts);
          for (int g = 0; g < n; ++g) {
            if (s.features.planes) planes_closest(s, valid[g], o[g], d[g], t[g], id[g], counts);
            sum[g] = sum[g] + t[g];
            if (first) first_id[g] = id[g];
          }
        }
      }
    }
    for (int g = 0; g < n; ++g) {
      alignas(64) T out[W];
      alignas(64) Id ids[W];
      sum[g].store_aligned(out);
      if (id_out) first_id[g].store_aligned(ids);
      for (int r = 0; r < rows[g]; ++r) {
        const std::size_t at = std::size_t(tj[g] + r - row_base) * cam.nx + ti[g];
        if constexpr (kWhole && std::is_same_v<T, float> && sizeof(Id) == sizeof(std::int32_t)) {
          std::memcpy(t_out + at, &out[r * kTileW], sizeof(float) * kTileW);  // one move a row
          if (id_out) std::memcpy(id_out + at, &ids[r * kTileW], sizeof(std::int32_t) * kTileW);
        } else {
          for (int c = 0; c < cols[g]; ++c) {
            t_out[at + c] = static_cast<float>(out[r * kTileW + c]);
            if (id_out) id_out[at + c] = static_cast<std::int32_t>(ids[r * kTileW + c]);
          }
        }
      }
    }
  }

  // ---- the primary intersection kernel alone (lancer bench --mode kernel) -------------------
  // Its camera rays are made once, beforehand, in the layout primary mode traces them in
  // (primary_rows): through a hierarchy, blocks of kGroup tiles walked together (pinhole
  // camera, float) or single tiles (gx = gy = 1); else rows of packets.
  static bool kernel_blocks(const Scene& s) noexcept {
    return kGroup > 1 && s.bvh.active() && !s.camera.orthographic && s.features.spheres;
  }
  // Packets camera_packets makes for rows [row_begin, row_end), row_begin a multiple of
  // kBlockRows (run_tiles' rows).
  static std::size_t camera_packet_count(const Scene& s, int row_begin, int row_end) noexcept {
    const PreparedCamera<T>& cam = s.camera;
    const std::size_t samples = std::size_t(cam.samples) * std::size_t(cam.samples);
    auto blocks = [&](int w, int h, int packets) {
      return std::size_t((row_end - row_begin + h - 1) / h) * std::size_t((cam.nx + w - 1) / w) *
             samples * std::size_t(packets);
    };
    if (kernel_blocks(s)) return blocks(kGroupPx, kBlockRows, kGroup);
    if (s.bvh.active()) return blocks(kTileW, kTileH, 1);
    return blocks(W, 1, 1);
  }
  // Per packet the origin then the direction, component by component, W lanes each (6 W
  // values), its live lanes as bits in lanes[p], and per lane the index of its camera ray in
  // the image's order, (row * samples^2 + sub-sample) * nx + column, or kNoCameraRay.
  static void camera_packets(const Scene& s, int row_begin, int row_end, T* rays, int* lanes,
                             std::uint32_t* where) noexcept {
    const PreparedCamera<T>& cam = s.camera;
    std::size_t p = 0;
    auto put = [&](const V& o, const V& d, unsigned live, auto ray_of) {
      T* r = rays + p * 6 * W;
      o.x.store_unaligned(r), o.y.store_unaligned(r + W), o.z.store_unaligned(r + 2 * W);
      d.x.store_unaligned(r + 3 * W), d.y.store_unaligned(r + 4 * W);
      d.z.store_unaligned(r + 5 * W);
      lanes[p] = int(live);
      for (int k = 0; k < W; ++k) where[p * W + k] = (live >> k & 1u) ? ray_of(k) : kNoCameraRay;
      ++p;
    };
    auto index = [&](int j, int b, int a, int i) {
      return std::uint32_t((std::size_t(j) * cam.samples * cam.samples +
                            std::size_t(b) * cam.samples + std::size_t(a)) *
                               std::size_t(cam.nx) +
                           std::size_t(i));
    };
    // Blocks of gx x gy tiles, as primary_blocks visits them; per block and sub-sample its tiles.
    auto blocks = [&](auto gx_, auto gy_) {
      constexpr int gx = decltype(gx_)::value, gy = decltype(gy_)::value, n = gx * gy;
      for (int j0 = row_begin; j0 < row_end; j0 += kTileH * gy)
        for (int i0 = 0; i0 < cam.nx; i0 += kTileW * gx) {
          const BlockTiles<gx, gy, false> tiles(cam, i0, j0, row_end);
          for (int b = 0; b < cam.samples; ++b)
            for (int a = 0; a < cam.samples; ++a) {
              V o[n], d[n];
              for (int g = 0; g < n; ++g) {
                tiles.rays(cam, g, a, b, o, d);
                put(o[g], d[g], bits(tiles.valid[g]), [&](int k) {
                  return index(tiles.tj[g] + k / kTileW, b, a, tiles.ti[g] + k % kTileW);
                });
              }
            }
        }
    };
    using One = std::integral_constant<int, 1>;
    if (kernel_blocks(s))
      return blocks(std::integral_constant<int, kGroupX>{}, std::integral_constant<int, kGroupY>{});
    if (s.bvh.active()) return blocks(One{}, One{});
    for (int j = row_begin; j < row_end; ++j)
      for (int b = 0; b < cam.samples; ++b)
        for (int a = 0; a < cam.samples; ++a)
          for (int i0 = 0; i0 < cam.nx; i0 += W) {
            V o, d;
            camera_packet(s, i0, j, a, b, o, d);
            const int live = std::min(W, cam.nx - i0);
            put(o, d, (1u << live) - 1u, [&](int k) { return index(j, b, a, i0 + k); });
          }
  }

  // The primary intersection kernel alone, as primary_rows runs it, over `count` packets made
  // by camera_packets() (a whole number of blocks where they are blocks): W nearest distances
  // per packet into t_out (infinity where missed).
  static M lanes_of(int live) noexcept {
    alignas(64) T v[W];
    for (int k = 0; k < W; ++k) v[k] = T((unsigned(live) >> k) & 1u);
    return B::load_aligned(v) != B(0);
  }
  [[gnu::flatten]] static void intersect_camera_packets(const Scene& s, const T* rays,
                                                        const int* lanes, std::size_t count,
                                                        T* t_out, RayCounts& counts) noexcept {
    auto load = [&](std::size_t p, V& o, V& d) {
      const T* r = rays + p * 6 * W;
      o = V{B::load_unaligned(r), B::load_unaligned(r + W), B::load_unaligned(r + 2 * W)};
      d = V{B::load_unaligned(r + 3 * W), B::load_unaligned(r + 4 * W),
            B::load_unaligned(r + 5 * W)};
    };
    static_assert(W <= 16, "lanes[] holds a packet's live lanes as bits of an int");
    constexpr int kFull = int((1u << W) - 1u);
    if constexpr (kGroup > 1) {
      if (kernel_blocks(s)) {
        for (std::size_t p = 0; p < count; p += kGroup) {
          V o[kGroup], d[kGroup];
          M valid[kGroup];
          B t[kGroup];
          I id[kGroup];
          for (int g = 0; g < kGroup; ++g) {
            load(p + g, o[g], d[g]);
            const int live = lanes[p + g];
            valid[g] = live == kFull ? M(true) : lanes_of(live);
            counts.camera += std::uint64_t(__builtin_popcount(unsigned(live)));
            t[g] = B(std::numeric_limits<T>::infinity()), id[g] = I(Id(-1));
          }
          closest_group_in_hierarchy<kGroup>(s, valid, o, d, t, id, counts);
          for (int g = 0; g < kGroup; ++g) {
            if (s.features.planes) planes_closest(s, valid[g], o[g], d[g], t[g], id[g], counts);
            t[g].store_unaligned(t_out + (p + g) * W);
          }
        }
        return;
      }
    }
    for (std::size_t p = 0; p < count; ++p) {
      V o, d;
      load(p, o, d);
      const int live = lanes[p];
      const M valid = live == kFull ? M(true) : lanes_of(live);
      counts.camera += std::uint64_t(__builtin_popcount(unsigned(live)));
      B t(std::numeric_limits<T>::infinity());
      I id(Id(-1));
      // primary_rows' dispatch, written out here too: a shared helper moved GCC's inlining of
      // closest_hit in render_rows and cost exact's full render 5%.
      if (s.camera.orthographic)
        closest_hit(s, valid, o, d, t, id, counts, I(Id(-1)), true);
      else
        closest_hit<true>(s, valid, o, d, t, id, counts);
      t.store_unaligned(t_out + p * W);
    }
  }

  static void closest_hit_packet(const Scene& s, const bool* valid, const T* rays, T* t,
                                 std::int32_t* id, bool* hit_out) noexcept {
    const M v = M::load_unaligned(valid);
    const V o{B::load_unaligned(rays), B::load_unaligned(rays + W),
              B::load_unaligned(rays + 2 * W)};
    const V d{B::load_unaligned(rays + 3 * W), B::load_unaligned(rays + 4 * W),
              B::load_unaligned(rays + 5 * W)};
    B bt = B::load_unaligned(t);
    I bid = load_ids(id);
    RayCounts unused;
    const M hit = closest_hit(s, v, o, d, bt, bid, unused);
    bt.store_unaligned(t);
    store_ids(bid, id, W);
    const unsigned hb = bits(hit);
    for (int k = 0; k < W; ++k) hit_out[k] = (hb >> k) & 1u;
  }

  static void occluded_packet(const Scene& s, const bool* valid, const T* rays, const T* tfar,
                              bool* blocked_out) noexcept {
    const M v = M::load_unaligned(valid);
    const V o{B::load_unaligned(rays), B::load_unaligned(rays + W),
              B::load_unaligned(rays + 2 * W)};
    const V d{B::load_unaligned(rays + 3 * W), B::load_unaligned(rays + 4 * W),
              B::load_unaligned(rays + 5 * W)};
    RayCounts unused;
    // No sphere is being left (-1): the rays start wherever the caller put them.
    // Any object blocks here (kGlass false): the API's occlusion is a yes/no query.
    const unsigned bb =
        bits(v & ~occluded<false>(s, v, o, d, B::load_unaligned(tfar), unused, I(-1)).pending);
    for (int k = 0; k < W; ++k) blocked_out[k] = (bb >> k) & 1u;
  }
};

// The table of one instantiation, made on first use inside this ISA's own code: the dispatcher
// calls it only once the CPU check has passed, so no instruction of the ISA runs before.
template <class Arch, class Real, class Mode>
const KernelTable<Real>* table() {
  using K = Kernel<Arch, Real, Mode>;
  static const KernelTable<Real> t{K::W,
                                   Arch::name(),
                                   &K::render_rows,
                                   &K::primary_rows,
                                   &K::camera_packet_count,
                                   &K::camera_packets,
                                   &K::intersect_camera_packets,
                                   &K::closest_hit_packet,
                                   &K::occluded_packet};
  return &t;
}

}  // namespace lancer::packet
