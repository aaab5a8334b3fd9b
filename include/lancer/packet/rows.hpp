// Row output: rows of the image rendered packet by packet (their camera hits first from the
// camera blocks, through a hierarchy), the primary hits alone, and the primary intersection
// kernel alone.
// Include only from code built for the batch's ISA (packet/kernel.hpp).
#pragma once

#include <algorithm>
#include <cstring>
#include <limits>
#include <vector>

#include "lancer/packet/camera.hpp"
#include "lancer/packet/radiance.hpp"

namespace lancer::packet {

template <class Arch, class Real, class Mode>
struct Rows : Radiance<Arch, Real, Mode>, CameraRays<Arch, Real, Mode> {
  using Ra = Radiance<Arch, Real, Mode>;
  using Ca = CameraRays<Arch, Real, Mode>;
  using Ca::camera_packet;
  using Ca::kernel_blocks;
  using Ca::tiled;
  using Ra::bits;
  using Ra::closest_hit;
  using Ra::count;
  using Ra::gather;
  using Ra::gather8;
  using Ra::iota;
  using Ra::kBlockRows;
  using Ra::kFast;
  using Ra::kGroup;
  using Ra::kGroupPx;
  using Ra::kGroupX;
  using Ra::kGroupY;
  using Ra::kProfile;
  using Ra::kTileH;
  using Ra::kTileW;
  using Ra::lap;
  using Ra::leaf_visit;
  using Ra::load_ids;
  using Ra::occupancy;
  using Ra::select3;
  using Ra::store_ids;
  using Ra::tests;
  using Ra::to_m;
  using Ra::to_mi;
  using Ra::unbounded_closest;
  using Ra::W;
  using Ra::walk_choice;
  using typename Ra::B;
  using typename Ra::GivenHit;
  using typename Ra::I;
  using typename Ra::Id;
  using typename Ra::Level;
  using typename Ra::M;
  using typename Ra::MI;
  using typename Ra::Mth;
  using typename Ra::Prepared;
  using typename Ra::T;
  using typename Ra::Tr;
  using typename Ra::V;
  template <int gx, int gy, bool kWhole>
  using BlockTiles = typename Ca::template BlockTiles<gx, gy, kWhole>;

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
  static void render_rows(const Prepared& s, Image& image, int row_begin, int row_end,
                          RayCounts& counts) noexcept {
    const PreparedCamera<T>& cam = s.camera;
    const bool blocks = cam.samples == 1 && kernel_blocks(s);
    // Shadow rays of secondary hits one ray at a time (exact float and double, by the scene): its
    // own instantiations, so that scenes without it keep their shading loops' code
    // (lorenzi-diffuse, width 16: 0.97x with the test in every loop).
    if constexpr (!kFast) {
      if (s.walk.shadow_one_ray_lanes > 0) {
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
  static void render_rows_as(const Prepared& s, Image& image, int row_begin, int row_end,
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
    if constexpr (kProfile) counts.profile->last_tsc = lancer::ticks();
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
              Ra::template radiance<kOneRay>(s, valid, o, d, levels, r, g, bl, counts, &hit);
            } else {
              Ra::template radiance<kOneRay>(s, valid, o, d, levels, r, g, bl, counts);
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

  static void primary_rows(const Prepared& s, float* t_out, std::int32_t* id_out, int row_begin,
                           int row_end, RayCounts& counts) noexcept {
    // Through a hierarchy, square packets (tiled()). The plain loop (the course scenes) keeps
    // rows.
    if (tiled(s))
      primary_tiles(s, t_out, id_out, row_begin, row_end, counts);
    else
      primary_packet_rows(s, t_out, id_out, row_begin, row_end, counts);
  }

  static void primary_packet_rows(const Prepared& s, float* t_out, std::int32_t* id_out,
                                  int row_begin, int row_end, RayCounts& counts) noexcept {
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
        if (id_out) store_ids(Ra::object_ids(s, first_id), id_out + at, lanes);
      }
    }
  }

  // The closest hit of one camera packet: its t added to `sum`, its ids kept if `first`.
  [[gnu::always_inline]] static void primary_hit(const Prepared& s, const M& valid, const V& o,
                                                 const V& d, B& sum, I& first_id, bool first,
                                                 RayCounts& counts) noexcept {
    B t(std::numeric_limits<T>::infinity());
    I id(Id(-1));
    if (s.camera.orthographic)
      closest_hit(s, valid, o, d, t, id, counts, I(Id(-1)), true);
    else
      Ra::template closest_hit<true>(s, valid, o, d, t, id, counts);
    sum = sum + t;
    if (first) first_id = id;
  }

  static void primary_tiles(const Prepared& s, float* t_out, std::int32_t* id_out, int row_begin,
                            int row_end, RayCounts& counts) noexcept {
    if (kernel_blocks(s))
      primary_blocks<kGroupX, kGroupY>(s, t_out, id_out, row_begin, row_end, 0, counts);
    else
      primary_blocks<1, 1>(s, t_out, id_out, row_begin, row_end, 0, counts);
    // The blocks keep hit ids (render_rows shades from them): object ids for the caller.
    if (id_out && Ra::Prims::Meshes::present(s))
      for (std::size_t k = std::size_t(row_begin) * std::size_t(s.camera.nx);
           k < std::size_t(row_end) * std::size_t(s.camera.nx); ++k)
        id_out[k] = Ra::Prims::Meshes::object_of(s, id_out[k]);
  }
  // Blocks of gx x gy tiles (the block's shape fixed at compile time: its loops unroll). Pixel
  // (i, j) goes to t_out[(j - row_base) * nx + i].
  template <int gx, int gy>
  static void primary_blocks(const Prepared& s, float* t_out, std::int32_t* id_out, int row_begin,
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

  template <int gx, int gy, bool kWhole>
  [[gnu::always_inline]] static void primary_block(const Prepared& s, int i0, int j0, int row_end,
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
          Ra::template closest_camera_block<gx, gy>(s, valid, o, d, t, id, counts);
          for (int g = 0; g < n; ++g) {
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

  // The primary intersection kernel alone, as primary_rows runs it, over `count` packets made
  // by camera_packets() (a whole number of blocks where they are blocks): W nearest distances
  // per packet into t_out (infinity where missed).
  static M lanes_of(int live) noexcept {
    alignas(64) T v[W];
    for (int k = 0; k < W; ++k) v[k] = T((unsigned(live) >> k) & 1u);
    return B::load_aligned(v) != B(0);
  }
  [[gnu::flatten]] static void intersect_camera_packets(const Prepared& s, const T* rays,
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
          Ra::template closest_camera_block<kGroupX, kGroupY>(s, valid, o, d, t, id, counts);
          for (int g = 0; g < kGroup; ++g) t[g].store_unaligned(t_out + (p + g) * W);
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
        Ra::template closest_hit<true>(s, valid, o, d, t, id, counts);
      t.store_unaligned(t_out + p * W);
    }
  }
};

}  // namespace lancer::packet
