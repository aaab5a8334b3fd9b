// Rays per second, measured as lancer bench reports them: every configuration run in turn within
// each repeat (so that machine noise falls on all alike), then the median of the repeats.
#pragma once

#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "lancer/precision.hpp"
#include "lancer/scene.hpp"
#include "lancer/stats.hpp"

namespace lancer {

struct BenchRow {
  std::string engine = "lancer";  // or a peer: "embree"
  // "primary": camera rays, closest hit only; "full": the whole render; "kernel": the primary
  // intersection kernel alone, over camera rays made beforehand (PrimaryKernelRun; packets
  // only). For the embree peer, "full" is every ray lancer's render traces (camera, shadow,
  // mirror) without the shading.
  std::string mode;
  int width = 1;    // lanes; for embree the packet call rtcIntersect1/4/8/16
  std::string isa;  // "embree" for the peer (Embree picks its own ISA inside)
  std::string precision = "exact";
  int threads = 1;
  std::uint64_t rays = 0;  // per run
  RayCounts by_kind;       // the same rays by kind (camera, shadow, reflected, refracted)
  double seconds = 0;      // per render, median over the repeats
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
  std::vector<std::string> modes{"primary", "full"};  // and/or "kernel"
  int repeat = 5;
  // Each timed run renders the scene as often as it takes to last this long, so that a small
  // scene is timed over milliseconds, not microseconds; its time per render is what counts.
  double min_seconds = 0.05;
  // Peers run beside lancer, interleaved within each repeat: "embree" (include/lancer/peer.hpp).
  // They get the same modes, threads and those widths they offer (peer::embree_widths).
  std::vector<std::string> peers;
  // Also time each ISA's peak, as one more configuration of the same rounds, so that the
  // fraction of peak compares figures the machine's noise fell on alike.
  bool peak = false;
};

struct BenchResult {
  std::vector<BenchRow> rows;
  std::vector<PeakRow> peaks;  // with options.peak, by width
};

BenchResult run_bench(const Scene& scene, const BenchOptions& options);

double median(std::vector<double> v);

// Times configurations side by side: one untimed warm-up of each, then `repeat` rounds with the
// configurations interleaved (machine noise falls on all alike), each timed run repeated until
// it lasts min_seconds. run[k]() does one render of configuration k and returns the seconds of
// its work alone. Returns each configuration's median seconds per render.
std::vector<double> time_interleaved(const std::vector<std::function<double()>>& run, int repeat,
                                     double min_seconds);

}  // namespace lancer
