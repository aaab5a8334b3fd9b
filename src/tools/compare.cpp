#include "lancer/compare.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>

#include "lancer/error.hpp"

namespace lancer {

namespace {
// Maps a float's bits onto a line where adjacent floats differ by one.
std::int64_t ordered(float f) {
  std::int32_t i;
  std::memcpy(&i, &f, sizeof i);
  return i < 0 ? std::int64_t(std::numeric_limits<std::int32_t>::min()) - i : i;
}
double clamp01(double v) { return v > 0 ? (v < 1 ? v : 1) : 0; }
}  // namespace

std::uint64_t ulp_distance(float a, float b) {
  const std::int64_t d = ordered(a) - ordered(b);
  return static_cast<std::uint64_t>(d < 0 ? -d : d);
}

BitDiff bit_diff(const Image& a, const Image& b) {
  LANCER_CHECK_OP(a.nx, ==, b.nx);
  LANCER_CHECK_OP(a.ny, ==, b.ny);
  BitDiff d;
  for (int j = 0; j < a.ny; ++j) {
    for (int i = 0; i < a.nx; ++i) {
      const float* pa = a.pixel(i, j);
      const float* pb = b.pixel(i, j);
      if (std::memcmp(pa, pb, 3 * sizeof(float)) == 0) continue;
      if (d.differing_pixels++ == 0) d.first_i = i, d.first_j = j;
      for (int c = 0; c < 3; ++c) d.max_ulps = std::max(d.max_ulps, ulp_distance(pa[c], pb[c]));
    }
  }
  return d;
}

ErrorStats error_stats(const Image& test, const Image& truth, double threshold, bool as_displayed) {
  LANCER_CHECK_OP(test.nx, ==, truth.nx);
  LANCER_CHECK_OP(test.ny, ==, truth.ny);
  ErrorStats e;
  double sq = 0;
  const std::size_t pixels = std::size_t(test.nx) * test.ny;
  for (std::size_t p = 0; p < pixels; ++p) {
    bool off = false;
    for (int c = 0; c < 3; ++c) {
      double a = test.rgb[p * 3 + c], b = truth.rgb[p * 3 + c];
      if (as_displayed) a = clamp01(a), b = clamp01(b);
      const double diff = std::isnan(a) != std::isnan(b) ? INFINITY : std::fabs(a - b);
      e.max_abs = std::max(e.max_abs, diff);
      sq += diff * diff;
      off = off || diff > threshold;
    }
    e.off_pixels += off;
  }
  e.off_fraction = pixels ? double(e.off_pixels) / double(pixels) : 0;
  const double mse = pixels ? sq / (3.0 * pixels) : 0;
  e.psnr_db = mse > 0 ? 10.0 * std::log10(1.0 / mse) : INFINITY;
  return e;
}

ImageComparison compare_images(const Image& a, const Image& b,
                               const std::vector<double>& thresholds, bool as_displayed) {
  ImageComparison c;
  c.bits = bit_diff(a, b);
  c.thresholds = thresholds;
  for (std::size_t k = 0; k < thresholds.size(); ++k) {
    const ErrorStats e = error_stats(a, b, thresholds[k], as_displayed);
    if (k == 0) c.error = e;
    c.off_fractions.push_back(e.off_fraction);
    c.off_pixels.push_back(e.off_pixels);
  }
  if (thresholds.empty()) c.error = error_stats(a, b, INFINITY, as_displayed);
  return c;
}

Image difference_image(const Image& a, const Image& b, double scale) {
  LANCER_CHECK_OP(a.nx, ==, b.nx);
  LANCER_CHECK_OP(a.ny, ==, b.ny);
  Image d(a.nx, a.ny);
  for (std::size_t k = 0; k < d.rgb.size(); ++k) {
    const double diff = std::fabs(double(a.rgb[k]) - double(b.rgb[k]));
    d.rgb[k] = float(std::isnan(diff) ? 1.0 : diff * scale);
  }
  return d;
}

}  // namespace lancer
