// Simple 2D drawings for lancer's figures (lancer flux --plot and --diagram): a list of lines,
// circles and text in pixel coordinates (y down), written as SVG text or rasterised into an
// Image by lancer itself (supersampled, with a built-in 5x7 bitmap font) and written by
// write_image. No drawing library is needed.
#pragma once

#include <string>
#include <vector>

#include "lancer/image.hpp"

namespace lancer::plot {

struct Color {
  double r = 0, g = 0, b = 0;  // 0 .. 1
};
inline constexpr Color kBlack{0, 0, 0};
inline constexpr Color kWhite{1, 1, 1};
inline constexpr Color kRed{0.85, 0, 0};
inline constexpr Color kBlue{0, 0.2, 0.9};
inline constexpr Color kGrey{0.55, 0.55, 0.55};
inline constexpr Color kPointBlue{0.12, 0.47, 0.71};  // matplotlib's first colour

struct Line {
  double x0, y0, x1, y1;
  Color color;
  double width;  // pixels
};

struct Circle {
  double cx, cy, r;
  Color color;
  double stroke;  // outline width in pixels; 0: filled disc
};

enum class Align { start, middle, end };

struct Text {
  double x, y;  // the anchor point
  std::string text;
  Align halign = Align::start;  // along the text
  Align valign = Align::start;  // across it: top, middle or bottom of the glyphs
  int scale = 2;                // bitmap font pixels per font dot: glyphs are 5*scale x 7*scale
  bool vertical = false;        // read bottom to top (turned 90 degrees counter-clockwise)
  Color color = kBlack;
};

// Drawn in order: lines, then circles, then texts.
struct Drawing {
  int width = 0, height = 0;  // pixels
  Color background = kWhite;
  std::vector<Line> lines;
  std::vector<Circle> circles;
  std::vector<Text> texts;
};

// The size in pixels of `text` drawn at font `scale`, along it (width) and across it (height).
double text_width(const std::string& text, int scale);
double text_height(int scale);

// Clips the segment to the rectangle [x0, x1] x [y0, y1] (Liang-Barsky). False when nothing of
// it is inside.
bool clip_segment(double& ax, double& ay, double& bx, double& by, double x0, double y0, double x1,
                  double y1);

// Rasterises with `supersample` x `supersample` samples per pixel, box-filtered.
Image rasterize(const Drawing& d, int supersample = 3);

// SVG 1.1 text of the drawing (texts in a monospace font of about the bitmap font's size).
std::string to_svg(const Drawing& d);

// Writes by extension: .svg as text, anything else rasterised and written by write_image.
// Either way the file appears whole or not at all.
void write_drawing(const Drawing& d, const std::string& path);

// Checks before any work that `path` can take a drawing (.svg or an image format write_image
// writes) and is not the scene file. Throws InputError naming `option` and the path.
void check_drawing_path(const std::string& path, const std::string& option,
                        const std::string& scene_path = "");
// The same for a text file (CSV): a writable folder, not a folder, not the scene file.
void check_text_path(const std::string& path, const std::string& option,
                     const std::string& scene_path = "");

// Writes `text` to `path` through a temporary file beside it, renamed into place.
void write_text_file(const std::string& text, const std::string& path);

// A scatter plot of y against x, as the flux text's figure: points, a box of axes with ticks
// and numbers, an x label below and a y label turned up the left side.
struct ScatterOptions {
  int width = 700, height = 500;
  std::string x_label = "x", y_label = "y", title;
  double point_radius = 3;
  Color point_color = kPointBlue;
  std::vector<std::string> labels;  // optional, one per point, drawn beside it
};
Drawing scatter_plot(const std::vector<double>& x, const std::vector<double>& y,
                     const ScatterOptions& options = {});

// Tick positions for an axis over [lo, hi]: multiples of 1, 2 or 5 times a power of ten, about
// `target` of them, and the number of decimals that prints them exactly.
struct Ticks {
  std::vector<double> values;
  int decimals = 0;
};
Ticks nice_ticks(double lo, double hi, int target = 6);

}  // namespace lancer::plot
