// The difference image `lancer compare --diff` writes by default: every differing pixel visible.
// A linear scale (|a - b| x the largest difference's inverse) left 64 of 65 differing pixels
// black when one of them differed far more than the rest; a log scale from the smallest non-zero
// difference to the largest shows each.
#pragma once

#include <cstdint>

#include "lancer/image.hpp"

namespace lancer {

struct DiffMap {
  Image image;               // the inputs' size, plus the colour bar's rows below
  double low = 0, high = 0;  // the colour bar's ends: the smallest and largest non-zero difference
  int bar_rows = 0;          // the colour bar under the image (after one black row)
  std::uint64_t coloured = 0;  // pixels with a difference, each drawn in colour
};

// Each pixel's largest channel difference |a - b|, coloured on a log scale from `low` (blue) to
// `high` (yellow) through green; identical pixels black, a NaN against a number white. Below
// the image, after a black row, a colour bar from low (left) to high (right).
DiffMap false_colour_difference(const Image& a, const Image& b);

// The map's colour at t in [0, 1] (0: low, 1: high).
void diff_colour(double t, float rgb[3]);

}  // namespace lancer
