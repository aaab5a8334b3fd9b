#include <cstdio>
#include <memory>
#include <nlohmann/json.hpp>

#include "commands.hpp"
#include "lancer/bench.hpp"
#include "lancer/error.hpp"
#include "lancer/packet/api.hpp"
#include "options.hpp"

namespace lancer::cli {

namespace {
struct BenchArgs {
  std::string scene;
  std::vector<std::string> widths{"all"};
  std::vector<std::string> threads{"1"};
  std::vector<std::string> modes{"primary", "full"};
  int repeat = 5;
  bool json = false;
  SceneOverrides overrides;
};

void print_table(const std::string& scene, const std::vector<BenchRow>& rows, int repeat) {
  std::printf("lancer bench: %s, exact precision, median of %d runs, widths interleaved\n",
              scene.c_str(), repeat);
  std::printf("  %-8s %-8s %5s %-8s %7s %12s %10s %10s %9s\n", "engine", "mode", "width", "isa",
              "threads", "rays", "seconds", "Mrays/s", "vs w=1");
  for (const BenchRow& r : rows) {
    // Speed-up against the reference row of the same mode and threads, when there is one.
    double base = 0;
    for (const BenchRow& b : rows)
      if (b.engine == "lancer" && b.mode == r.mode && b.threads == r.threads && b.width == 1)
        base = b.mrays_per_s();
    char ratio[32] = "-";
    if (base > 0) std::snprintf(ratio, sizeof ratio, "%.2fx", r.mrays_per_s() / base);
    std::printf("  %-8s %-8s %5d %-8s %7d %12llu %10.5f %10.2f %9s\n", r.engine.c_str(),
                r.mode.c_str(), r.width, r.isa.c_str(), r.threads, (unsigned long long)r.rays,
                r.seconds, r.mrays_per_s(), ratio);
  }
}

void print_json(const std::string& scene, const std::vector<BenchRow>& rows) {
  nlohmann::json out;
  out["scene"] = scene;
  out["results"] = nlohmann::json::array();
  for (const BenchRow& r : rows)
    out["results"].push_back({{"engine", r.engine},
                              {"mode", r.mode},
                              {"width", r.width},
                              {"isa", r.isa},
                              {"precision", r.precision},
                              {"threads", r.threads},
                              {"rays", r.rays},
                              {"seconds", r.seconds},
                              {"mrays_per_s", r.mrays_per_s()}});
  std::printf("%s\n", out.dump(2).c_str());
}

void run_bench_cmd(const BenchArgs& a) {
  Scene scene = load_scene(a.scene);
  apply_overrides(scene, a.overrides);
  BenchOptions opt;
  opt.widths = parse_width_list(a.widths, "--width");
  opt.threads = parse_int_list(a.threads, "--threads", 1);
  if (a.repeat < 1) throw InputError("--repeat: must be >= 1");
  opt.repeat = a.repeat;
  opt.modes.clear();
  for (const std::string& m : a.modes) {
    if (m != "primary" && m != "full") throw InputError("--mode: must be primary or full");
    opt.modes.push_back(m);
  }
  const std::vector<BenchRow> rows = run_bench(scene, opt);
  if (a.json)
    print_json(a.scene, rows);
  else
    print_table(a.scene, rows, a.repeat);
}
}  // namespace

void add_bench(CLI::App& app) {
  auto args = std::make_shared<BenchArgs>();
  CLI::App* cmd = app.add_subcommand(
      "bench", "Rays per second of each width, primary rays and full renders, side by side");
  cmd->add_option("scene", args->scene, "Scene file")->required();
  cmd->add_option("--width", args->widths,
                  "Widths, e.g. 1,4,8,16 or all (default: all this CPU runs; 1 = reference)");
  cmd->add_option("--threads", args->threads, "Thread counts, e.g. 1,2 (default 1)");
  cmd->add_option("--mode", args->modes, "primary and/or full (default both)");
  cmd->add_option("--repeat", args->repeat, "Timed runs per configuration; the median is shown")
      ->capture_default_str();
  cmd->add_flag("--json", args->json, "Print one JSON object instead of a table");
  cmd->add_option("--supersample", args->overrides.supersample, "Override the scene's");
  cmd->add_option("--resolution", args->overrides.resolution, "Override the scene's, NXxNY");
  cmd->callback([args] { run_bench_cmd(*args); });
}

}  // namespace lancer::cli
