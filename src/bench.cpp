#include "lancer/bench.hpp"

#include <algorithm>
#include <chrono>
#include <map>
#include <memory>
#include <stdexcept>
#include <tuple>

#include "lancer/error.hpp"
#include "lancer/packet/api.hpp"
#include "lancer/peak.hpp"
#include "lancer/peer.hpp"
#include "lancer/render.hpp"

namespace lancer {

double median(std::vector<double> v) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  const std::size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

BenchResult run_bench(const Scene& scene, const BenchOptions& opt) {
  // Peers: their scene (Embree's BVH) is built once, here, untimed.
  std::unique_ptr<peer::EmbreeScene> embree;
  for (const std::string& p : opt.peers) {
    if (p != "embree") throw InputError("--peer: unknown peer '" + p + "' (known: embree)");
    if (!embree) embree = std::make_unique<peer::EmbreeScene>(scene, peer::plane_mode_from_env());
  }
  if (opt.widths.size() != opt.precisions.size())
    throw std::logic_error("run_bench: one list of widths per precision");
  BenchResult out;
  std::vector<BenchRow>& rows = out.rows;
  std::vector<Precision> row_precision;  // what each row renders with (exact for the peer)
  bool peer_rows_added = false;
  for (std::size_t k = 0; k < opt.precisions.size(); ++k) {
    const Precision precision = opt.precisions[k];
    // The peer's rows once, beside lancer's first precision.
    const bool with_peer = embree && !peer_rows_added;
    peer_rows_added = peer_rows_added || with_peer;
    const std::vector<int> embree_widths =
        with_peer ? peer::embree_widths(opt.widths[k]) : std::vector<int>{};
    for (const std::string& mode : opt.modes)
      for (int width : opt.widths[k])
        for (int threads : opt.threads) {
          // The kernel alone runs float packets only.
          const bool kernel = mode == "kernel";
          if (kernel && (width == 1 || precision == Precision::dbl)) continue;
          BenchRow r;
          r.mode = mode, r.width = width, r.threads = threads;
          r.precision = to_string(precision);
          r.isa = packet::isa_name(width, precision);
          rows.push_back(r);
          row_precision.push_back(precision);
          // The peer's row of the same mode, width and threads right after lancer's.
          if (!kernel &&
              std::find(embree_widths.begin(), embree_widths.end(), width) != embree_widths.end()) {
            r.engine = "embree";
            r.isa = "embree";
            r.precision = "float";  // Embree's own single-precision arithmetic
            rows.push_back(r);
            row_precision.push_back(Precision::exact);
          }
        }
  }

  if (rows.empty())
    throw InputError(
        "--mode kernel: the kernel alone runs float packets (exact or fast, width 4, 8 or 16): "
        "nothing to run");

  // The kernel rows' camera rays are made here, once, untimed.
  std::vector<std::unique_ptr<PrimaryKernelRun>> kernels(rows.size());
  std::vector<std::function<double()>> run;
  for (std::size_t k = 0; k < rows.size(); ++k) {
    BenchRow& row = rows[k];
    RenderOptions ro;
    ro.width = row.width;
    ro.threads = row.threads;
    ro.precision = row_precision[k];
    if (row.engine == "lancer" && row.mode == "kernel")
      kernels[k] = std::make_unique<PrimaryKernelRun>(scene, ro);
    run.push_back([&scene, &embree, &row, ro, kernel = kernels[k].get()]() -> double {
      if (row.engine == "embree") {
        if (row.mode == "primary") {
          const PrimaryResult p = embree->primary(row.width, row.threads);
          return row.by_kind = p.rays, row.rays = p.rays.total(), p.seconds;
        }
        const peer::EmbreeScene::RaysResult f = embree->trace_all(row.width, row.threads);
        return row.by_kind = f.rays, row.rays = f.rays.total(), f.seconds;
      }
      if (kernel) {
        const PrimaryResult p = kernel->run();
        return row.by_kind = p.rays, row.rays = p.rays.total(), p.seconds;
      }
      if (row.mode == "primary") {
        const PrimaryResult p = render_primary(scene, ro);
        return row.by_kind = p.rays, row.rays = p.rays.total(), p.seconds;
      }
      const RenderResult f = render(scene, ro);
      return row.by_kind = f.rays, row.rays = f.rays.total(), f.seconds;
    });
  }

  // The peaks: each ISA's FMA and mul+add chains as configurations of the same rounds.
  struct PeakRun {
    std::size_t row;
    bool fma;
    double flops = 0;
  };
  std::vector<PeakRun> peak_runs;
  if (opt.peak) {
    std::vector<int> widths = packet::supported_widths();
    std::sort(widths.begin(), widths.end());
    for (int w : widths) {
      out.peaks.push_back({w, packet::isa_name(w), 0, 0});
      for (bool fma : {true, false})
        if (fma || w >= 8) peak_runs.push_back({out.peaks.size() - 1, fma});
    }
  }
  for (PeakRun& p : peak_runs) {
    const PeakKernel kernel = peak_kernel(out.peaks[p.row].width, p.fma);
    run.push_back([kernel, &p]() -> double {
      const auto start = std::chrono::steady_clock::now();
      p.flops = kernel(kPeakBatch);
      return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    });
  }

  const std::vector<double> seconds = time_interleaved(run, opt.repeat, opt.min_seconds);
  for (std::size_t k = 0; k < rows.size(); ++k) rows[k].seconds = seconds[k];
  for (std::size_t k = 0; k < peak_runs.size(); ++k) {
    const PeakRun& p = peak_runs[k];
    const double gflops = p.flops / seconds[rows.size() + k] * 1e-9;
    PeakRow& peak = out.peaks[p.row];
    (p.fma ? peak.gflops : peak.muladd_gflops) = gflops;
    if (peak.width < 8) peak.muladd_gflops = peak.gflops;  // one kernel: mul+add
  }
  return out;
}

std::vector<double> time_interleaved(const std::vector<std::function<double()>>& run, int repeat,
                                     double min_seconds) {
  std::vector<std::vector<double>> times(run.size());
  for (int rep = -1; rep < repeat; ++rep) {
    for (std::size_t k = 0; k < run.size(); ++k) {
      double seconds = 0;
      int renders = 0;
      do {
        seconds += run[k]();
        ++renders;
      } while (rep >= 0 && seconds < min_seconds);
      if (rep >= 0) times[k].push_back(seconds / renders);
    }
  }
  std::vector<double> medians;
  for (const auto& t : times) medians.push_back(median(t));
  return medians;
}

}  // namespace lancer
