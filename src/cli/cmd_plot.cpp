// lancer plot DATA.csv -o FIG.svg: a chart of one CSV column against another, one series per
// value of a third, with linear or log10 axes; e.g. the scaling figure, Mrays/s against sphere
// count, log-log, one series per engine:
//   lancer plot scaling.csv --x spheres --y mrays_per_s --group engine --log xy -o scaling.svg
#include <cstdio>
#include <memory>

#include "commands.hpp"
#include "lancer/error.hpp"
#include "lancer/input_file.hpp"
#include "lancer/plot.hpp"
#include "lancer/text.hpp"

namespace lancer::cli {

namespace {
// The CSV is held in memory with the chart made of it (docs/limits.md).
constexpr std::size_t kMaxCsvBytes = std::size_t(1) << 30;

struct PlotArgs {
  std::string csv, output, x, y, group, log, title, x_label, y_label, mark = "line_points";
  int width = 800, height = 540;
};

// A log axis shows no value <= 0: those points are taken out here, and counted, so that the
// summary says what was drawn and what was left out rather than counting points not drawn.
std::size_t drop_off_scale(plot::Chart& c) {
  const bool log_x = c.x.scale == plot::Scale::log10, log_y = c.y.scale == plot::Scale::log10;
  std::size_t dropped = 0;
  for (plot::Series& s : c.series) {
    std::size_t kept = 0;
    for (std::size_t i = 0; i < s.x.size(); ++i) {
      if ((log_x && !(s.x[i] > 0)) || (log_y && !(s.y[i] > 0))) {
        ++dropped;
        continue;
      }
      s.x[kept] = s.x[i], s.y[kept] = s.y[i];
      if (i < s.labels.size()) s.labels[kept] = s.labels[i];
      ++kept;
    }
    s.x.resize(kept), s.y.resize(kept);
    if (s.labels.size() > kept) s.labels.resize(kept);
  }
  return dropped;
}

void run_plot(const PlotArgs& a) {
  plot::check_drawing_path(a.output, "-o", a.csv);
  if (a.log.find_first_not_of("xy") != std::string::npos)
    throw InputError("--log: must be x, y or xy, not '" + a.log + "'");
  const plot::Mark mark = a.mark == "points"        ? plot::Mark::points
                          : a.mark == "line"        ? plot::Mark::line
                          : a.mark == "line_points" ? plot::Mark::line_points
                                                    : throw InputError(
                                                          "--mark: must be points, line or "
                                                          "line_points, not '" +
                                                          a.mark + "'");
  if (a.width < 200 || a.height < 150 || a.width > 10000 || a.height > 10000)
    throw InputError("--width, --height: from 200x150 to 10000x10000");
  // Through the one bounded reader: /dev/zero or a FIFO is refused, not read for ever.
  const std::string text = read_input_file(a.csv, kMaxCsvBytes, "CSV file", "1 GiB");
  plot::Chart c = plot::chart_from_csv(text, a.csv, a.x, a.y, a.group, mark);
  c.width = a.width, c.height = a.height;
  c.title = a.title.empty() ? a.y + " against " + a.x : a.title;
  if (!a.x_label.empty()) c.x.label = a.x_label;
  if (!a.y_label.empty()) c.y.label = a.y_label;
  if (a.log.find('x') != std::string::npos) c.x.scale = plot::Scale::log10;
  if (a.log.find('y') != std::string::npos) c.y.scale = plot::Scale::log10;
  const std::size_t dropped = drop_off_scale(c);
  std::size_t points = 0;
  for (const plot::Series& s : c.series) points += s.x.size();
  if (points == 0 && dropped > 0)
    throw InputError("--log " + a.log + ": every point has a value <= 0 on the log axis (" +
                     std::to_string(dropped) + " points): nothing to draw");
  plot::write_chart(c, a.output);
  const std::string off =
      dropped ? " (" + std::to_string(dropped) + " with a value <= 0 on the log axis left out)"
              : "";
  std::printf("lancer plot: %s: %zu series, %zu point%s%s -> %s\n", shown_path(a.csv).c_str(),
              c.series.size(), points, points == 1 ? "" : "s", off.c_str(),
              shown_path(a.output).c_str());
}
}  // namespace

void add_plot(CLI::App& app) {
  auto args = std::make_shared<PlotArgs>();
  CLI::App* cmd = app.add_subcommand(
      "plot", "Draw a chart from CSV columns (.png, .svg or .pdf), one series per --group value");
  cmd->add_option("csv", args->csv, "CSV file: a header row, then rows of numbers")->required();
  cmd->add_option("-o,--output", args->output, "Figure: .png, .svg, .pdf")->required();
  cmd->add_option("--x", args->x, "Column along x")->required();
  cmd->add_option("--y", args->y, "Column along y")->required();
  cmd->add_option("--group", args->group, "Column whose values name the series (e.g. engine)");
  cmd->add_option("--log", args->log, "Log10 axes: x, y or xy");
  cmd->add_option("--title", args->title, "Title (default: Y against X)");
  cmd->add_option("--x-label", args->x_label, "x axis label with its unit (default: the column)");
  cmd->add_option("--y-label", args->y_label, "y axis label with its unit (default: the column)");
  cmd->add_option("--mark", args->mark, "points, line or line_points")->capture_default_str();
  cmd->add_option("--width", args->width, "Figure width in points (PNG pixels), 200 to 10000")
      ->capture_default_str();
  cmd->add_option("--height", args->height, "Figure height, 150 to 10000")->capture_default_str();
  cmd->callback([args] { run_plot(*args); });
}

}  // namespace lancer::cli
