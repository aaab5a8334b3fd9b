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
  std::vector<std::vector<double>> times;
  for (const std::string& mode : opt.modes)
    for (int width : opt.widths)
      for (int threads : opt.threads) {
        BenchRow r;
        r.mode = mode, r.width = width, r.threads = threads;
        r.isa = packet::isa_name(width);
        rows.push_back(r);
        times.emplace_back();
        // The peer's row of the same mode, width and threads right after lancer's.
        if (std::find(embree_widths.begin(), embree_widths.end(), width) != embree_widths.end()) {
          r.engine = "embree";
          r.isa = "embree";
          r.precision = "float";  // Embree's own single-precision arithmetic
          rows.push_back(r);
          times.emplace_back();
        }
      }
  // One untimed warm-up of each configuration, then `repeat` rounds, configurations interleaved.
  for (int rep = -1; rep < opt.repeat; ++rep) {
    for (std::size_t k = 0; k < rows.size(); ++k) {
      RenderOptions ro;
      ro.width = rows[k].width;
      ro.threads = rows[k].threads;
      double seconds = 0;
      int renders = 0;
      do {
        if (rows[k].engine == "embree") {
          if (rows[k].mode == "primary") {
            const PrimaryResult p = embree->primary(rows[k].width, rows[k].threads);
            seconds += p.seconds, rows[k].rays = p.rays.total();
          } else {
            const peer::EmbreeScene::RaysResult f =
                embree->trace_all(rows[k].width, rows[k].threads);
            seconds += f.seconds, rows[k].rays = f.rays.total();
          }
        } else if (rows[k].mode == "primary") {
          const PrimaryResult p = render_primary(scene, ro);
          seconds += p.seconds, rows[k].rays = p.rays.total();
        } else {
          const RenderResult f = render(scene, ro);
          seconds += f.seconds, rows[k].rays = f.rays.total();
        }
        ++renders;
      } while (rep >= 0 && seconds < opt.min_seconds);
      if (rep >= 0) times[k].push_back(seconds / renders);
    }
  }
  for (std::size_t k = 0; k < rows.size(); ++k) rows[k].seconds = median(times[k]);
  return rows;
}

}  // namespace lancer
