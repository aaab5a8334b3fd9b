// The speed/accuracy trade: for each precision and width, rays per second and the error against
// the double-precision reference (lancer trade).
#pragma once

#include <string>
#include <vector>

#include "lancer/bvh.hpp"
#include "lancer/compare.hpp"
#include "lancer/plot.hpp"
#include "lancer/precision.hpp"
#include "lancer/scene.hpp"

namespace lancer {

struct TradeRow {
  Precision precision = Precision::exact;
  int width = 1;
  std::string isa;
  double mrays_per_s = 0;        // full render, single thread, median of the repeats
  double max_abs_diff = 0;       // largest |difference| of any channel, radiance unclamped
  double psnr_db = 0;            // of the image as displayed (clamped to [0, 1]), peak 1
  double off_pixel_frac = 0;     // pixels with a displayed channel off by more than 1/255
  double hit_mismatch_frac = 0;  // camera rays whose first hit is another object (or none)
};

struct TradeOptions {
  std::vector<Precision> precisions{Precision::exact, Precision::fast, Precision::dbl};
  int repeat = 5;
  double min_seconds = 0.05;
  int threads = 1;
  Accel accel = Accel::automatic;
};

// Every precision at every width this machine runs it, timed with configurations interleaved
// within each repeat; errors against the double reference at width 1.
std::vector<TradeRow> run_trade(const Scene& scene, const TradeOptions& options);

// Speed (x, Mrays/s) against error (y, % of pixels off by more than 1/255): one series per
// precision, one labelled point per width. plot::write_chart (lancer_plot) draws it.
plot::Chart trade_chart(const std::vector<TradeRow>& rows, const std::string& scene_name);

}  // namespace lancer
