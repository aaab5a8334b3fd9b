#include "lancer/bench.hpp"

#include <algorithm>
#include <map>
#include <memory>
#include <tuple>

#include "lancer/error.hpp"
#include "lancer/packet/api.hpp"
#include "lancer/peer.hpp"
#include "lancer/render.hpp"

namespace lancer {

double median(std::vector<double> v) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  const std::size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

std::vector<BenchRow> run_bench(const Scene& scene, const BenchOptions& opt) {
  // Peers: their scene (Embree's BVH) is built once, here, untimed.
  std::unique_ptr<peer::EmbreeScene> embree;
  for (const std::string& p : opt.peers) {
    if (p != "embree") throw InputError("--peer: unknown peer '" + p + "' (known: embree)");
    if (!embree) embree = std::make_unique<peer::EmbreeScene>(scene, peer::plane_mode_from_env());
  }
  const std::vector<int> embree_widths =
      embree ? peer::embree_widths(opt.widths) : std::vector<int>{};
  std::vector<BenchRow> rows;
  for (const std::string& mode : opt.modes)
    for (int width : opt.widths)
      for (int threads : opt.threads) {
        BenchRow r;
        r.mode = mode, r.width = width, r.threads = threads;
        r.isa = packet::isa_name(width);
        rows.push_back(r);
        // The peer's row of the same mode, width and threads right after lancer's.
        if (std::find(embree_widths.begin(), embree_widths.end(), width) != embree_widths.end()) {
          r.engine = "embree";
          r.isa = "embree";
          r.precision = "float";  // Embree's own single-precision arithmetic
          rows.push_back(r);
        }
      }
  std::vector<std::function<double()>> run;
  for (BenchRow& row : rows) {
    run.push_back([&scene, &embree, &row]() -> double {
      if (row.engine == "embree") {
        if (row.mode == "primary") {
          const PrimaryResult p = embree->primary(row.width, row.threads);
          return row.rays = p.rays.total(), p.seconds;
        }
        const peer::EmbreeScene::RaysResult f = embree->trace_all(row.width, row.threads);
        return row.rays = f.rays.total(), f.seconds;
      }
      RenderOptions ro;
      ro.width = row.width;
      ro.threads = row.threads;
      if (row.mode == "primary") {
        const PrimaryResult p = render_primary(scene, ro);
        return row.rays = p.rays.total(), p.seconds;
      }
      const RenderResult f = render(scene, ro);
      return row.rays = f.rays.total(), f.seconds;
    });
  }
  const std::vector<double> seconds = time_interleaved(run, opt.repeat, opt.min_seconds);
  for (std::size_t k = 0; k < rows.size(); ++k) rows[k].seconds = seconds[k];
  return rows;
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
