#include "lancer/render.hpp"

#include <tbb/blocked_range.h>
#include <tbb/combinable.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <thread>

#include "lancer/error.hpp"
#include "lancer/packet/api.hpp"
#include "lancer/prepared.hpp"
#include "lancer/reference.hpp"

namespace lancer {

const char* to_string(Precision p) { return p == Precision::exact ? "exact" : "double"; }

Precision parse_precision(const std::string& text, const std::string& option) {
  if (text == "exact") return Precision::exact;
  if (text == "double") return Precision::dbl;
  throw InputError(option + ": must be exact or double, not '" + text + "'");
}

int hardware_threads() { return std::max(1u, std::thread::hardware_concurrency()); }

int resolve_width(int requested, Precision precision, const std::string& option) {
  if (precision == Precision::dbl) {
    // Double precision runs on the reference only, for now.
    if (requested > 1)
      throw InputError(option + ": double precision runs at width 1 only (got " +
                       std::to_string(requested) + ")");
    return 1;
  }
  if (requested == 0) return packet::supported_widths().front();
  if (requested == 1) return 1;
  if (requested != 4 && requested != 8 && requested != 16)
    throw InputError(option + ": must be auto, 1, 4, 8 or 16, not " + std::to_string(requested));
  if (!packet::kernels_for(requested))
    throw InputError(option + ": width " + std::to_string(requested) + " needs " +
                     packet::isa_name(requested) + ", which this CPU or OS does not run");
  return requested;
}

namespace {

using Clock = std::chrono::steady_clock;

template <class T>
PreparedScene<T> prepare_for(const Scene& scene, const RenderOptions& opt) {
  PreparedScene<T> p = prepare<T>(scene);
  if (opt.model_everything) {
    // The sphere and plane flags stay: a type the scene lacks has no data to gather normals
    // from, and its intersection loop is empty either way.
    Features& f = p.features;
    f.lights = f.specular = f.reflection = true;
  }
  return p;
}

// Runs body(row_begin, row_end, counts) over row tiles on `threads` threads and sums the
// counts. Each pixel depends only on its own rays, so the image is the same for any split.
template <class Body>
RayCounts run_tiles(int ny, int threads, const RenderOptions& opt, Body body) {
  // Small tiles balance the load across rows of different cost; four rows keep packets busy.
  constexpr int kTileRows = 4;
  const int tiles = (ny + kTileRows - 1) / kTileRows;
  std::atomic<int> rows_done{0};
  auto tile = [&](int t, RayCounts& counts) {
    const int r0 = t * kTileRows, r1 = std::min(ny, r0 + kTileRows);
    body(r0, r1, counts);
    const int done = rows_done += r1 - r0;
    if (opt.on_progress) opt.on_progress(done, ny);
  };
  if (threads == 1) {
    RayCounts counts;
    for (int t = 0; t < tiles; ++t) tile(t, counts);
    return counts;
  }
  tbb::combinable<RayCounts> per_thread;
  tbb::task_arena arena(threads);
  arena.execute([&] {
    tbb::parallel_for(
        tbb::blocked_range<int>(0, tiles, 1),
        [&](const tbb::blocked_range<int>& r) {
          RayCounts& counts = per_thread.local();
          for (int t = r.begin(); t < r.end(); ++t) tile(t, counts);
        },
        tbb::simple_partitioner());
  });
  RayCounts total;
  per_thread.combine_each([&](const RayCounts& c) { total += c; });
  return total;
}

int resolve_threads(int requested) {
  if (requested < 0) throw InputError("--threads: must be >= 0 (0 = all cores)");
  return requested == 0 ? hardware_threads() : requested;
}

}  // namespace

RenderResult render(const Scene& scene, const RenderOptions& opt) {
  RenderResult res;
  res.precision = opt.precision;
  res.width = resolve_width(opt.width, opt.precision);
  res.threads = resolve_threads(opt.threads);
  res.isa = packet::isa_name(res.width);
  res.image = Image(scene.camera.nx, scene.camera.ny);
  const auto start = Clock::now();
  if (opt.precision == Precision::dbl) {
    const auto prepared = prepare_for<double>(scene, opt);
    res.rays = run_tiles(scene.camera.ny, res.threads, opt, [&](int r0, int r1, RayCounts& c) {
      reference::render_rows(prepared, res.image, r0, r1, c);
    });
  } else {
    const auto prepared = prepare_for<float>(scene, opt);
    const packet::Kernels* k = res.width == 1 ? nullptr : packet::kernels_for(res.width);
    res.rays = run_tiles(scene.camera.ny, res.threads, opt, [&](int r0, int r1, RayCounts& c) {
      if (k)
        k->render_rows(prepared, res.image, r0, r1, c);
      else
        reference::render_rows(prepared, res.image, r0, r1, c);
    });
  }
  res.seconds = std::chrono::duration<double>(Clock::now() - start).count();
  return res;
}

PrimaryResult render_primary(const Scene& scene, const RenderOptions& opt) {
  PrimaryResult res;
  res.width = resolve_width(opt.width, opt.precision);
  res.threads = resolve_threads(opt.threads);
  res.t.assign(std::size_t(scene.camera.nx) * scene.camera.ny, 0.0f);
  const auto prepared = prepare_for<float>(scene, opt);
  const packet::Kernels* k = res.width == 1 ? nullptr : packet::kernels_for(res.width);
  const auto start = Clock::now();
  res.rays = run_tiles(scene.camera.ny, res.threads, opt, [&](int r0, int r1, RayCounts& c) {
    if (k)
      k->primary_rows(prepared, res.t.data(), r0, r1, c);
    else
      reference::primary_rows(prepared, res.t.data(), r0, r1, c);
  });
  res.seconds = std::chrono::duration<double>(Clock::now() - start).count();
  return res;
}

}  // namespace lancer
