#include "lancer/trade.hpp"

#include <algorithm>
#include <filesystem>
#include <map>
#include <memory>

#include "lancer/bench.hpp"
#include "lancer/packet/api.hpp"
#include "lancer/plot.hpp"
#include "lancer/render.hpp"

namespace lancer {

std::vector<TradeRow> run_trade(const Scene& scene, const TradeOptions& opt) {
  RenderOptions truth_opt;
  truth_opt.precision = Precision::dbl;
  truth_opt.width = 1;
  truth_opt.threads = opt.threads;
  truth_opt.accel = opt.accel;
  const Image truth = render(scene, truth_opt).image;
  const std::vector<std::int32_t> truth_ids = render_primary_with_ids(scene, truth_opt).id;

  std::vector<TradeRow> rows;
  std::vector<RenderOptions> configs;
  for (Precision p : opt.precisions)
    for (int width : packet::supported_widths(p)) {
      TradeRow r;
      r.precision = p, r.width = width, r.isa = packet::isa_name(width, p);
      rows.push_back(r);
      RenderOptions ro;
      ro.precision = p, ro.width = width, ro.threads = opt.threads;
      ro.accel = opt.accel;
      configs.push_back(ro);
    }

  // The scene prepared once per precision, as lancer bench does: no timed frame follows its
  // own build.
  std::map<Precision, std::unique_ptr<PreparedRun>> prepared;
  for (const RenderOptions& ro : configs) {
    std::unique_ptr<PreparedRun>& p = prepared[ro.precision];
    if (!p) p = std::make_unique<PreparedRun>(scene, ro);
  }
  auto run_of = [&](std::size_t k) -> const PreparedRun& {
    return *prepared[configs[k].precision];
  };
  auto frame = [&](std::size_t k) {
    return run_of(k).render(configs[k].width, configs[k].threads);
  };

  // Errors: one render of each.
  for (std::size_t k = 0; k < rows.size(); ++k) {
    const Image im = frame(k).image;
    const ErrorStats raw = error_stats(im, truth, 1.0 / 255.0, /*as_displayed=*/false);
    const ErrorStats shown = error_stats(im, truth, 1.0 / 255.0, /*as_displayed=*/true);
    rows[k].max_abs_diff = raw.max_abs;
    rows[k].psnr_db = shown.psnr_db;
    rows[k].off_pixel_frac = shown.off_fraction;
    const std::vector<std::int32_t> ids =
        run_of(k).primary(configs[k].width, configs[k].threads, true).id;
    std::size_t mismatched = 0;
    for (std::size_t i = 0; i < ids.size(); ++i) mismatched += ids[i] != truth_ids[i];
    rows[k].hit_mismatch_frac = ids.empty() ? 0 : double(mismatched) / double(ids.size());
  }

  // Speed: configurations interleaved within each repeat, each timed run (after an untimed one
  // of its own) at least min_seconds.
  std::vector<std::function<double()>> run;
  std::vector<std::uint64_t> rays(rows.size());
  for (std::size_t k = 0; k < rows.size(); ++k)
    run.push_back([&, k] {
      const RenderResult r = frame(k);
      rays[k] = r.rays.total();
      return r.seconds;
    });
  const std::vector<double> seconds = time_interleaved(run, opt.repeat, opt.min_seconds);
  for (std::size_t k = 0; k < rows.size(); ++k) rows[k].mrays_per_s = rays[k] / seconds[k] * 1e-6;
  return rows;
}

plot::Chart trade_chart(const std::vector<TradeRow>& rows, const std::string& scene_name) {
  plot::Chart c;
  c.width = 860, c.height = 540;
  c.title = "Speed against error: " + std::filesystem::path(scene_name).filename().string();
  c.subtitle = "full render, 1 thread, median of the repeats; error against the double reference";
  c.x.label = "Mrays/s (full render, 1 thread)";
  c.y.label = "pixels off by more than 1/255 (%)";
  c.x.from_zero = true;
  c.y.from_zero = true;
  // One series per precision, in the order the rows first name them; each point labelled with
  // its width and ISA.
  for (const TradeRow& r : rows) {
    const std::string name = to_string(r.precision);
    auto it = std::find_if(c.series.begin(), c.series.end(),
                           [&](const plot::Series& s) { return s.name == name; });
    if (it == c.series.end()) {
      plot::Series s;
      s.name = name;
      s.color = plot::palette(int(c.series.size()));
      s.mark = plot::Mark::points;
      s.marker_radius = 5;
      c.series.push_back(s);
      it = c.series.end() - 1;
    }
    it->x.push_back(r.mrays_per_s);
    it->y.push_back(100.0 * r.off_pixel_frac);
    it->labels.push_back(r.width == 1 ? "scalar" : "w" + std::to_string(r.width) + " " + r.isa);
  }
  return c;
}

}  // namespace lancer
