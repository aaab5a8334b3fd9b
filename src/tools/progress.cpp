#include "lancer/progress.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace lancer {

std::string format_duration(double s) {
  char buf[32];
  if (!(s >= 0) || !std::isfinite(s)) return "?";
  if (s < 60)
    std::snprintf(buf, sizeof buf, "%.1f s", s);
  else if (s < 3600)
    std::snprintf(buf, sizeof buf, "%d min %02d s", int(s) / 60, int(s) % 60);
  else
    std::snprintf(buf, sizeof buf, "%d h %02d min", int(s) / 3600, int(s) % 3600 / 60);
  return buf;
}

std::string progress_line(int done, int all, double elapsed, int columns) {
  const int percent = all > 0 ? int(100LL * done / all) : 100;
  const double rate = elapsed > 0 ? done / elapsed : 0;
  char buf[160];
  std::string text;
  std::snprintf(buf, sizeof buf, " %3d%%", percent);
  const std::string pct = buf;
  std::snprintf(buf, sizeof buf, "  %d/%d rows", done, all);
  const std::string rows = buf;
  const std::string time = "  " + format_duration(elapsed) + " elapsed";
  std::snprintf(buf, sizeof buf, "  %.0f rows/s", rate);
  const std::string speed = rate > 0 ? buf : "";
  const std::string left = done >= all ? "  done"
                           : rate > 0  ? "  " + format_duration((all - done) / rate) + " left"
                                       : "";
  // Parts by priority: the percentage always, then time left, elapsed, rows, rate.
  std::string tail = pct;
  for (const std::string* part : {&left, &time, &rows, &speed})
    if (int(tail.size() + part->size()) + 12 <= columns) tail += *part;
  const int bar = std::clamp(columns - 1 - int(tail.size()) - 2, 0, 40);
  std::string line;
  if (bar >= 5) {
    line = "[";
    const int filled = all > 0 ? int(std::lround(double(bar) * done / all)) : bar;
    line += std::string(std::clamp(filled, 0, bar), '#') +
            std::string(bar - std::clamp(filled, 0, bar), '.');
    line += "]";
  }
  line += tail;
  // One column spare: some terminals wrap when the last column is written.
  if (int(line.size()) > columns - 1) line.resize(std::max(0, columns - 1));
  return line;
}

}  // namespace lancer
