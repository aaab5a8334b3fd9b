// Parsing and applying the options the subcommands share.
#pragma once

#include <string>
#include <vector>

#include "lancer/render.hpp"
#include "lancer/scene.hpp"

namespace lancer::cli {

// "a,b" "c" -> a, b, c: list options given as repeated values, comma-separated, or both.
std::vector<std::string> split_list(const std::vector<std::string>& items);

// "auto" -> 0, else a whole number; throws InputError naming `option`.
int parse_width(const std::string& text, const std::string& option);
// "1,4,16" or "all" (every width this machine runs, widest first).
std::vector<int> parse_width_list(const std::vector<std::string>& items, const std::string& option,
                                  Precision precision = Precision::exact);
std::vector<int> parse_int_list(const std::vector<std::string>& items, const std::string& option,
                                int min_value);

// "NXxNY", each side a whole number from 1 to kMaxResolution, nothing else (no spaces); throws
// InputError naming `option`.
void parse_size(const std::string& text, const std::string& option, int& nx, int& ny);

// Overrides from the command line; kUnset and empty strings leave the scene's values.
inline constexpr int kUnset = -2147483647 - 1;
struct SceneOverrides {
  int supersample = kUnset;
  std::string resolution;  // "NXxNY"
};
// Applies the overrides, then checks the sample cap and check_memory.
void apply_overrides(Scene& scene, const SceneOverrides& o);

// Refuses (InputError) an image whose pixels alone need more memory than this process may use
// (physical memory, or the ulimit -v), before any work.
void check_memory(const Scene& scene);

// A progress bar on stderr when it is a terminal; nothing otherwise.
void attach_progress(RenderOptions& options);

// --repeat of bench and trade: 1 to kMaxRepeat timed runs per configuration (docs/limits.md).
inline constexpr int kMaxRepeat = 1000;
void check_repeat(int repeat);

// --accel's text: auto, none, bvh or one (InputError naming `option` otherwise).
Accel parse_accel(const std::string& text, const std::string& option);

}  // namespace lancer::cli
