// The sphere hierarchy: its build (deterministic, every sphere once, boxes that hold them), and
// renders through it bit-identical to the plain loop over all objects, the definition, on seeded
// random scenes of up to 64k spheres, with ties (duplicate spheres), rays starting inside the
// cloud and far plane hits.
#include <gtest/gtest.h>
#include <sys/mman.h>
#include <tbb/task_arena.h>
#include <unistd.h>

#include <array>
#include <cmath>
#include <cstring>
#include <fstream>
#include <nlohmann/json.hpp>
#include <random>
#include <sstream>
#include <string>
#include <tuple>

#include "lancer/bvh.hpp"
#include "lancer/compare.hpp"
#include "lancer/huge_pages.hpp"
#include "lancer/packet/api.hpp"
#include "lancer/prepared.hpp"
#include "lancer/reference.hpp"
#include "lancer/render.hpp"
#include "support/test_util.hpp"

namespace lancer {
namespace {

using nlohmann::json;

struct CloudOptions {
  int spheres = 1000;
  double duplicates = 0.05;  // share of spheres that repeat an earlier one (equal t: ties)
  bool eye_inside = false;   // the camera inside the cloud
  int nx = 48, ny = 32;
  int max_depth = 3;
  double scale = 1;   // every length times this
  double radius = 1;  // the radii (0.2 to 0.6) times this
  bool second_light =
      false;            // another light, left of and behind the cloud: shadow rays that
                        // go down x and z, where the nodes' near-first order is not slot order
  double transmit = 0;  // the spheres' (glass: ior 1.5)
  double transmit_spread = 0;  // each sphere's transmit uniform in transmit -+ this: a shadow
                               // ray's product of transmits then depends on its order
  bool far_wall = false;  // a mirror 1e4 away behind the cloud: rays from beyond the origin limit
  std::array<double, 3> direction = {0.1, -0.05, -1.0};  // the camera's
};

// N random spheres in a box before the camera, a ground plane far below (so reflections hit it
// far away), reflective materials, one light.
Scene cloud(std::uint64_t seed, const CloudOptions& o) {
  std::mt19937_64 rng(seed);
  auto uniform = [&](double lo, double hi) {
    return lo + (hi - lo) * (double(rng() >> 11) * 0x1.0p-53);
  };
  const double side = 2.0 * std::cbrt(double(o.spheres));
  const double k = o.scale;
  json objects = json::array();
  std::vector<json> made;
  for (int i = 0; i < o.spheres; ++i) {
    json s;
    if (!made.empty() && uniform(0, 1) < o.duplicates) {
      s = made[std::size_t(uniform(0, double(made.size())))];
    } else {
      s = {{"type", "sphere"},
           {"center",
            {k * uniform(-side / 2, side / 2), k * uniform(-side / 2, side / 2),
             k * uniform(-side - (o.eye_inside ? 0 : 5), o.eye_inside ? side / 2 : -5.0)}},
           {"radius", k * o.radius * uniform(0.2, 0.6)}};
    }
    // Each copy its own colour: a tie won by the wrong id shows in the image.
    s["material"] = {{"color", {uniform(0.1, 1), uniform(0.1, 1), uniform(0.1, 1)}},
                     {"ka", 0.1},
                     {"kd", 0.8},
                     {"ks", 0.4},
                     {"shininess", 20},
                     {"reflect", 0.4}};
    if (o.transmit > 0)
      s["material"]["transmit"] = o.transmit + uniform(-o.transmit_spread, o.transmit_spread),
      s["material"]["ior"] = 1.5;
    made.push_back(s);
    objects.push_back(s);
  }
  objects.push_back({{"type", "plane"},
                     {"point", {0, k * (-side / 2 - 1), 0}},
                     {"normal", {0, 1, 0}},
                     {"material", {{"color", {0.8, 0.8, 0.8}}, {"kd", 0.8}, {"reflect", 0.3}}}});
  if (o.far_wall)
    objects.push_back({{"type", "plane"},
                       {"point", {0, 0, -1e4 * k}},
                       {"normal", {0.05, 0.02, 1}},
                       {"material", {{"color", {0.5, 0.6, 0.7}}, {"kd", 0.5}, {"reflect", 0.9}}}});
  json lights = {{{"position", {k * side, k * side, k * 5}}, {"intensity", 1}, {"ambient", 0.2}}};
  if (o.second_light)
    lights.push_back(
        {{"position", {-k * side, k * side, -k * 3 * side}}, {"intensity", 0.7}, {"ambient", 0.1}});
  const json j{{"camera",
                {{"type", "pinhole"},
                 {"position", {0, 0, 0}},
                 {"direction", o.direction},
                 {"distance", 5 * k},
                 {"resolution", {o.nx, o.ny}},
                 {"bounds", {-3 * k, 3 * k, -2 * k, 2 * k}}}},
               {"background", {0.1, 0.1, 0.2}},
               {"max_depth", o.max_depth},
               {"lights", lights},
               {"objects", objects}};
  return parse_scene(j.dump(), "cloud.json");
}

RenderResult run(const Scene& s, int width, Accel accel, Precision p = Precision::exact) {
  RenderOptions opt;
  opt.width = width;
  opt.accel = accel;
  opt.precision = p;
  opt.threads = 2;
  return render(s, opt);
}

void expect_same(const RenderResult& a, const RenderResult& b, const std::string& what) {
  const BitDiff d = bit_diff(a.image, b.image);
  EXPECT_TRUE(d.identical()) << what << ": " << d.differing_pixels << " pixels differ, first at ("
                             << d.first_i << ", " << d.first_j << ")";
  EXPECT_TRUE(a.rays == b.rays) << what << ": other rays traced";
}

TEST(Bvh, BuildIsDeterministicAndHoldsEverySphereOnce) {
  const PreparedScene<float> a = prepare<float>(cloud(7, {}), Accel::bvh);
  const PreparedScene<float> b = prepare<float>(cloud(7, {}), Accel::bvh);
  ASSERT_TRUE(a.bvh.active());
  ASSERT_EQ(a.bvh.nodes.size(), b.bvh.nodes.size());
  EXPECT_EQ(0, std::memcmp(a.bvh.nodes.data(), b.bvh.nodes.data(),
                           a.bvh.nodes.size() * sizeof(a.bvh.nodes[0])));
  EXPECT_EQ(a.bvh.id, b.bvh.id);
  // Every sphere in exactly one leaf, inside the box its parent holds for that leaf.
  std::vector<int> seen(std::size_t(a.num_spheres), 0);
  for (const auto& n : a.bvh.nodes)
    for (int k = 0; k < n.arity; ++k)
      for (int j = n.child[k]; n.count[k] >= 0 && j < n.child[k] + n.count[k]; ++j) {
        const std::int32_t id = a.bvh.id[std::size_t(j)];
        ++seen[std::size_t(id)];
        const float r = a.spheres.r[std::size_t(id)];
        EXPECT_LE(n.lo_x[k], a.spheres.cx[std::size_t(id)] - r);
        EXPECT_GE(n.hi_x[k], a.spheres.cx[std::size_t(id)] + r);
        EXPECT_LE(n.lo_y[k], a.spheres.cy[std::size_t(id)] - r);
        EXPECT_GE(n.hi_y[k], a.spheres.cy[std::size_t(id)] + r);
        EXPECT_LE(n.lo_z[k], a.spheres.cz[std::size_t(id)] - r);
        EXPECT_GE(n.hi_z[k], a.spheres.cz[std::size_t(id)] + r);
      }
  for (int c : seen) ASSERT_EQ(c, 1);
  // The leaf copy holds each sphere's own bits, and leaf_of finds it there (the API's hit fields
  // read centres through it).
  ASSERT_EQ(a.bvh.leaf_of.size(), std::size_t(a.num_spheres));
  for (std::size_t j = 0; j < a.bvh.id.size(); ++j) {
    const std::size_t id = std::size_t(a.bvh.id[j]);
    ASSERT_EQ(a.bvh.leaf_of[id], std::int32_t(j));
    EXPECT_EQ(a.bvh.cx[j], a.spheres.cx[id]);
    EXPECT_EQ(a.bvh.cy[j], a.spheres.cy[id]);
    EXPECT_EQ(a.bvh.cz[j], a.spheres.cz[id]);
    EXPECT_EQ(a.bvh.r2[j], a.spheres.r2[id]);
  }
}

// Each wide node's order table (one per direction code) lists every slot once, its children in
// use first: a traversal taking the first `arity` slots of any order visits each child once.
TEST(Bvh, WideNodeOrdersArePermutationsOfTheChildren) {
  CloudOptions o;
  o.spheres = 3000;
  const PreparedScene<float> a = prepare<float>(cloud(11, o), Accel::bvh);
  using H = Bvh<float>;
  ASSERT_TRUE(a.bvh.active());
  for (const auto& n : a.bvh.nodes) {
    ASSERT_GE(n.arity, 2);  // only a one-sphere tree's root has one child
    ASSERT_LE(n.arity, H::kWidth);
    for (int u = 0; u < 8; ++u) {
      unsigned seen = 0;
      for (int p = 0; p < H::kWidth; ++p) {
        const int k = int(unsigned(n.order[u]) >> (H::kOrderBits * p)) & (H::kWidth - 1);
        EXPECT_EQ(p < n.arity, k < n.arity) << "node order " << u << " position " << p;
        seen |= 1u << k;
      }
      EXPECT_EQ(seen, (1u << H::kWidth) - 1);
    }
    for (int k = 0; k < n.arity; ++k) EXPECT_TRUE(n.count[k] < 0 || n.count[k] > 0);
  }
  EXPECT_LE((H::kWidth - 1) * a.bvh.depth + 1, H::kStack);
}

TEST(Bvh, OneSphereAndAutoThreshold) {
  CloudOptions o;
  o.spheres = 1;
  const Scene one = cloud(3, o);
  expect_same(run(one, 1, Accel::none), run(one, 1, Accel::bvh), "1 sphere, reference");
  for (int w : testing::packet_widths())
    expect_same(run(one, 1, Accel::none), run(one, w, Accel::bvh), "1 sphere, packets");
  EXPECT_EQ(resolve_accel(one, Accel::automatic), Accel::none);
  o.spheres = kBvhMinSpheres;
  EXPECT_EQ(resolve_accel(cloud(3, o), Accel::automatic), Accel::bvh);
}

// The reference through the hierarchy against its own plain loop, ray by ray: the same (t, id)
// for random rays from inside and outside the cloud, ties included.
TEST(Bvh, ReferenceClosestHitMatchesThePlainLoop) {
  CloudOptions o;
  o.spheres = 3000;
  o.duplicates = 0.2;
  o.eye_inside = true;
  const Scene s = cloud(11, o);
  const PreparedScene<float> plain = prepare<float>(s, Accel::none);
  const PreparedScene<float> tree = prepare<float>(s, Accel::bvh);
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> u(-1, 1), pos(-20, 20);
  int hits = 0;
  for (int k = 0; k < 20000; ++k) {
    const Vec3<float> origin{pos(rng), pos(rng), pos(rng) - 10};
    const Vec3<float> dir = normalize(Vec3<float>{u(rng), u(rng), u(rng)});
    const auto a = reference::closest_hit(plain, origin, dir);
    const auto b = reference::closest_hit(tree, origin, dir);
    ASSERT_EQ(a.id, b.id) << "ray " << k;
    if (a.id >= 0) {
      ASSERT_EQ(a.t, b.t) << "ray " << k;
    }
    hits += a.id >= 0 && a.id < plain.num_spheres;
  }
  EXPECT_GT(hits, 1000);  // the rays do meet spheres
}

// Packets and the reference through the hierarchy against the plain loop's render, full
// shading (shadows, reflections to depth 3), at every width; float and double.
TEST(Bvh, RendersMatchThePlainLoopOnRandomClouds) {
  for (std::uint64_t seed : {1, 2, 3}) {
    CloudOptions o;
    o.spheres = seed == 1 ? 1000 : seed == 2 ? 4000 : 200;
    o.eye_inside = seed == 3;
    o.duplicates = seed == 2 ? 0.3 : 0.05;
    const Scene s = cloud(seed, o);
    SCOPED_TRACE(seed);
    const RenderResult truth = run(s, 1, Accel::none);
    expect_same(truth, run(s, 1, Accel::bvh), "reference + bvh");
    for (int w : testing::packet_widths()) expect_same(truth, run(s, w, Accel::bvh), "packets");
    const RenderResult dtruth = run(s, 1, Accel::none, Precision::dbl);
    for (int w : packet::supported_widths(Precision::dbl))
      expect_same(dtruth, run(s, w, Accel::bvh, Precision::dbl), "double");
  }
}

// Tens of thousands of spheres: packets + hierarchy against the reference + hierarchy (the plain
// loop's equality is proven above), and the plain loop on the camera rays alone.
TEST(Bvh, SixtyFourThousandSpheres) {
  CloudOptions o;
  o.spheres = 65536;
  o.nx = 40, o.ny = 24;
  const Scene s = cloud(64, o);
  const RenderResult ref = run(s, 1, Accel::bvh);
  EXPECT_EQ(ref.structure.kind, "bvh");
  EXPECT_EQ(ref.structure.spheres, 65536);
  for (int w : testing::packet_widths()) expect_same(ref, run(s, w, Accel::bvh), "packets");
  RenderOptions po;
  po.width = 1, po.accel = Accel::none, po.threads = 2;
  const PrimaryResult plain = render_primary_with_ids(s, po);
  po.width = 0, po.accel = Accel::bvh;
  const PrimaryResult tree = render_primary_with_ids(s, po);
  EXPECT_EQ(plain.t, tree.t);
  EXPECT_EQ(plain.id, tree.id);
}

// Through the hierarchy, camera rays go in square packets (4x4, 4x2, 2x2, 2x1 pixels): each
// pixel's t and id as the reference's plain loop gives them, at every width, float and double,
// with tiles cut by the image's edges (37x23) and by the row ranges of two threads.
TEST(Bvh, SquarePrimaryPacketsMatchThePlainLoop) {
  CloudOptions o;
  o.spheres = 2000;
  o.duplicates = 0.2;
  o.nx = 37, o.ny = 23;
  Scene ortho = cloud(21, o);  // orthographic (no shared eye) and 2x2 sub-samples per pixel
  ortho.camera.type = CameraType::orthographic;
  ortho.supersample = 2;
  for (const Scene& s : {cloud(21, o), ortho})
    for (Precision p : {Precision::exact, Precision::dbl}) {
      RenderOptions po;
      po.precision = p, po.threads = 2;
      po.width = 1, po.accel = Accel::none;
      const PrimaryResult plain = render_primary_with_ids(s, po);
      int hits = 0;
      for (float id : plain.id) hits += id >= 0;
      EXPECT_GT(hits, 100);
      for (int w : testing::packet_widths(p)) {
        po.width = w, po.accel = Accel::bvh;
        const PrimaryResult tree = render_primary_with_ids(s, po);
        EXPECT_EQ(plain.t, tree.t) << "width " << w;
        EXPECT_EQ(plain.id, tree.id) << "width " << w;
      }
    }
}

// Pinhole camera packets walk the hierarchy in groups of tiles as one interval ray (Traversal::
// closest_frustum), whose bounds must hold for every lane's rounded slab values. Each pixel's t
// and id as the plain loop's, at every width, at log-uniform scales (1e-4 to 1e6: the slab
// products' magnitudes) and view directions whose tiles agree in sign on every axis or straddle
// one (a direction component 0: the 2^-64 reciprocal clamp), with duplicate spheres (ties).
TEST(Bvh, CameraGroupsMatchThePlainLoopAtAnyScale) {
  std::mt19937_64 rng(2026);
  const std::array<std::array<double, 3>, 4> directions = {
      {{0.1, -0.05, -1.0}, {0.0, 0.0, -1.0}, {0.7, 0.6, -0.4}, {-0.3, 0.0, -1.0}}};
  for (int round = 0; round < 6; ++round) {
    CloudOptions o;
    o.spheres = 1500;
    o.duplicates = 0.2;
    o.nx = 45, o.ny = 22;
    o.scale = std::pow(10.0, -4.0 + 10.0 * double(rng() >> 11) * 0x1.0p-53);
    o.direction = directions[std::size_t(round) % directions.size()];
    const Scene s = cloud(100 + std::uint64_t(round), o);
    SCOPED_TRACE("scale " + std::to_string(o.scale) + ", direction " +
                 std::to_string(o.direction[0]) + " " + std::to_string(o.direction[1]) + " " +
                 std::to_string(o.direction[2]));
    RenderOptions po;
    po.threads = 2;
    po.width = 1, po.accel = Accel::none;
    const PrimaryResult plain = render_primary_with_ids(s, po);
    int hits = 0;
    for (float id : plain.id) hits += id >= 0 && id < 1500;
    EXPECT_GT(hits, 50);  // the spheres are in view
    for (int w : testing::packet_widths(Precision::exact)) {
      po.width = w, po.accel = Accel::bvh;
      const PrimaryResult tree = render_primary_with_ids(s, po);
      EXPECT_EQ(plain.t, tree.t) << "width " << w;
      EXPECT_EQ(plain.id, tree.id) << "width " << w;
    }
  }
}

// 1200 spheres, a fifth of them repeating another (ties), seen at nx x ny pixels.
CloudOptions tied_cloud(int nx, int ny) {
  CloudOptions o;
  o.spheres = 1200;
  o.duplicates = 0.2;
  o.nx = nx, o.ny = ny;
  return o;
}

// Camera blocks (32x8 pixels at width 16, in four registers of four 4x4 tiles; 8x8 at widths 8
// and 4) cut by the image's edges and by threads' row ranges anywhere: a register whose four
// tiles all lie outside the image (13 columns), single rows of tiles, blocks cut on both
// sides. Each pixel's t and id as the plain loop's.
TEST(Bvh, CameraBlocksCutAnywhereMatchThePlainLoop) {
  const std::array<std::array<int, 2>, 5> sizes = {{{13, 9}, {17, 3}, {33, 17}, {64, 16}, {5, 30}}};
  for (const auto& [nx, ny] : sizes)
    for (int threads : {1, 2}) {
      CloudOptions o = tied_cloud(nx, ny);
      const Scene s = cloud(300 + std::uint64_t(nx), o);
      SCOPED_TRACE(std::to_string(nx) + "x" + std::to_string(ny) + ", " + std::to_string(threads) +
                   " threads");
      RenderOptions po;
      po.threads = threads;
      po.width = 1, po.accel = Accel::none;
      const PrimaryResult plain = render_primary_with_ids(s, po);
      int hits = 0;
      for (float id : plain.id) hits += id >= 0 && id < 1200;
      EXPECT_GT(hits, 0);
      for (int w : testing::packet_widths(Precision::exact)) {
        po.width = w, po.accel = Accel::bvh;
        const PrimaryResult tree = render_primary_with_ids(s, po);
        EXPECT_EQ(plain.t, tree.t) << "width " << w;
        EXPECT_EQ(plain.id, tree.id) << "width " << w;
      }
    }
}

// Full renders take their camera rays' closest hits from the camera blocks, a band of 8 rows at
// a time, and shade them in rows: the plain loop's image and rays at every width, with bands cut
// by the image's edges and by row ranges that start anywhere (mid-band, single rows), in
// reflective and in glass clouds (the ray tree's path), with ties.
TEST(Bvh, FullRendersShadeTheCameraBlocksHits) {
  const std::array<std::array<int, 2>, 4> sizes = {{{13, 9}, {33, 17}, {45, 22}, {70, 11}}};
  for (const auto& [nx, ny] : sizes)
    for (double transmit : {0.0, 0.6}) {
      CloudOptions o = tied_cloud(nx, ny);
      o.transmit = transmit;
      const Scene s = cloud(500 + std::uint64_t(nx), o);
      SCOPED_TRACE(std::to_string(nx) + "x" + std::to_string(ny) + ", transmit " +
                   std::to_string(transmit));
      const RenderResult truth = run(s, 1, Accel::none);
      EXPECT_GT(truth.rays.reflected, 0u);
      if (transmit > 0) {
        EXPECT_GT(truth.rays.refracted, 0u);
      }
      const auto prepared = prepare<float>(s, Accel::bvh);
      ASSERT_TRUE(prepared.bvh.active());
      std::array<int, 6> cuts = {0, 3, 4, 13, 21, ny};  // bands from rows 0, 3, 4, 13, 21
      for (int& c : cuts) c = std::min(c, ny);
      for (int w : testing::packet_widths(Precision::exact)) {
        Image img(nx, ny);
        RayCounts total;
        for (std::size_t c = 0; c + 1 < cuts.size(); ++c) {
          if (cuts[c] >= cuts[c + 1]) continue;
          RayCounts part;
          packet::kernels_for(w)->render_rows(prepared, img, cuts[c], cuts[c + 1], part);
          total += part;
        }
        const BitDiff d = bit_diff(truth.image, img);
        EXPECT_TRUE(d.identical())
            << "width " << w << ": " << d.differing_pixels << " pixels differ, first at ("
            << d.first_i << ", " << d.first_j << ")";
        EXPECT_TRUE(total == truth.rays) << "width " << w << ": other rays traced";
      }
    }
}

// The one-ray walks of expect_one_ray_walks_match below at every packet width of precision T.
template <class T>
void expect_one_ray_walks_match(const Scene& s, const RenderResult& truth, int nx, int ny,
                                int default_lanes = 0) {
  constexpr Precision p = std::is_same_v<T, float> ? Precision::exact : Precision::dbl;
  SCOPED_TRACE(to_string(p));
  auto prepared = prepare<T>(s, Accel::bvh);
  // Below kOneRayMinSpheres (1500 spheres above): packets by default.
  EXPECT_EQ(prepared.walk.one_ray_lanes, default_lanes);
  EXPECT_EQ(prepared.walk.shadow_one_ray_lanes, kOneRayShadowLanes);
  // Every packet apart (spread 0: the one-ray walks everywhere), and the scene's own choice,
  // where packets whose rays stay together walk whole.
  const T built_spread = prepared.bvh.coherent_spread;
  for (const T spread : {T(0), built_spread})
    for (int lanes : {1, 2, 16}) {
      prepared.walk.one_ray_lanes = prepared.walk.shadow_one_ray_lanes = lanes;
      prepared.bvh.coherent_spread = spread;
      for (int w : testing::packet_widths(p)) {
        Image img(nx, ny);
        RayCounts counts;
        if constexpr (std::is_same_v<T, float>)
          packet::kernels_for(w)->render_rows(prepared, img, 0, ny, counts);
        else
          packet::double_kernels(w)->render_rows(prepared, img, 0, ny, counts);
        const BitDiff d = bit_diff(truth.image, img);
        EXPECT_TRUE(d.identical())
            << "width " << w << ", one ray at " << lanes << " lanes, spread " << spread << ": "
            << d.differing_pixels << " pixels differ, first at (" << d.first_i << ", " << d.first_j
            << ")";
        EXPECT_TRUE(counts == truth.rays) << "width " << w << ": other rays traced";
      }
    }
}

// Secondary rays' closest hits and their shadow rays one ray at a time (Bvh::one_ray_lanes,
// shadow_one_ray_lanes: a lane alone below a subtree few lanes enter, or every lane from the
// root): the plain loop's image and rays at every width, float and double, in reflective and
// glass clouds (shadow rays through several transmitting spheres: the product's order) with ties
// (duplicates), the camera inside the cloud, and reflections off a far ground plane (rays from
// beyond the origin limit: padded boxes), at log-uniform scales.
TEST(Bvh, SecondaryRaysOneAtATimeMatchThePlainLoop) {
  std::mt19937_64 rng(77);
  for (int round = 0; round < 4; ++round) {
    CloudOptions o;
    o.spheres = 1500;
    o.duplicates = 0.3;
    o.nx = 40, o.ny = 27;
    o.eye_inside = round == 1;
    o.transmit = round == 2 ? 0.6 : 0.0;
    o.transmit_spread = 0.35;
    if (round == 2) o.radius = 2, o.second_light = true;  // through three glass spheres or more
    o.far_wall = round == 3;
    o.scale = std::pow(10.0, -3.0 + 6.0 * double(rng() >> 11) * 0x1.0p-53);
    const Scene s = cloud(700 + std::uint64_t(round), o);
    SCOPED_TRACE("round " + std::to_string(round) + ", scale " + std::to_string(o.scale));
    // Through glass, the reference's walk of the same hierarchy: shadow rays multiply their
    // transmits in its depth-first order, the plain loop in id order (docs/precision.md).
    const Accel truth_accel = o.transmit > 0 ? Accel::bvh : Accel::none;
    const RenderResult truth = run(s, 1, truth_accel);
    EXPECT_GT(truth.rays.reflected, 100u);
    if (o.transmit > 0) {
      const BitDiff loop = bit_diff(run(s, 1, Accel::none).image, truth.image);
      EXPECT_FALSE(loop.identical()) << "the transmits' order no longer shows in this scene";
    }
    expect_one_ray_walks_match<float>(s, truth, o.nx, o.ny);
    expect_one_ray_walks_match<double>(s, run(s, 1, truth_accel, Precision::dbl), o.nx, o.ny);
  }
}

// Leaves of eight spheres (kLargeLeafMinSpheres and more), whose closest hits one ray at a time
// test a leaf's eight at once where the ISA has AVX2 (one ymm of floats): the plain loop's image,
// with ties inside leaves (duplicates) and leaves of fewer than eight (8197 spheres).
TEST(Bvh, LeavesOfEightOneRayAtATimeMatchThePlainLoop) {
  CloudOptions o;
  o.spheres = kLargeLeafMinSpheres + 5;
  o.duplicates = 0.3;
  o.nx = 40, o.ny = 27;
  const Scene s = cloud(731, o);
  ASSERT_EQ(prepare<float>(s, Accel::bvh).bvh.max_leaf, 8);
  const RenderResult truth = run(s, 1, Accel::none);
  EXPECT_GT(truth.rays.reflected, 100u);
  expect_one_ray_walks_match<float>(s, truth, o.nx, o.ny, kMaxLanes);
}

// The sphere counts from which secondary rays and their shadow rays go one at a time, and the
// band in which clustered packets walk as packets down to where few lanes part (float and double
// alike). The table is written for these constants: change it with them.
static_assert(kOneRayShadowMinSpheres == 1024 && kClusteredMinSpheres == 1024 &&
              kOneRayMinSpheres == 8192 && kClusteredMaxSpheres == 262144);
TEST(Bvh, OneRayThresholdsFollowTheSphereCount) {
  for (const auto& [n, lanes, shadow, clustered] : std::vector<std::tuple<int, int, int, int>>{
           {1023, 0, 0, 0},
           {1024, 0, kOneRayShadowLanes, kClusteredLanes},
           {8191, 0, kOneRayShadowLanes, kClusteredLanes},
           {8192, kMaxLanes, kOneRayShadowLanes, kClusteredLanes}}) {
    CloudOptions o;
    o.spheres = n;
    o.duplicates = 0;
    o.nx = 8, o.ny = 8;
    const Scene s = cloud(900, o);
    const auto f = prepare<float>(s, Accel::bvh);
    const auto d = prepare<double>(s, Accel::bvh);
    EXPECT_EQ(f.walk.one_ray_lanes, lanes) << n << " spheres";
    EXPECT_EQ(f.walk.shadow_one_ray_lanes, shadow) << n << " spheres";
    EXPECT_EQ(d.walk.one_ray_lanes, lanes) << n << " spheres";
    EXPECT_EQ(d.walk.shadow_one_ray_lanes, shadow) << n << " spheres";
    EXPECT_EQ(f.walk.clustered_lanes, clustered) << n << " spheres";
    EXPECT_EQ(d.walk.clustered_lanes, clustered) << n << " spheres";
  }
  // Clustered packets up to kClusteredMaxSpheres (prepare() takes walk_settings as above).
  for (const auto& [n, clustered] : std::vector<std::pair<int, int>>{
           {kClusteredMaxSpheres - 1, kClusteredLanes}, {kClusteredMaxSpheres, kMaxLanes}}) {
    const WalkSettings<float> w = walk_settings<float>(n);
    EXPECT_EQ(w.one_ray_lanes, kMaxLanes) << n << " spheres";
    EXPECT_EQ(w.clustered_lanes, clustered) << n << " spheres";
    EXPECT_EQ(w.shadow_one_ray_lanes, kOneRayShadowLanes) << n << " spheres";
  }
}

// The summary says how the secondary rays walked, as they ran: exact float and double packets by
// the scene's thresholds, the reference as it always does.
TEST(Bvh, SummaryReportsTheSecondaryWalkThatRan) {
  CloudOptions o;
  o.spheres = kOneRayShadowMinSpheres + 100;
  o.nx = 16, o.ny = 8;
  const Scene s = cloud(41, o);
  // Below kOneRayMinSpheres, only clustered packets' lanes go alone, where the packet is wider
  // than the lanes they go alone at.
  auto expected = [](int width) {
    return std::string("closest hits packets") +
           (width > kClusteredLanes
                ? " (one ray alone at 4 lanes or fewer where they leave one leaf box)"
                : "") +
           "; shadow rays packets, one ray alone at 1 lane";
  };
  for (int w : testing::packet_widths(Precision::exact)) {
    const RenderResult r = run(s, w, Accel::bvh);
    EXPECT_EQ(r.structure.one_ray_lanes, 0);
    EXPECT_EQ(r.structure.clustered_lanes, kClusteredLanes);
    EXPECT_EQ(r.structure.shadow_one_ray_lanes, kOneRayShadowLanes);
    EXPECT_EQ(secondary_walk(r.structure, r.width), expected(r.width));
  }
  for (int w : testing::packet_widths(Precision::dbl)) {
    const RenderResult d = run(s, w, Accel::bvh, Precision::dbl);
    EXPECT_EQ(secondary_walk(d.structure, d.width), expected(d.width));
  }
  const RenderResult ref = run(s, 1, Accel::bvh);
  EXPECT_EQ(secondary_walk(ref.structure, ref.width), "one ray at a time (the reference)");
  StructureInfo st;
  st.one_ray_lanes = 2, st.shadow_one_ray_lanes = 16;
  EXPECT_EQ(secondary_walk(st, 16),
            "closest hits packets, one ray alone at 2 lanes or fewer, their walks interleaved (a "
            "packet whole where its rays stay together); shadow rays one ray at a time, 16 walks "
            "interleaved");
  st.one_ray_lanes = kMaxLanes;
  EXPECT_EQ(secondary_walk(st, 8),
            "closest hits one ray at a time, 8 walks interleaved (a packet whole where its rays "
            "stay together); shadow rays one ray at a time, 8 walks interleaved");
  st.clustered_lanes = kClusteredLanes;
  EXPECT_EQ(secondary_walk(st, 16),
            "closest hits one ray at a time, 16 walks interleaved (a packet whole where its rays "
            "stay together, one ray alone at 4 lanes or fewer where they leave one leaf box); "
            "shadow rays one ray at a time, 16 walks interleaved");
  EXPECT_EQ(secondary_walk(st, 4),
            "closest hits one ray at a time, 4 walks interleaved (a packet whole where its rays "
            "stay together); shadow rays one ray at a time, 4 walks interleaved");
}

// lancer bench prepares a scene once and times many frames of it (PreparedRun): each frame, at
// any width, is the image and the hits of a render that prepares for itself, and frames do not
// change one another (the prepared scene is only read).
TEST(Bvh, PreparedRunFramesMatchOneShotRenders) {
  CloudOptions o;
  o.spheres = 3000;
  o.duplicates = 0.2;
  const Scene s = cloud(33, o);
  for (Precision p : {Precision::exact, Precision::dbl}) {
    SCOPED_TRACE(to_string(p));
    RenderOptions opt;
    opt.precision = p, opt.accel = Accel::bvh, opt.threads = 2;
    const PreparedRun prepared(s, opt);
    std::vector<int> widths = testing::packet_widths(p);
    widths.insert(widths.begin(), 1);  // the reference
    for (int w : widths) {
      opt.width = w;
      const RenderResult one = render(s, opt);
      const RenderResult first = prepared.render(w, 2), second = prepared.render(w, 2);
      expect_same(one, first, "first frame, width " + std::to_string(w));
      expect_same(one, second, "second frame, width " + std::to_string(w));
      EXPECT_EQ(first.width, w);
      EXPECT_EQ(first.structure.kind, "bvh");
      // What bench reads without a frame: the frames' structure.
      const StructureInfo st = prepared.structure();
      EXPECT_EQ(st.kind, first.structure.kind);
      EXPECT_EQ(st.nodes, first.structure.nodes);
      EXPECT_EQ(st.bytes, first.structure.bytes);
      EXPECT_EQ(st.build_seconds, first.structure.build_seconds);
      const PrimaryResult hits = render_primary_with_ids(s, opt);
      const PrimaryResult frame = prepared.primary(w, 2, true);
      EXPECT_EQ(hits.t, frame.t) << "width " << w;
      EXPECT_EQ(hits.id, frame.id) << "width " << w;
      EXPECT_TRUE(prepared.primary(w, 2).id.empty());
    }
  }
  RenderOptions bad;
  bad.width = 3;
  EXPECT_THROW(PreparedRun(s, bad), InputError);
}

// The build runs large subtrees as parallel tasks: the same bytes on one thread as on two.
TEST(Bvh, BuildIsTheSameOnAnyThreadCount) {
  CloudOptions o;
  o.spheres = 20000;
  const Scene s = cloud(9, o);
  PreparedScene<float> one, two;
  tbb::task_arena(1).execute([&] { one = prepare<float>(s, Accel::bvh); });
  tbb::task_arena(2).execute([&] { two = prepare<float>(s, Accel::bvh); });
  ASSERT_EQ(one.bvh.nodes.size(), two.bvh.nodes.size());
  EXPECT_EQ(0, std::memcmp(one.bvh.nodes.data(), two.bvh.nodes.data(),
                           one.bvh.nodes.size() * sizeof(one.bvh.nodes[0])));
  EXPECT_EQ(one.bvh.id, two.bvh.id);
  EXPECT_EQ(one.bvh.leaf_of, two.bvh.leaf_of);
  EXPECT_EQ(one.bvh.depth, two.bvh.depth);
}

// The hierarchy's large arrays: 2 MiB aligned, advised as huge pages (THPeligible in smaps,
// where the kernel has transparent huge pages), usable, and freed; small ones are plain.
TEST(HugePages, LargeArraysAreAlignedAndAdvised) {
  const std::size_t n = (kHugePageBytes + 12345) / sizeof(float);
  BigVector<float> big(n, 1.5f);
  const auto at = reinterpret_cast<std::uintptr_t>(big.data());
  EXPECT_EQ(at % kHugePageBytes, 0u) << std::hex << at;
  big.back() = 2.5f;
  EXPECT_EQ(big.front() + big.back(), 4.0f);
  BigVector<Bvh<float>::Node> small(3);
  EXPECT_EQ(reinterpret_cast<std::uintptr_t>(small.data()) % alignof(Bvh<float>::Node), 0u);

  std::ifstream mode("/sys/kernel/mm/transparent_hugepage/enabled");
  std::string modes;
  std::getline(mode, modes);
  if (modes.empty() || modes.find("[never]") != std::string::npos)
    GTEST_SKIP() << "no transparent huge pages here: '" << modes << "'";
  // The mapping holding the array, and its THPeligible line (kernels from 5.0 print it).
  std::ifstream smaps("/proc/self/smaps");
  std::string line, eligible;
  bool inside = false;
  while (std::getline(smaps, line)) {
    unsigned long long lo = 0, hi = 0;
    char dash = 0;
    std::istringstream head(line);
    if (head >> std::hex >> lo >> dash >> hi && dash == '-' && line.find(':') > line.find(' ')) {
      inside = lo <= at && at < hi;
    } else if (inside && line.rfind("THPeligible:", 0) == 0) {
      eligible = line;
    }
  }
  if (eligible.empty()) GTEST_SKIP() << "this kernel's smaps has no THPeligible";
  EXPECT_NE(eligible.find('1'), std::string::npos) << eligible << " (THP: " << modes << ")";
}

// prepare_pages: a std::vector's reserved buffer is resident before anything writes it (one
// MADV_POPULATE_WRITE call instead of a fault per page).
TEST(HugePages, PreparedPagesArePresentBeforeTheFirstWrite) {
  const std::size_t n = 3 * kHugePageBytes / sizeof(float);
  std::vector<float> v;
  v.reserve(n);
  prepare_pages(v.data(), n * sizeof(float));
  const auto page = std::uintptr_t(sysconf(_SC_PAGESIZE));
  const std::uintptr_t lo = reinterpret_cast<std::uintptr_t>(v.data()) / page * page;
  const std::uintptr_t hi =
      (reinterpret_cast<std::uintptr_t>(v.data() + n) + page - 1) / page * page;
  std::vector<unsigned char> in(std::size_t((hi - lo) / page));
  ASSERT_EQ(0, mincore(reinterpret_cast<void*>(lo), hi - lo, in.data()));
  std::size_t resident = 0;
  for (const unsigned char c : in) resident += c & 1u;
  if (resident < in.size()) {  // a kernel before 5.14 (or an emulator) ignores the call
    void* probe = mmap(nullptr, page, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
    ASSERT_NE(probe, MAP_FAILED);
    unsigned char there = 0;
    const bool honoured = madvise(probe, page, MADV_POPULATE_WRITE) == 0 &&
                          mincore(probe, page, &there) == 0 && (there & 1u);
    munmap(probe, page);
    if (!honoured) GTEST_SKIP() << "MADV_POPULATE_WRITE not honoured here";
  }
  EXPECT_EQ(resident, in.size()) << "pages of " << in.size() << " resident";
}

}  // namespace
}  // namespace lancer
