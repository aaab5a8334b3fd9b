// Rays per second, measured as lancer bench reports them: every configuration run in turn within
// each repeat (so that machine noise falls on all alike), then the median of the repeats.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "lancer/scene.hpp"

namespace lancer {

struct BenchRow {
  std::string engine = "lancer";
  std::string mode;  // "primary": camera rays, closest hit only; "full": the whole render
  int width = 1;
  std::string isa;
  std::string precision = "exact";
  int threads = 1;
  std::uint64_t rays = 0;  // per run
  double seconds = 0;      // per render, median over the repeats
  double mrays_per_s() const { return seconds > 0 ? rays / seconds * 1e-6 : 0; }
};

struct BenchOptions {
  std::vector<int> widths;   // resolved widths (1 = the reference)
  std::vector<int> threads;  // e.g. {1}
  std::vector<std::string> modes{"primary", "full"};
  int repeat = 5;
  // Each timed run renders the scene as often as it takes to last this long, so that a small
  // scene is timed over milliseconds, not microseconds; its time per render is what counts.
  double min_seconds = 0.05;
};

std::vector<BenchRow> run_bench(const Scene& scene, const BenchOptions& options);

double median(std::vector<double> v);

}  // namespace lancer
