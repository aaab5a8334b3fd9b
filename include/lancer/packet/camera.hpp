// Camera rays: row packets and square tiles (the same rays, from the camera's tables), the
// camera blocks' tiles, and the camera packets made once for the kernel alone (bench --mode
// kernel).
// Include only from code built for the batch's ISA (packet/kernel.hpp).
#pragma once

#include <algorithm>
#include <cstdint>
#include <type_traits>

#include "lancer/packet/lane_traits.hpp"

namespace lancer::packet {

template <class Arch, class Real, class Mode>
struct CameraRays : Lanes<Arch, Real, Mode> {
  using L = Lanes<Arch, Real, Mode>;
  using L::bits;
  using L::kBlockRows;
  using L::kGroup;
  using L::kGroupPx;
  using L::kGroupX;
  using L::kGroupY;
  using L::kTileH;
  using L::kTileW;
  using L::W;
  using typename L::B;
  using typename L::M;
  using typename L::Mth;
  using typename L::Prepared;
  using typename L::T;
  using typename L::V;

  // Camera rays of columns i0 .. i0+W-1 of row j at sub-sample (a, b); screen coordinates come
  // from the camera's tables, computed once by the same formula.
  static void camera_packet(const Prepared& s, int i0, int j, int a, int b, V& o, V& d) noexcept {
    const PreparedCamera<T>& cam = s.camera;
    const B x = B::load_unaligned(&cam.screen_x[std::size_t(a) * cam.nx + i0]);
    const B y(cam.screen_y[std::size_t(b) * cam.ny + j]);
    camera_ray<Mth>(cam, x, y, o, d);
  }

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

  // ---- the primary intersection kernel alone (lancer bench --mode kernel) -------------------
  // Its camera rays are made once, beforehand, in the layout primary mode traces them in
  // (primary_rows): through a hierarchy (the spheres' or the shapes'), blocks of kGroup tiles
  // walked together (pinhole camera, float) or single tiles (gx = gy = 1); else rows of packets.
  static bool kernel_blocks(const Prepared& s) noexcept {
    return kGroup > 1 && !s.camera.orthographic &&
           ((s.bvh.active() && s.features.spheres) || s.features.shapes);
  }
  // Square packets (tiles) wherever a hierarchy is walked, the spheres' or the shapes': their
  // rays diverge less than a row's, so they share more of the nodes and leaves they visit.
  static bool tiled(const Prepared& s) noexcept { return s.bvh.active() || s.features.shapes; }
  // Packets camera_packets makes for rows [row_begin, row_end), row_begin a multiple of
  // kBlockRows (run_tiles' rows).
  static std::size_t camera_packet_count(const Prepared& s, int row_begin, int row_end) noexcept {
    const PreparedCamera<T>& cam = s.camera;
    const std::size_t samples = std::size_t(cam.samples) * std::size_t(cam.samples);
    auto blocks = [&](int w, int h, int packets) {
      return std::size_t((row_end - row_begin + h - 1) / h) * std::size_t((cam.nx + w - 1) / w) *
             samples * std::size_t(packets);
    };
    if (kernel_blocks(s)) return blocks(kGroupPx, kBlockRows, kGroup);
    if (tiled(s)) return blocks(kTileW, kTileH, 1);
    return blocks(W, 1, 1);
  }
  // Per packet the origin then the direction, component by component, W lanes each (6 W
  // values), its live lanes as bits in lanes[p], and per lane the index of its camera ray in
  // the image's order, (row * samples^2 + sub-sample) * nx + column, or kNoCameraRay.
  static void camera_packets(const Prepared& s, int row_begin, int row_end, T* rays, int* lanes,
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
    if (tiled(s)) return blocks(One{}, One{});
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
};

}  // namespace lancer::packet
