// Figures without a drawing library: SVG text, or a supersampled rasteriser with a 5x7 font.
#include "lancer/plot.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>

#include "lancer/error.hpp"

namespace lancer::plot {

namespace fs = std::filesystem;

namespace {

// ---------------------------------------------------------------------------------------------
// The font: 5 x 7 dots per glyph, one string per row from the top, '#' for a dot.

struct Glyph {
  char c;
  const char* rows[7];
};

// clang-format off
const Glyph kFont[] = {
  {' ', {".....", ".....", ".....", ".....", ".....", ".....", "....."}},
  {'0', {".###.", "#...#", "#..##", "#.#.#", "##..#", "#...#", ".###."}},
  {'1', {"..#..", ".##..", "..#..", "..#..", "..#..", "..#..", ".###."}},
  {'2', {".###.", "#...#", "....#", "...#.", "..#..", ".#...", "#####"}},
  {'3', {"#####", "...#.", "..#..", "...#.", "....#", "#...#", ".###."}},
  {'4', {"...#.", "..##.", ".#.#.", "#..#.", "#####", "...#.", "...#."}},
  {'5', {"#####", "#....", "####.", "....#", "....#", "#...#", ".###."}},
  {'6', {"..##.", ".#...", "#....", "####.", "#...#", "#...#", ".###."}},
  {'7', {"#####", "....#", "...#.", "..#..", ".#...", ".#...", ".#..."}},
  {'8', {".###.", "#...#", "#...#", ".###.", "#...#", "#...#", ".###."}},
  {'9', {".###.", "#...#", "#...#", ".####", "....#", "...#.", ".##.."}},
  {'a', {".....", ".....", ".###.", "....#", ".####", "#...#", ".####"}},
  {'b', {"#....", "#....", "#.##.", "##..#", "#...#", "#...#", "####."}},
  {'c', {".....", ".....", ".###.", "#....", "#....", "#...#", ".###."}},
  {'d', {"....#", "....#", ".##.#", "#..##", "#...#", "#...#", ".####"}},
  {'e', {".....", ".....", ".###.", "#...#", "#####", "#....", ".###."}},
  {'f', {"..##.", ".#..#", ".#...", "###..", ".#...", ".#...", ".#..."}},
  {'g', {".....", ".####", "#...#", "#...#", ".####", "....#", ".###."}},
  {'h', {"#....", "#....", "#.##.", "##..#", "#...#", "#...#", "#...#"}},
  {'i', {"..#..", ".....", ".##..", "..#..", "..#..", "..#..", ".###."}},
  {'j', {"...#.", ".....", "..##.", "...#.", "...#.", "#..#.", ".##.."}},
  {'k', {"#....", "#....", "#..#.", "#.#..", "##...", "#.#..", "#..#."}},
  {'l', {".##..", "..#..", "..#..", "..#..", "..#..", "..#..", ".###."}},
  {'m', {".....", ".....", "##.#.", "#.#.#", "#.#.#", "#...#", "#...#"}},
  {'n', {".....", ".....", "#.##.", "##..#", "#...#", "#...#", "#...#"}},
  {'o', {".....", ".....", ".###.", "#...#", "#...#", "#...#", ".###."}},
  {'p', {".....", ".....", "####.", "#...#", "####.", "#....", "#...."}},
  {'q', {".....", ".....", ".##.#", "#..##", ".####", "....#", "....#"}},
  {'r', {".....", ".....", "#.##.", "##..#", "#....", "#....", "#...."}},
  {'s', {".....", ".....", ".###.", "#....", ".###.", "....#", "####."}},
  {'t', {".#...", ".#...", "###..", ".#...", ".#...", ".#..#", "..##."}},
  {'u', {".....", ".....", "#...#", "#...#", "#...#", "#..##", ".##.#"}},
  {'v', {".....", ".....", "#...#", "#...#", "#...#", ".#.#.", "..#.."}},
  {'w', {".....", ".....", "#...#", "#...#", "#.#.#", "#.#.#", ".#.#."}},
  {'x', {".....", ".....", "#...#", ".#.#.", "..#..", ".#.#.", "#...#"}},
  {'y', {".....", ".....", "#...#", "#...#", ".####", "....#", ".###."}},
  {'z', {".....", ".....", "#####", "...#.", "..#..", ".#...", "#####"}},
  {'A', {".###.", "#...#", "#...#", "#####", "#...#", "#...#", "#...#"}},
  {'B', {"####.", "#...#", "#...#", "####.", "#...#", "#...#", "####."}},
  {'C', {".###.", "#...#", "#....", "#....", "#....", "#...#", ".###."}},
  {'D', {"###..", "#..#.", "#...#", "#...#", "#...#", "#..#.", "###.."}},
  {'E', {"#####", "#....", "#....", "####.", "#....", "#....", "#####"}},
  {'F', {"#####", "#....", "#....", "####.", "#....", "#....", "#...."}},
  {'G', {".###.", "#...#", "#....", "#.###", "#...#", "#...#", ".####"}},
  {'H', {"#...#", "#...#", "#...#", "#####", "#...#", "#...#", "#...#"}},
  {'I', {".###.", "..#..", "..#..", "..#..", "..#..", "..#..", ".###."}},
  {'J', {"..###", "...#.", "...#.", "...#.", "...#.", "#..#.", ".##.."}},
  {'K', {"#...#", "#..#.", "#.#..", "##...", "#.#..", "#..#.", "#...#"}},
  {'L', {"#....", "#....", "#....", "#....", "#....", "#....", "#####"}},
  {'M', {"#...#", "##.##", "#.#.#", "#.#.#", "#...#", "#...#", "#...#"}},
  {'N', {"#...#", "#...#", "##..#", "#.#.#", "#..##", "#...#", "#...#"}},
  {'O', {".###.", "#...#", "#...#", "#...#", "#...#", "#...#", ".###."}},
  {'P', {"####.", "#...#", "#...#", "####.", "#....", "#....", "#...."}},
  {'Q', {".###.", "#...#", "#...#", "#...#", "#.#.#", "#..#.", ".##.#"}},
  {'R', {"####.", "#...#", "#...#", "####.", "#.#..", "#..#.", "#...#"}},
  {'S', {".####", "#....", "#....", ".###.", "....#", "....#", "####."}},
  {'T', {"#####", "..#..", "..#..", "..#..", "..#..", "..#..", "..#.."}},
  {'U', {"#...#", "#...#", "#...#", "#...#", "#...#", "#...#", ".###."}},
  {'V', {"#...#", "#...#", "#...#", "#...#", "#...#", ".#.#.", "..#.."}},
  {'W', {"#...#", "#...#", "#...#", "#.#.#", "#.#.#", "#.#.#", ".#.#."}},
  {'X', {"#...#", "#...#", ".#.#.", "..#..", ".#.#.", "#...#", "#...#"}},
  {'Y', {"#...#", "#...#", ".#.#.", "..#..", "..#..", "..#..", "..#.."}},
  {'Z', {"#####", "....#", "...#.", "..#..", ".#...", "#....", "#####"}},
  {'.', {".....", ".....", ".....", ".....", ".....", ".##..", ".##.."}},
  {',', {".....", ".....", ".....", ".....", ".##..", "..#..", ".#..."}},
  {'-', {".....", ".....", ".....", "#####", ".....", ".....", "....."}},
  {'+', {".....", "..#..", "..#..", "#####", "..#..", "..#..", "....."}},
  {':', {".....", ".##..", ".##..", ".....", ".##..", ".##..", "....."}},
  {'(', {"...#.", "..#..", ".#...", ".#...", ".#...", "..#..", "...#."}},
  {')', {".#...", "..#..", "...#.", "...#.", "...#.", "..#..", ".#..."}},
  {'[', {".###.", ".#...", ".#...", ".#...", ".#...", ".#...", ".###."}},
  {']', {".###.", "...#.", "...#.", "...#.", "...#.", "...#.", ".###."}},
  {'=', {".....", ".....", "#####", ".....", "#####", ".....", "....."}},
  {'/', {".....", "....#", "...#.", "..#..", ".#...", "#....", "....."}},
  {'_', {".....", ".....", ".....", ".....", ".....", ".....", "#####"}},
  {'%', {"##...", "##..#", "...#.", "..#..", ".#...", "#..##", "...##"}},
  {'\'', {"..#..", "..#..", ".#...", ".....", ".....", ".....", "....."}},
};
// clang-format on
const Glyph kUnknown = {'?', {"#####", "#...#", "#...#", "#...#", "#...#", "#...#", "#####"}};

const Glyph& glyph(char c) {
  for (const Glyph& g : kFont)
    if (g.c == c) return g;
  return kUnknown;
}

constexpr int kGlyphW = 5, kGlyphH = 7, kAdvance = 6;

// ---------------------------------------------------------------------------------------------
// The raster: samples at ss x the output resolution, filled span by span.

class Canvas {
 public:
  Canvas(int width, int height, int ss, Color bg)
      : w_(width),
        h_(height),
        ss_(ss),
        W_(width * ss),
        H_(height * ss),
        buf_(std::size_t(W_) * H_ * 3) {
    for (std::size_t k = 0; k < buf_.size(); k += 3) {
      buf_[k] = float(bg.r);
      buf_[k + 1] = float(bg.g);
      buf_[k + 2] = float(bg.b);
    }
  }

  // Sample rows whose centres lie in [y0, y1] (output pixel coordinates), with their centre y.
  template <class F>
  void for_rows(double y0, double y1, F f) {
    if (!(y0 <= y1) || std::ceil(y0 * ss_ - 0.5) >= H_ || std::floor(y1 * ss_ - 0.5) < 0) return;
    const int r0 = to_index(std::ceil(y0 * ss_ - 0.5), H_);
    const int r1 = to_index(std::floor(y1 * ss_ - 0.5), H_);
    for (int r = r0; r <= r1; ++r) f(r, (r + 0.5) / ss_);
  }

  // Colours the samples of sample row r whose centres lie in [x0, x1].
  void span(int r, double x0, double x1, const Color& c) {
    if (!(x0 <= x1)) return;
    if (std::ceil(x0 * ss_ - 0.5) >= W_ || std::floor(x1 * ss_ - 0.5) < 0) return;
    const int c0 = to_index(std::ceil(x0 * ss_ - 0.5), W_);
    const int c1 = to_index(std::floor(x1 * ss_ - 0.5), W_);
    if (c0 > c1) return;
    float* p = buf_.data() + (std::size_t(r) * W_ + c0) * 3;
    for (int k = c0; k <= c1; ++k, p += 3) {
      p[0] = float(c.r);
      p[1] = float(c.g);
      p[2] = float(c.b);
    }
  }

  void rect(double x0, double y0, double x1, double y1, const Color& c) {
    for_rows(y0, y1, [&](int r, double) { span(r, x0, x1, c); });
  }

  // A thick segment with round ends: the points within width/2 of it.
  void line(const Line& l) {
    const double h = std::max(l.width, 0.5) / 2;
    const double dx = l.x1 - l.x0, dy = l.y1 - l.y0;
    const double len = std::hypot(dx, dy);
    const double tx = len > 0 ? dx / len : 1, ty = len > 0 ? dy / len : 0;
    const double nx = -ty, ny = tx;
    for_rows(std::min(l.y0, l.y1) - h, std::max(l.y0, l.y1) + h, [&](int r, double y) {
      double lo = std::numeric_limits<double>::infinity(), hi = -lo;
      auto add = [&](double a, double b) {
        if (a <= b) lo = std::min(lo, a), hi = std::max(hi, b);
      };
      for (const auto& e : {std::pair<double, double>{l.x0, l.y0}, {l.x1, l.y1}}) {
        const double d = y - e.second;
        if (std::abs(d) <= h) {
          const double s = std::sqrt(h * h - d * d);
          add(e.first - s, e.first + s);
        }
      }
      // The rectangle: 0 <= (P - A).t <= len and -h <= (P - A).n <= h, each linear in x.
      double a = -std::numeric_limits<double>::infinity(), b = -a;
      bool empty = false;
      auto clip = [&](double coef, double cst, double mn, double mx) {
        if (coef == 0) {
          if (cst < mn || cst > mx) empty = true;
          return;
        }
        double u = (mn - cst) / coef, v = (mx - cst) / coef;
        if (u > v) std::swap(u, v);
        a = std::max(a, u);
        b = std::min(b, v);
      };
      const double ry = y - l.y0;
      clip(tx, -l.x0 * tx + ry * ty, 0, len);
      clip(nx, -l.x0 * nx + ry * ny, -h, h);
      if (!empty) add(a, b);
      if (lo <= hi) span(r, lo, hi, l.color);
    });
  }

  void circle(const Circle& c) {
    const double ro = c.stroke > 0 ? c.r + c.stroke / 2 : c.r;
    const double ri = c.stroke > 0 ? std::max(0.0, c.r - c.stroke / 2) : 0.0;
    for_rows(c.cy - ro, c.cy + ro, [&](int r, double y) {
      const double d = y - c.cy;
      if (std::abs(d) > ro) return;
      const double so = std::sqrt(ro * ro - d * d);
      if (std::abs(d) < ri) {
        const double si = std::sqrt(ri * ri - d * d);
        span(r, c.cx - so, c.cx - si, c.color);
        span(r, c.cx + si, c.cx + so, c.color);
      } else {
        span(r, c.cx - so, c.cx + so, c.color);
      }
    });
  }

  void text(const Text& t) {
    const double s = t.scale;
    const double along = text_width(t.text, t.scale), across = text_height(t.scale);
    const double a0 = t.halign == Align::start ? 0 : t.halign == Align::middle ? along / 2 : along;
    const double c0 = t.valign == Align::start    ? 0
                      : t.valign == Align::middle ? across / 2
                                                  : across;
    for (std::size_t k = 0; k < t.text.size(); ++k) {
      const Glyph& g = glyph(t.text[k]);
      for (int row = 0; row < kGlyphH; ++row)
        for (int col = 0; col < kGlyphW; ++col) {
          if (g.rows[row][col] != '#') continue;
          // The dot's square in the text frame: along [a, a + s], across [c, c + s].
          const double a = (double(k) * kAdvance + col) * s - a0, c = row * s - c0;
          if (!t.vertical)
            rect(t.x + a, t.y + c, t.x + a + s, t.y + c + s, t.color);
          else
            rect(t.x + c, t.y - a - s, t.x + c + s, t.y - a, t.color);
        }
    }
  }

  // A sample index clamped to [0, n - 1] before converting (the double may be huge).
  static int to_index(double v, int n) { return int(std::clamp(v, 0.0, double(n - 1))); }

  Image downsample() const {
    Image im(w_, h_);
    const float norm = 1.0f / float(ss_ * ss_);
    for (int j = 0; j < h_; ++j)
      for (int i = 0; i < w_; ++i) {
        float sum[3] = {0, 0, 0};
        for (int b = 0; b < ss_; ++b)
          for (int a = 0; a < ss_; ++a) {
            const float* p = buf_.data() + (std::size_t(j * ss_ + b) * W_ + (i * ss_ + a)) * 3;
            for (int k = 0; k < 3; ++k) sum[k] += p[k];
          }
        float* o = im.pixel(i, j);
        for (int k = 0; k < 3; ++k) o[k] = sum[k] * norm;
      }
    return im;
  }

 private:
  int w_, h_, ss_, W_, H_;
  std::vector<float> buf_;
};

// ---------------------------------------------------------------------------------------------
// SVG

std::string svg_color(const Color& c) {
  auto byte = [](double v) { return int(std::lround(std::clamp(v, 0.0, 1.0) * 255)); };
  char buf[16];
  std::snprintf(buf, sizeof buf, "#%02x%02x%02x", byte(c.r), byte(c.g), byte(c.b));
  return buf;
}

std::string xml_escape(const std::string& s) {
  std::string out;
  for (char c : s) {
    switch (c) {
      case '&':
        out += "&amp;";
        break;
      case '<':
        out += "&lt;";
        break;
      case '>':
        out += "&gt;";
        break;
      case '"':
        out += "&quot;";
        break;
      default:
        out += c;
    }
  }
  return out;
}

std::string lower_extension(const std::string& path) {
  std::string ext = fs::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return char(std::tolower(c)); });
  return ext;
}

std::string format_tick(double v, int decimals) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*f", decimals, v);
  std::string s = buf;
  // "-0", "-0.00": no sign on zero.
  if (s[0] == '-' && s.find_first_not_of("-0.") == std::string::npos) s.erase(0, 1);
  return s;
}

}  // namespace

double text_width(const std::string& text, int scale) {
  return text.empty() ? 0.0 : double(text.size() * kAdvance - 1) * scale;
}
double text_height(int scale) { return double(kGlyphH) * scale; }

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

Image rasterize(const Drawing& d, int supersample) {
  LANCER_CHECK(d.width > 0 && d.height > 0 && supersample >= 1);
  Canvas canvas(d.width, d.height, supersample, d.background);
  for (const Line& l : d.lines) canvas.line(l);
  for (const Circle& c : d.circles) canvas.circle(c);
  for (const Text& t : d.texts) canvas.text(t);
  return canvas.downsample();
}

std::string to_svg(const Drawing& d) {
  std::string s;
  char buf[512];
  std::snprintf(buf, sizeof buf,
                "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
                "<svg xmlns=\"http://www.w3.org/2000/svg\" version=\"1.1\" width=\"%d\" "
                "height=\"%d\" viewBox=\"0 0 %d %d\">\n"
                "<rect x=\"0\" y=\"0\" width=\"%d\" height=\"%d\" fill=\"%s\"/>\n",
                d.width, d.height, d.width, d.height, d.width, d.height,
                svg_color(d.background).c_str());
  s += buf;
  s += "<g fill=\"none\" stroke-linecap=\"round\">\n";
  for (const Line& l : d.lines) {
    std::snprintf(buf, sizeof buf,
                  "<line x1=\"%.2f\" y1=\"%.2f\" x2=\"%.2f\" y2=\"%.2f\" stroke=\"%s\" "
                  "stroke-width=\"%g\"/>\n",
                  l.x0, l.y0, l.x1, l.y1, svg_color(l.color).c_str(), l.width);
    s += buf;
  }
  for (const Circle& c : d.circles) {
    if (c.stroke > 0)
      std::snprintf(
          buf, sizeof buf,
          "<circle cx=\"%.2f\" cy=\"%.2f\" r=\"%.2f\" stroke=\"%s\" stroke-width=\"%g\"/>\n", c.cx,
          c.cy, c.r, svg_color(c.color).c_str(), c.stroke);
    else
      std::snprintf(buf, sizeof buf, "<circle cx=\"%.2f\" cy=\"%.2f\" r=\"%.2f\" fill=\"%s\"/>\n",
                    c.cx, c.cy, c.r, svg_color(c.color).c_str());
    s += buf;
  }
  s += "</g>\n";
  for (const Text& t : d.texts) {
    // Glyph boxes are cap height, so the baseline is the box's bottom.
    const double across = text_height(t.scale);
    const double c0 = t.valign == Align::start    ? 0
                      : t.valign == Align::middle ? across / 2
                                                  : across;
    const char* anchor = t.halign == Align::start    ? "start"
                         : t.halign == Align::middle ? "middle"
                                                     : "end";
    std::string transform;
    double bx = t.x, by = t.y + across - c0;
    if (t.vertical) {
      std::snprintf(buf, sizeof buf, " transform=\"rotate(-90 %.2f %.2f)\"", t.x, t.y);
      transform = buf;
      by = t.y + across - c0;
    }
    std::snprintf(buf, sizeof buf,
                  "<text x=\"%.2f\" y=\"%.2f\" font-family=\"DejaVu Sans Mono, monospace\" "
                  "font-size=\"%.1f\" text-anchor=\"%s\" fill=\"%s\"%s>",
                  bx, by, 9.5 * t.scale, anchor, svg_color(t.color).c_str(), transform.c_str());
    s += buf;
    s += xml_escape(t.text);
    s += "</text>\n";
  }
  s += "</svg>\n";
  return s;
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
  if (lower_extension(path) == ".svg") return check_text_path(path, option, scene_path);
  try {
    check_output_path(path, scene_path);
  } catch (const InputError& e) {
    throw InputError(option + " " + e.what());
  }
}

void write_text_file(const std::string& text, const std::string& path) {
  write_file_atomically(path, [&](const std::string& tmp) {
    std::ofstream out(tmp, std::ios::binary);
    out << text;
    out.flush();
    if (!out) throw InputError(path + ": write failed: " + std::strerror(errno));
  });
}

void write_drawing(const Drawing& d, const std::string& path) {
  if (lower_extension(path) == ".svg")
    write_text_file(to_svg(d), path);
  else
    write_image(rasterize(d), path);
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

Drawing scatter_plot(const std::vector<double>& x, const std::vector<double>& y,
                     const ScatterOptions& o) {
  LANCER_CHECK_OP(x.size(), ==, y.size());
  Drawing d;
  d.width = o.width;
  d.height = o.height;

  // Data ranges with 5% margins, as matplotlib's; a flat range is widened.
  auto range = [](const std::vector<double>& v, double& lo, double& hi) {
    lo = std::numeric_limits<double>::infinity(), hi = -lo;
    for (double e : v)
      if (std::isfinite(e)) lo = std::min(lo, e), hi = std::max(hi, e);
    if (!(lo <= hi)) lo = 0, hi = 1;
    if (hi - lo <= 1e-12 * std::max(std::abs(lo), std::abs(hi))) {
      const double pad = lo == 0 ? 0.5 : std::abs(lo) * 0.1;
      lo -= pad, hi += pad;
    }
    const double m = (hi - lo) * 0.05;
    lo -= m, hi += m;
  };
  double xl, xh, yl, yh;
  range(x, xl, xh);
  range(y, yl, yh);
  const Ticks xt = nice_ticks(xl, xh, 7), yt = nice_ticks(yl, yh, 6);

  const int fs = 2;  // font scale
  const double th = text_height(fs), tick = 6, gap = 6;
  double ytw = 0;
  for (double v : yt.values) ytw = std::max(ytw, text_width(format_tick(v, yt.decimals), fs));
  const double left = 12 + th + 2 * gap + ytw + tick;
  const double right = 12 + text_width(format_tick(xh, xt.decimals), fs) / 2;
  const double top = o.title.empty() ? 16 : 16 + th + 2 * gap;
  const double bottom = tick + gap + th + 2 * gap + th + 12;
  const double pw = d.width - left - right, ph = d.height - top - bottom;
  LANCER_CHECK(pw > 10 && ph > 10);
  auto px = [&](double v) { return left + (v - xl) / (xh - xl) * pw; };
  auto py = [&](double v) { return top + (yh - v) / (yh - yl) * ph; };

  const double axis_w = 1.5;
  const double x0 = left, x1 = left + pw, y0 = top, y1 = top + ph;
  d.lines.push_back({x0, y0, x1, y0, kBlack, axis_w});
  d.lines.push_back({x1, y0, x1, y1, kBlack, axis_w});
  d.lines.push_back({x1, y1, x0, y1, kBlack, axis_w});
  d.lines.push_back({x0, y1, x0, y0, kBlack, axis_w});
  for (double v : xt.values) {
    const double p = px(v);
    d.lines.push_back({p, y1, p, y1 + tick, kBlack, 1});
    d.texts.push_back({p, y1 + tick + gap, format_tick(v, xt.decimals), Align::middle, Align::start,
                       fs, false, kBlack});
  }
  for (double v : yt.values) {
    const double p = py(v);
    d.lines.push_back({x0 - tick, p, x0, p, kBlack, 1});
    d.texts.push_back({x0 - tick - gap, p, format_tick(v, yt.decimals), Align::end, Align::middle,
                       fs, false, kBlack});
  }
  d.texts.push_back({(x0 + x1) / 2, y1 + tick + gap + th + 2 * gap, o.x_label, Align::middle,
                     Align::start, fs, false, kBlack});
  d.texts.push_back({12, (y0 + y1) / 2, o.y_label, Align::middle, Align::start, fs, true, kBlack});
  if (!o.title.empty())
    d.texts.push_back({(x0 + x1) / 2, 16, o.title, Align::middle, Align::start, fs, false, kBlack});
  // Point labels: above right, below right, above left or below left of the point, the first
  // that overlaps no label placed before it.
  struct Box {
    double x0, y0, x1, y1;
  };
  std::vector<Box> placed;
  auto overlaps = [&](const Box& b) {
    for (const Box& p : placed)
      if (b.x0 < p.x1 && p.x0 < b.x1 && b.y0 < p.y1 && p.y0 < b.y1) return true;
    return false;
  };
  for (std::size_t k = 0; k < x.size(); ++k) {
    if (!std::isfinite(x[k]) || !std::isfinite(y[k])) continue;
    const double cx = px(x[k]), cy = py(y[k]), r = o.point_radius;
    d.circles.push_back({cx, cy, r, o.point_color, 0});
    if (k >= o.labels.size() || o.labels[k].empty()) continue;
    const double w = text_width(o.labels[k], 1), h = text_height(1), m = r + 3;
    const Box candidates[4] = {{cx + m, cy - m - h, cx + m + w, cy - m},
                               {cx + m, cy + m, cx + m + w, cy + m + h},
                               {cx - m - w, cy - m - h, cx - m, cy - m},
                               {cx - m - w, cy + m, cx - m, cy + m + h}};
    Box chosen = candidates[0];
    for (const Box& b : candidates)
      if (!overlaps(b)) {
        chosen = b;
        break;
      }
    placed.push_back(chosen);
    d.texts.push_back(
        {chosen.x0, chosen.y0, o.labels[k], Align::start, Align::start, 1, false, kBlack});
  }
  return d;
}

}  // namespace lancer::plot
