// Google Benchmark cases: rays per second (items/s) for every scene in scenes/, every width this
// CPU runs (1 = the scalar reference) and both modes, plus what modelling only what a scene
// requires saves (the same renders with every term forced on), and the library API's closest
// hits of 16-ray packets: camera rays in 4x4 tiles, and the mirror reflections of their hits;
// and bench's ao and diffuse ray sets through the library API at widths 1, 4, 8 and 16.
//
//   build/bench/lancer_bench --benchmark_filter=reflections --benchmark_repetitions=5
//   build/bench/lancer_bench --scene=my.json      (or LANCER_BENCH_SCENE=a.json:b.json): your
//                                                  own scenes instead of scenes/
#include <benchmark/benchmark.h>

#include <algorithm>
#include <array>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "lancer/lancer.hpp"
#include "lancer/packet/api.hpp"
#include "lancer/profile.hpp"
#include "lancer/ray_sets.hpp"
#include "lancer/render.hpp"
#include "lancer/scene.hpp"
#include "lancer/vec3.hpp"

namespace {

using namespace lancer;

void full(benchmark::State& state, const Scene* scene, int width, bool everything) {
  RenderOptions opt;
  opt.width = width;
  opt.threads = 1;
  opt.model_everything = everything;
  // Prepared once, untimed, as the Embree cases' scene: each iteration is one frame.
  const PreparedRun prepared(*scene, opt);
  std::uint64_t rays = 0;
  for (auto _ : state) {
    const RenderResult r = prepared.render(width, opt.threads);
    benchmark::DoNotOptimize(r.image.rgb.data());
    rays += r.rays.total();
  }
  state.SetItemsProcessed(static_cast<int64_t>(rays));
  state.SetLabel(packet::isa_name(width));
}

void primary(benchmark::State& state, const Scene* scene, int width) {
  RenderOptions opt;
  opt.width = width;
  opt.threads = 1;
  const PreparedRun prepared(*scene, opt);
  std::uint64_t rays = 0;
  for (auto _ : state) {
    const PrimaryResult r = prepared.primary(width, opt.threads);
    benchmark::DoNotOptimize(r.t.data());
    rays += r.rays.total();
  }
  state.SetItemsProcessed(static_cast<int64_t>(rays));
  state.SetLabel(packet::isa_name(width));
}

// The profiled kernels (lancer profile): what instrumentation would cost if render used them.
void profiled(benchmark::State& state, const Scene* scene, int width) {
  std::uint64_t rays = 0;
  for (auto _ : state) {
    const ProfileResult r = profile_render(*scene, width);
    rays += r.camera_rays + r.shadow_rays + r.reflected_rays;
  }
  state.SetItemsProcessed(static_cast<int64_t>(rays));
  state.SetLabel(packet::isa_name(width) + " profiled");
}

// The library API's intersect<16> over packets made once, at registration: every camera ray of
// the image in 4x4 tiles (coherent), or, reflections = true, each hit's mirror reflection (rays
// from points on the objects; a cloud's diverge, a flat mirror's stay together). docs/api.md.
struct ApiPackets {
  std::unique_ptr<api::Scene> scene;
  std::vector<api::Ray16> rays;
  std::vector<std::array<int, 16>> valid;
  std::uint64_t lanes = 0;  // valid rays over all packets
};

std::unique_ptr<ApiPackets> api_packets(const Scene* scene, bool reflections) {
  api::Options opt;
  opt.precision = Precision::exact;
  auto out = std::make_unique<ApiPackets>();
  out->scene = std::make_unique<api::Scene>(api::Scene::from_description(*scene, opt));
  const api::Scene& s = *out->scene;
  const api::Info& in = s.info();
  for (int j0 = 0; j0 + 4 <= in.ny; j0 += 4)
    for (int i0 = 0; i0 + 4 <= in.nx; i0 += 4) {
      api::Ray16 r;
      for (int k = 0; k < 16; ++k) {
        float o[3], d[3];
        s.camera_ray(i0 + k % 4, j0 + k / 4, 0, 0, o, d);
        r.org_x[k] = o[0], r.org_y[k] = o[1], r.org_z[k] = o[2];
        r.dir_x[k] = d[0], r.dir_y[k] = d[1], r.dir_z[k] = d[2];
        r.tfar[k] = std::numeric_limits<float>::infinity();
        r.tnear[k] = 0, r.mask[k] = api::kAllObjects;
      }
      std::array<int, 16> v;
      v.fill(-1);
      if (reflections) {
        api::Hit16 h;
        s.intersect(nullptr, r, h);
        for (int k = 0; k < 16; ++k) {
          v[k] = h.id[k] >= 0 ? -1 : 0;
          if (!v[k]) continue;
          const Vec3<float> o{r.org_x[k], r.org_y[k], r.org_z[k]};
          const Vec3<float> d{r.dir_x[k], r.dir_y[k], r.dir_z[k]};
          const Vec3<float> n{h.ng_x[k], h.ng_y[k], h.ng_z[k]};
          // Off the surface on the side the ray came from, well beyond the scene's epsilon.
          const Vec3<float> p = along(o, d, h.t[k]) + n * (dot(d, n) < 0 ? 1e-3f : -1e-3f);
          const Vec3<float> m = normalize(reflect(d, n));
          r.org_x[k] = p.x, r.org_y[k] = p.y, r.org_z[k] = p.z;
          r.dir_x[k] = m.x, r.dir_y[k] = m.y, r.dir_z[k] = m.z;
        }
      }
      for (int x : v) out->lanes += x != 0;
      out->rays.push_back(r);
      out->valid.push_back(v);
    }
  return out;
}

void api_intersect(benchmark::State& state, const ApiPackets* packets) {
  const api::Scene& s = *packets->scene;
  api::Hit16 h;
  for (auto _ : state)
    for (std::size_t p = 0; p < packets->rays.size(); ++p) {
      s.intersect(packets->valid[p].data(), packets->rays[p], h);
      benchmark::DoNotOptimize(h.t);
    }
  state.SetItemsProcessed(static_cast<int64_t>(packets->lanes * state.iterations()));
  state.SetLabel(s.info().isa);
}

// bench's ao and diffuse modes (lancer/ray_sets.hpp) through the library API: the set and its
// packets of `width` made on the case's first run, outside the timed loop; each iteration
// traces the whole set with occluded<width> or intersect<width>, as a user calls them.
// The library's scene as the ray-set cases trace it: exact, one thread.
api::Scene exact_one_thread(const Scene& scene) {
  api::Options opt;
  opt.precision = Precision::exact;
  opt.threads = 1;
  return api::Scene::from_description(scene, opt);
}

struct RaySetCase {
  const Scene* scene;
  rays::Kind kind;
  int width;
  std::unique_ptr<api::Scene> api;
  std::unique_ptr<rays::ApiPackets> packets;
};

void ray_set(benchmark::State& state, RaySetCase* c) {
  if (!c->packets) {
    c->api = std::make_unique<api::Scene>(exact_one_thread(*c->scene));
    c->packets = std::make_unique<rays::ApiPackets>(rays::make_set(*c->api, c->kind), c->width);
  }
  for (auto _ : state) c->packets->trace(*c->api, 1);
  state.SetItemsProcessed(static_cast<int64_t>(c->packets->rays() * state.iterations()));
  state.SetLabel(rays::api_isa(*c->api, c->width));
}

// The same sets straight into the packet kernels (rays::KernelPackets: the rays moved into the
// prepared frame beforehand, as the Embree peer gets them): what the library API's per-call work
// costs on top, read against ao/<scene>/w<N>. Packet widths only.
struct RaySetKernelCase {
  const Scene* scene;
  rays::Kind kind;
  int width;
  std::unique_ptr<rays::KernelPackets> packets;
};

void ray_set_kernel(benchmark::State& state, RaySetKernelCase* c) {
  if (!c->packets) {
    const api::Scene s = exact_one_thread(*c->scene);
    c->packets = std::make_unique<rays::KernelPackets>(
        rays::KernelPackets::prepare(*c->scene, Precision::exact), rays::make_set(s, c->kind),
        c->width);
  }
  for (auto _ : state) c->packets->trace(1);
  state.SetItemsProcessed(static_cast<int64_t>(c->packets->rays() * state.iterations()));
  state.SetLabel(packet::isa_name(c->width) + " kernels, prepared frame");
}

}  // namespace

#ifdef LANCER_WITH_EMBREE_BENCH
void register_embree_benchmarks(const std::string& scene_path);
#endif

// The scenes to time: --scene=PATH (repeatable, taken out of argv before Google Benchmark parses
// it), else LANCER_BENCH_SCENE (paths separated by ':'), else every scene in scenes/.
std::vector<std::string> scene_paths(int& argc, char** argv) {
  std::vector<std::string> paths;
  int kept = 1;
  for (int k = 1; k < argc; ++k) {
    const std::string arg = argv[k];
    if (arg.rfind("--scene=", 0) == 0)
      paths.push_back(arg.substr(8));
    else
      argv[kept++] = argv[k];
  }
  argc = kept;
  if (paths.empty())
    if (const char* env = std::getenv("LANCER_BENCH_SCENE")) {
      std::string list = env;
      for (std::size_t start = 0; start <= list.size();) {
        const std::size_t end = std::min(list.find(':', start), list.size());
        if (end > start) paths.push_back(list.substr(start, end - start));
        start = end + 1;
      }
    }
  if (paths.empty()) {
    for (const auto& e : std::filesystem::directory_iterator(LANCER_SOURCE_DIR "/scenes"))
      if (e.path().extension() == ".json") paths.push_back(e.path().string());
    std::sort(paths.begin(), paths.end());
  }
  return paths;
}

// Every case is timed by the wall clock (UseRealTime): renders and the peer run on TBB's worker
// threads, whose CPU time the main thread's clock does not see. Times in microseconds, so that
// sub-millisecond frames keep their digits.
benchmark::internal::Benchmark* timed(benchmark::internal::Benchmark* b) {
  return b->UseRealTime()->Unit(benchmark::kMicrosecond);
}

int main(int argc, char** argv) {
  static std::vector<std::unique_ptr<Scene>> scenes;
  static std::vector<std::unique_ptr<ApiPackets>> packets;
  static std::vector<std::unique_ptr<RaySetCase>> ray_sets;
  static std::vector<std::unique_ptr<RaySetKernelCase>> ray_kernels;
  const std::vector<std::string> paths = scene_paths(argc, argv);
  for (const std::string& path : paths) {
    try {
      scenes.push_back(std::make_unique<Scene>(load_scene(path)));
    } catch (const std::exception& e) {
      std::fprintf(stderr, "lancer_bench: %s\n", e.what());
      return 2;
    }
    const Scene* s = scenes.back().get();
    const std::string name = std::filesystem::path(path).stem().string();
    const std::vector<int> widths = packet::supported_widths();
    const int widest = *std::max_element(widths.begin(), widths.end());
    for (int width : widths) {
      const std::string w = "/w" + std::to_string(width);
      timed(benchmark::RegisterBenchmark(("primary/" + name + w).c_str(), primary, s, width));
      timed(benchmark::RegisterBenchmark(("full/" + name + w).c_str(), full, s, width, false));
      if (width != widest) continue;
      // The same render computing every term: the difference is what pruning saves. And the
      // profiled kernels' cost. At the widest width only: the other widths tell nothing more.
      timed(benchmark::RegisterBenchmark(("full_everything/" + name + w).c_str(), full, s, width,
                                         true));
      timed(
          benchmark::RegisterBenchmark(("full_profiled/" + name + w).c_str(), profiled, s, width));
    }
    for (const bool reflections : {false, true}) {
      // A case that would trace nothing (no hit to reflect, e.g. a scene of planes seen edge-on)
      // is not registered: it would report 0 items/s from a loop that measures nothing.
      packets.push_back(api_packets(s, reflections));
      if (packets.back()->lanes == 0) continue;
      timed(benchmark::RegisterBenchmark(
          ("api_intersect16/" + name + (reflections ? "/reflections" : "/camera_tiles")).c_str(),
          api_intersect, packets.back().get()));
    }
    for (const rays::Kind kind : {rays::Kind::ao, rays::Kind::diffuse})
      for (const int width : {1, 4, 8, 16}) {
        if (width > 1 && std::find(widths.begin(), widths.end(), width) == widths.end()) continue;
        ray_sets.push_back(
            std::make_unique<RaySetCase>(RaySetCase{s, kind, width, nullptr, nullptr}));
        timed(benchmark::RegisterBenchmark(
            (std::string(rays::to_string(kind)) + "/" + name + "/w" + std::to_string(width))
                .c_str(),
            ray_set, ray_sets.back().get()));
        // The kernels alone: float packets of spheres and planes (shapes run on the reference).
        if (width == 1 || !s->shapes.empty()) continue;
        ray_kernels.push_back(std::make_unique<RaySetKernelCase>());
        RaySetKernelCase* k = ray_kernels.back().get();
        k->scene = s, k->kind = kind, k->width = width;
        timed(benchmark::RegisterBenchmark(
            (std::string(rays::to_string(kind)) + "_kernel/" + name + "/w" + std::to_string(width))
                .c_str(),
            ray_set_kernel, k));
      }
#ifdef LANCER_WITH_EMBREE_BENCH
    register_embree_benchmarks(path);
#endif
  }
  // 0.1 s per case unless --benchmark_min_time says otherwise (Google Benchmark's 0.5 s made
  // --benchmark_filter=reflections, 63 cases, take 100 s).
  std::vector<char*> args(argv, argv + argc);
  static char min_time[] = "--benchmark_min_time=0.1";
  if (std::none_of(args.begin() + 1, args.end(), [](const char* a) {
        return std::string(a).rfind("--benchmark_min_time", 0) == 0;
      }))
    args.insert(args.begin() + 1, min_time);
  argc = int(args.size());
  args.push_back(nullptr);
  argv = args.data();
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
