// The data side of lancer's figures, in the core library (no drawing library): charts as plain
// values, tick positions, clipping, output-path checks, charts from CSV. Drawing them is
// src/tools/plot_cairo.cpp, in lancer_plot.
#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>

#include "lancer/error.hpp"
#include "lancer/image.hpp"
#include "lancer/output_file.hpp"
#include "lancer/plot.hpp"
#include "lancer/text.hpp"

namespace lancer::plot {

namespace fs = std::filesystem;

namespace {

std::string lower_extension(const std::string& path) {
  std::string ext = fs::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return char(std::tolower(c)); });
  return ext;
}

}  // namespace

bool operator==(const Color& a, const Color& b) { return a.r == b.r && a.g == b.g && a.b == b.b; }

Color palette(int k) {
  static constexpr Color kTableau[] = {
      {0.122, 0.467, 0.706}, {1.000, 0.498, 0.055}, {0.173, 0.627, 0.173}, {0.839, 0.153, 0.157},
      {0.580, 0.404, 0.741}, {0.549, 0.337, 0.294}, {0.890, 0.467, 0.761}, {0.498, 0.498, 0.498},
      {0.737, 0.741, 0.133}, {0.090, 0.745, 0.812}};
  return kTableau[((k % 10) + 10) % 10];
}

bool clip_segment(double& ax, double& ay, double& bx, double& by, double x0, double y0, double x1,
                  double y1) {
  const double dx = bx - ax, dy = by - ay;
  double t0 = 0, t1 = 1;
  const double p[4] = {-dx, dx, -dy, dy};
  const double q[4] = {ax - x0, x1 - ax, ay - y0, y1 - ay};
  for (int k = 0; k < 4; ++k) {
    if (p[k] == 0) {
      if (q[k] < 0) return false;
      continue;
    }
    const double t = q[k] / p[k];
    if (p[k] < 0)
      t0 = std::max(t0, t);
    else
      t1 = std::min(t1, t);
    if (t0 > t1) return false;
  }
  const double sx = ax, sy = ay;
  ax = sx + t0 * dx, ay = sy + t0 * dy;
  bx = sx + t1 * dx, by = sy + t1 * dy;
  return true;
}

void check_text_path(const std::string& path, const std::string& option,
                     const std::string& scene_path) {
  if (path.empty()) throw InputError(option + ": output path is empty");
  try {
    check_writable_target(path, scene_path);
  } catch (const InputError& e) {
    throw InputError(option + " " + e.what());
  }
}

void check_drawing_path(const std::string& path, const std::string& option,
                        const std::string& scene_path) {
  if (path.empty()) throw InputError(option + ": output path is empty");
  const std::string ext = lower_extension(path);
  if (ext == ".svg" || ext == ".pdf") return check_text_path(path, option, scene_path);
  // A drawing takes .svg and .pdf beside the image formats: say so, not just the images'.
  bool image = false;
  std::string known = ".svg .pdf";
  for (const ImageFormat& f : image_formats()) {
    image = image || ext == f.extension;
    known += std::string(" ") + f.extension;
  }
  if (!image && path != "-")  // "-": check_output_path says a drawing is a file, not stdout
    throw InputError(option + " " + shown_path(path) + ": " +
                     (ext.empty() ? "no extension to choose a format from"
                                  : "lancer does not draw '" + ext + "' files") +
                     " (it draws " + known + ")");
  try {
    check_output_path(path, scene_path);
  } catch (const InputError& e) {
    throw InputError(option + " " + e.what());
  }
}

void write_text_file(const std::string& text, const std::string& path) {
  write_file_atomically(path, [&](OutputFile& out) { out.write(text.data(), text.size()); });
}

Ticks nice_ticks(double lo, double hi, int target) {
  Ticks t;
  if (!(hi > lo) || !std::isfinite(lo) || !std::isfinite(hi)) return t;
  const double raw = (hi - lo) / std::max(1, target);
  const double mag = std::pow(10.0, std::floor(std::log10(raw)));
  const double norm = raw / mag;
  const double mult = norm < 1.5 ? 1 : norm < 3 ? 2 : norm < 7 ? 5 : 10;
  const double step = mult * mag;
  t.decimals = std::max(0, -int(std::floor(std::log10(step) + 1e-9)));
  const long long k0 = (long long)std::ceil(lo / step - 1e-9);
  const long long k1 = (long long)std::floor(hi / step + 1e-9);
  for (long long k = k0; k <= k1; ++k) t.values.push_back(double(k) * step);
  return t;
}

namespace {
std::vector<std::string> split_csv_line(const std::string& line) {
  std::vector<std::string> cells;
  std::stringstream ss(line);
  for (std::string cell; std::getline(ss, cell, ',');) {
    cell.erase(0, cell.find_first_not_of(" \t\r"));
    cell.erase(cell.find_last_not_of(" \t\r") + 1);
    cells.push_back(cell);
  }
  if (!line.empty() && line.back() == ',') cells.emplace_back();
  return cells;
}

// A header cell's name without the unit it may carry: "time (s)" and "time [s]" are "time".
std::string column_name(const std::string& cell) {
  const auto open = cell.find_first_of("([");
  if (open == std::string::npos || open == 0) return cell;
  std::string name = cell.substr(0, open);
  name.erase(name.find_last_not_of(" \t") + 1);
  return name;
}
}  // namespace

std::string column_label(const std::string& cell) {
  if (cell.find_first_of("([") != std::string::npos) return cell;  // the unit is written
  auto ends = [&cell](const std::string& tail) {
    return cell.size() > tail.size() &&
           cell.compare(cell.size() - tail.size(), tail.size(), tail) == 0;
  };
  auto head = [&cell](std::size_t tail) { return cell.substr(0, cell.size() - tail); };
  if (cell == "mrays_per_s") return "Mrays/s";
  if (ends("_per_s")) return head(6) + " (/s)";
  for (const char* unit : {"s", "ms", "us", "ns", "db", "mb", "bytes"}) {
    const std::string u = unit;
    if (ends("_" + u))
      return head(u.size() + 1) + " (" + (u == "db" ? "dB" : u == "mb" ? "MB" : u) + ")";
  }
  if (cell == "seconds") return "seconds (s)";
  return cell;
}

Chart chart_from_csv(const std::string& csv, const std::string& source, const std::string& x,
                     const std::string& y, const std::string& group, Mark mark) {
  std::stringstream in(csv);
  std::string line;
  int line_no = 0;
  while (std::getline(in, line) && ++line_no &&
         line.find_first_not_of(" \t\r") == std::string::npos) {
  }
  if (line_no == 0 || line.empty()) throw InputError(source + ": empty, expected a header row");
  const std::vector<std::string> header = split_csv_line(line);
  auto column = [&](const std::string& name, const std::string& option) {
    auto it = std::find(header.begin(), header.end(), name);
    if (it == header.end())
      it = std::find_if(header.begin(), header.end(),
                        [&](const std::string& cell) { return column_name(cell) == name; });
    if (it == header.end())
      throw InputError(source + ":" + std::to_string(line_no) + ": no column '" + name + "' (for " +
                       option + ")");
    return std::size_t(it - header.begin());
  };
  const std::size_t cx = column(x, "--x"), cy = column(y, "--y");
  const std::size_t cg = group.empty() ? std::size_t(-1) : column(group, "--group");
  Chart chart;
  chart.x.label = column_label(header[cx]);
  chart.y.label = column_label(header[cy]);
  std::map<std::string, std::size_t> index;
  while (std::getline(in, line)) {
    ++line_no;
    if (line.find_first_not_of(" \t\r") == std::string::npos) continue;
    const std::vector<std::string> cells = split_csv_line(line);
    if (cells.size() != header.size())
      throw InputError(source + ":" + std::to_string(line_no) + ": " +
                       std::to_string(cells.size()) + " cells, the header has " +
                       std::to_string(header.size()));
    auto number = [&](std::size_t c) {
      const std::string& t = cells[c];
      char* end = nullptr;
      const double v = std::strtod(t.c_str(), &end);
      if (t.empty() || *end != 0 || !std::isfinite(v))
        throw InputError(source + ":" + std::to_string(line_no) + ": " + header[c] + ": '" + t +
                         "' is not a finite number");
      return v;
    };
    const std::string key = cg == std::size_t(-1) ? "" : cells[cg];
    auto it = index.find(key);
    if (it == index.end()) {
      it = index.emplace(key, chart.series.size()).first;
      Series s;
      s.name = key;  // the group's value, e.g. the engine
      s.color = palette(int(chart.series.size()));
      s.mark = mark;
      chart.series.push_back(s);
    }
    Series& s = chart.series[it->second];
    s.x.push_back(number(cx));
    s.y.push_back(number(cy));
  }
  if (chart.series.empty()) throw InputError(source + ": no data rows");
  return chart;
}

}  // namespace lancer::plot
