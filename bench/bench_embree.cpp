// Google Benchmark cases for the Embree peer (include/lancer/peer.hpp), beside lancer's own:
//   primary/<scene>/w<width>/embree   camera rays, rtcIntersect<width>
//   full/<scene>/w<width>/embree      every ray of lancer's render (camera, shadow, mirror), no
//                                     shading: rtcIntersect<width> + rtcOccluded<width>
//   ao/<scene>/w<width>/embree       bench's ao and diffuse ray sets (lancer/ray_sets.hpp):
//   diffuse/<scene>/w<width>/embree  rtcOccluded / rtcIntersect<width>, or 1M streams
// items/s is rays per second, single thread, as in lancer's cases; the label is "embree".
// Embree's scene (its BVH) is built on a case's first run, outside the timed loop.
// LANCER_EMBREE_PLANES=quad models planes as large quads instead of exact user geometry.
//
//   build/bench/lancer_bench --benchmark_filter='primary/lorenzi-reflections'
#include <benchmark/benchmark.h>

#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "lancer/lancer.hpp"
#include "lancer/packet/api.hpp"
#include "lancer/peer.hpp"
#include "lancer/ray_sets.hpp"
#include "lancer/scene.hpp"

namespace {

using namespace lancer;

// One scene in one Embree setup (peer::embree_setups: the setups lancer bench tries).
struct EmbreeCase {
  const Scene* scene;
  peer::EmbreeConfig how;
  std::unique_ptr<peer::EmbreeScene> embree;  // built on first use

  const peer::EmbreeScene& get() {
    if (!embree)
      embree = std::make_unique<peer::EmbreeScene>(*scene, peer::plane_mode_from_env(), "", how);
    return *embree;
  }
};

// "user-spheres-high-tiles": a setup as a benchmark name's last part.
std::string slug(const peer::EmbreeConfig& how) {
  std::string s = !how.name_spheres  ? "shapes"
                  : how.user_spheres ? "user-spheres"
                                     : "sphere-points";
  if (how.high_quality) s += "-high";
  if (how.tiles) s += "-tiles";
  if (how.streams) s += "-streams";
  if (how.compact) s += "-compact";
  if (how.robust) s += "-robust";
  if (how.curves) s += "-curves";
  return s;
}

void embree_primary(benchmark::State& state, EmbreeCase* c, int width) {
  const peer::EmbreeScene& e = c->get();
  std::uint64_t rays = 0;
  for (auto _ : state) {
    const PrimaryResult r = e.primary(width, 1);
    benchmark::DoNotOptimize(r.t.data());
    rays += r.rays.total();
  }
  state.SetItemsProcessed(static_cast<int64_t>(rays));
  state.SetLabel("embree: " + c->how.name());
}

void embree_full(benchmark::State& state, EmbreeCase* c, int width) {
  const peer::EmbreeScene& e = c->get();
  std::uint64_t rays = 0;
  for (auto _ : state) {
    const peer::EmbreeScene::RaysResult r = e.trace_all(width, 1);
    rays += r.rays.total();
  }
  state.SetItemsProcessed(static_cast<int64_t>(rays));
  state.SetLabel("embree: " + c->how.name());
}

// A ray set, made (from the library API's camera hits, exact) and moved into the peer's frame
// on the case's first run.
struct EmbreeRaysCase {
  EmbreeCase* scene;
  rays::Kind kind;
  std::shared_ptr<const peer::EmbreeScene::Rays> rays;
  std::size_t count = 0;
};

void embree_rays(benchmark::State& state, EmbreeRaysCase* c, int width) {
  const peer::EmbreeScene& e = c->scene->get();
  if (!c->rays) {
    api::Options opt;
    opt.precision = Precision::exact;
    opt.threads = 1;
    const api::Scene s = api::Scene::from_description(*c->scene->scene, opt);
    const rays::RaySet set = rays::make_set(s, c->kind);
    c->rays = e.load_rays(set);
    c->count = set.size();
  }
  for (auto _ : state) e.trace_rays(*c->rays, width, 1, nullptr);
  state.SetItemsProcessed(static_cast<int64_t>(c->count * state.iterations()));
  state.SetLabel("embree: " + c->scene->how.name());
}

}  // namespace

// Registers the Embree cases of one scene file; nothing when lancer was built without Embree.
void register_embree_benchmarks(const std::string& scene_path) {
  if (!peer::embree_available()) return;
  static std::vector<std::unique_ptr<Scene>> scenes;
  static std::vector<std::unique_ptr<EmbreeCase>> cases;
  static std::vector<std::unique_ptr<EmbreeRaysCase>> ray_cases;
  scenes.push_back(std::make_unique<Scene>(load_scene(scene_path)));
  const std::string name = std::filesystem::path(scene_path).stem().string();
  for (const peer::EmbreeConfig& how : peer::embree_setups({scenes.back().get()})) {
    cases.push_back(std::make_unique<EmbreeCase>(EmbreeCase{scenes.back().get(), how, nullptr}));
    EmbreeCase* c = cases.back().get();
    EmbreeRaysCase* sets[2] = {nullptr, nullptr};
    if (!how.tiles)  // square packets are for camera rays
      for (int k = 0; k < 2; ++k) {
        ray_cases.push_back(std::make_unique<EmbreeRaysCase>(
            EmbreeRaysCase{c, k == 0 ? rays::Kind::ao : rays::Kind::diffuse, nullptr, 0}));
        sets[k] = ray_cases.back().get();
      }
    for (int width : peer::embree_widths(packet::supported_widths())) {
      const std::string w = "/w" + std::to_string(width);
      if (how.tiles && width == 1) continue;  // square packets: widths 4, 8 and 16
      const std::string tail = "/embree/" + slug(how);
      benchmark::RegisterBenchmark(("primary/" + name + w + tail).c_str(), embree_primary, c, width)
          ->UseRealTime()
          ->Unit(benchmark::kMicrosecond);
      for (EmbreeRaysCase* r : sets)
        if (r && (!how.streams || width == 1))  // a stream is one call whatever the width
          benchmark::RegisterBenchmark(
              (std::string(rays::to_string(r->kind)) + "/" + name + w + tail).c_str(), embree_rays,
              r, width)
              ->UseRealTime()
              ->Unit(benchmark::kMicrosecond);
      if (how.tiles || how.streams) continue;  // camera rays only
      benchmark::RegisterBenchmark(("full/" + name + w + tail).c_str(), embree_full, c, width)
          ->UseRealTime()
          ->Unit(benchmark::kMicrosecond);
    }
  }
}
