// lancer's figures, drawn with cairo (the lancer_plot library; the core lancer library does not
// link it): charts with a title, axes with units and ticks (linear or log10), a legend outside
// the plot area, a colour per series, and point labels placed so that they neither overlap each
// other nor leave the frame. One drawing gives PNG, SVG or PDF by the file's extension (other
// raster formats go through write_image).
#pragma once

#include <limits>
#include <string>
#include <vector>

namespace lancer::plot {

struct Color {
  double r = 0, g = 0, b = 0;  // 0 .. 1
};
bool operator==(const Color& a, const Color& b);
inline constexpr Color kBlack{0, 0, 0};
inline constexpr Color kWhite{1, 1, 1};
inline constexpr Color kGrey{0.55, 0.55, 0.55};
inline constexpr Color kRed{0.84, 0.15, 0.16};
inline constexpr Color kBlue{0.12, 0.47, 0.71};
// A qualitative palette (Tableau 10, the default of matplotlib): series k gets palette(k).
Color palette(int k);

enum class Scale { linear, log10 };

struct Axis {
  std::string label;  // with its unit, e.g. "Mrays/s (1 thread)"
  Scale scale = Scale::linear;
  bool from_zero = false;  // linear: include 0 in the range
  // A fixed range (both finite), instead of the data's with a margin; data beyond is clipped.
  double min = std::numeric_limits<double>::quiet_NaN();
  double max = std::numeric_limits<double>::quiet_NaN();
};

enum class Mark {
  points,       // a marker per point
  line,         // a polyline through the points in order
  line_points,  // both
  segments,     // independent segments: points 2k and 2k + 1
};

struct Series {
  std::string name;  // in the legend; empty: not in the legend
  Color color;
  Mark mark = Mark::points;
  std::vector<double> x, y;
  std::vector<std::string> labels;  // optional, one per point, placed beside it
  double line_width = 1.5;          // points (1/72 inch)
  double marker_radius = 3.5;
  bool dashed = false;
};

// A circle in data units (the flux diagram's spheres), drawn with the series.
struct Circle {
  double cx, cy, r;
  Color color;
  double line_width = 1.5;
};

struct Chart {
  int width = 800, height = 540;  // points; PNG pixels
  std::string title, subtitle;
  Axis x, y;
  std::vector<Series> series;
  std::vector<Circle> circles;
  std::vector<std::string> legend_circles;  // legend entries for the circles, e.g. "spheres"
  bool equal_aspect = false;                // one data unit is as long on both axes
  std::string note;                         // a line under the plot, e.g. the machine
};

// Tick positions for a linear axis over [lo, hi]: multiples of 1, 2 or 5 times a power of ten,
// about `target` of them, and the number of decimals that prints them exactly.
struct Ticks {
  std::vector<double> values;
  int decimals = 0;
};
Ticks nice_ticks(double lo, double hi, int target = 6);

// Writes by extension: .png, .svg, .pdf drawn by cairo; other image formats (.jpg, .tif, .exr,
// .pfm...) rasterised by cairo and written by write_image. The file appears whole or not at all.
void write_chart(const Chart& chart, const std::string& path);

// Where each point label of write_chart went, in device units (for tests): label boxes never
// overlap each other and stay inside the frame.
struct LabelBox {
  double x0, y0, x1, y1;
};
std::vector<LabelBox> label_boxes(const Chart& chart);

// Checks before any work that `path` can take a figure (.svg, .pdf, .png or an image format
// write_image writes) and is not the scene file. Throws InputError naming `option` and the path.
void check_drawing_path(const std::string& path, const std::string& option,
                        const std::string& scene_path = "");
// The same for a text file (CSV): a writable folder, not a folder, not the scene file.
void check_text_path(const std::string& path, const std::string& option,
                     const std::string& scene_path = "");

// Writes `text` to `path` through a temporary file beside it, renamed into place.
void write_text_file(const std::string& text, const std::string& path);

// Clips the segment to the rectangle [x0, x1] x [y0, y1] (Liang-Barsky). False when nothing of
// it is inside.
bool clip_segment(double& ax, double& ay, double& bx, double& by, double x0, double y0, double x1,
                  double y1);

// An axis label for a CSV column, with its unit: the header's own "time (s)" or "time [s]" as
// written, else one read from the name's suffix ("build_s": "build (s)", "mrays_per_s":
// "Mrays/s", "_ms", "_us", "_ns", "_db", "_mb", "_bytes", "_per_s"), else the name.
std::string column_label(const std::string& header_cell);
// A chart from CSV text (a header row, then numbers): `y` against `x`, one series per distinct
// value of `group` (none: one series); a column is named with or without its "(unit)", and the
// axes are labelled by column_label. Throws InputError naming `source` and the line.
Chart chart_from_csv(const std::string& csv, const std::string& source, const std::string& x,
                     const std::string& y, const std::string& group, Mark mark);

}  // namespace lancer::plot
