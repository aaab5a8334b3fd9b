// Rays per second, measured as lancer bench reports them: every configuration run in turn within
// each repeat (so that machine noise falls on all alike), then the median of the repeats.
#pragma once

#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "lancer/scene.hpp"

namespace lancer {

struct BenchRow {
  std::string engine = "lancer";  // or a peer: "embree"
  // "primary": camera rays, closest hit only; "full": the whole render. For the embree peer,
  // "full" is every ray lancer's render traces (camera, shadow, mirror) without the shading.
  std::string mode;
  int width = 1;    // lanes; for embree the packet call rtcIntersect1/4/8/16
  std::string isa;  // "embree" for the peer (Embree picks its own ISA inside)
  std::string precision = "exact";
  int threads = 1;
  std::uint64_t rays = 0;  // per run
  double seconds = 0;      // per render, median over the repeats
  double mrays_per_s() const { return seconds > 0 ? rays / seconds * 1e-6 : 0; }
  // With --peak, lancer's primary rows: intersection GFLOP/s (include/lancer/peak.hpp), what the
  // SIMD lanes execute, and the first against the single-thread peak x threads.
  std::optional<double> gflops, lane_gflops, peak_fraction;
};

struct BenchOptions {
  std::vector<int> widths;   // resolved widths (1 = the reference)
  std::vector<int> threads;  // e.g. {1}
  std::vector<std::string> modes{"primary", "full"};
  int repeat = 5;
  // Each timed run renders the scene as often as it takes to last this long, so that a small
  // scene is timed over milliseconds, not microseconds; its time per render is what counts.
  double min_seconds = 0.05;
  // Peers run beside lancer, interleaved within each repeat: "embree" (include/lancer/peer.hpp).
  // They get the same modes, threads and those widths they offer (peer::embree_widths).
  std::vector<std::string> peers;
};

std::vector<BenchRow> run_bench(const Scene& scene, const BenchOptions& options);

double median(std::vector<double> v);

// Times configurations side by side: one untimed warm-up of each, then `repeat` rounds with the
// configurations interleaved (machine noise falls on all alike), each timed run repeated until
// it lasts min_seconds. run[k]() does one render of configuration k and returns the seconds of
// its work alone. Returns each configuration's median seconds per render.
std::vector<double> time_interleaved(const std::vector<std::function<double()>>& run, int repeat,
                                     double min_seconds);

}  // namespace lancer
