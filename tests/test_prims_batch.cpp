// The triangle and cylinder formulas (lancer/prim/*.hpp) run on xsimd batches give each lane
// the bits the scalar reference gets: the packets will share them.
#include <gtest/gtest.h>

#include <cstring>
#include <random>
#include <xsimd/xsimd.hpp>

#include "lancer/prim/cylinder.hpp"
#include "lancer/prim/triangle.hpp"

namespace lancer {
namespace {

using B = xsimd::batch<float>;
constexpr std::size_t W = B::size;

bool same_bits(float a, float b) { return std::memcmp(&a, &b, sizeof a) == 0; }

B lanes(const float (&v)[W]) { return B::load_unaligned(v); }
Vec3<B> lanes(const Vec3<float> (&v)[W]) {
  float x[W], y[W], z[W];
  for (std::size_t k = 0; k < W; ++k) x[k] = v[k].x, y[k] = v[k].y, z[k] = v[k].z;
  return {B::load_unaligned(x), B::load_unaligned(y), B::load_unaligned(z)};
}
float lane(const B& b, std::size_t k) {
  alignas(64) float out[W];
  b.store_unaligned(out);
  return out[k];
}

Vec3<float> random_vec(std::mt19937& rng, float scale) {
  std::uniform_real_distribution<float> u(-1, 1);
  return Vec3<float>{u(rng), u(rng), u(rng)} * scale;
}

// Rays at triangles, some through their edges and vertices (edge functions exactly 0 there
// take the recomputed path), lane by lane against the scalar formulas.
TEST(PrimsBatch, TriangleFormulasGiveEachLaneTheScalarBits) {
  std::mt19937 rng(5);
  std::size_t inside = 0, zero_edges = 0;
  for (int round = 0; round < 2000; ++round) {
    Vec3<float> a[W], b[W], c[W];
    float sx[W], sy[W], sz[W];
    Vec3<float> dir[W];
    for (std::size_t k = 0; k < W; ++k) {
      const Vec3<float> o = random_vec(rng, 10);
      const Vec3<float> v0 = random_vec(rng, 4), v1 = random_vec(rng, 4), v2 = random_vec(rng, 4);
      // Aim at a vertex, an edge's midpoint or inside.
      const int aim = int(rng() % 3);
      const Vec3<float> target = aim == 0   ? v1
                                 : aim == 1 ? (v0 + v2) * 0.5f
                                            : (v0 + v1 + v2) * (1.0f / 3);
      dir[k] = normalize(target - o);
      const prim::RayShear<float> sh = prim::ray_shear(dir[k]);
      a[k] = prim::permuted(v0 - o, sh), b[k] = prim::permuted(v1 - o, sh);
      c[k] = prim::permuted(v2 - o, sh);
      sx[k] = sh.sx, sy[k] = sh.sy, sz[k] = sh.sz;
    }
    const prim::TriangleEdges<B> e =
        prim::triangle_edges<float>(lanes(a), lanes(b), lanes(c), lanes(sx), lanes(sy), lanes(sz));
    const auto in = prim::triangle_inside(e);
    const B t = prim::triangle_t(e);
    const Vec3<B> bary = prim::triangle_barycentrics(e);
    for (std::size_t k = 0; k < W; ++k) {
      const prim::TriangleEdges<float> s =
          prim::triangle_edges<float>(a[k], b[k], c[k], sx[k], sy[k], sz[k]);
      ASSERT_TRUE(same_bits(lane(e.u, k), s.u) && same_bits(lane(e.v, k), s.v) &&
                  same_bits(lane(e.w, k), s.w) && same_bits(lane(e.det, k), s.det) &&
                  same_bits(lane(e.t_scaled, k), s.t_scaled))
          << "round " << round << " lane " << k;
      const bool scalar_in = prim::triangle_inside(s);
      EXPECT_EQ(bool(in.get(k)), scalar_in);
      inside += scalar_in;
      zero_edges += s.u == 0 || s.v == 0 || s.w == 0;
      if (scalar_in) {
        EXPECT_TRUE(same_bits(lane(t, k), prim::triangle_t(s)));
        EXPECT_TRUE(same_bits(lane(bary.y, k), prim::triangle_barycentrics(s).y));
      }
    }
  }
  EXPECT_GT(inside, W * 500);
}

TEST(PrimsBatch, CylinderFormulasGiveEachLaneTheScalarBits) {
  std::mt19937 rng(6);
  std::size_t hits = 0;
  for (int round = 0; round < 2000; ++round) {
    Vec3<float> f[W], d[W];
    for (std::size_t k = 0; k < W; ++k) {
      f[k] = random_vec(rng, 5);
      d[k] = normalize(random_vec(rng, 1) * 0.5f - f[k]);
    }
    const Vec3<float> axis = normalize(random_vec(rng, 1));
    const float h = 2, r2 = 0.8f;
    for (bool caps : {true, false}) {
      const prim::CylinderHit<B> hb = prim::cylinder_closest(
          lanes(f), lanes(d), Vec3<B>::from(axis), B(h), B(r2), caps, B(1e-4f));
      for (std::size_t k = 0; k < W; ++k) {
        const prim::CylinderHit<float> hs =
            prim::cylinder_closest(f[k], d[k], axis, h, r2, caps, 1e-4f);
        ASSERT_TRUE(same_bits(lane(hb.t, k), hs.t)) << round << " " << k;
        ASSERT_TRUE(same_bits(lane(hb.part, k), hs.part));
        hits += hs.t < 1e30f;
      }
    }
  }
  EXPECT_GT(hits, W * 1000);
}

}  // namespace
}  // namespace lancer
