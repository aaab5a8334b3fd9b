#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>

#include "commands.hpp"
#include "lancer/error.hpp"
#include "lancer/packet/api.hpp"
#include "lancer/plot.hpp"
#include "lancer/trade.hpp"
#include "options.hpp"

namespace lancer::cli {

namespace {
struct TradeArgs {
  std::string scene, plot, accel = "auto";
  bool json = false;
  int repeat = 5;
  SceneOverrides overrides;
};

// JSON has no infinity: an identical image's PSNR is reported as null.
nlohmann::json number_or_null(double v) {
  return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr);
}

void run_trade_cmd(const TradeArgs& a) {
  Scene scene = load_scene(a.scene);
  apply_overrides(scene, a.overrides);
  check_repeat(a.repeat);
  if (!a.plot.empty()) plot::check_drawing_path(a.plot, "--plot", a.scene);
  TradeOptions opt;
  opt.repeat = a.repeat;
  opt.accel = parse_accel(a.accel, "--accel");
  // Every precision runs at each width it has here; fast has none without packets. Said before
  // the runs, not left for the reader to notice in the table.
  for (Precision p : opt.precisions)
    if (packet::supported_widths(p).empty()) {
      const char* cap = std::getenv("LANCER_MAX_WIDTH");
      std::fprintf(stderr,
                   "lancer trade: no %s rows: %s precision runs on packets of 4 lanes or "
                   "more, which %s\n",
                   to_string(p), to_string(p),
                   cap && std::atoi(cap) < 4
                       ? ("LANCER_MAX_WIDTH=" + std::string(cap) + " leaves out").c_str()
                       : "this CPU or OS does not run");
    }
  const std::vector<TradeRow> rows = run_trade(scene, opt);
  if (a.json) {
    nlohmann::json out;
    out["scene"] = a.scene;
    out["results"] = nlohmann::json::array();
    for (const TradeRow& r : rows)
      out["results"].push_back({{"precision", to_string(r.precision)},
                                {"width", r.width},
                                {"isa", r.isa},
                                {"mrays_per_s", r.mrays_per_s},
                                {"max_abs_diff", r.max_abs_diff},
                                {"psnr_db", number_or_null(r.psnr_db)},
                                {"off_pixel_frac", r.off_pixel_frac},
                                {"hit_mismatch_frac", r.hit_mismatch_frac}});
    std::printf("%s\n", out.dump(2).c_str());
  } else {
    std::printf(
        "lancer trade: %s, single thread, median of %d runs; error against double at "
        "width 1\n",
        a.scene.c_str(), a.repeat);
    std::printf("  %-9s %5s %-11s %9s %12s %9s %11s %11s\n", "precision", "width", "isa", "Mrays/s",
                "max |diff|", "PSNR dB", "off >1/255", "hit differs");
    for (const TradeRow& r : rows)
      std::printf("  %-9s %5d %-11s %9.2f %12.3g %9.1f %10.4f%% %10.4f%%\n", to_string(r.precision),
                  r.width, r.isa.c_str(), r.mrays_per_s, r.max_abs_diff,
                  std::isfinite(r.psnr_db) ? r.psnr_db : INFINITY, 100 * r.off_pixel_frac,
                  100 * r.hit_mismatch_frac);
  }
  if (!a.plot.empty()) {
    plot::write_chart(trade_chart(rows, a.scene), a.plot);
    // On stderr beside --json, whose stdout is one JSON object.
    std::fprintf(a.json ? stderr : stdout,
                 "lancer trade: wrote %s (Mrays/s against error, %zu points)\n", a.plot.c_str(),
                 rows.size());
  }
}
}  // namespace

void add_trade(CLI::App& app) {
  auto args = std::make_shared<TradeArgs>();
  CLI::App* cmd = app.add_subcommand(
      "trade", "Speed against accuracy: every precision and width, Mrays/s and error vs double");
  cmd->add_option("scene", args->scene, "Scene file")->required();
  cmd->add_flag("--json", args->json, "Print one JSON object instead of a table");
  cmd->add_option("--plot", args->plot,
                  "Draw speed against error: .png, .svg, .pdf (or another image format)");
  cmd->add_option("--accel", args->accel, "auto, none, bvh or one")->capture_default_str();
  cmd->add_option("--repeat", args->repeat,
                  "Timed runs per configuration, 1 to " + std::to_string(kMaxRepeat) +
                      "; the median is shown")
      ->capture_default_str();
  cmd->add_option("--supersample", args->overrides.supersample, "Override the scene's");
  cmd->add_option("--resolution", args->overrides.resolution, "Override the scene's, NXxNY");
  cmd->callback([args] { run_trade_cmd(*args); });
}

}  // namespace lancer::cli
