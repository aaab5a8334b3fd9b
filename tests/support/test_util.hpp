// Helpers the lancer test executables share: paths, temporary folders, running the CLI.
#pragma once

#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "lancer/error.hpp"
#include "lancer/image.hpp"
#include "lancer/packet/api.hpp"
#include "lancer/render.hpp"
#include "lancer/scene.hpp"

// AddressSanitizer reserves terabytes of address space for its shadow memory, so a test that
// caps the address space (ulimit -v, RLIMIT_AS) cannot run under it (the asan preset).
#if defined(__SANITIZE_ADDRESS__)
#define LANCER_TEST_UNDER_ASAN 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define LANCER_TEST_UNDER_ASAN 1
#endif
#endif

namespace lancer::testing {

// The message of the InputError that loading `text` as a scene file named s.json gives, or
// "(no error)".
inline std::string load_error(const std::string& text) {
  try {
    parse_scene(text, "s.json");
  } catch (const InputError& e) {
    return e.what();
  }
  return "(no error)";
}

// A whole file's bytes ("" when it cannot be read).
inline std::string slurp(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

inline std::string source_path(const std::string& rel) {
  return std::string(LANCER_SOURCE_DIR) + "/" + rel;
}

// The scene files the project ships, sorted by name.
inline std::vector<std::string> shipped_scenes() {
  std::vector<std::string> out;
  for (const auto& e : std::filesystem::directory_iterator(source_path("scenes")))
    if (e.path().extension() == ".json") out.push_back(e.path().string());
  std::sort(out.begin(), out.end());
  return out;
}

// A fresh folder removed with everything in it when the object goes.
class TempDir {
 public:
  TempDir() {
    std::string pattern = (std::filesystem::temp_directory_path() / "lancer-test-XXXXXX").string();
    path_ = mkdtemp(pattern.data());
  }
  ~TempDir() {
    std::error_code ec;
    std::filesystem::remove_all(path_, ec);
  }
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
  std::string file(const std::string& name) const { return path_ + "/" + name; }
  const std::string& path() const { return path_; }

 private:
  std::string path_;
};

struct CommandResult {
  int status = -1;  // exit status, or -1 if it did not exit normally
  std::string out;  // stdout and stderr together
};

// Runs a shell command line, capturing its output.
inline CommandResult run_command(const std::string& command) {
  CommandResult r;
  FILE* p = popen((command + " 2>&1").c_str(), "r");
  if (!p) return r;
  std::array<char, 4096> buf;
  std::size_t n;
  while ((n = fread(buf.data(), 1, buf.size(), p)) > 0) r.out.append(buf.data(), n);
  const int st = pclose(p);
  r.status = WIFEXITED(st) ? WEXITSTATUS(st) : -1;
  return r;
}

inline std::string cli() { return LANCER_CLI; }

// The packet widths (not 1) this machine runs for a precision, widest first.
inline std::vector<int> packet_widths(Precision p = Precision::exact) {
  std::vector<int> w;
  for (int width : packet::supported_widths(p))
    if (width > 1) w.push_back(width);
  return w;
}

inline Image render_with(const Scene& scene, int width, Precision precision = Precision::exact,
                         int threads = 1) {
  RenderOptions opt;
  opt.width = width;
  opt.precision = precision;
  opt.threads = threads;
  return render(scene, opt).image;
}

}  // namespace lancer::testing

// Skips a test that runs the packets (a tool given a width, validate, profile, a packet-width
// loop) where this run offers none: a CPU without SSE4.2, or LANCER_MAX_WIDTH=1, under which the
// tools rightly refuse with exit 2. A macro, as GTEST_SKIP must return from the test body.
#define LANCER_SKIP_WITHOUT_PACKETS()                                      \
  if (::lancer::testing::packet_widths().empty())                          \
  GTEST_SKIP() << "no packet width in this run (a CPU without SSE4.2, or " \
                  "LANCER_MAX_WIDTH=1)"
