// The library API's one-ray queries against Embree's: api::Scene::intersect<1> / occluded<1>
// on the one-ray kernels (packet/one_ray.hpp) and on the reference (Options::width 1), beside
// rtcIntersect1 / rtcOccluded1 (sphere points and user spheres), on the same seeded incoherent
// rays, one thread, the sides interleaved round by round. Prints per side the median Mrays/s
// and the spread (min .. max) over the rounds, timed by the thread's CPU clock.
//
//   build/bench/lancer_one_ray_bench --spheres 65536 [--seed 1] [--rays 200000] [--rounds 9]
//                                    [--precision double] [--only one-ray|reference|embree]
//                                    [--rays-from box|hits]
//   build/bench/lancer_one_ray_bench --scene scenes/lorenzi-shadows.json
//
// Rays: closest hit, from uniform points in the spheres' bounding box along uniform random
// directions (tnear 0, tfar infinity); occlusion, segments between two such points (tfar their
// distance). --rays-from hits: 4 cosine directions from each camera hit (every 4th pixel, then
// the others), occlusion out to a tenth of the scene's size. LANCER_MAX_WIDTH=8 runs the AVX2
// one-ray kernels on an AVX-512 machine.
#include <time.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "lancer/generate.hpp"
#include "lancer/lancer.hpp"
#include "lancer/peer.hpp"
#include "lancer/prepared.hpp"
#include "lancer/scene.hpp"

namespace {

using namespace lancer;

// The calling thread's CPU time: the sides run one after another in this thread, and another
// process taking the core (a shared machine) does not count against whichever side is running.
double cpu_seconds() {
  timespec t;
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return double(t.tv_sec) + 1e-9 * double(t.tv_nsec);
}

struct WorldRay {
  Vec3<double> o, d;
  float tfar;
};

std::vector<WorldRay> make_rays(const Scene& s, std::size_t n, bool segments, std::uint64_t seed) {
  Vec3<double> lo{1e300, 1e300, 1e300}, hi{-1e300, -1e300, -1e300};
  for (const Sphere& sp : s.spheres) {
    lo = {std::min(lo.x, sp.center.x - sp.radius), std::min(lo.y, sp.center.y - sp.radius),
          std::min(lo.z, sp.center.z - sp.radius)};
    hi = {std::max(hi.x, sp.center.x + sp.radius), std::max(hi.y, sp.center.y + sp.radius),
          std::max(hi.z, sp.center.z + sp.radius)};
  }
  std::mt19937_64 g(seed);
  std::uniform_real_distribution<double> u(0, 1);
  auto point = [&] {
    return Vec3<double>{lo.x + (hi.x - lo.x) * u(g), lo.y + (hi.y - lo.y) * u(g),
                        lo.z + (hi.z - lo.z) * u(g)};
  };
  std::normal_distribution<double> nd;
  std::vector<WorldRay> rays(n);
  for (WorldRay& r : rays) {
    // Rounded to float first: the direction sent is then unit within float's rounding.
    const Vec3<double> o = point();
    r.o = {double(float(o.x)), double(float(o.y)), double(float(o.z))};
    Vec3<double> d;
    if (segments) {
      d = point() - r.o;
      r.tfar = float(length(d));
    } else {
      do d = {nd(g), nd(g), nd(g)};
      while (length(d) < 1e-3);
      r.tfar = std::numeric_limits<float>::infinity();
    }
    d = normalize(d);
    r.d = {double(float(d.x)), double(float(d.y)), double(float(d.z))};
  }
  return rays;
}

// Rays leaving the camera's hits (every 4th pixel, one sample), 4 cosine-distributed
// directions about each hit's normal on the side the camera sees, from the hit point moved
// 1e-3 off the surface: incoherent secondary rays. Occlusion: the same rays, as ambient
// occlusion's, out to a tenth of the scene's size.
std::vector<WorldRay> hit_rays(const api::Scene& s, std::size_t n, bool occlusion,
                               std::uint64_t seed) {
  std::mt19937_64 g(seed);
  std::uniform_real_distribution<double> u(0, 1);
  const api::Info& in = s.info();
  std::vector<WorldRay> rays;
  Vec3<double> lo{1e300, 1e300, 1e300}, hi{-1e300, -1e300, -1e300};
  for (const Sphere& sp : s.description().spheres) {
    lo = {std::min(lo.x, sp.center.x - sp.radius), std::min(lo.y, sp.center.y - sp.radius),
          std::min(lo.z, sp.center.z - sp.radius)};
    hi = {std::max(hi.x, sp.center.x + sp.radius), std::max(hi.y, sp.center.y + sp.radius),
          std::max(hi.z, sp.center.z + sp.radius)};
  }
  const double reach = length(hi - lo);
  for (int pass = 0; rays.size() < n && pass < 16; ++pass)
    for (int j = pass % 4; j < in.ny && rays.size() < n; j += 4)
      for (int i = pass / 4; i < in.nx && rays.size() < n; i += 4) {
        api::Ray1 r;
        api::Hit1 h;
        float co[3], cd[3];
        s.camera_ray(i, j, 0, 0, co, cd);
        r.org_x[0] = co[0], r.org_y[0] = co[1], r.org_z[0] = co[2];
        r.dir_x[0] = cd[0], r.dir_y[0] = cd[1], r.dir_z[0] = cd[2];
        r.tnear[0] = 0, r.tfar[0] = std::numeric_limits<float>::infinity();
        r.mask[0] = api::kAllObjects;
        s.intersect(nullptr, r, h);
        if (h.id[0] < 0) continue;
        const Vec3<double> d{r.dir_x[0], r.dir_y[0], r.dir_z[0]};
        Vec3<double> nrm{h.ng_x[0], h.ng_y[0], h.ng_z[0]};
        if (dot(d, nrm) > 0) nrm = -nrm;
        const Vec3<double> p =
            Vec3<double>{r.org_x[0], r.org_y[0], r.org_z[0]} + d * double(h.t[0]) + nrm * 1e-3;
        const Vec3<double> a =
            std::fabs(nrm.x) > 0.5 ? Vec3<double>{0, 1, 0} : Vec3<double>{1, 0, 0};
        const Vec3<double> t1 = normalize(cross(nrm, a)), t2 = cross(nrm, t1);
        for (int k = 0; k < 4 && rays.size() < n; ++k) {
          const double r2 = u(g), phi = 2 * 3.141592653589793 * u(g), rr = std::sqrt(r2);
          const Vec3<double> dir = normalize(t1 * (rr * std::cos(phi)) + t2 * (rr * std::sin(phi)) +
                                             nrm * std::sqrt(1 - r2));
          WorldRay w;
          w.o = {double(float(p.x)), double(float(p.y)), double(float(p.z))};
          w.d = {double(float(dir.x)), double(float(dir.y)), double(float(dir.z))};
          w.tfar = occlusion ? float(0.1 * reach) : std::numeric_limits<float>::infinity();
          rays.push_back(w);
        }
      }
  return rays;
}

// One round of api queries: seconds and what was found (hits or blocked rays).
double api_round(const api::Scene& s, const std::vector<WorldRay>& rays, bool occluded,
                 std::size_t& found) {
  api::Ray1 r;
  api::Hit1 h;
  std::size_t count = 0;
  const double start = cpu_seconds();
  for (const WorldRay& w : rays) {
    r.org_x[0] = float(w.o.x), r.org_y[0] = float(w.o.y), r.org_z[0] = float(w.o.z);
    r.dir_x[0] = float(w.d.x), r.dir_y[0] = float(w.d.y), r.dir_z[0] = float(w.d.z);
    r.tnear[0] = 0, r.tfar[0] = w.tfar, r.mask[0] = api::kAllObjects;
    if (occluded) {
      int blocked;
      s.occluded(nullptr, r, &blocked);
      count += blocked != 0;
    } else {
      s.intersect(nullptr, r, h);
      count += h.id[0] >= 0;
    }
  }
  found = count;
  return cpu_seconds() - start;
}

struct Side {
  std::string name;
  std::vector<double> mrays;
  std::size_t found = 0;
};

void report(const char* query, std::vector<Side>& sides) {
  std::printf("%s\n", query);
  for (Side& s : sides) {
    if (s.mrays.empty()) continue;
    std::sort(s.mrays.begin(), s.mrays.end());
    const double med = s.mrays[s.mrays.size() / 2];
    std::printf("  %-34s median %7.2f Mrays/s  (%.2f .. %.2f)  found %zu\n", s.name.c_str(), med,
                s.mrays.front(), s.mrays.back(), s.found);
  }
}

int run(int argc, char** argv) {
  long long spheres = 0;
  std::uint64_t seed = 1;
  std::size_t n = 200000;
  int rounds = 9;
  std::string scene_path, only, kind = "box";
  Precision precision = Precision::exact;
  for (int k = 1; k + 1 < argc; k += 2) {
    const std::string a = argv[k], v = argv[k + 1];
    if (a == "--spheres")
      spheres = std::atoll(v.c_str());
    else if (a == "--seed")
      seed = std::strtoull(v.c_str(), nullptr, 10);
    else if (a == "--rays")
      n = std::size_t(std::atoll(v.c_str()));
    else if (a == "--rounds")
      rounds = std::atoi(v.c_str());
    else if (a == "--scene")
      scene_path = v;
    else if (a == "--precision")  // exact (float, the default) or double
      precision = parse_precision(v, "--precision");
    else if (a == "--rays-from")  // box (the default) or hits (the camera's hits)
      kind = v;
    else if (a == "--only")  // one side alone (for a profiler): one-ray, reference or embree
      only = v;
    else
      throw InputError("one_ray_bench: unknown option " + a);
  }
  if (argc % 2 == 0) throw InputError("one_ray_bench: an option without its value");
  if (kind != "box" && kind != "hits")
    throw InputError("one_ray_bench: --rays-from must be box or hits, not '" + kind + "'");
  Scene scene;
  if (!scene_path.empty()) {
    scene = load_scene(scene_path);
  } else {
    generate::Options g;
    g.spheres = spheres > 0 ? spheres : 1024;
    g.seed = seed;
    scene = parse_scene(generate::scene_json(g), "generated");
  }
  auto make = [&](int width) {
    api::Options o;
    o.precision = precision;
    o.width = width;
    o.threads = 1;
    return api::Scene::from_description(scene, o);
  };
  const api::Scene fast = make(0), ref = make(1);
  std::printf(
      "%zu spheres, %zu planes, %s; one-ray path: %s (reference side: %s); %zu rays a round\n",
      scene.spheres.size(), scene.planes.size(), to_string(precision), fast.info().one_ray.c_str(),
      ref.info().one_ray.c_str(), n);
  const Frame frame = prepare<float>(scene).frame;
  std::vector<std::unique_ptr<peer::EmbreeScene>> embree;
  std::vector<std::string> embree_names;
  // Embree on the ISA lancer's kernels are held to (LANCER_MAX_WIDTH=8: AVX2).
  const char* cap = std::getenv("LANCER_MAX_WIDTH");
  const std::string config = cap && std::string(cap) == "8" ? "isa=avx2,threads=1" : "threads=1";
  if (peer::embree_available())
    for (const bool user : {false, true}) {
      peer::EmbreeConfig how;
      how.user_spheres = user;
      embree.push_back(
          std::make_unique<peer::EmbreeScene>(scene, peer::PlaneMode::user, config, how));
      embree_names.push_back("embree " + how.name() + " (" + config + ")");
    }
  for (const bool occluded : {false, true}) {
    const std::vector<WorldRay> rays = kind == "hits"
                                           ? hit_rays(ref, n, occluded, seed * 7 + occluded)
                                           : make_rays(scene, n, occluded, seed * 7 + occluded);
    n = rays.size();
    // Embree's rays in the prepared frame, where its scene lies (peer.hpp).
    std::vector<float> prepared(8 * n);
    for (std::size_t i = 0; i < n; ++i) {
      const Vec3<double> o = frame.point(rays[i].o), d = frame.direction(rays[i].d);
      const float v[8] = {float(o.x), float(o.y), float(o.z), float(d.x),
                          float(d.y), float(d.z), 0.0f,       rays[i].tfar};
      std::copy(v, v + 8, prepared.begin() + std::ptrdiff_t(8 * i));
    }
    std::vector<Side> sides{{"lancer one-ray (" + fast.info().one_ray + ")", {}, 0},
                            {"lancer reference (width 1)", {}, 0}};
    for (const std::string& e : embree_names) sides.push_back({e, {}, 0});
    auto runs = [&](const char* side) { return only.empty() || only == side; };
    for (int round = 0; round < rounds; ++round) {
      if (runs("one-ray"))
        sides[0].mrays.push_back(1e-6 * double(n) /
                                 api_round(fast, rays, occluded, sides[0].found));
      if (runs("reference"))
        sides[1].mrays.push_back(1e-6 * double(n) / api_round(ref, rays, occluded, sides[1].found));
      for (std::size_t e = 0; e < embree.size() && runs("embree"); ++e) {
        const double start = cpu_seconds();
        embree[e]->one_rays(prepared.data(), n, occluded, sides[2 + e].found);
        sides[2 + e].mrays.push_back(1e-6 * double(n) / (cpu_seconds() - start));
      }
    }
    report(occluded ? "occluded<1> / rtcOccluded1" : "intersect<1> / rtcIntersect1", sides);
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    return run(argc, argv);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "%s\n", e.what());
    return 2;
  }
}
