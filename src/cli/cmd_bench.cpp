#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <sstream>

#include "commands.hpp"
#include "lancer/bench.hpp"
#include "lancer/error.hpp"
#include "lancer/mpi.hpp"
#include "lancer/packet/api.hpp"
#include "lancer/peak.hpp"
#include "lancer/peer.hpp"
#include "options.hpp"

namespace lancer::cli {

namespace {
constexpr int kMaxWarmup = 100;
constexpr double kMaxMinTime = 3600;
constexpr int kMaxRounds = 1000;

struct BenchArgs {
  std::string accel = "auto";
  std::vector<std::string> scenes;
  std::vector<std::string> widths{"all"};
  std::vector<std::string> threads{"1"};
  std::vector<std::string> modes{"primary", "full"};
  std::vector<std::string> precisions{"exact"};
  // Unless given: 5, or 9 with --format gbench (compare.py's U test wants 9 or more).
  int repeat = 5;
  bool repeat_given = false;
  int warmup = 1;
  double min_time = 0;
  std::string cache = "hot";
  std::string time_unit = "auto";
  bool json = false;
  std::string format;  // table, json, csv or gbench (Google Benchmark's JSON)
  std::vector<std::string> peers;
  bool peak = false;
  SceneOverrides overrides;
};

// The flop model (peak.hpp) counts the plain loop's tests, every camera ray against every object:
// through a hierarchy, which tests a few of them, it would report several times the peak (and
// take hours to count at a million spheres). It knows spheres and planes only: triangles, meshes
// and cylinders walk a hierarchy of their own. Such rows get no GFLOP/s.
bool flops_counted(const StructureInfo& structure) {
  return structure.kind != "bvh" && structure.shape_primitives == 0;
}

// Fills gflops, lane_gflops and peak_fraction of lancer's exact primary and kernel rows.
void add_flops(const Scene& scene, const StructureInfo& structure,
               const std::vector<PeakRow>& peaks, std::vector<BenchRow>& rows) {
  if (!flops_counted(structure)) return;
  for (BenchRow& r : rows) {
    // The counts are those of exact mode's arithmetic; both modes run the same intersections.
    if (r.engine != "lancer" || r.mode == "full" || r.precision != "exact") continue;
    const PrimaryFlops f = primary_flops(scene, r.width);
    const double rays_per_s = r.mrays_per_s() * 1e6;
    r.gflops = rays_per_s * f.per_ray * 1e-9;
    r.lane_gflops = rays_per_s * f.per_lane * 1e-9;
    for (const PeakRow& p : peaks)
      if (p.width == r.width && p.gflops > 0) r.peak_fraction = *r.gflops / (p.gflops * r.threads);
  }
}

void print_peaks(const std::vector<PeakRow>& peaks) {
  std::printf("peak, single thread, float: independent chains of x = x * a + b\n");
  std::printf("  %5s %-8s %-16s %10s %16s\n", "width", "isa", "op", "GFLOP/s", "mul+add GFLOP/s");
  for (const PeakRow& p : peaks)
    std::printf("  %5d %-8s %-16s %10.1f %16.1f\n", p.width, p.isa.c_str(),
                p.width >= 8 ? "fma (2 flops)" : "mul+add (2 flops)", p.gflops, p.muladd_gflops);
}

// As hyperfine does: a warning naming the rows whose repeats spread too widely for their median
// to be trusted, and those with outliers.
void print_noise_warning(const std::vector<BenchRow>& rows) {
  std::vector<std::string> noisy;
  for (const BenchRow& r : rows) {
    const double cv = spread(r.samples).cv();
    const int out = outliers(r.samples);
    if (cv > kNoisyCv || out > 0) {
      char line[64];
      std::snprintf(line, sizeof line, ": cv %.1f%%, %d outlier%s", 100 * cv, out,
                    out == 1 ? "" : "s");
      noisy.push_back(bench_row_name(r) + (r.config.empty() ? "" : " (" + r.config + ")") + line);
    }
  }
  if (noisy.empty()) return;
  std::printf(
      "  Warning: %zu of %zu rows spread widely (coefficient of variation over %.0f%%) or have "
      "statistical outliers (repeats beyond 1.5 interquartile ranges): their medians may be "
      "off. A quieter machine, more --repeat or --min-time help:\n",
      noisy.size(), rows.size(), 100 * kNoisyCv);
  for (const std::string& n : noisy) std::printf("    %s\n", n.c_str());
}

std::string csv_cell(const std::string& text) {
  if (text.find_first_of(",\"\n") == std::string::npos) return text;
  std::string q = "\"";
  for (char c : text) q += c == '"' ? std::string("\"\"") : std::string(1, c);
  return q + "\"";
}

// One line per row, for `lancer plot` and spreadsheets: the columns of --json's results.
void print_csv(const std::vector<std::string>& scenes, const std::vector<BenchResult>& results) {
  std::printf(
      "scene,engine,mode,precision,width,isa,threads,rays,seconds,mrays_per_s,seconds_min,"
      "seconds_max,cv,repeats,config\n");
  for (std::size_t i = 0; i < results.size(); ++i)
    for (const BenchRow& r : results[i].rows) {
      const Spread sp = spread(r.samples);
      std::printf("%s,%s,%s,%s,%d,%s,%d,%llu,%.9g,%.6g,%.9g,%.9g,%.4g,%zu,%s\n",
                  csv_cell(scenes[i]).c_str(), r.engine.c_str(), r.mode.c_str(),
                  r.precision.c_str(), r.width, r.isa.c_str(), r.threads,
                  (unsigned long long)r.rays, r.seconds, r.mrays_per_s(), sp.min, sp.max, sp.cv(),
                  r.samples.size(), csv_cell(r.config).c_str());
    }
}

// The ao and diffuse sets as made, and how every row's answers compared with the reference's.
void print_ray_sets(const BenchResult& result) {
  for (const RaySetInfo& r : result.ray_sets)
    std::printf(
        "  %s rays: %llu (%d cosine-weighted per camera hit, %llu hits, seed %llu), origins %.3g "
        "off the surface, tfar %.6g (extent %.6g)\n",
        r.mode.c_str(), (unsigned long long)r.rays, r.per_hit, (unsigned long long)r.camera_hits,
        (unsigned long long)r.seed, r.offset, r.tfar, r.extent);
  // lancer's rows one by one; the peer's setups in one line per mode (all are in --json).
  std::map<std::string, std::pair<std::uint64_t, std::uint64_t>> peer;  // rows, most differing
  for (const RaySetCheck& c : result.checks) {
    if (c.engine != "lancer") {
      auto& p = peer[c.mode];
      p.first += 1, p.second = std::max(p.second, c.differ);
      continue;
    }
    char how[64];
    if (c.tolerance > 0)
      std::snprintf(how, sizeof how, "exact's width 1, t within %g", c.tolerance);
    else
      std::snprintf(how, sizeof how, "%s's width 1, bit for bit", c.precision.c_str());
    std::printf("  %s lancer %s w%d%s: %llu of %llu rays differ from the reference (%s)\n",
                c.mode.c_str(), c.precision.c_str(), c.width,
                c.config.empty() ? "" : (" (" + c.config + ")").c_str(),
                (unsigned long long)c.differ, (unsigned long long)c.rays, how);
  }
  for (const auto& [mode, p] : peer)
    std::printf(
        "  %s embree: at most %llu rays of a setup differ from the reference (exact's width 1, t "
        "within 1e-4; %llu setups and widths)\n",
        mode.c_str(), (unsigned long long)p.second, (unsigned long long)p.first);
}

void print_table(const std::string& scene, const std::vector<BenchRow>& rows,
                 const StructureInfo& structure, const BenchOptions& opt, bool peak) {
  const int rounds = rows.empty() ? 0 : int(rows[0].samples.size());
  std::printf("lancer bench: %s, median of %d runs, configurations interleaved%s", scene.c_str(),
              rounds, opt.hot ? ", each after an untimed run of its own" : ", caches shared");
  if (opt.warmup != 1) std::printf(", %d warm-up runs each", opt.warmup);
  if (opt.min_time > 0) std::printf(", at least %g s timed each", opt.min_time);
  std::printf("\n");
  std::printf("  %-8s %-8s %-9s %5s %-10s %7s %12s %10s %10s %9s", "engine", "mode", "precision",
              "width", "isa", "threads", "rays", "seconds", "Mrays/s", "vs w=1");
  std::printf(" %17s %6s", "min..max Mrays/s", "cv");
  if (peak) std::printf(" %9s %11s %7s", "GFLOP/s", "lane GFLOP/s", "of peak");
  std::printf("\n");
  for (const BenchRow& r : rows) {
    // Speed-up against the reference row of the same mode, threads and precision (exact for
    // the peer), when there is one.
    double base = 0;
    const std::string& precision = r.engine == "lancer" ? r.precision : "exact";
    for (const BenchRow& b : rows)
      if (b.engine == "lancer" && b.mode == r.mode && b.threads == r.threads && b.width == 1 &&
          b.precision == precision)
        base = b.mrays_per_s();
    char ratio[32] = "-";
    if (base > 0) std::snprintf(ratio, sizeof ratio, "%.2fx", r.mrays_per_s() / base);
    std::printf("  %-8s %-8s %-9s %5d %-10s %7d %12llu %10.5f %10.2f %9s", r.engine.c_str(),
                r.mode.c_str(), r.precision.c_str(), r.width, r.isa.c_str(), r.threads,
                (unsigned long long)r.rays, r.seconds, r.mrays_per_s(), ratio);
    // The spread over the repeats: on a shared machine run-to-run noise can reach 2x.
    const Spread sp = spread(r.samples);
    char range[40] = "-";
    if (sp.min > 0)
      std::snprintf(range, sizeof range, "%.4g..%.4g", r.rays / sp.max * 1e-6,
                    r.rays / sp.min * 1e-6);
    std::printf(" %17s %5.1f%%", range, 100 * sp.cv());
    if (peak && r.gflops)
      std::printf(" %9.2f %11.2f %6.1f%%", *r.gflops, *r.lane_gflops,
                  100 * r.peak_fraction.value_or(0));
    if (!r.config.empty()) std::printf("  (%s)", r.config.c_str());
    std::printf("\n");
  }
  print_noise_warning(rows);
  // What a full render traces, by kind: the same for every width (exact, double) of a scene.
  for (const BenchRow& r : rows)
    if (r.engine == "lancer" && r.mode == "full") {
      const RayCounts& k = r.by_kind;
      std::printf(
          "  full render rays by kind: %llu camera, %llu shadow, %llu reflected, %llu "
          "refracted\n",
          (unsigned long long)k.camera, (unsigned long long)k.shadow,
          (unsigned long long)k.reflected, (unsigned long long)k.refracted);
      break;
    }
  if (peak && !flops_counted(structure))
    std::printf(
        "  GFLOP/s: not counted through a hierarchy: the flop model (include/lancer/peak.hpp) is "
        "the plain loop's,\n  every camera ray against every sphere and plane; --accel none times "
        "the plain loop of a\n  scene without triangles, meshes or cylinders against the peak.\n");
  else if (peak)
    std::printf(
        "  GFLOP/s: flops of lancer's ray-sphere and ray-plane tests per camera ray (counts in "
        "include/lancer/peak.hpp;\n  ray generation not included) x rays/s. lane GFLOP/s: what "
        "the SIMD lanes execute (whole packets on the hit path,\n  idle lanes of partial "
        "packets). of peak: GFLOP/s / (that width's single-thread peak x threads), the peak\n"
        "  timed in the same rounds. primary times camera rays, the kernel and the stores; "
        "kernel the intersection\n  kernel alone, over camera rays made beforehand.\n");
}

// How the rows were timed (--warmup, --min-time, --cache), for --json.
nlohmann::json timing_json(const BenchOptions& opt) {
  return {
      {"warmup", opt.warmup}, {"min_time", opt.min_time}, {"cache", opt.hot ? "hot" : "shared"}};
}

nlohmann::json peaks_json(const std::vector<PeakRow>& peaks) {
  nlohmann::json out = nlohmann::json::array();
  for (const PeakRow& p : peaks)
    out.push_back({{"width", p.width},
                   {"isa", p.isa},
                   {"gflops", p.gflops},
                   {"muladd_gflops", p.muladd_gflops}});
  return out;
}

nlohmann::json result_json(const std::string& scene, const BenchResult& result,
                           const std::vector<PeakRow>* peaks) {
  const std::vector<BenchRow>& rows = result.rows;
  const StructureInfo& st = result.structure;
  nlohmann::json out;
  out["scene"] = scene;
  out["repeats"] = rows.empty() ? 0 : rows[0].samples.size();
  if (result.peer_build_seconds >= 0) out["peer_build_seconds"] = result.peer_build_seconds;
  // lancer's own structure, as its renders built it; the ao and diffuse rows run through the
  // library API, which does not report one, so with only those there is none to show.
  if (std::any_of(rows.begin(), rows.end(), [](const BenchRow& r) {
        return r.engine == "lancer" && r.mode != "ao" && r.mode != "diffuse";
      })) {
    out["structure"] = {{"kind", st.kind},
                        {"build_seconds", st.build_seconds},
                        {"bytes", st.bytes},
                        {"objects", st.spheres},
                        {"nodes", st.nodes}};
    // Triangles, meshes and cylinders have their own hierarchy, which holds the spheres too
    // where the scene has both (spheres_in_hierarchy; the spheres' own is then the reference's).
    if (st.shape_primitives > 0)
      out["structure"]["shapes"] = {{"primitives", st.shape_primitives},
                                    {"spheres_in_hierarchy", st.shape_spheres},
                                    {"nodes", st.shape_nodes},
                                    {"bytes", st.shape_bytes},
                                    {"build_seconds", st.shape_build_seconds}};
  }
  out["results"] = nlohmann::json::array();
  for (const BenchRow& r : rows) {
    nlohmann::json row{
        {"engine", r.engine}, {"mode", r.mode},           {"width", r.width},
        {"isa", r.isa},       {"precision", r.precision}, {"threads", r.threads},
        {"rays", r.rays},     {"seconds", r.seconds},     {"mrays_per_s", r.mrays_per_s()}};
    if (!r.config.empty()) row["config"] = r.config;
    if (!r.secondary.empty()) row["secondary"] = r.secondary;
    if (r.build_seconds >= 0) row["build_seconds"] = r.build_seconds;
    const Spread sp = spread(r.samples);
    row["samples_seconds"] = r.samples;
    row["seconds_min"] = sp.min, row["seconds_max"] = sp.max;
    row["cv"] = sp.cv();
    row["outliers"] = outliers(r.samples);
    row["rays_by_kind"] = {{"camera", r.by_kind.camera},
                           {"shadow", r.by_kind.shadow},
                           {"reflected", r.by_kind.reflected},
                           {"refracted", r.by_kind.refracted}};
    if (r.gflops) row["gflops"] = *r.gflops;
    if (r.lane_gflops) row["lane_gflops"] = *r.lane_gflops;
    if (r.peak_fraction) row["peak_fraction"] = *r.peak_fraction;
    out["results"].push_back(row);
  }
  if (!result.peer_setups.empty()) {
    out["peer_setups"] = nlohmann::json::array();
    for (const BenchRow& r : result.peer_setups)
      out["peer_setups"].push_back({{"mode", r.mode},
                                    {"width", r.width},
                                    {"threads", r.threads},
                                    {"config", r.config},
                                    {"build_seconds", r.build_seconds},
                                    {"mrays_per_s", r.mrays_per_s()}});
  }
  for (const RaySetInfo& r : result.ray_sets)
    out["ray_sets"].push_back({{"mode", r.mode},
                               {"seed", r.seed},
                               {"per_hit", r.per_hit},
                               {"camera_hits", r.camera_hits},
                               {"rays", r.rays},
                               {"extent", r.extent},
                               {"offset", r.offset},
                               {"tfar", r.tfar}});
  for (const RaySetCheck& c : result.checks)
    out["agreement"].push_back({{"mode", c.mode},
                                {"engine", c.engine},
                                {"precision", c.precision},
                                {"width", c.width},
                                {"config", c.config},
                                {"tolerance", c.tolerance},
                                {"rays", c.rays},
                                {"differ", c.differ}});
  if (peaks) out["peak"] = peaks_json(*peaks);
  return out;
}

// A row's configuration, as the side-by-side lines name it.
std::string row_label(const BenchRow& r) {
  return r.engine + " " + r.mode + " " + r.precision + " w" + std::to_string(r.width) + " " +
         std::to_string(r.threads) + (r.threads == 1 ? " thread" : " threads");
}

void print_side_by_side(const std::vector<std::string>& scenes,
                        const std::vector<BenchResult>& results,
                        const std::vector<SideBySide>& ratios) {
  std::printf(
      "side by side: time per ray against %s, per round of this run (the scenes of a "
      "configuration run one after the other in each round): median (min..max) of %d rounds\n",
      scenes[0].c_str(), ratios.empty() ? 0 : int(ratios[0].ratios.size()));
  for (const SideBySide& r : ratios) {
    const BenchRow& row = results[r.scene].rows[r.row];
    std::printf("  %-44s %-40s %7.3fx (%.3f..%.3f)\n", scenes[r.scene].c_str(),
                row_label(row).c_str(), r.median, r.min, r.max);
  }
}

nlohmann::json side_by_side_json(const std::vector<std::string>& scenes,
                                 const std::vector<BenchResult>& results,
                                 const std::vector<SideBySide>& ratios) {
  nlohmann::json out = nlohmann::json::array();
  for (const SideBySide& r : ratios) {
    const BenchRow& row = results[r.scene].rows[r.row];
    out.push_back({{"scene", scenes[r.scene]},
                   {"against", scenes[0]},
                   {"engine", row.engine},
                   {"mode", row.mode},
                   {"precision", row.precision},
                   {"width", row.width},
                   {"threads", row.threads},
                   {"time_per_ray_ratio", r.median},
                   {"ratio_min", r.min},
                   {"ratio_max", r.max},
                   {"ratios", r.ratios}});
  }
  return out;
}

// Under mpirun: full renders on 1..N ranks (src/mpi, docs/mpi.md), one precision and width
// (default: the widest every rank runs).
void run_bench_mpi(const BenchArgs& a, const BenchOptions& opt) {
  mpi::BenchJob job;
  const bool default_width = a.widths == std::vector<std::string>{"all"};
  if (mpi::built_with_mpi() && (opt.precisions.size() != 1 || !opt.peers.empty() || opt.peak ||
                                (!default_width && opt.widths[0].size() != 1)))
    throw InputError(
        "bench under mpirun: measures full renders across ranks at one --precision and one "
        "--width, without --peer or --peak");
  if (a.scenes.size() != 1)
    throw InputError("bench under mpirun: one scene at a time (" + std::to_string(a.scenes.size()) +
                     " given)");
  job.load = [&a] {
    Scene s = load_scene(a.scenes[0]);
    apply_overrides(s, a.overrides);
    return s;
  };
  job.scene_path = a.scenes[0];
  job.precision = opt.precisions[0];
  job.width = default_width ? 0 : opt.widths[0][0];
  job.threads_list = opt.threads;
  job.repeat = opt.repeat;
  job.json = a.json;
  mpi::bench_command(job);  // without MPI: refuses, saying how to get it
}

void run_bench_cmd(const BenchArgs& a) {
  BenchOptions opt;
  opt.precisions.clear();
  for (const std::string& p : split_list(a.precisions)) {
    const Precision precision = parse_precision(p, "--precision");
    if (precision == Precision::automatic)
      throw InputError("--precision: bench measures exact, double or fast, not auto");
    opt.precisions.push_back(precision);
    opt.widths.push_back(parse_width_list(a.widths, "--width", precision));
  }
  if (opt.precisions.empty()) throw InputError("--precision: no precision given");
  // The thread counts that will run (0 = all cores, more than the cores capped), each once.
  for (int t : parse_int_list(a.threads, "--threads", 0)) {
    const int ran = resolve_threads(t);
    if (ran != t && t != 0)
      std::fprintf(stderr, "lancer: --threads %d: this machine runs %d at once; rows say %d\n", t,
                   ran, ran);
    if (std::find(opt.threads.begin(), opt.threads.end(), ran) == opt.threads.end())
      opt.threads.push_back(ran);
  }
  check_repeat(a.repeat);
  opt.repeat = !a.repeat_given && a.format == "gbench" ? 9 : a.repeat;
  // Limits that keep a typo from running for days (docs/limits.md).
  if (a.warmup < 0 || a.warmup > kMaxWarmup)
    throw InputError("--warmup: must be 0 to " + std::to_string(kMaxWarmup) + ", not " +
                     std::to_string(a.warmup));
  opt.warmup = a.warmup;
  if (!(a.min_time >= 0 && a.min_time <= kMaxMinTime))
    throw InputError("--min-time: must be 0 to " + std::to_string(int(kMaxMinTime)) + " seconds");
  opt.min_time = a.min_time;
  if (a.cache != "hot" && a.cache != "shared")
    throw InputError("--cache: hot or shared, not '" + a.cache + "'");
  opt.hot = a.cache == "hot";
  opt.max_rounds = kMaxRounds;
  if (a.time_unit != "auto" && a.time_unit != "ns" && a.time_unit != "us" && a.time_unit != "ms" &&
      a.time_unit != "s")
    throw InputError("--time-unit: must be auto, ns, us, ms or s, not '" + a.time_unit + "'");
  opt.modes.clear();
  for (const std::string& m : split_list(a.modes)) {
    if (m != "primary" && m != "full" && m != "kernel" && m != "ao" && m != "diffuse")
      throw InputError("--mode: must be primary, full, kernel, ao or diffuse, not '" + m + "'");
    opt.modes.push_back(m);
  }
  if (opt.modes.empty()) throw InputError("--mode: no mode given");
  for (const std::string& p : split_list(a.peers)) {
    if (p != "embree") throw InputError("--peer: must be embree, not '" + p + "'");
    if (!peer::embree_available())
      throw InputError(
          "--peer embree: this lancer was built without Embree (install libembree-dev and "
          "configure with -DLANCER_WITH_EMBREE=ON)");
    // Before any row is timed, not when the peer's first scene is built.
    if (const char* config = std::getenv("LANCER_EMBREE_CONFIG")) peer::check_embree_config(config);
    opt.peers.push_back(p);
  }
  opt.peak = a.peak;
  opt.accel = parse_accel(a.accel, "--accel");
  opt.on_note = [](const std::string& note) { std::fprintf(stderr, "lancer: %s\n", note.c_str()); };
  const bool ray_sets = std::any_of(opt.modes.begin(), opt.modes.end(), [](const std::string& m) {
    return m == "ao" || m == "diffuse";
  });
  if (opt.accel != Accel::automatic && ray_sets)
    throw InputError(
        "--accel: the ao and diffuse modes trace through the library API, which chooses its own "
        "structure (as --accel auto); run them without --accel");
  if (!a.format.empty() && a.format != "table" && a.format != "json" && a.format != "gbench" &&
      a.format != "csv")
    throw InputError("--format: must be table, json, csv or gbench, not '" + a.format + "'");
  if (a.json && !a.format.empty() && a.format != "json")
    throw InputError("--json: conflicts with --format " + a.format);
  if (a.format == "gbench" && a.scenes.size() > 1)
    throw InputError(
        "--format gbench: one scene at a time (Google Benchmark's JSON has one "
        "context); table or json for several");
  if (mpi::launch_from_environment().size > 1) return run_bench_mpi(a, opt);
  std::vector<Scene> scenes;
  scenes.reserve(a.scenes.size());
  for (const std::string& path : a.scenes) {
    scenes.push_back(load_scene(path));
    apply_overrides(scenes.back(), a.overrides);
  }
  std::vector<const Scene*> ptrs;
  for (const Scene& s : scenes) ptrs.push_back(&s);
  std::vector<BenchResult> results = run_bench(ptrs, opt);
  if (a.peak)
    for (std::size_t i = 0; i < scenes.size(); ++i)
      add_flops(scenes[i], results[i].structure, results[i].peaks, results[i].rows);
  const std::vector<SideBySide> ratios = bench_side_by_side(results);
  const bool json = a.json || a.format == "json";
  const auto context = [&] {
    return nlohmann::json::parse(bench_context_json("lancer bench", a.scenes[0]));
  };
  if (a.format == "gbench") {
    std::printf("%s\n", gbench_json(results[0], a.scenes[0], "lancer bench", a.time_unit).c_str());
  } else if (a.format == "csv") {
    print_csv(a.scenes, results);
  } else if (json && scenes.size() == 1) {
    nlohmann::json out = result_json(a.scenes[0], results[0], a.peak ? &results[0].peaks : nullptr);
    out["context"] = context();
    out["timing"] = timing_json(opt);
    std::printf("%s\n", out.dump(2).c_str());
  } else if (json) {
    nlohmann::json out;
    out["context"] = context();
    out["timing"] = timing_json(opt);
    out["scenes"] = nlohmann::json::array();
    for (std::size_t i = 0; i < scenes.size(); ++i)
      out["scenes"].push_back(result_json(a.scenes[i], results[i], nullptr));
    if (a.peak) out["peak"] = peaks_json(results[0].peaks);
    out["side_by_side"] = side_by_side_json(a.scenes, results, ratios);
    std::printf("%s\n", out.dump(2).c_str());
  } else {
    for (std::size_t i = 0; i < scenes.size(); ++i) {
      print_table(a.scenes[i], results[i].rows, results[i].structure, opt, a.peak);
      print_ray_sets(results[i]);
    }
    if (scenes.size() > 1) print_side_by_side(a.scenes, results, ratios);
    if (a.peak) print_peaks(results[0].peaks);
  }
}
}  // namespace

void add_bench(CLI::App& app) {
  auto args = std::make_shared<BenchArgs>();
  CLI::App* cmd = app.add_subcommand(
      "bench", "Rays per second of each width, primary rays and full renders, side by side");
  cmd->add_option("scenes", args->scenes,
                  "Scene file; with several, each configuration runs on every scene in the same "
                  "rounds, and each scene's time per ray is given against the first's, round by "
                  "round")
      ->required()
      ->expected(1, -1);
  cmd->add_option("--accel", args->accel,
                  "Structure over the spheres: auto (a BVH from 16 spheres on), none (plain loop), "
                  "bvh, or one (as auto, and one hierarchy over the spheres and the shapes)")
      ->capture_default_str();
  cmd->add_option("--width", args->widths,
                  "Widths, e.g. 1,4,8,16 or all (default: all this CPU runs; 1 = reference)");
  cmd->add_option("--threads", args->threads,
                  "Thread counts, e.g. 1,2 (default 1; 0 = all cores; more than the cores is "
                  "capped at the cores)");
  cmd->add_option("--mode", args->modes,
                  "primary, full, kernel (the primary intersection kernel alone, packets only), "
                  "ao and/or diffuse (4 cosine-weighted rays per camera hit: occlusion within 5% "
                  "of the scene's extent, closest hit; through the library API); default "
                  "primary,full");
  cmd->add_option("--precision", args->precisions,
                  "exact, fast and/or double, e.g. exact,fast (default exact)");
  CLI::Option* repeat =
      cmd->add_option("--repeat", args->repeat,
                      "Timed runs per configuration, 1 to " + std::to_string(kMaxRepeat) +
                          "; the median is shown (default 5; 9 with --format gbench)");
  cmd->add_option("--warmup", args->warmup,
                  "Untimed runs of each configuration before the first timed one (0 to " +
                      std::to_string(kMaxWarmup) + ")")
      ->capture_default_str();
  cmd->add_option("--min-time", args->min_time,
                  "Seconds: after --repeat rounds, more rounds until every configuration has been "
                  "timed at least this long in all (at most " +
                      std::to_string(int(kMaxMinTime)) + " s, " + std::to_string(kMaxRounds) +
                      " rounds)");
  cmd->add_option("--cache", args->cache,
                  "hot: each timed run after an untimed run of its own configuration (none timed "
                  "on the caches another left); shared: each as the run before left the caches")
      ->capture_default_str();
  cmd->add_option("--time-unit", args->time_unit,
                  "--format gbench's unit: ns, us, ms, s, or auto (per row, the largest in which "
                  "its median is >= 100; fix it when comparing runs whose rows may cross a unit)")
      ->capture_default_str();
  cmd->add_flag("--json", args->json, "Print one JSON object instead of a table");
  cmd->add_option("--format", args->format,
                  "table, json (as --json), csv (one line per row, for lancer plot) or gbench: "
                  "Google Benchmark's JSON, which its tools/compare.py reads");
  cmd->add_option("--peer", args->peers,
                  "Run a peer beside lancer, interleaved: embree (Embree 3, if built with it)");
  cmd->add_flag("--peak", args->peak,
                "Time each ISA's single-thread peak GFLOP/s in the same rounds and report exact "
                "primary and kernel rows' intersection GFLOP/s against it");
  cmd->add_option("--supersample", args->overrides.supersample, "Override the scene's");
  cmd->add_option("--resolution", args->overrides.resolution, "Override the scene's, NXxNY");
  // Under mpirun, main() ends every rank with one line for an error here (mpi::end_job).
  cmd->callback([args, repeat] {
    args->repeat_given = repeat->count() > 0;
    run_bench_cmd(*args);
  });
}

}  // namespace lancer::cli
