// Rays per second, measured as lancer bench reports them: every configuration run in turn within
// each repeat (so that machine noise falls on all alike), then the median of the repeats.
#pragma once

#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "lancer/precision.hpp"
#include "lancer/render.hpp"
#include "lancer/scene.hpp"
#include "lancer/stats.hpp"

namespace lancer {

struct BenchRow {
  std::string engine = "lancer";  // or a peer: "embree"
  // "primary": camera rays, closest hit only; "full": the whole render; "kernel": the primary
  // intersection kernel alone, over camera rays made beforehand (PrimaryKernelRun; packets
  // only); "ao" and "diffuse": incoherent ray sets made from the camera hits beforehand
  // (lancer/ray_sets.hpp), traced through the library API (occluded<N>, intersect<N>), by the
  // packet kernels directly (config "kernels, prepared frame"; rays::KernelPackets) or by the
  // peer (rtcOccluded, rtcIntersect). For the embree peer, "full" is every ray lancer's render
  // traces (camera, shadow, mirror) without the shading.
  std::string mode;
  int width = 1;    // lanes; for embree the packet call rtcIntersect1/4/8/16
  std::string isa;  // "embree" for the peer (Embree picks its own ISA inside)
  std::string precision = "exact";
  std::string config;         // the peer's setup (peer::EmbreeConfig::name), "" for lancer
  double build_seconds = -1;  // the peer's scene build with that setup
  int threads = 1;
  std::uint64_t rays = 0;       // per run
  RayCounts by_kind;            // the same rays by kind (camera, shadow, reflected, refracted)
  double seconds = 0;           // per render, median over the repeats
  std::vector<double> samples;  // seconds per render of each repeat, in the order they ran
  // The process's CPU seconds per render over the same timed runs (every thread of it, the
  // run's untimed set-up, if any, included).
  std::vector<double> cpu_samples;
  std::string secondary;  // lancer's full renders through a hierarchy: secondary_walk()
  double mrays_per_s() const { return seconds > 0 ? rays / seconds * 1e-6 : 0; }
  // With --peak, lancer's exact primary and kernel rows: intersection GFLOP/s
  // (include/lancer/peak.hpp), what the SIMD lanes execute, and the first against the
  // single-thread peak of the row's width x threads.
  std::optional<double> gflops, lane_gflops, peak_fraction;
};

// One ISA's single-thread peak (include/lancer/peak.hpp), timed interleaved with the rows.
struct PeakRow {
  int width = 1;
  std::string isa;
  double gflops = 0;         // FMA at widths 8 and 16, mul+add at 1 and 4
  double muladd_gflops = 0;  // mul+add at every width: lancer's own ceiling
};

struct BenchOptions {
  // The precisions to run and, for each, its resolved widths (1 = the reference).
  std::vector<Precision> precisions{Precision::exact};
  std::vector<std::vector<int>> widths;
  std::vector<int> threads;                           // e.g. {1}
  std::vector<std::string> modes{"primary", "full"};  // and/or "kernel", "ao", "diffuse"
  int repeat = 5;
  // Untimed runs of every configuration before the first round.
  int warmup = 1;
  // More rounds after `repeat` until every configuration has been timed this many seconds in
  // all (0: exactly `repeat` rounds), at most max_rounds rounds in all.
  double min_time = 0;
  int max_rounds = 1000;
  // Each timed run after an untimed run of its own configuration (TimingPlan::hot).
  bool hot = true;
  // Each timed run renders the scene as often as it takes to last this long, so that a small
  // scene is timed over milliseconds, not microseconds; its time per render is what counts.
  double min_seconds = 0.05;
  // Peers run beside lancer, interleaved within each repeat: "embree" (include/lancer/peer.hpp).
  // They get the same modes, threads and those widths they offer (peer::embree_widths).
  std::vector<std::string> peers;
  // Also time each ISA's peak, as one more configuration of the same rounds, so that the
  // fraction of peak compares figures the machine's noise fell on alike.
  bool peak = false;
  Accel accel = Accel::automatic;  // lancer's structure over the spheres
  // Told, before the first row runs, of each asked-for row that cannot run (e.g. the ao mode at
  // double's width 2, which the library API has no packets of), one line each, so that the
  // table does not miss a row without a word. Unset: not told.
  std::function<void(const std::string&)> on_note;
};

// A ray set of the ao or diffuse mode (lancer/ray_sets.hpp), as made for the rows.
struct RaySetInfo {
  std::string mode;
  std::uint64_t seed = 1;
  int per_hit = 4;
  double extent = 0, offset = 0, tfar = 0;
  std::uint64_t camera_hits = 0, rays = 0;
};

// Before the timing, each ao or diffuse row's answers on every ray of its set against the
// reference's (the library API's width 1): lancer's exact and double rows against their own
// precision's, bitwise (occluded flags, object ids, t); fast rows and the peer's against exact's,
// within `tolerance` of t (relative beyond 1).
struct RaySetCheck {
  std::string mode, engine, precision, config;
  int width = 1;
  double tolerance = 0;
  std::uint64_t rays = 0, differ = 0;
};

struct BenchResult {
  std::vector<BenchRow> rows;
  std::vector<PeakRow> peaks;  // with options.peak, by width
  // Embree's scene build (device, geometry, BVH) with the setup of its first row; -1 if none.
  double peer_build_seconds = -1;
  // Every setup the peer ran, each row of it, before the fastest per row was kept.
  std::vector<BenchRow> peer_setups;
  StructureInfo structure;           // as lancer's renders built it
  std::vector<RaySetInfo> ray_sets;  // with the ao and diffuse modes
  std::vector<RaySetCheck> checks;   // of every ao and diffuse row, peer setups included
};

BenchResult run_bench(const Scene& scene, const BenchOptions& options);
// Several scenes timed in the same rounds: within each round every configuration runs on each
// scene in turn, so that figures of two scenes are seconds apart. One result per scene, in
// order, each with the same rows (and the same peaks).
std::vector<BenchResult> run_bench(const std::vector<const Scene*>& scenes,
                                   const BenchOptions& options);

// Time per ray of a scene against the first scene's, row by row, per round of one run
// (results from run_bench over several scenes): a ratio between scene sizes that the machine's
// drift from minute to minute does not reach.
struct SideBySide {
  std::size_t scene = 0;       // index into the results (1 and up)
  std::size_t row = 0;         // the row's index, the same in every result
  std::vector<double> ratios;  // per round: (seconds / rays) / the first scene's
  double median = 0, min = 0, max = 0;
};
std::vector<SideBySide> bench_side_by_side(const std::vector<BenchResult>& results);

double median(std::vector<double> v);

// Times configurations side by side: one untimed warm-up of each, then `repeat` rounds with the
// configurations interleaved (machine noise falls on all alike), each timed run after an untimed
// one of its own (TimingPlan::hot) and repeated until it lasts min_seconds. run[k]() does one
// render of configuration k and returns the seconds of its work alone. Returns each configuration's
// median seconds per render.
std::vector<double> time_interleaved(const std::vector<std::function<double()>>& run, int repeat,
                                     double min_seconds);
// The same, returning every repeat's seconds per render (samples[k][rep]).
std::vector<std::vector<double>> time_interleaved_samples(
    const std::vector<std::function<double()>>& run, int repeat, double min_seconds);

// How configurations are timed: `warmup` untimed runs of each, then rounds with the
// configurations interleaved, each timed run (after an untimed one of its own where hot)
// repeated until it lasts min_seconds; `repeat` rounds, and more while a configuration's timed
// seconds add up to less than min_time, up to max_rounds.
struct TimingPlan {
  int repeat = 5;
  int warmup = 1;
  // hot: each timed run follows one untimed run of its own configuration, so none is timed on
  // the caches, TLB and pages another configuration left (a peer's rows evict the data of the
  // row after them; docs/tools.md). Else each run starts as the one before left the machine.
  bool hot = true;
  double min_seconds = 0.05;
  double min_time = 0;
  int max_rounds = 1000;
};
// Per configuration, per round: wall seconds per render (what run[k]() returns) and the
// process's CPU seconds per render over the same runs.
struct RoundSamples {
  std::vector<std::vector<double>> wall, cpu;
};
RoundSamples time_rounds(const std::vector<std::function<double()>>& run, const TimingPlan& plan);

// The spread of a row's samples, as rays per second would show it (seconds: lower is faster).
struct Spread {
  double min = 0, median = 0, max = 0;
  double mean = 0, stddev = 0;  // sample standard deviation (n - 1)
  double cv() const { return mean > 0 ? stddev / mean : 0; }
};
Spread spread(const std::vector<double>& samples);

// Above this coefficient of variation a row's median is flagged as unreliable (bench warns).
constexpr double kNoisyCv = 0.05;
// Repeats further than 1.5 interquartile ranges outside the quartiles (Tukey's fences, which
// hyperfine's outlier warning uses too).
int outliers(const std::vector<double>& samples);

// A row's name in Google Benchmark's JSON: engine/mode/precision/wWIDTH/threads:N.
std::string bench_row_name(const BenchRow& row);
// The rows in Google Benchmark's JSON shape (context; per row one "iteration" entry per repeat and
// mean, median, stddev and cv aggregates), readable by its tools/compare.py.
// time_unit: ns, us, ms or s; "" or "auto" picks one per row, the largest in which the row's
// median is at least 100. cpu_time is the rows' cpu_samples.
std::string gbench_json(const BenchResult& result, const std::string& scene,
                        const std::string& executable, const std::string& time_unit = "auto");
// The context both JSON outputs carry (date, host, CPU, caches, commit, lancer's version), as
// a JSON object's text.
std::string bench_context_json(const std::string& executable, const std::string& scene);

// The primary intersection kernel alone (lancer bench --mode kernel): the camera rays of every
// pixel and sub-sample are made once, at construction, untimed, laid out as primary mode
// traces them (camera blocks or tiles through a hierarchy, else rows of packets); each run()
// times only the closest-hit kernel of primary mode over them (on options.threads threads) and
// returns the nearest t of every camera ray, infinity where missed, at (row * samples^2 +
// sub-sample b * samples + a) * nx + column. Float packets only (exact or fast): InputError
// otherwise, naming --width or --precision.
class PrimaryKernelRun {
 public:
  PrimaryKernelRun(const Scene& scene, const RenderOptions& options);
  ~PrimaryKernelRun();
  PrimaryKernelRun(const PrimaryKernelRun&) = delete;
  PrimaryKernelRun& operator=(const PrimaryKernelRun&) = delete;
  PrimaryResult run();

 private:
  struct State;
  std::unique_ptr<State> state_;
};

}  // namespace lancer
