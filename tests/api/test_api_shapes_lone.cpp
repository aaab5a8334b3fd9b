// Incoherent rays over triangles, meshes and cylinders through the library API's packets, whose
// lanes go on one ray at a time over the shapes' hierarchy (packet/prim/shapes_lone.hpp), against
// the reference (Options::width 1): every field of every answer, bit for bit, in exact float and
// double, at every packet width this machine runs. The rays are those of `lancer bench`'s
// diffuse and ambient-occlusion sets: from the camera's hits, offset along the normal, in random
// directions over the hemisphere, four per hit, so that a packet's lanes diverge at once; and
// the same rays from the hit points themselves (the scene's epsilon keeps the surface out).
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "api/api_util.hpp"
#include "lancer/lancer.hpp"
#include "support/test_util.hpp"

namespace lancer {
namespace {

using testing::with;
constexpr float kInf = std::numeric_limits<float>::infinity();

struct Ray {
  float o[3], d[3];
  float tfar = kInf;
};

// A unit direction uniform over the hemisphere about n.
void hemisphere(const float* n, float* d, std::mt19937_64& g) {
  std::normal_distribution<double> nd;
  double v[3], l;
  do {
    for (double& x : v) x = nd(g);
    l = std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
  } while (l < 1e-3);
  const double side = v[0] * n[0] + v[1] * n[1] + v[2] * n[2] < 0 ? -1 : 1;
  for (int a = 0; a < 3; ++a) d[a] = float(side * v[a] / l);
}

// Four rays per camera hit of every `step`-th pixel, from the hit point offset by `offset`
// along its normal (turned to the camera), AO rays ending at ao_tfar (0: diffuse, no end).
std::vector<Ray> rays_from_hits(const api::Scene& ref, int step, float offset, float ao_tfar,
                                std::uint64_t seed) {
  std::mt19937_64 g(seed);
  std::vector<Ray> out;
  const api::Info& in = ref.info();
  for (int j = 0; j < in.ny; j += step)
    for (int i = 0; i < in.nx; i += step) {
      float o[3], d[3];
      ref.camera_ray(i, j, 0, 0, o, d);
      api::Ray1 c;
      c.org_x[0] = o[0], c.org_y[0] = o[1], c.org_z[0] = o[2];
      c.dir_x[0] = d[0], c.dir_y[0] = d[1], c.dir_z[0] = d[2];
      c.tnear[0] = 0, c.tfar[0] = kInf, c.mask[0] = api::kAllObjects;
      api::Hit1 h;
      ref.intersect(nullptr, c, h);
      if (h.id[0] < 0) continue;
      float n[3] = {h.ng_x[0], h.ng_y[0], h.ng_z[0]};
      const float nl = std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
      if (!(nl > 0)) continue;
      const float side = n[0] * d[0] + n[1] * d[1] + n[2] * d[2] > 0 ? -1.0f : 1.0f;
      for (float& x : n) x *= side / nl;
      for (int k = 0; k < 4; ++k) {
        Ray ray;
        for (int a = 0; a < 3; ++a) ray.o[a] = o[a] + h.t[0] * d[a] + offset * n[a];
        hemisphere(n, ray.d, g);
        if (ao_tfar > 0) ray.tfar = ao_tfar;
        out.push_back(ray);
      }
    }
  return out;
}

bool same_bits(float a, float b) { return std::memcmp(&a, &b, sizeof a) == 0; }

template <int N>
void set_lanes(api::RayPacket<N>& r, const std::vector<Ray>& rays, std::size_t first) {
  for (int k = 0; k < N; ++k) {
    const Ray& x = rays[first + std::size_t(k)];
    r.org_x[k] = x.o[0], r.org_y[k] = x.o[1], r.org_z[k] = x.o[2];
    r.dir_x[k] = x.d[0], r.dir_y[k] = x.d[1], r.dir_z[k] = x.d[2];
    r.tnear[k] = 0, r.tfar[k] = x.tfar, r.mask[k] = api::kAllObjects;
  }
}

// Every lane's closest hit and occlusion from `s` against the reference's, every field.
template <int N>
int compare_packets(const api::Scene& s, const api::Scene& ref, const std::vector<Ray>& rays,
                    std::size_t& hits) {
  int differ = 0;
  for (std::size_t i = 0; i + N <= rays.size() && differ < 5; i += N) {
    api::RayPacket<N> r;
    set_lanes(r, rays, i);
    api::HitPacket<N> a, b;
    int oa[N], ob[N];
    s.intersect(nullptr, r, a), ref.intersect(nullptr, r, b);
    s.occluded(nullptr, r, oa), ref.occluded(nullptr, r, ob);
    for (int k = 0; k < N; ++k) {
      const bool same = a.id[k] == b.id[k] && a.prim_id[k] == b.prim_id[k] &&
                        same_bits(a.t[k], b.t[k]) && same_bits(a.u[k], b.u[k]) &&
                        same_bits(a.v[k], b.v[k]) && same_bits(a.ng_x[k], b.ng_x[k]) &&
                        same_bits(a.ng_y[k], b.ng_y[k]) && same_bits(a.ng_z[k], b.ng_z[k]) &&
                        oa[k] == ob[k];
      EXPECT_TRUE(same) << "ray " << i + std::size_t(k) << ": id " << a.id[k] << " vs " << b.id[k]
                        << ", prim " << a.prim_id[k] << " vs " << b.prim_id[k] << ", t " << a.t[k]
                        << " vs " << b.t[k] << ", u " << a.u[k] << " vs " << b.u[k] << ", occluded "
                        << oa[k] << " vs " << ob[k];
      differ += !same;
      hits += b.id[k] >= 0;
    }
  }
  return differ;
}

// Ray1 one ray at a time, from epsilon and from a tnear of its own, every field.
int compare_one(const api::Scene& s, const api::Scene& ref, const std::vector<Ray>& rays) {
  int differ = 0;
  for (std::size_t i = 0; i < rays.size() && differ < 5; i += 3)
    for (float tnear : {0.0f, 1e-2f}) {
      api::Ray1 r;
      set_lanes(r, rays, i);
      r.tnear[0] = tnear;
      api::Hit1 a, b;
      int oa = 0, ob = 0;
      s.intersect(nullptr, r, a), ref.intersect(nullptr, r, b);
      s.occluded(nullptr, r, &oa), ref.occluded(nullptr, r, &ob);
      const bool same = a.id[0] == b.id[0] && a.prim_id[0] == b.prim_id[0] &&
                        same_bits(a.t[0], b.t[0]) && same_bits(a.u[0], b.u[0]) &&
                        same_bits(a.v[0], b.v[0]) && same_bits(a.ng_x[0], b.ng_x[0]) &&
                        same_bits(a.ng_y[0], b.ng_y[0]) && same_bits(a.ng_z[0], b.ng_z[0]) &&
                        oa == ob;
      EXPECT_TRUE(same) << "Ray1 " << i << " tnear " << tnear << ": id " << a.id[0] << " vs "
                        << b.id[0] << ", t " << a.t[0] << " vs " << b.t[0] << ", occluded " << oa
                        << " vs " << ob;
      differ += !same;
    }
  return differ;
}

void compare_scene(const std::string& path) {
  const Scene desc = load_scene(path);
  for (Precision p : {Precision::exact, Precision::dbl}) {
    const api::Scene ref = api::Scene::from_description(desc, with(p, 1));
    // An offset of a thousandth of the scene's size, and none: from the surface itself.
    for (float offset : {1e-3f, 0.0f})
      for (float ao : {0.0f, 0.1f}) {
        const std::vector<Ray> rays = rays_from_hits(ref, 12, offset, ao, 5);
        for (int w : testing::packet_widths(p)) {
          const api::Scene s = api::Scene::from_description(desc, with(p, w));
          SCOPED_TRACE(path + " " + to_string(p) + " width " + std::to_string(w) + " offset " +
                       std::to_string(offset) + " ao " + std::to_string(ao));
          std::size_t hits = 0;
          compare_packets<16>(s, ref, rays, hits);
          compare_packets<8>(s, ref, rays, hits);
          compare_one(s, ref, rays);
          // Rays that hit and rays that miss.
          EXPECT_GT(hits, 0u);
        }
      }
  }
}

TEST(ApiShapesLone, IncoherentPacketsGiveTheReferencesBits) {
  for (const char* scene :
       {"scenes/prims/bunny.json", "scenes/prims/cylinders.json", "scenes/prims/glass-mesh.json"})
    compare_scene(testing::source_path(scene));
}

}  // namespace
}  // namespace lancer
