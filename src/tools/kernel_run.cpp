// The primary intersection kernel alone (lancer bench --mode kernel; include/lancer/bench.hpp):
// camera rays made once, untimed, then only primary mode's closest-hit kernel timed over them.
#include <chrono>
#include <memory>
#include <vector>

#include "lancer/bench.hpp"
#include "lancer/error.hpp"
#include "lancer/packet/api.hpp"
#include "lancer/tiles.hpp"

namespace lancer {

struct PrimaryKernelRun::State {
  PreparedScene<float> scene;
  const packet::KernelTable<float>* kernels = nullptr;
  int threads = 1;
  std::vector<float> rays, t;  // the packets' rays and, per run, their lanes' t
  std::vector<int> lanes;
  std::vector<std::uint32_t> where;  // each lane's camera ray in the image's order
  std::size_t camera_rays = 0;
};

PrimaryKernelRun::PrimaryKernelRun(const Scene& scene, const RenderOptions& opt)
    : state_(std::make_unique<State>()) {
  if (opt.precision != Precision::exact && opt.precision != Precision::fast)
    throw InputError("--precision: the kernel alone runs float packets: exact or fast");
  const int width = resolve_width(opt.width, opt.precision);
  if (width == 1) throw InputError("--width: the kernel alone runs packets: 4, 8 or 16, not 1");
  State& st = *state_;
  st.scene = prepare_for<float>(scene, opt);
  st.kernels = packet::float_kernels(width, opt.precision, st.scene.features.shapes);
  st.threads = resolve_threads(opt.threads);
  const int ny = scene.camera.ny;
  const std::size_t packets = st.kernels->camera_packet_count(st.scene, 0, ny);
  st.rays.resize(packets * 6 * std::size_t(width));
  st.t.resize(packets * std::size_t(width));
  st.lanes.resize(packets);
  st.where.resize(packets * std::size_t(width));
  st.kernels->camera_packets(st.scene, 0, ny, st.rays.data(), st.lanes.data(), st.where.data());
  const int samples = st.scene.camera.samples;
  st.camera_rays =
      std::size_t(ny) * std::size_t(scene.camera.nx) * std::size_t(samples) * std::size_t(samples);
}

PrimaryKernelRun::~PrimaryKernelRun() = default;

PrimaryResult PrimaryKernelRun::run() {
  State& st = *state_;
  const int w = st.kernels->width;
  PrimaryResult res;
  res.width = w;
  res.threads = st.threads;
  res.structure = structure_of(st.scene);
  const auto start = std::chrono::steady_clock::now();
  {
    res.rays = lancer::run_tiles(st.scene.camera.ny, st.threads, [&](int r0, int r1, RayCounts& c) {
      const std::size_t first = st.kernels->camera_packet_count(st.scene, 0, r0);
      const std::size_t count = st.kernels->camera_packet_count(st.scene, r0, r1);
      st.kernels->intersect_camera_packets(st.scene, st.rays.data() + first * 6 * w,
                                           st.lanes.data() + first, count, st.t.data() + first * w,
                                           c);
    });
  }
  res.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  // Untimed: each camera ray's t to its place in the image's order.
  res.t.assign(st.camera_rays, 0.0f);
  for (std::size_t k = 0; k < st.where.size(); ++k)
    if (st.where[k] != packet::kNoCameraRay) res.t[st.where[k]] = st.t[k];
  return res;
}

}  // namespace lancer
