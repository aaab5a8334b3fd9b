#include "lancer/bench.hpp"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <ctime>
#include <limits>
#include <map>
#include <memory>
#include <stdexcept>
#include <tuple>

#include "lancer/error.hpp"
#include "lancer/lancer.hpp"
#include "lancer/packet/api.hpp"
#include "lancer/peak.hpp"
#include "lancer/peer.hpp"
#include "lancer/ray_sets.hpp"
#include "lancer/render.hpp"

namespace lancer {

double median(std::vector<double> v) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  const std::size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

namespace {

// One scene's rows and what they run on: its prepared scenes, kernel runs and the peer's scenes.
struct SceneRun {
  const Scene* scene = nullptr;
  BenchResult out;
  std::vector<int> row_setup;            // index into embrees of each row, -1 for lancer's
  std::vector<Precision> row_precision;  // what each row renders with (exact for the peer)
  std::vector<std::unique_ptr<PrimaryKernelRun>> kernels;
  std::map<Precision, std::unique_ptr<PreparedRun>> prepared;
  std::vector<const PreparedRun*> lancer_runs;
  std::vector<std::unique_ptr<peer::EmbreeScene>> embrees;
  double first_build = std::numeric_limits<double>::infinity();
  // The ao and diffuse modes: the library API's scene per precision, the sets by mode, each
  // lancer row's packets and each mode's rays in the peer's frame (the same for every setup).
  std::map<Precision, std::unique_ptr<api::Scene>> api_scenes;
  std::map<std::string, rays::RaySet> sets;
  std::vector<std::unique_ptr<rays::ApiPackets>> packets;
  std::map<Precision, std::shared_ptr<const rays::KernelPackets::Prepared>> kernel_scenes;
  std::vector<std::unique_ptr<rays::KernelPackets>> kernel_packets;
  std::map<std::string, std::shared_ptr<const peer::EmbreeScene::Rays>> peer_rays;
};

bool ray_set_mode(const std::string& mode) { return mode == "ao" || mode == "diffuse"; }

// The config of lancer's ao and diffuse rows that skip the library API (rays::KernelPackets).
constexpr const char* kKernelsConfig = "kernels, prepared frame";

// The library API's packets, which the ao and diffuse rows trace through: double's width 2 has
// none (and its float kernels, the kernels-only rows, none of double at all).
bool api_width(int width) { return width == 1 || width == 4 || width == 8 || width == 16; }

// A row the options ask for that plan_rows leaves out: why, and which rows.
struct LeftOut {
  std::string cause, rows;
  bool peer = false;
};

// The ao and diffuse modes at a width the library API has no packets of, and the peer at a width
// Embree has no packets of (with lancer's first precision, the one it runs beside). The kernel
// mode's width 1 and double rows are not here: "packets only" is what --mode kernel means.
std::vector<LeftOut> rows_left_out(const BenchOptions& opt, bool with_peer) {
  std::vector<std::string> ray_modes;
  for (const std::string& m : opt.modes)
    if (ray_set_mode(m) && std::find(ray_modes.begin(), ray_modes.end(), m) == ray_modes.end())
      ray_modes.push_back(m);
  const bool both = ray_modes.size() > 1;
  std::vector<LeftOut> out;
  for (std::size_t k = 0; k < opt.precisions.size(); ++k)
    for (int width : opt.widths[k]) {
      const std::string w = std::to_string(width);
      const std::string at = " at width " + w + " (" + to_string(opt.precisions[k]) + " precision)";
      if (!ray_modes.empty() && !api_width(width))
        out.push_back({"--width " + w + ": the " +
                           (both ? "ao and diffuse modes trace" : ray_modes[0] + " mode traces") +
                           " through the library API, whose packets are 1, 4, 8 or 16 rays",
                       "no " + (both ? std::string("ao or diffuse") : ray_modes[0]) + " row" + at});
      if (with_peer && k == 0 && peer::embree_widths({width}).empty())
        out.push_back({"--peer embree: Embree's packets are 1, 4, 8 or 16 rays on this machine",
                       "no embree row" + at, true});
    }
  return out;
}

// The rows: every precision, mode, width and thread count, each peer setup's rows right after
// lancer's of the same mode, width and threads. They depend on the options only.
void plan_rows(SceneRun& s, const std::vector<peer::EmbreeConfig>& setups,
               const BenchOptions& opt) {
  std::vector<BenchRow>& rows = s.out.rows;
  bool peer_rows_added = false;
  for (std::size_t k = 0; k < opt.precisions.size(); ++k) {
    const Precision precision = opt.precisions[k];
    // The peer's rows once, beside lancer's first precision.
    const bool with_peer = !setups.empty() && !peer_rows_added;
    peer_rows_added = peer_rows_added || with_peer;
    const std::vector<int> embree_widths =
        with_peer ? peer::embree_widths(opt.widths[k]) : std::vector<int>{};
    for (const std::string& mode : opt.modes)
      for (int width : opt.widths[k])
        for (int threads : opt.threads) {
          // The kernel alone runs float packets only.
          const bool kernel = mode == "kernel";
          if (kernel && (width == 1 || precision == Precision::dbl)) continue;
          // The library API's packets are 1, 4, 8 or 16 rays (double's width 2 has none).
          if (ray_set_mode(mode) && !api_width(width)) continue;  // rows_left_out says so
          BenchRow r;
          r.mode = mode, r.width = width, r.threads = threads;
          r.precision = to_string(precision);
          r.isa = packet::isa_name(width, precision);
          rows.push_back(r);
          s.row_precision.push_back(precision);
          s.row_setup.push_back(-1);
          // The same rays straight into the float packet kernels, beside the API's row.
          if (ray_set_mode(mode) && width > 1 && precision != Precision::dbl) {
            r.config = kKernelsConfig;
            rows.push_back(r);
            s.row_precision.push_back(precision);
            s.row_setup.push_back(-1);
            r.config.clear();
          }
          // The peer's rows of the same mode, width and threads right after lancer's.
          if (!kernel &&
              std::find(embree_widths.begin(), embree_widths.end(), width) != embree_widths.end()) {
            r.engine = "embree";
            r.isa = "embree";
            r.precision = "float";  // Embree's own single-precision arithmetic
            for (std::size_t e = 0; e < setups.size(); ++e) {
              const peer::EmbreeConfig& how = setups[e];
              // Square packets and streams exist for camera rays only (square packets from width
              // 4 up): elsewhere they would run the rows of another setup under their name.
              const bool tiles_here = mode == "primary" && width > 1;
              const bool streams_here = mode != "full";
              if (((how.tiles && !tiles_here) || (how.streams && !streams_here)) &&
                  setups.size() > 1)
                continue;
              r.config = how.name();
              rows.push_back(r);
              s.row_precision.push_back(Precision::exact);
              s.row_setup.push_back(static_cast<int>(e));
            }
          }
        }
  }
}

// lancer's side, untimed: the kernel rows' camera rays, the other rows' scene prepared once per
// precision.
void prepare_lancer(SceneRun& s, bool with_peer, const BenchOptions& opt) {
  const std::vector<BenchRow>& rows = s.out.rows;
  s.kernels.resize(rows.size());
  s.lancer_runs.assign(rows.size(), nullptr);
  for (std::size_t k = 0; k < rows.size(); ++k) {
    const BenchRow& row = rows[k];
    if (row.engine != "lancer") continue;
    RenderOptions ro;
    ro.width = row.width;
    ro.threads = row.threads;
    ro.precision = s.row_precision[k];
    ro.accel = opt.accel;
    if (row.mode == "kernel") {
      s.kernels[k] = std::make_unique<PrimaryKernelRun>(*s.scene, ro);
    } else if (!ray_set_mode(row.mode)) {
      std::unique_ptr<PreparedRun>& p = s.prepared[ro.precision];
      if (!p) {
        // Beside a peer, lancer's build time is the faster of two as the peer's is (the first
        // released first: the second reuses what memory the process kept; docs/accel.md,
        // fourteenth round).
        if (with_peer)
          s.first_build =
              std::min(s.first_build, PreparedRun(*s.scene, ro).structure().build_seconds);
        p = std::make_unique<PreparedRun>(*s.scene, ro);
      }
      s.lancer_runs[k] = p.get();
    }
  }
}

// The peer's scenes (Embree's BVH, once per setup that builds differently), untimed.
void prepare_peer(SceneRun& s, const std::vector<peer::EmbreeConfig>& setups) {
  for (const peer::EmbreeConfig& how : setups) {
    const peer::EmbreeScene* built = nullptr;
    for (const auto& e : s.embrees)
      if (!built && how.same_build(e->config())) built = e.get();
    s.embrees.push_back(built ? std::make_unique<peer::EmbreeScene>(*built, how)
                              : std::make_unique<peer::EmbreeScene>(
                                    *s.scene, peer::plane_mode_from_env(), "", how));
  }
  for (std::size_t k = 0; k < s.out.rows.size(); ++k)
    if (s.row_setup[k] >= 0)
      s.out.rows[k].build_seconds = s.embrees[std::size_t(s.row_setup[k])]->build_seconds();
}

// The library API's scene of a precision, prepared once (the widest kernel this machine runs).
const api::Scene& api_scene(SceneRun& s, Precision precision) {
  std::unique_ptr<api::Scene>& a = s.api_scenes[precision];
  if (!a) {
    api::Options o;
    o.precision = precision;
    o.threads = 1;
    a = std::make_unique<api::Scene>(api::Scene::from_description(*s.scene, o));
  }
  return *a;
}

// A mode's ray set, made once from the exact scene's camera hits.
const rays::RaySet& ray_set(SceneRun& s, const std::string& mode) {
  auto it = s.sets.find(mode);
  if (it != s.sets.end()) return it->second;
  const api::Scene& exact = api_scene(s, Precision::exact);
  rays::RaySet set = rays::make_set(exact, mode == "ao" ? rays::Kind::ao : rays::Kind::diffuse);
  RaySetInfo info;
  info.mode = mode;
  info.seed = set.options.seed, info.per_hit = set.options.per_hit;
  info.extent = set.extent, info.offset = set.offset, info.tfar = set.tfar;
  info.camera_hits = set.camera_hits, info.rays = set.size();
  s.out.ray_sets.push_back(info);
  return s.sets.emplace(mode, std::move(set)).first->second;
}

// The reference a row is held to, and how closely: the library API's width 1 (intersect<1>,
// occluded<1>) of the row's own precision, bit for bit, for exact and double; of exact, within
// 1e-4 of t, for fast (which has no width 1) and for the peer. Traced once per mode and precision.
struct Reference {
  const rays::Answers* answers;
  double tolerance;
};
Reference reference_for(SceneRun& s, const std::string& mode, const rays::RaySet& set, bool lancer,
                        Precision p,
                        std::map<std::pair<std::string, Precision>, rays::Answers>& cache) {
  const bool own = lancer && p != Precision::fast;
  const Precision of = own ? p : Precision::exact;
  auto it = cache.find({mode, of});
  if (it == cache.end()) {
    it = cache.emplace(std::make_pair(mode, of), rays::Answers{}).first;
    rays::ApiPackets(set, 1).trace(api_scene(s, of), 1, &it->second);
  }
  return {&it->second, own ? 0.0 : 1e-4};
}

// The ao and diffuse rows, untimed: each lancer row's packets laid out, the peer's rays moved
// into its frame, and every row's answers checked against the reference's (RaySetCheck).
void prepare_ray_sets(SceneRun& s) {
  std::vector<BenchRow>& rows = s.out.rows;
  s.packets.resize(rows.size());
  s.kernel_packets.resize(rows.size());
  std::map<std::pair<std::string, Precision>, rays::Answers> references;
  for (std::size_t k = 0; k < rows.size(); ++k) {
    BenchRow& row = rows[k];
    if (!ray_set_mode(row.mode)) continue;
    const rays::RaySet& set = ray_set(s, row.mode);
    RaySetCheck c;
    c.mode = row.mode, c.engine = row.engine, c.precision = row.precision, c.config = row.config;
    c.width = row.width;
    rays::Answers got;
    if (row.engine == "lancer" && row.config == kKernelsConfig) {
      const Precision p = s.row_precision[k];
      auto& prepared = s.kernel_scenes[p];
      if (!prepared) prepared = rays::KernelPackets::prepare(*s.scene, p);
      s.kernel_packets[k] = std::make_unique<rays::KernelPackets>(prepared, set, row.width);
      s.kernel_packets[k]->trace(row.threads, &got);
    } else if (row.engine == "lancer") {
      const Precision p = s.row_precision[k];
      const api::Scene& a = api_scene(s, p);
      row.isa = rays::api_isa(a, row.width);  // what runs
      s.packets[k] = std::make_unique<rays::ApiPackets>(set, row.width);
      s.packets[k]->trace(a, row.threads, &got);
    } else {
      const peer::EmbreeScene& e = *s.embrees[std::size_t(s.row_setup[k])];
      // Every setup's scene is made from the same prepared floats: one frame for all.
      std::shared_ptr<const peer::EmbreeScene::Rays>& r = s.peer_rays[row.mode];
      if (!r) r = e.load_rays(set);
      e.trace_rays(*r, row.width, row.threads, &got);
    }
    const Reference ref =
        reference_for(s, row.mode, set, row.engine == "lancer", s.row_precision[k], references);
    c.tolerance = ref.tolerance;
    const rays::Agreement a = rays::compare(set, *ref.answers, got, c.tolerance);
    c.rays = a.rays, c.differ = a.differ;
    row.rays = set.size();
    s.out.checks.push_back(c);
  }
}

// Row k's timed run: one render (or trace) of its configuration, returning its seconds.
std::function<double()> row_run(SceneRun& s, std::size_t k) {
  BenchRow& row = s.out.rows[k];
  BenchResult& out = s.out;
  const PreparedRun* lancer_run = s.lancer_runs[k];
  const peer::EmbreeScene* embree =
      s.row_setup[k] >= 0 ? s.embrees[std::size_t(s.row_setup[k])].get() : nullptr;
  if (ray_set_mode(row.mode)) {
    const rays::ApiPackets* packets = s.packets[k].get();
    const rays::KernelPackets* kernels = s.kernel_packets[k].get();
    const api::Scene* api = packets ? s.api_scenes.at(s.row_precision[k]).get() : nullptr;
    const peer::EmbreeScene::Rays* peer_rays = embree ? s.peer_rays.at(row.mode).get() : nullptr;
    return [&row, packets, kernels, api, embree, peer_rays]() -> double {
      if (packets) return packets->trace(*api, row.threads);
      if (kernels) return kernels->trace(row.threads);
      return embree->trace_rays(*peer_rays, row.width, row.threads, nullptr);
    };
  }
  return [embree, &row, &out, lancer_run, kernel = s.kernels[k].get()]() -> double {
    if (embree) {
      if (row.mode == "primary") {
        const PrimaryResult p = embree->primary(row.width, row.threads);
        return row.by_kind = p.rays, row.rays = p.rays.total(), p.seconds;
      }
      const peer::EmbreeScene::RaysResult f = embree->trace_all(row.width, row.threads);
      return row.by_kind = f.rays, row.rays = f.rays.total(), f.seconds;
    }
    if (kernel) {
      const PrimaryResult p = kernel->run();
      out.structure = p.structure;
      return row.by_kind = p.rays, row.rays = p.rays.total(), p.seconds;
    }
    if (row.mode == "primary") {
      const PrimaryResult p = lancer_run->primary(row.width, row.threads);
      out.structure = p.structure;
      return row.by_kind = p.rays, row.rays = p.rays.total(), p.seconds;
    }
    const RenderResult f = lancer_run->render(row.width, row.threads);
    out.structure = f.structure;
    if (f.structure.kind == "bvh") row.secondary = secondary_walk(f.structure, f.width);
    return row.by_kind = f.rays, row.rays = f.rays.total(), f.seconds;
  };
}

// After the timing: of the peer's setups, the fastest of each row stays (all are kept in
// peer_setups); lancer's build time the faster of two where one precision was prepared.
void keep_fastest(SceneRun& s) {
  BenchResult& out = s.out;
  std::vector<BenchRow> kept;
  for (BenchRow& row : out.rows) {
    if (row.engine == "lancer") {
      kept.push_back(row);
      continue;
    }
    out.peer_setups.push_back(row);
    BenchRow* same = kept.empty() ? nullptr : &kept.back();
    const bool same_row = same && same->engine == row.engine && same->mode == row.mode &&
                          same->width == row.width && same->threads == row.threads;
    if (!same_row)
      kept.push_back(row);
    else if (row.seconds < same->seconds)
      *same = row;
  }
  for (const BenchRow& r : kept)
    if (r.engine != "lancer" && out.peer_build_seconds < 0)
      out.peer_build_seconds = r.build_seconds;
  if (s.prepared.size() == 1 && out.structure.kind == "bvh")
    out.structure.build_seconds = std::min(out.structure.build_seconds, s.first_build);
  out.rows = std::move(kept);
}

}  // namespace

BenchResult run_bench(const Scene& scene, const BenchOptions& opt) {
  return std::move(run_bench(std::vector<const Scene*>{&scene}, opt).front());
}

std::vector<BenchResult> run_bench(const std::vector<const Scene*>& scenes,
                                   const BenchOptions& opt) {
  // Peers: every setup runs as a row of its own, interleaved with the rest; the fastest per row
  // is kept.
  std::vector<peer::EmbreeConfig> setups;
  for (const std::string& p : opt.peers) {
    if (p != "embree") throw InputError("--peer: unknown peer '" + p + "' (known: embree)");
    if (setups.empty()) setups = peer::embree_setups(scenes);
  }
  if (opt.widths.size() != opt.precisions.size())
    throw std::logic_error("run_bench: one list of widths per precision");
  if (scenes.empty()) throw std::logic_error("run_bench: no scene");
  std::vector<SceneRun> runs(scenes.size());
  for (std::size_t i = 0; i < scenes.size(); ++i) {
    runs[i].scene = scenes[i];
    plan_rows(runs[i], setups, opt);
  }
  const std::size_t n_rows = runs[0].out.rows.size();
  const std::vector<LeftOut> left_out = rows_left_out(opt, !setups.empty());
  if (n_rows == 0) {
    // Every asked-for row left out: one line with each cause, rather than a table of nothing.
    std::string why;
    if (std::find(opt.modes.begin(), opt.modes.end(), "kernel") != opt.modes.end())
      why = "--mode kernel: the kernel alone runs float packets (exact or fast, width 4, 8 or 16)";
    for (const LeftOut& gap : left_out)
      if (!gap.peer) why += (why.empty() ? "" : "; ") + gap.cause;
    throw InputError(why + ": nothing to run");
  }
  if (opt.on_note)
    for (const LeftOut& gap : left_out) opt.on_note(gap.cause + ": " + gap.rows);

  // lancer's scenes first, then the peer's: lancer's structure is a fraction of Embree's six,
  // and built after them (a million spheres: some GB resident) lancer's build took 2.5 times as
  // long as in a fresh process (AMD EPYC, Zen 5). TBB's worker threads started first, so that
  // neither engine's build (both use TBB tasks) pays for starting them.
  tbb::parallel_for(0, 1024, [](int) {});
  for (SceneRun& s : runs) prepare_lancer(s, !setups.empty(), opt);
  for (SceneRun& s : runs) prepare_peer(s, setups);
  for (SceneRun& s : runs) prepare_ray_sets(s);

  // Each configuration's scenes one after the other within a round, so that a ratio between
  // scenes (bench_side_by_side) compares runs seconds apart.
  std::vector<std::function<double()>> run;
  for (std::size_t k = 0; k < n_rows; ++k)
    for (SceneRun& s : runs) run.push_back(row_run(s, k));

  // The peaks: each ISA's FMA and mul+add chains as configurations of the same rounds.
  struct PeakRun {
    std::size_t row;
    bool fma;
    double flops = 0;
  };
  std::vector<PeakRow> peaks;
  std::vector<PeakRun> peak_runs;
  if (opt.peak) {
    std::vector<int> widths = packet::supported_widths();
    std::sort(widths.begin(), widths.end());
    for (int w : widths) {
      peaks.push_back({w, packet::isa_name(w), 0, 0});
      for (bool fma : {true, false})
        if (fma || w >= 8) peak_runs.push_back({peaks.size() - 1, fma});
    }
  }
  for (PeakRun& p : peak_runs) {
    const PeakKernel kernel = peak_kernel(peaks[p.row].width, p.fma);
    run.push_back([kernel, &p]() -> double {
      const auto start = std::chrono::steady_clock::now();
      p.flops = kernel(kPeakBatch);
      return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    });
  }

  TimingPlan plan;
  plan.repeat = opt.repeat;
  plan.warmup = opt.warmup;
  plan.hot = opt.hot;
  plan.min_seconds = opt.min_seconds;
  plan.min_time = opt.min_time;
  plan.max_rounds = std::max(opt.max_rounds, opt.repeat);
  const RoundSamples rounds = time_rounds(run, plan);
  const std::vector<std::vector<double>>& samples = rounds.wall;
  for (std::size_t k = 0; k < n_rows; ++k)
    for (std::size_t i = 0; i < runs.size(); ++i) {
      BenchRow& row = runs[i].out.rows[k];
      row.samples = samples[k * runs.size() + i];
      row.cpu_samples = rounds.cpu[k * runs.size() + i];
      row.seconds = median(row.samples);
    }
  for (std::size_t k = 0; k < peak_runs.size(); ++k) {
    const PeakRun& p = peak_runs[k];
    const double gflops = p.flops / median(samples[n_rows * runs.size() + k]) * 1e-9;
    PeakRow& peak = peaks[p.row];
    (p.fma ? peak.gflops : peak.muladd_gflops) = gflops;
    if (peak.width < 8) peak.muladd_gflops = peak.gflops;  // one kernel: mul+add
  }
  std::vector<BenchResult> out;
  for (SceneRun& s : runs) {
    keep_fastest(s);
    s.out.peaks = peaks;
    out.push_back(std::move(s.out));
  }
  return out;
}

std::vector<SideBySide> bench_side_by_side(const std::vector<BenchResult>& results) {
  std::vector<SideBySide> out;
  if (results.empty()) return out;
  for (std::size_t i = 1; i < results.size(); ++i)
    for (std::size_t k = 0; k < results[i].rows.size() && k < results[0].rows.size(); ++k) {
      const BenchRow& a = results[0].rows[k];
      const BenchRow& b = results[i].rows[k];
      if (a.rays == 0 || b.rays == 0 || a.samples.size() != b.samples.size()) continue;
      SideBySide r;
      r.scene = i, r.row = k;
      for (std::size_t rep = 0; rep < a.samples.size(); ++rep)
        r.ratios.push_back((b.samples[rep] / double(b.rays)) / (a.samples[rep] / double(a.rays)));
      const Spread sp = spread(r.ratios);
      r.median = sp.median, r.min = sp.min, r.max = sp.max;
      out.push_back(r);
    }
  return out;
}

std::vector<double> time_interleaved(const std::vector<std::function<double()>>& run, int repeat,
                                     double min_seconds) {
  std::vector<double> medians;
  for (const auto& t : time_interleaved_samples(run, repeat, min_seconds))
    medians.push_back(median(t));
  return medians;
}

Spread spread(const std::vector<double>& v) {
  Spread s;
  if (v.empty()) return s;
  s.min = *std::min_element(v.begin(), v.end());
  s.max = *std::max_element(v.begin(), v.end());
  s.median = median(v);
  double sum = 0;
  for (double x : v) sum += x;
  s.mean = sum / double(v.size());
  double sq = 0;
  for (double x : v) sq += (x - s.mean) * (x - s.mean);
  s.stddev = v.size() > 1 ? std::sqrt(sq / double(v.size() - 1)) : 0;
  return s;
}

std::vector<std::vector<double>> time_interleaved_samples(
    const std::vector<std::function<double()>>& run, int repeat, double min_seconds) {
  TimingPlan plan;
  plan.repeat = repeat;
  plan.min_seconds = min_seconds;
  return time_rounds(run, plan).wall;
}

namespace {
double process_cpu_seconds() {
  timespec t{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
  return double(t.tv_sec) + 1e-9 * double(t.tv_nsec);
}
}  // namespace

RoundSamples time_rounds(const std::vector<std::function<double()>>& run, const TimingPlan& plan) {
  RoundSamples out;
  out.wall.resize(run.size());
  out.cpu.resize(run.size());
  for (int w = 0; w < plan.warmup; ++w)
    for (const auto& r : run) r();
  std::vector<double> total(run.size(), 0.0);
  for (int rep = 0; rep < plan.max_rounds; ++rep) {
    const bool enough =
        std::all_of(total.begin(), total.end(), [&](double t) { return t >= plan.min_time; });
    if (rep >= plan.repeat && enough) break;
    for (std::size_t k = 0; k < run.size(); ++k) {
      double seconds = 0;
      int renders = 0;
      if (plan.hot) run[k]();
      const double cpu0 = process_cpu_seconds();
      do {
        seconds += run[k]();
        ++renders;
      } while (seconds < plan.min_seconds);
      out.cpu[k].push_back((process_cpu_seconds() - cpu0) / renders);
      out.wall[k].push_back(seconds / renders);
      total[k] += seconds;
    }
  }
  return out;
}

int outliers(const std::vector<double>& v) {
  if (v.size() < 4) return 0;
  std::vector<double> s = v;
  std::sort(s.begin(), s.end());
  // Quartiles by linear interpolation between closest ranks.
  auto quantile = [&s](double q) {
    const double at = q * double(s.size() - 1);
    const std::size_t lo = std::size_t(at);
    const double f = at - double(lo);
    return lo + 1 < s.size() ? s[lo] + f * (s[lo + 1] - s[lo]) : s[lo];
  };
  const double q1 = quantile(0.25), q3 = quantile(0.75), iqr = q3 - q1;
  int n = 0;
  for (double x : s) n += x < q1 - 1.5 * iqr || x > q3 + 1.5 * iqr;
  return n;
}

}  // namespace lancer
