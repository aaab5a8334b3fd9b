// Comparing two renders of the same scene: bit identity (validate) and error (tests, trade).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "lancer/image.hpp"

namespace lancer {

// Distance between two floats in units in the last place (0 for identical bits, also 0 for
// +0 vs -0; huge for NaN against a number).
std::uint64_t ulp_distance(float a, float b);

struct BitDiff {
  std::uint64_t differing_pixels = 0;
  std::uint64_t max_ulps = 0;
  int first_i = -1, first_j = -1;  // first differing pixel in row-major order, or -1
  bool identical() const { return differing_pixels == 0; }
};
// Same size required (checked).
BitDiff bit_diff(const Image& a, const Image& b);

struct ErrorStats {
  double max_abs = 0;       // over channels
  double psnr_db = 0;       // against peak 1; infinity when identical
  double off_fraction = 0;  // pixels with some channel off by more than `threshold`
  std::uint64_t off_pixels = 0;
};
// Values are clamped to [0, 1] first when `as_displayed` (what an 8-bit file would show).
ErrorStats error_stats(const Image& test, const Image& truth, double threshold,
                       bool as_displayed = true);

// Everything `lancer compare A B` reports about two images of the same size: bit identity and
// ULPs (bit_diff), error and PSNR on the values as stored (error_stats, unclamped unless
// `as_displayed`), and the fraction of pixels off by more than each of `thresholds`.
struct ImageComparison {
  BitDiff bits;
  ErrorStats error;  // at thresholds[0]; off_fraction per threshold below
  std::vector<double> thresholds;
  std::vector<double> off_fractions;  // one per threshold
  std::vector<std::uint64_t> off_pixels;
};
ImageComparison compare_images(const Image& a, const Image& b,
                               const std::vector<double>& thresholds, bool as_displayed = false);

// |a - b| per channel, times `scale`: the difference image `lancer compare --diff` writes.
Image difference_image(const Image& a, const Image& b, double scale);

}  // namespace lancer
