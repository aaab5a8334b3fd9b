#include "options.hpp"

#include <sys/ioctl.h>
#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <chrono>
#include <cstdio>
#include <memory>
#include <mutex>
#include <sstream>

#include "lancer/error.hpp"
#include "lancer/packet/api.hpp"
#include "lancer/progress.hpp"

namespace lancer::cli {

namespace {
int parse_int(const std::string& text, const std::string& option) {
  std::size_t used = 0;
  long v = 0;
  try {
    // std::stol skips leading spaces and takes a '+': " 5" and "+5" are refused.
    if (!text.empty() && (std::isdigit(static_cast<unsigned char>(text[0])) || text[0] == '-'))
      v = std::stol(text, &used);
  } catch (...) {
    used = 0;
  }
  if (used == 0 || used != text.size() || v < -2147483647L || v > 2147483647L)
    throw InputError(option + ": '" + text + "' is not a whole number");
  return static_cast<int>(v);
}

}  // namespace

std::vector<std::string> split_list(const std::vector<std::string>& items) {
  std::vector<std::string> out;
  for (const std::string& item : items) {
    std::stringstream ss(item);
    std::string part;
    while (std::getline(ss, part, ',')) out.push_back(part);
  }
  return out;
}

int parse_width(const std::string& text, const std::string& option) {
  if (text == "auto") return 0;
  const int w = parse_int(text, option);
  if (w != 1 && w != 2 && w != 4 && w != 8 && w != 16)
    throw InputError(option + ": must be auto, 1, 2, 4, 8 or 16, not " + text);
  return w;
}

std::vector<int> parse_width_list(const std::vector<std::string>& items, const std::string& option,
                                  Precision precision) {
  std::vector<int> out;
  for (const std::string& part : split_list(items)) {
    if (part == "all") {
      const std::vector<int> all = packet::supported_widths(precision);
      // None only for fast precision without packets: resolve_width names the cause (the cap
      // or the CPU) where "no width given" blamed the user.
      if (all.empty()) resolve_width(0, precision, option);
      out.insert(out.end(), all.begin(), all.end());
      continue;
    }
    const int w = parse_width(part, option);
    out.push_back(resolve_width(w, precision, option));
  }
  if (out.empty()) throw InputError(option + ": no width given");
  return out;
}

std::vector<int> parse_int_list(const std::vector<std::string>& items, const std::string& option,
                                int min_value) {
  std::vector<int> out;
  for (const std::string& part : split_list(items)) {
    const int v = parse_int(part, option);
    if (v < min_value)
      throw InputError(option + ": must be >= " + std::to_string(min_value) + ", not " + part);
    out.push_back(v);
  }
  if (out.empty()) throw InputError(option + ": no value given");
  return out;
}

void parse_size(const std::string& text, const std::string& option, int& nx, int& ny) {
  const auto x = text.find_first_of("xX");
  if (x == std::string::npos) throw InputError(option + ": must be NXxNY, e.g. 640x480");
  const int w = parse_int(text.substr(0, x), option);
  const int h = parse_int(text.substr(x + 1), option);
  if (w <= 0 || h <= 0 || w > kMaxResolution || h > kMaxResolution)
    throw InputError(option + ": each side must be from 1 to " + std::to_string(kMaxResolution) +
                     " (docs/limits.md)");
  nx = w, ny = h;
}

void apply_overrides(Scene& scene, const SceneOverrides& o) {
  if (o.supersample != kUnset) {
    if (o.supersample < 1 || o.supersample > kMaxSupersample)
      throw InputError("--supersample: must be from 1 to " + std::to_string(kMaxSupersample) +
                       " (docs/limits.md)");
    scene.supersample = o.supersample;
  }
  if (!o.resolution.empty())
    parse_size(o.resolution, "--resolution", scene.camera.nx, scene.camera.ny);
  const auto& c = scene.camera;
  if (static_cast<long long>(c.nx) * c.ny * scene.supersample * scene.supersample > kMaxSamples)
    throw InputError("--resolution/--supersample: more than " + std::to_string(kMaxSamples) +
                     " samples (docs/limits.md)");
  check_memory(scene);
}

void check_memory(const Scene& scene) {
  // What every command holds per pixel: the float RGB image (12 bytes) and, for an 8-bit file,
  // its bytes (3), beside what this process may use: physical memory, or less under ulimit -v.
  constexpr double kBytesPerPixel = 15;
  const double pixels = double(scene.camera.nx) * scene.camera.ny;
  const double needed = pixels * kBytesPerPixel;
  double available = double(sysconf(_SC_PHYS_PAGES)) * double(sysconf(_SC_PAGESIZE));
  rlimit limit{};
  if (getrlimit(RLIMIT_AS, &limit) == 0 && limit.rlim_cur != RLIM_INFINITY)
    available = std::min(available, double(limit.rlim_cur));
  if (available > 0 && needed > available) {
    char msg[200];
    std::snprintf(msg, sizeof msg,
                  "%d x %d pixels: the image needs %.1f GB (15 bytes a pixel) and this process "
                  "may use %.1f GB (docs/limits.md)",
                  scene.camera.nx, scene.camera.ny, needed * 1e-9, available * 1e-9);
    throw InputError(msg);
  }
}

void attach_progress(RenderOptions& options) {
  if (!isatty(STDERR_FILENO)) return;
  struct State {
    std::mutex mutex;
    std::chrono::steady_clock::time_point start = std::chrono::steady_clock::now(), last;
    int shown = -1;
  };
  auto state = std::make_shared<State>();
  options.on_progress = [state](int done, int all) {
    std::lock_guard<std::mutex> lock(state->mutex);
    const auto now = std::chrono::steady_clock::now();
    // At most 10 redraws a second, and the last one always.
    if (done != all && state->shown >= 0 && now - state->last < std::chrono::milliseconds(100))
      return;
    state->last = now, state->shown = done;
    winsize ws{};
    const int columns =
        ioctl(STDERR_FILENO, TIOCGWINSZ, &ws) == 0 && ws.ws_col > 0 ? ws.ws_col : 80;
    const double elapsed = std::chrono::duration<double>(now - state->start).count();
    // \r back to the start, the line, then clear what a longer previous line left.
    std::fprintf(stderr, "\r%s\033[K%s", progress_line(done, all, elapsed, columns).c_str(),
                 done == all ? "\n" : "");
    std::fflush(stderr);
  };
}

void check_repeat(int repeat) {
  // Each timed run lasts at least 0.05 s per configuration: 1000 of them are nearly a minute per
  // configuration, and 2^31 ran for ever.
  if (repeat < 1 || repeat > kMaxRepeat)
    throw InputError("--repeat: must be from 1 to " + std::to_string(kMaxRepeat) + ", not " +
                     std::to_string(repeat) + " (docs/limits.md)");
}

Accel parse_accel(const std::string& text, const std::string& option) {
  if (text == "auto") return Accel::automatic;
  if (text == "none") return Accel::none;
  if (text == "bvh") return Accel::bvh;
  if (text == "one") return Accel::one;
  throw InputError(option + ": must be auto, none, bvh or one, not '" + text + "'");
}

}  // namespace lancer::cli
