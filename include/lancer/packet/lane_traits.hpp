// The lanes trait every packet stage shares: the lane types of one xsimd::batch<Real, Arch>
// (values, masks, object ids), the maths policy (ExactMath, the reference's formulas; FastMath),
// the camera blocks' shape, the profiling hooks (they compile to nothing outside ProfiledMode)
// and the gathers and mask conversions the stages use. Include only from code built for the
// batch's ISA (src/isa/*.cpp, through packet/kernel.hpp).
#pragma once

#include <cstdint>
#include <cstring>
#include <type_traits>
#include <vector>
#include <xsimd/xsimd.hpp>

#include "lancer/cycles.hpp"
#include "lancer/formulas.hpp"
#include "lancer/packet/api.hpp"
#include "lancer/packet/fast_math.hpp"
#include "lancer/packet/intrin.hpp"
#include "lancer/packet/lanes.hpp"
#include "lancer/packet/traversal.hpp"
#include "lancer/stage_profile.hpp"

namespace lancer::packet {

// How a secondary packet walks the hierarchy where its scene sends such rays one at a time
// (Hybrid::secondary_walk): whole, as a packet until few lanes enter a subtree (clustered), or
// every lane alone from the root (apart).
enum class SecondaryWalk { whole, clustered, apart };

template <class Arch, class Real, class Mode>
struct Lanes {
  using T = Real;
  using B = xsimd::batch<T, Arch>;
  using M = xsimd::batch_bool<T, Arch>;
  using V = Vec3<B>;
  // Object ids: integers of Real's width, one per lane (exact for any count of objects).
  using Id = xsimd::as_integer_t<T>;
  using I = xsimd::batch<Id, Arch>;
  using MI = xsimd::batch_bool<Id, Arch>;
  using Tr = Traversal<Arch, T>;
  using Arithmetic = typename ModeTraits<Mode>::Arithmetic;
  static constexpr bool kFast = std::is_same_v<Arithmetic, FastMode>;
  static constexpr bool kProfile = std::is_same_v<Arithmetic, ProfiledMode>;
  using Mth = std::conditional_t<kFast, FastMath<Arch>, ExactMath>;
  static constexpr int W = static_cast<int>(B::size);
  using Prepared = PreparedScene<T>;
  static_assert(W <= kMaxLanes, "camera tables are padded for kMaxLanes lanes");
  static_assert(std::is_same_v<Arithmetic, ExactMode> || std::is_same_v<T, float>,
                "fast and profiled modes are for float");

  // Packets of kTileW x kTileH pixels (16: 4x4, 8: 4x2, 4: 2x2, 2: 2x1), lane k at column
  // i0 + k % kTileW, row j0 + k / kTileW; each lane's ray is the one a row packet makes for
  // that pixel (the same table entries, the same formula), so the values do not change.
  static constexpr int kTileW = W >= 8 ? 4 : 2;
  static constexpr int kTileH = W / kTileW;

  // Pinhole cameras (float): kGroup tiles side by side (a block kGroupPx wide, kBlockRows high)
  // walk the hierarchy together (closest_group_in_hierarchy), each tile's rays tested at the
  // leaves as its own packet. Measured at 65536 spheres: docs/accel.md.
  static constexpr int kGroupPx = std::is_same_v<T, float> ? (W >= 16 ? 32 : 8) : kTileW;
  static constexpr int kGroupX = kGroupPx / kTileW;
  static constexpr int kBlockRows = 8;  // within run_tiles' rows (tiles.hpp kTileRows)
  static constexpr int kGroupY = std::is_same_v<T, float> ? kBlockRows / kTileH : 1;
  static constexpr int kGroup = kGroupX * kGroupY;

  // Profiling (ProfiledMode only; compiled out of every other instantiation). The laps form one
  // chain: each charges the cycles since the previous lap to a stage, so the stages cover the
  // kernel's whole time between them.
  static void lap(RayCounts& c, int stage) noexcept {
    if constexpr (kProfile) {
      const std::uint64_t now = lancer::ticks();
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
  // How a secondary packet walked the hierarchy where its scene sends such rays one at a time
  // (Hybrid::secondary_walk).
  static void walk_choice(RayCounts& c, SecondaryWalk how) noexcept {
    if constexpr (kProfile)
      (how == SecondaryWalk::whole       ? c.profile->walked_whole
       : how == SecondaryWalk::clustered ? c.profile->walked_clustered
                                         : c.profile->walked_apart)[c.profile->current] += 1;
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
  [[gnu::always_inline]] static B gather(const Prepared& s, const std::vector<T>& field,
                                         const I& id) noexcept {
    return gather(field, id, s.num_objects());
  }

  static V select3(const M& m, const V& a, const V& b) noexcept {
    return {xsimd::select(m, a.x, b.x), xsimd::select(m, a.y, b.y), xsimd::select(m, a.z, b.z)};
  }
};

}  // namespace lancer::packet
