// The camera tiles' cones (Traversal::closest_coherent, widths 16 and 8): each tile's rays, all
// leaving the pinhole eye, bounded by one cone around an axis through the tile's centre; at a
// leaf a sphere is tested against every tile's cone at once (lane i: tile i), and a tile goes
// on to the exact per-lane tests with only the spheres its cone may meet. The cull is
// conservative by a margin far above the sphere test's rounding (docs/accel.md, "Tile cones"),
// so every hit the plain loop finds survives it. Include only from code built for the batch's
// ISA (packet/traversal.hpp).
#pragma once

#include <cstdint>
#include <cstring>
#include <xsimd/xsimd.hpp>

#include "lancer/packet/fused.hpp"
#include "lancer/packet/intrin.hpp"
#include "lancer/packet/lanes.hpp"
#include "lancer/prepared.hpp"
#include "lancer/vec3.hpp"

namespace lancer::packet {

// The cones of a camera block's kTiles tiles, one tile a lane: 16 4x4 tiles in a zmm (width 16),
// 8 4x2 tiles in a ymm (width 8), 16 2x2 tiles in four xmm (width 4). Tile i's rays d (unit,
// from the eye) make angles of at most theta with its axis a (unit): cos(theta) >= cos_bound and
// sin(theta) <= sin_bound. From the chord: for unit d and a, |d - a|^2 = 2 - 2 cos and
// sin <= |d - a|, so the greatest |d - a|^2 over the tile's live lanes, E, gives
// cos >= 1 - E / 2 and sin <= sqrt(E) without the cancellation of 1 - cos^2 (a tile spans a few
// thousandths of a radian). kSlack covers |d| and |a| off 1 by their rounding and the rounding
// of E.
template <class Arch, int kTiles>
struct TileCones {
  using B = xsimd::batch<float, Arch>;
  using M = xsimd::batch_bool<float, Arch>;
  using V = Vec3<B>;
  using R = typename B::register_type;
  static constexpr int kW = int(B::size);
  static constexpr int kRegs = kTiles > kW ? kTiles / kW : 1;  // (whole: Traversal::kTileCones)
  // The two lanes whose directions' sum points through a tile's centre (4x4: (1,1) and (2,2);
  // 4x2: (1,0) and (2,1); 2x2: (0,0) and (1,1)).
  static constexpr int kLane1 = kW == 16 ? 5 : kW == 8 ? 1 : 0;
  static constexpr int kLane2 = kW == 16 ? 10 : kW == 8 ? 6 : 3;
  static constexpr float kSlack = 0x1p-19f;

  // Lane i: the greatest lane of x[i] (a transposed reduction, one vector per lane).
  static R greatest_per_lane(const R* x) noexcept {
    if constexpr (kW == 16) {
      // Per four vectors, x[4q + p]'s greatest in lanes 4p .. 4p + 3 of q's.
      auto quad = [](const R* v) { return fold_quarters<true>(v); };
      const R q0 = quad(x), q1 = quad(x + 4), q2 = quad(x + 8), q3 = quad(x + 12);
      const __m512i pick =
          _mm512_setr_epi32(0, 4, 8, 12, 16, 20, 24, 28, 0, 4, 8, 12, 16, 20, 24, 28);
      return _mm512_mask_blend_ps(__mmask16(0xFF00), _mm512_permutex2var_ps(q0, pick, q1),
                                  _mm512_permutex2var_ps(q2, pick, q3));
    } else if constexpr (kW == 8) {
      // Per two vectors, x[2p]'s greatest in lanes 0-3 and x[2p + 1]'s in lanes 4-7.
      R g[4];
      for (int p = 0; p < 4; ++p) {
        const R a = x[2 * p], b = x[2 * p + 1];
        R u = _mm256_max_ps(_mm256_permute2f128_ps(a, b, 0x20), _mm256_permute2f128_ps(a, b, 0x31));
        u = _mm256_max_ps(u, _mm256_permute_ps(u, _MM_SHUFFLE(2, 3, 0, 1)));
        g[p] = _mm256_max_ps(u, _mm256_permute_ps(u, _MM_SHUFFLE(1, 0, 3, 2)));
      }
      // Lanes 0 and 4 of g[0..3] in the order 0, 2, 4, 6, 1, 3, 5, 7, then put in place.
      const R t01 = _mm256_shuffle_ps(g[0], g[1], 0), t23 = _mm256_shuffle_ps(g[2], g[3], 0);
      const R t = _mm256_shuffle_ps(t01, t23, _MM_SHUFFLE(2, 0, 2, 0));
      return _mm256_permutevar8x32_ps(t, _mm256_setr_epi32(0, 4, 1, 5, 2, 6, 3, 7));
    } else {
      R t0 = x[0], t1 = x[1], t2 = x[2], t3 = x[3];
      _MM_TRANSPOSE4_PS(t0, t1, t2, t3);
      return _mm_max_ps(_mm_max_ps(t0, t1), _mm_max_ps(t2, t3));
    }
  }

  // Per register g, tiles g kW .. g kW + kW - 1; cos2: cos_bound^2 (0: the tile culls nothing).
  B ax[kRegs], ay[kRegs], az[kRegs], cos2[kRegs], sin_bound[kRegs];

  // The eye's tables in the hierarchy's leaf order (PreparedScene::leaf_eye), which keep() tests.
  const float *eye_fx, *eye_fy, *eye_fz, *eye_reach;

  // d[i], valid[i]: tile i's rays and live lanes (i < kTiles); eye: the tables above.
  TileCones(const V* d, const M* valid, const EyeSphere<float>& eye) noexcept
      : eye_fx(eye.fx.data()),
        eye_fy(eye.fy.data()),
        eye_fz(eye.fz.data()),
        eye_reach(eye.reach.data()) {
    auto at = [](const B& v, int l) {
      float f;
      std::memcpy(&f, reinterpret_cast<const char*>(&v) + sizeof(float) * std::size_t(l), sizeof f);
      return f;
    };
    for (int g = 0; g < kRegs; ++g) {
      const V* dg = d + g * kW;
      alignas(64) float x[kW], y[kW], z[kW];
      for (int i = 0; i < kW; ++i) {
        x[i] = at(dg[i].x, kLane1) + at(dg[i].x, kLane2);
        y[i] = at(dg[i].y, kLane1) + at(dg[i].y, kLane2);
        z[i] = at(dg[i].z, kLane1) + at(dg[i].z, kLane2);
      }
      const B bx = B::load_aligned(x), by = B::load_aligned(y), bz = B::load_aligned(z);
      const B len = xsimd::sqrt(bx * bx + by * by + bz * bz);
      ax[g] = bx / len, ay[g] = by / len, az[g] = bz / len;
      ax[g].store_aligned(x), ay[g].store_aligned(y), az[g].store_aligned(z);
      R e[kW];
      for (int i = 0; i < kW; ++i) {
        const B ex = dg[i].x - B(x[i]), ey = dg[i].y - B(y[i]), ez = dg[i].z - B(z[i]);
        e[i] = R(xsimd::select(valid[g * kW + i], ex * ex + ey * ey + ez * ez, B(0.0f)));
      }
      const B chord2 = B(greatest_per_lane(e));
      const B cos_bound = B(1.0f) - chord2 * B(0.5f) - B(kSlack);
      // A cone of 60 degrees or more (a tile a few pixels wide never is): no cull.
      const M narrow = cos_bound >= B(0.5f);
      cos2[g] = xsimd::select(narrow, cos_bound * cos_bound, B(0.0f));
      sin_bound[g] =
          xsimd::select(narrow, xsimd::min(xsimd::sqrt(chord2) + B(kSlack), B(1.0f)), B(1.0f));
    }
  }

  // keep() below against the leaf-order tables the cones were made with.
  unsigned keep(int first, int n, std::uint32_t* which, unsigned regs = ~0u) const noexcept {
    return keep(eye_fx, eye_fy, eye_fz, eye_reach, first, n, which, regs);
  }
  // The tiles (bit i) whose cone may meet some sphere of leaf-order [first, first + n), and per
  // tile the spheres it may meet (which[i], bit j: sphere first + j; n <= 32). fx, fy, fz:
  // the eye minus each sphere's centre; reach: radius plus margin (prepare.cpp's eye_reach).
  //
  // The distance from centre C to any ray of tile i (forward from the eye) is at least
  // |V| sin(phi - theta), V = C - eye = -f, phi the angle between V and the axis: with
  // P = |V x a| = |V| sin(phi) and A = V . a = |V| cos(phi), that is cos(theta) P - sin(theta) A
  // >= cos_bound P - sin_bound max(A, 0). A tile whose bound exceeds the reach misses the
  // sphere; compared squared (both sides >= 0).
  // regs: the registers of tiles to test (bit g: tiles g kW ..); the others' tiles keep nothing.
  unsigned keep(const float* fx, const float* fy, const float* fz, const float* reach, int first,
                int n, std::uint32_t* which, unsigned regs = ~0u) const noexcept {
    unsigned tiles = 0;
    B bits[kRegs];  // which, as float lanes' bits (only ORed and selected)
    for (int g = 0; g < kRegs; ++g) bits[g] = B(0.0f);
    for (int j = 0; j < n; ++j) {
      const B X(fx[first + j]), Y(fy[first + j]), Z(fz[first + j]), reach_j(reach[first + j]);
      float bit;
      const std::uint32_t one = 1u << j;
      std::memcpy(&bit, &one, sizeof bit);
      for (int g = 0; g < kRegs; ++g) {
        if (kRegs > 1 && !(regs >> g & 1u)) continue;
        const B along = X * ax[g] + Y * ay[g] + Z * az[g];  // -A
        const B cx = Y * az[g] - Z * ay[g], cy = Z * ax[g] - X * az[g], cz = X * ay[g] - Y * ax[g];
        const B p2 = cx * cx + cy * cy + cz * cz;
        const B r = sin_bound[g] * xsimd::max(-along, B(0.0f)) + reach_j;
        const M meets = cos2[g] * p2 <= r * r;
        tiles |= lane_bits(meets) << (g * kW);
        bits[g] = xsimd::select(meets, bits[g] | B(bit), bits[g]);
      }
    }
    alignas(64) float out[kTiles];
    for (int g = 0; g < kRegs; ++g) bits[g].store_aligned(out + g * kW);
    std::memcpy(which, out, sizeof out);
    return tiles;
  }
};

}  // namespace lancer::packet
