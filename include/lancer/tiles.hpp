// Splitting an image's rows into tiles over threads (TBB), the one way every engine in lancer
// (the reference, the packets, the Embree peer) spreads a render over cores.
#pragma once

#include <tbb/blocked_range.h>
#include <tbb/combinable.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <map>
#include <memory>
#include <mutex>

#include "lancer/stats.hpp"

namespace lancer {

// Small tiles balance rows of different cost; eight rows: the camera blocks' height
// (packet/kernel.hpp kBlockRows).
inline constexpr int kTileRows = 8;

// One arena per thread count, kept for the process: a render (a benchmark repeats them by the
// thousand) then finds its worker threads already made, not started for it. Never destroyed:
// arenas must not outlive TBB's own statics at exit.
inline tbb::task_arena& arena_for(int threads) {
  static std::mutex mutex;
  static auto* arenas = new std::map<int, std::unique_ptr<tbb::task_arena>>;
  const std::lock_guard<std::mutex> lock(mutex);
  std::unique_ptr<tbb::task_arena>& a = (*arenas)[threads];
  if (!a) a = std::make_unique<tbb::task_arena>(threads);
  return *a;
}

// Runs body(row_begin, row_end, counts) over the row tiles of an image ny rows high on `threads`
// threads (1: in the calling thread, no TBB), then on_tile(rows_in_that_tile) after each, and
// returns the summed counts. Each pixel depends only on its own rays, so the image is the same
// for any split.
template <class Body, class OnTile>
RayCounts run_tiles(int ny, int threads, Body body, OnTile on_tile) {
  const int tiles = (ny + kTileRows - 1) / kTileRows;
  auto tile = [&](int t, RayCounts& counts) {
    const int r0 = t * kTileRows, r1 = std::min(ny, r0 + kTileRows);
    body(r0, r1, counts);
    on_tile(r1 - r0);
  };
  if (threads <= 1) {
    RayCounts counts;
    for (int t = 0; t < tiles; ++t) tile(t, counts);
    return counts;
  }
  tbb::combinable<RayCounts> per_thread;
  arena_for(threads).execute([&] {
    tbb::parallel_for(
        tbb::blocked_range<int>(0, tiles, 1),
        [&](const tbb::blocked_range<int>& r) {
          RayCounts& counts = per_thread.local();
          for (int t = r.begin(); t < r.end(); ++t) tile(t, counts);
        },
        tbb::simple_partitioner());
  });
  RayCounts total;
  per_thread.combine_each([&](const RayCounts& c) { total += c; });
  return total;
}

template <class Body>
RayCounts run_tiles(int ny, int threads, Body body) {
  return run_tiles(ny, threads, body, [](int) {});
}

}  // namespace lancer
