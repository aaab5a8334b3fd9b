// Drawing lancer's charts with cairo: anti-aliased text and lines, and PNG, SVG and PDF from one
// drawing. Layout first (every box measured with cairo's own text extents), then drawing, so that
// tests can check where the labels went without drawing.
#include <cairo-pdf.h>
#include <cairo-svg.h>
#include <cairo.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <memory>

#include "lancer/error.hpp"
#include "lancer/image.hpp"
#include "lancer/output_file.hpp"
#include "lancer/plot.hpp"

namespace lancer::plot {

namespace {

constexpr const char* kFont = "DejaVu Sans";
constexpr double kTitleSize = 16, kSubtitleSize = 11.5, kLabelSize = 13, kTickSize = 11.5;
constexpr double kLegendSize = 12, kPointLabelSize = 10.5, kPad = 10;

struct Surface {
  cairo_surface_t* s;
  ~Surface() { cairo_surface_destroy(s); }
};
struct Context {
  cairo_t* cr;
  ~Context() { cairo_destroy(cr); }
};

struct Size {
  double w = 0, h = 0;
};

void font(cairo_t* cr, double size, bool bold = false) {
  cairo_select_font_face(cr, kFont, CAIRO_FONT_SLANT_NORMAL,
                         bold ? CAIRO_FONT_WEIGHT_BOLD : CAIRO_FONT_WEIGHT_NORMAL);
  cairo_set_font_size(cr, size);
}

// Width by the advance, height by the font's ascent + descent: boxes of every string of one size
// are equally tall, so rows of labels line up.
Size measure(cairo_t* cr, const std::string& text, double size, bool bold = false) {
  font(cr, size, bold);
  cairo_text_extents_t te;
  cairo_font_extents_t fe;
  cairo_text_extents(cr, text.c_str(), &te);
  cairo_font_extents(cr, &fe);
  return {text.empty() ? 0 : te.x_advance, fe.ascent + fe.descent};
}

// Draws `text` with its box's top-left corner at (x, y).
void text_at(cairo_t* cr, const std::string& text, double x, double y, double size, const Color& c,
             bool bold = false) {
  font(cr, size, bold);
  cairo_font_extents_t fe;
  cairo_font_extents(cr, &fe);
  cairo_set_source_rgb(cr, c.r, c.g, c.b);
  cairo_move_to(cr, x, y + fe.ascent);
  cairo_show_text(cr, text.c_str());
}

std::string format_linear(double v, int decimals) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*f", decimals, v);
  std::string s = buf;
  if (s[0] == '-' && s.find_first_not_of("-0.") == std::string::npos) s.erase(0, 1);
  return s;
}

std::string format_log(double v) {
  char buf[64];
  const double e = std::log10(v);
  if (v >= 1e-3 && v < 1e6)
    std::snprintf(buf, sizeof buf, "%g", v);
  else if (std::fabs(e - std::round(e)) < 1e-9)
    std::snprintf(buf, sizeof buf, "1e%d", int(std::round(e)));
  else
    std::snprintf(buf, sizeof buf, "%.3g", v);
  return buf;
}

// One axis: data range (in transformed units: log10 of the values on a log axis) and ticks.
struct AxisLayout {
  Scale scale = Scale::linear;
  double lo = 0, hi = 1;             // transformed
  std::vector<double> ticks, minor;  // transformed
  std::vector<std::string> tick_text;
  double t(double v) const { return scale == Scale::log10 ? std::log10(v) : v; }
  bool usable(double v) const { return std::isfinite(v) && (scale == Scale::linear || v > 0); }
};

void set_ticks(AxisLayout& a) {
  a.ticks.clear(), a.minor.clear(), a.tick_text.clear();
  if (a.scale == Scale::linear) {
    const Ticks t = nice_ticks(a.lo, a.hi, 6);
    for (double v : t.values)
      a.ticks.push_back(v), a.tick_text.push_back(format_linear(v, t.decimals));
    return;
  }
  const int e0 = int(std::floor(a.lo)), e1 = int(std::ceil(a.hi));
  // Decades, thinned when there are many; 2 and 5 between them when there are few.
  const int step = std::max(1, (e1 - e0) / 8);
  for (int e = e0; e <= e1; ++e) {
    for (int m = 1; m < 10; ++m) {
      const double v = std::log10(m * std::pow(10.0, e));
      if (v < a.lo - 1e-9 || v > a.hi + 1e-9) continue;
      const bool major = m == 1 ? (e - e0) % step == 0 : (e1 - e0 <= 2 && (m == 2 || m == 5));
      if (major) {
        a.ticks.push_back(v);
        a.tick_text.push_back(format_log(m * std::pow(10.0, e)));
      } else {
        a.minor.push_back(v);
      }
    }
  }
}

AxisLayout axis_range(const Axis& axis, const Chart& c, bool is_x) {
  AxisLayout a;
  a.scale = axis.scale;
  if (std::isfinite(axis.min) && std::isfinite(axis.max) && axis.max > axis.min &&
      a.usable(axis.min) && a.usable(axis.max)) {
    a.lo = a.t(axis.min), a.hi = a.t(axis.max);
    return a;
  }
  double lo = INFINITY, hi = -INFINITY;
  auto add = [&](double v) {
    if (!a.usable(v)) return;
    lo = std::min(lo, a.t(v)), hi = std::max(hi, a.t(v));
  };
  for (const Series& s : c.series)
    for (double v : is_x ? s.x : s.y) add(v);
  for (const Circle& k : c.circles) {
    const double m = is_x ? k.cx : k.cy;
    add(m - k.r), add(m + k.r);
  }
  if (axis.from_zero && a.scale == Scale::linear) lo = std::min(lo, 0.0), hi = std::max(hi, 0.0);
  if (!(lo <= hi)) lo = 0, hi = 1;
  if (hi - lo < 1e-12 * std::max(1.0, std::fabs(hi))) {
    const double d = a.scale == Scale::log10 ? 0.5 : std::max(1.0, std::fabs(hi) * 0.1);
    lo -= d, hi += d;
  }
  const double pad = 0.05 * (hi - lo);
  a.lo = lo - pad;  // also below a zero, so that markers on it are not cut by the frame
  a.hi = hi + pad;
  return a;
}

struct Layout {
  double px0, py0, px1, py1;  // the plot area
  AxisLayout ax, ay;
  double title_y = kPad, subtitle_y = 0;
  double legend_x = 0, legend_y = 0, legend_row = 0;
  std::vector<LabelBox> labels;  // one per labelled point, in order; x0 > x1: not placed
  std::vector<std::pair<double, double>> label_anchor;
  double X(double v) const { return px0 + (ax.t(v) - ax.lo) / (ax.hi - ax.lo) * (px1 - px0); }
  double Y(double v) const { return py1 - (ay.t(v) - ay.lo) / (ay.hi - ay.lo) * (py1 - py0); }
};

bool overlaps(const LabelBox& a, const LabelBox& b) {
  return a.x0 < b.x1 && b.x0 < a.x1 && a.y0 < b.y1 && b.y0 < a.y1;
}

struct LegendEntry {
  std::string name;
  Color color;
  Mark mark;
  bool dashed;
  bool circle;
};

std::vector<LegendEntry> legend_entries(const Chart& c) {
  std::vector<LegendEntry> out;
  for (const Series& s : c.series)
    if (!s.name.empty()) out.push_back({s.name, s.color, s.mark, s.dashed, false});
  if (!c.legend_circles.empty() && !c.circles.empty())
    out.push_back({c.legend_circles.front(), c.circles.front().color, Mark::line, false, true});
  return out;
}

Layout layout(const Chart& c, cairo_t* cr) {
  Layout L;
  L.ax = axis_range(c.x, c, true);
  L.ay = axis_range(c.y, c, false);
  set_ticks(L.ax), set_ticks(L.ay);

  double top = kPad;
  if (!c.title.empty()) top += measure(cr, c.title, kTitleSize, true).h + 2;
  L.subtitle_y = top;
  if (!c.subtitle.empty()) top += measure(cr, c.subtitle, kSubtitleSize).h;
  top += kPad;

  double ytick_w = 0;
  for (const std::string& t : L.ay.tick_text)
    ytick_w = std::max(ytick_w, measure(cr, t, kTickSize).w);
  const double label_h = measure(cr, "Mg", kLabelSize).h, tick_h = measure(cr, "0", kTickSize).h;
  const double left = kPad + (c.y.label.empty() ? 0 : label_h + 6) + ytick_w + 8;
  double bottom = kPad + tick_h + 6 + (c.x.label.empty() ? 0 : label_h + 4);
  if (!c.note.empty()) bottom += measure(cr, c.note, kTickSize).h + 4;

  const std::vector<LegendEntry> legend = legend_entries(c);
  double legend_w = 0;
  for (const LegendEntry& e : legend)
    legend_w = std::max(legend_w, measure(cr, e.name, kLegendSize).w);
  const double right = legend.empty() ? kPad + 12 : kPad + 28 + legend_w + kPad + 6;

  L.px0 = left, L.py0 = top, L.px1 = c.width - right, L.py1 = c.height - bottom;
  if (L.px1 - L.px0 < 40 || L.py1 - L.py0 < 40)
    throw InputError("figure: " + std::to_string(c.width) + "x" + std::to_string(c.height) +
                     " is too small for its labels");
  L.legend_x = L.px1 + kPad + 6;
  L.legend_y = L.py0;
  L.legend_row = measure(cr, "Mg", kLegendSize).h + 4;

  if (c.equal_aspect) {
    // Widen the range that is too narrow for its side, around its centre.
    const double w = L.px1 - L.px0, h = L.py1 - L.py0;
    const double ux = (L.ax.hi - L.ax.lo) / w, uy = (L.ay.hi - L.ay.lo) / h;
    if (ux < uy) {
      const double mid = (L.ax.lo + L.ax.hi) / 2;
      L.ax.lo = mid - uy * w / 2, L.ax.hi = mid + uy * w / 2;
    } else {
      const double mid = (L.ay.lo + L.ay.hi) / 2;
      L.ay.lo = mid - ux * h / 2, L.ay.hi = mid + ux * h / 2;
    }
    set_ticks(L.ax), set_ticks(L.ay);
  }

  // Point labels: the first of a ring of places around the point that stays in the plot area and
  // overlaps no label already placed (nor, if it can, any marker); farther rings get a leader
  // line. A label with no free place is left out rather than drawn over another.
  std::vector<LabelBox> markers;
  for (const Series& s : c.series) {
    if (s.mark == Mark::line || s.mark == Mark::segments) continue;
    for (std::size_t i = 0; i < s.x.size() && i < s.y.size(); ++i) {
      if (!L.ax.usable(s.x[i]) || !L.ay.usable(s.y[i])) continue;
      const double x = L.X(s.x[i]), y = L.Y(s.y[i]), r = s.marker_radius + 1;
      markers.push_back({x - r, y - r, x + r, y + r});
    }
  }
  for (const Series& s : c.series) {
    for (std::size_t i = 0; i < s.labels.size() && i < s.x.size() && i < s.y.size(); ++i) {
      LabelBox none{1, 0, 0, 0};
      if (s.labels[i].empty() || !L.ax.usable(s.x[i]) || !L.ay.usable(s.y[i])) {
        L.labels.push_back(none), L.label_anchor.push_back({0, 0});
        continue;
      }
      const Size sz = measure(cr, s.labels[i], kPointLabelSize);
      const double x = L.X(s.x[i]), y = L.Y(s.y[i]);
      LabelBox best = none;
      bool found = false;
      for (int ring = 1; ring <= 8 && !found; ++ring) {
        const double d = s.marker_radius + 3 + (ring - 1) * 0.9 * sz.h;
        for (int k = 0; k < 16 && !found; ++k) {
          const double a = k * M_PI / 8;  // 0: right, then counter-clockwise
          const double ca = std::cos(a), sa = -std::sin(a);
          // Anchor the box's nearest side or corner at distance d in direction a.
          const double bx = x + d * ca - (ca < -0.3 ? sz.w : ca > 0.3 ? 0 : sz.w / 2);
          const double by = y + d * sa - (sa < -0.3 ? sz.h : sa > 0.3 ? 0 : sz.h / 2);
          const LabelBox b{bx, by, bx + sz.w, by + sz.h};
          if (b.x0 < L.px0 + 2 || b.x1 > L.px1 - 2 || b.y0 < L.py0 + 2 || b.y1 > L.py1 - 2)
            continue;
          bool clash = false;
          for (const LabelBox& o : L.labels) clash = clash || (o.x0 <= o.x1 && overlaps(b, o));
          for (const LabelBox& m : markers) clash = clash || overlaps(b, m);
          if (!clash) best = b, found = true;
        }
      }
      L.labels.push_back(best);
      L.label_anchor.push_back({x, y});
    }
  }
  return L;
}

void set_color(cairo_t* cr, const Color& c, double alpha = 1) {
  cairo_set_source_rgba(cr, c.r, c.g, c.b, alpha);
}

void marker(cairo_t* cr, double x, double y, double r, const Color& c) {
  cairo_new_sub_path(cr);
  cairo_arc(cr, x, y, r, 0, 2 * M_PI);
  set_color(cr, c);
  cairo_fill_preserve(cr);
  cairo_set_source_rgb(cr, 1, 1, 1);
  cairo_set_line_width(cr, 0.8);
  cairo_stroke(cr);
}

// The grid, then the data clipped to the plot area.
void draw_data(const Chart& c, const Layout& L, cairo_t* cr) {
  const Color grid{0.88, 0.88, 0.88}, faint{0.94, 0.94, 0.94};
  // Grid.
  cairo_set_line_width(cr, 0.8);
  auto vline = [&](double tx, const Color& col) {
    const double x = L.px0 + (tx - L.ax.lo) / (L.ax.hi - L.ax.lo) * (L.px1 - L.px0);
    set_color(cr, col);
    cairo_move_to(cr, x, L.py0), cairo_line_to(cr, x, L.py1), cairo_stroke(cr);
  };
  auto hline = [&](double ty, const Color& col) {
    const double y = L.py1 - (ty - L.ay.lo) / (L.ay.hi - L.ay.lo) * (L.py1 - L.py0);
    set_color(cr, col);
    cairo_move_to(cr, L.px0, y), cairo_line_to(cr, L.px1, y), cairo_stroke(cr);
  };
  for (double t : L.ax.minor) vline(t, faint);
  for (double t : L.ay.minor) hline(t, faint);
  for (double t : L.ax.ticks) vline(t, grid);
  for (double t : L.ay.ticks) hline(t, grid);

  // Data, clipped to the plot area.
  cairo_save(cr);
  cairo_rectangle(cr, L.px0, L.py0, L.px1 - L.px0, L.py1 - L.py0);
  cairo_clip(cr);
  cairo_set_line_join(cr, CAIRO_LINE_JOIN_ROUND);
  cairo_set_line_cap(cr, CAIRO_LINE_CAP_ROUND);
  const double sx = (L.px1 - L.px0) / (L.ax.hi - L.ax.lo);
  for (const Circle& k : c.circles) {
    if (L.ax.scale != Scale::linear || L.ay.scale != Scale::linear) break;
    cairo_save(cr);
    cairo_translate(cr, L.X(k.cx), L.Y(k.cy));
    const double sy = (L.py1 - L.py0) / (L.ay.hi - L.ay.lo);
    cairo_scale(cr, sx, sy);
    cairo_new_sub_path(cr);
    cairo_arc(cr, 0, 0, k.r, 0, 2 * M_PI);
    cairo_restore(cr);
    set_color(cr, k.color);
    cairo_set_line_width(cr, k.line_width);
    cairo_stroke(cr);
  }
  for (const Series& s : c.series) {
    const std::size_t n = std::min(s.x.size(), s.y.size());
    set_color(cr, s.color);
    cairo_set_line_width(cr, s.line_width);
    const double dash[] = {5, 3};
    cairo_set_dash(cr, dash, s.dashed ? 2 : 0, 0);
    if (s.mark == Mark::segments) {
      for (std::size_t i = 0; i + 1 < n; i += 2) {
        if (!L.ax.usable(s.x[i]) || !L.ay.usable(s.y[i]) || !L.ax.usable(s.x[i + 1]) ||
            !L.ay.usable(s.y[i + 1]))
          continue;
        cairo_move_to(cr, L.X(s.x[i]), L.Y(s.y[i]));
        cairo_line_to(cr, L.X(s.x[i + 1]), L.Y(s.y[i + 1]));
      }
      cairo_stroke(cr);
    } else if (s.mark == Mark::line || s.mark == Mark::line_points) {
      bool pen = false;
      for (std::size_t i = 0; i < n; ++i) {
        if (!L.ax.usable(s.x[i]) || !L.ay.usable(s.y[i])) {
          pen = false;
          continue;
        }
        (pen ? cairo_line_to : cairo_move_to)(cr, L.X(s.x[i]), L.Y(s.y[i]));
        pen = true;
      }
      cairo_stroke(cr);
    }
    cairo_set_dash(cr, dash, 0, 0);
    if (s.mark == Mark::points || s.mark == Mark::line_points)
      for (std::size_t i = 0; i < n; ++i)
        if (L.ax.usable(s.x[i]) && L.ay.usable(s.y[i]))
          marker(cr, L.X(s.x[i]), L.Y(s.y[i]), s.marker_radius, s.color);
  }
  cairo_restore(cr);
}

// Point labels, the frame and its ticks.
void draw_frame(const Chart& c, const Layout& L, cairo_t* cr) {
  const Color ink{0.1, 0.1, 0.1};
  // Point labels, with a leader line when they sit away from their point.
  std::size_t k = 0;
  for (const Series& s : c.series)
    for (std::size_t i = 0; i < s.labels.size() && i < s.x.size() && i < s.y.size(); ++i, ++k) {
      const LabelBox& b = L.labels[k];
      if (b.x0 > b.x1) continue;
      const auto [x, y] = L.label_anchor[k];
      const double cx = std::clamp(x, b.x0, b.x1), cy = std::clamp(y, b.y0, b.y1);
      if (std::hypot(cx - x, cy - y) > s.marker_radius + 6) {
        set_color(cr, s.color, 0.6);
        cairo_set_line_width(cr, 0.7);
        cairo_move_to(cr, x, y), cairo_line_to(cr, cx, cy), cairo_stroke(cr);
      }
      text_at(cr, s.labels[i], b.x0, b.y0, kPointLabelSize, ink);
    }

  // Frame and ticks.
  set_color(cr, ink);
  cairo_set_line_width(cr, 1);
  cairo_rectangle(cr, L.px0, L.py0, L.px1 - L.px0, L.py1 - L.py0);
  cairo_stroke(cr);
  for (std::size_t i = 0; i < L.ax.ticks.size(); ++i) {
    const double x = L.px0 + (L.ax.ticks[i] - L.ax.lo) / (L.ax.hi - L.ax.lo) * (L.px1 - L.px0);
    set_color(cr, ink);
    cairo_move_to(cr, x, L.py1), cairo_line_to(cr, x, L.py1 + 4), cairo_stroke(cr);
    const Size sz = measure(cr, L.ax.tick_text[i], kTickSize);
    // Keep the first and last labels inside the figure.
    const double tx = std::clamp(x - sz.w / 2, 2.0, c.width - 2 - sz.w);
    text_at(cr, L.ax.tick_text[i], tx, L.py1 + 6, kTickSize, ink);
  }
  for (std::size_t i = 0; i < L.ay.ticks.size(); ++i) {
    const double y = L.py1 - (L.ay.ticks[i] - L.ay.lo) / (L.ay.hi - L.ay.lo) * (L.py1 - L.py0);
    set_color(cr, ink);
    cairo_move_to(cr, L.px0 - 4, y), cairo_line_to(cr, L.px0, y), cairo_stroke(cr);
    const Size sz = measure(cr, L.ay.tick_text[i], kTickSize);
    text_at(cr, L.ay.tick_text[i], L.px0 - 7 - sz.w,
            std::clamp(y - sz.h / 2, 2.0, c.height - 2 - sz.h), kTickSize, ink);
  }
}

// Axis labels, title, note, and the legend outside the plot area on the right.
void draw_labels(const Chart& c, const Layout& L, cairo_t* cr) {
  const Color ink{0.1, 0.1, 0.1};
  const double tick_h = measure(cr, "0", kTickSize).h;
  // Axis labels, title, note.
  if (!c.x.label.empty()) {
    const Size sz = measure(cr, c.x.label, kLabelSize);
    text_at(cr, c.x.label, std::max(2.0, (L.px0 + L.px1) / 2 - sz.w / 2), L.py1 + 6 + tick_h + 4,
            kLabelSize, ink);
  }
  if (!c.y.label.empty()) {
    const Size sz = measure(cr, c.y.label, kLabelSize);
    cairo_save(cr);
    cairo_translate(cr, kPad, std::min(c.height - 2.0, (L.py0 + L.py1) / 2 + sz.w / 2));
    cairo_rotate(cr, -M_PI / 2);
    text_at(cr, c.y.label, 0, 0, kLabelSize, ink);
    cairo_restore(cr);
  }
  if (!c.title.empty()) text_at(cr, c.title, L.px0, kPad, kTitleSize, ink, true);
  if (!c.subtitle.empty())
    text_at(cr, c.subtitle, L.px0, L.subtitle_y, kSubtitleSize, Color{0.35, 0.35, 0.35});
  if (!c.note.empty()) {
    const Size sz = measure(cr, c.note, kTickSize);
    text_at(cr, c.note, L.px0, c.height - kPad - sz.h, kTickSize, Color{0.35, 0.35, 0.35});
  }

  // Legend, outside the plot area on the right: it can cover no data.
  double y = L.legend_y;
  for (const LegendEntry& e : legend_entries(c)) {
    const double mid = y + L.legend_row / 2 - 2;
    set_color(cr, e.color);
    if (e.circle) {
      cairo_set_line_width(cr, 1.5);
      cairo_new_sub_path(cr);
      cairo_arc(cr, L.legend_x + 10, mid, 6, 0, 2 * M_PI);
      cairo_stroke(cr);
    } else {
      if (e.mark != Mark::points) {
        const double dash[] = {5, 3};
        cairo_set_dash(cr, dash, e.dashed ? 2 : 0, 0);
        cairo_set_line_width(cr, 2);
        cairo_move_to(cr, L.legend_x, mid), cairo_line_to(cr, L.legend_x + 20, mid);
        cairo_stroke(cr);
        cairo_set_dash(cr, dash, 0, 0);
      }
      if (e.mark == Mark::points || e.mark == Mark::line_points)
        marker(cr, L.legend_x + 10, mid, 4, e.color);
    }
    text_at(cr, e.name, L.legend_x + 28, y, kLegendSize, ink);
    y += L.legend_row;
  }
}

void draw(const Chart& c, const Layout& L, cairo_t* cr) {
  cairo_set_source_rgb(cr, 1, 1, 1);
  cairo_paint(cr);
  draw_data(c, L, cr);
  draw_frame(c, L, cr);
  draw_labels(c, L, cr);
}

std::string lower_ext(const std::string& path) {
  std::string e = std::filesystem::path(path).extension().string();
  for (char& ch : e) ch = char(std::tolower((unsigned char)ch));
  return e;
}

void check_status(cairo_surface_t* s, const std::string& path) {
  if (cairo_surface_status(s) != CAIRO_STATUS_SUCCESS)
    throw InputError(path + ": cannot draw: " + cairo_status_to_string(cairo_surface_status(s)));
}

void render_to(cairo_surface_t* surface, const Chart& c, const std::string& path) {
  check_status(surface, path);
  Context ctx{cairo_create(surface)};
  const Layout L = layout(c, ctx.cr);
  draw(c, L, ctx.cr);
  if (cairo_status(ctx.cr) != CAIRO_STATUS_SUCCESS)
    throw InputError(path + ": cannot draw: " + cairo_status_to_string(cairo_status(ctx.cr)));
}

// cairo's stream writer: every byte through lancer's OutputFile, which checks each write. Written
// to a file name instead, cairo's PDF surface reported success with a truncated file on a full
// disk. Success is returned even after a failure, so that cairo carries on to the end and the
// failure is reported once, by write_file_atomically, naming the user's path.
cairo_status_t to_output(void* closure, const unsigned char* data, unsigned int length) {
  static_cast<OutputFile*>(closure)->write(data, length);
  return CAIRO_STATUS_SUCCESS;
}

}  // namespace

std::vector<LabelBox> label_boxes(const Chart& c) {
  Surface s{cairo_image_surface_create(CAIRO_FORMAT_ARGB32, 1, 1)};
  Context ctx{cairo_create(s.s)};
  return layout(c, ctx.cr).labels;
}

void write_chart(const Chart& c, const std::string& path) {
  LANCER_CHECK(c.width > 0 && c.height > 0);
  const std::string ext = lower_ext(path);
  if (ext == ".svg" || ext == ".pdf") {
    write_file_atomically(path, [&](OutputFile& out) {
      Surface s{ext == ".svg"
                    ? cairo_svg_surface_create_for_stream(to_output, &out, c.width, c.height)
                    : cairo_pdf_surface_create_for_stream(to_output, &out, c.width, c.height)};
      render_to(s.s, c, path);
      cairo_surface_finish(s.s);
      if (out.error() == 0) check_status(s.s, path);
    });
    return;
  }
  Surface s{cairo_image_surface_create(CAIRO_FORMAT_RGB24, c.width, c.height)};
  render_to(s.s, c, path);
  cairo_surface_flush(s.s);
  if (ext == ".png") {
    write_file_atomically(path, [&](OutputFile& out) {
      const cairo_status_t status = cairo_surface_write_to_png_stream(s.s, to_output, &out);
      if (status != CAIRO_STATUS_SUCCESS && out.error() == 0)
        throw InputError(path + ": cannot write the PNG: " + cairo_status_to_string(status));
    });
    return;
  }
  // Any other format: the pixels as an Image (8-bit values / 255, as a PNG would hold them).
  Image im(c.width, c.height);
  const unsigned char* data = cairo_image_surface_get_data(s.s);
  const int stride = cairo_image_surface_get_stride(s.s);
  for (int j = 0; j < c.height; ++j)
    for (int i = 0; i < c.width; ++i) {
      std::uint32_t px;
      std::memcpy(&px, data + std::size_t(j) * stride + 4 * i, 4);
      float* p = im.pixel(i, j);
      p[0] = float((px >> 16) & 255) / 255.0f;
      p[1] = float((px >> 8) & 255) / 255.0f;
      p[2] = float(px & 255) / 255.0f;
    }
  write_image(im, path);
}

}  // namespace lancer::plot
