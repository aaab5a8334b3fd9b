// LANCER_EMBREE_CONFIG, checked before Embree sees it: rtcNewDevice ignores a key it does not
// know and takes an ISA name it does not know for none, so a typo would silently measure another
// configuration than the one asked for.
#include <algorithm>
#include <cctype>
#include <string>

#include "lancer/error.hpp"
#include "lancer/peer.hpp"

namespace lancer::peer {

namespace {
std::string trimmed(const std::string& s) {
  const auto b = s.find_first_not_of(" \t");
  if (b == std::string::npos) return "";
  return s.substr(b, s.find_last_not_of(" \t") - b + 1);
}

bool whole_number(const std::string& s) {
  return !s.empty() &&
         std::all_of(s.begin(), s.end(), [](unsigned char c) { return std::isdigit(c); });
}
}  // namespace

void check_embree_config(const std::string& config, const std::string& name) {
  // Embree 3's rtcNewDevice keys (its API reference) and the ISA names it parses.
  static const char* const kNumbers[] = {"threads",
                                         "user_threads",
                                         "set_affinity",
                                         "start_threads",
                                         "hugepages",
                                         "verbose",
                                         "enable_selockmemoryprivilege",
                                         "tessellation_cache_size"};
  static const char* const kIsas[] = {"sse2", "sse4.2", "sse4_2",    "avx",
                                      "avx2", "avx512", "avx512skx", "avx512knl"};
  static const char* const kFrequencies[] = {"simd128", "simd256", "simd512"};
  auto one_of = [](const std::string& v, const auto& list) {
    return std::find(std::begin(list), std::end(list), v) != std::end(list);
  };
  std::size_t start = 0;
  while (start <= config.size()) {
    const std::size_t comma = std::min(config.find(',', start), config.size());
    const std::string item = trimmed(config.substr(start, comma - start));
    start = comma + 1;
    if (item.empty()) continue;
    const std::size_t eq = item.find('=');
    const std::string key = trimmed(item.substr(0, eq));
    const std::string value = eq == std::string::npos ? "" : trimmed(item.substr(eq + 1));
    std::string want;
    if (one_of(key, kNumbers)) {
      if (!whole_number(value)) want = "a whole number";
    } else if (key == "isa" || key == "max_isa") {
      if (!one_of(value, kIsas)) want = "sse2, sse4.2, avx, avx2 or avx512";
    } else if (key == "frequency_level") {
      if (!one_of(value, kFrequencies)) want = "simd128, simd256 or simd512";
    } else {
      throw InputError(name + ": unknown setting '" + key +
                       "' (Embree 3 takes threads, user_threads, set_affinity, start_threads, "
                       "isa, max_isa, hugepages, enable_selockmemoryprivilege, verbose, "
                       "frequency_level, tessellation_cache_size)");
    }
    if (!want.empty())
      throw InputError(name + ": " + key + " must be " + want + ", not '" + value + "'");
  }
}

}  // namespace lancer::peer
