#include "lancer/diff_map.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace lancer {

void diff_colour(double t, float rgb[3]) {
  // Blue, cyan, green, yellow: every stop bright enough to stand out on black.
  static const float stops[4][3] = {
      {0.20f, 0.35f, 1.00f}, {0.10f, 0.80f, 0.90f}, {0.25f, 0.85f, 0.25f}, {1.00f, 0.92f, 0.15f}};
  t = std::clamp(std::isfinite(t) ? t : 1.0, 0.0, 1.0) * 3;
  const int k = std::min(int(t), 2);
  const float f = float(t - k);
  for (int c = 0; c < 3; ++c) rgb[c] = stops[k][c] + f * (stops[k + 1][c] - stops[k][c]);
}

DiffMap false_colour_difference(const Image& a, const Image& b) {
  DiffMap m;
  const std::size_t pixels = std::size_t(a.nx) * std::size_t(a.ny);
  std::vector<double> d(pixels, 0.0);  // largest channel difference; infinity: NaN vs number
  m.low = std::numeric_limits<double>::infinity();
  for (std::size_t p = 0; p < pixels; ++p) {
    for (int c = 0; c < 3; ++c) {
      const float x = a.rgb[p * 3 + c], y = b.rgb[p * 3 + c];
      const double diff = std::isnan(x) != std::isnan(y) ? std::numeric_limits<double>::infinity()
                          : std::isnan(x)                ? 0.0
                                                         : std::fabs(double(x) - double(y));
      d[p] = std::max(d[p], diff);
    }
    if (d[p] > 0 && std::isfinite(d[p])) {
      m.low = std::min(m.low, d[p]);
      m.high = std::max(m.high, d[p]);
    }
    m.coloured += d[p] > 0;
  }
  if (!(m.high > 0)) m.low = m.high = 0;
  m.bar_rows = std::clamp(a.ny / 16, 4, 32);
  m.image = Image(a.nx, a.ny + 1 + m.bar_rows);
  const double span = m.high > m.low ? std::log(m.high / m.low) : 0;
  auto t_of = [&](double v) { return span > 0 ? std::log(v / m.low) / span : 1.0; };
  for (std::size_t p = 0; p < pixels; ++p) {
    float* out = m.image.rgb.data() + p * 3;
    if (std::isinf(d[p]))
      out[0] = out[1] = out[2] = 1.0f;
    else if (d[p] > 0)
      diff_colour(t_of(d[p]), out);
  }
  for (int j = a.ny + 1; j < m.image.ny; ++j)
    for (int i = 0; i < a.nx; ++i)
      diff_colour(a.nx > 1 ? double(i) / double(a.nx - 1) : 1.0, m.image.pixel(i, j));
  return m;
}

}  // namespace lancer
