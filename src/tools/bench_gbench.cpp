// lancer bench's rows in Google Benchmark's JSON shape (what --benchmark_format=json prints),
// so that Google Benchmark's tools/compare.py and the dashboards that read that JSON take them.
#include "lancer/bench.hpp"

#include <unistd.h>

#include <cmath>
#include <ctime>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>

#include "lancer/lancer.hpp"
#include "lancer_git_commit.hpp"  // generated at build time (src/CMakeLists.txt)

namespace lancer {

namespace {

std::string read_line(const std::string& path) {
  std::ifstream f(path);
  std::string s;
  std::getline(f, s);
  return s;
}

// "model name" and "cpu MHz" of /proc/cpuinfo's first processor.
std::string cpuinfo_field(const std::string& key) {
  std::ifstream f("/proc/cpuinfo");
  for (std::string line; std::getline(f, line);) {
    if (line.compare(0, key.size(), key) != 0) continue;
    const auto colon = line.find(':');
    if (colon == std::string::npos) continue;
    std::string v = line.substr(colon + 1);
    v.erase(0, v.find_first_not_of(" \t"));
    return v;
  }
  return "";
}

// "48K" -> 49152, as Google Benchmark reads sysfs.
long long cache_bytes(const std::string& text) {
  if (text.empty()) return 0;
  long long v = std::atoll(text.c_str());
  switch (text.back()) {
    case 'K':
      v *= 1024;
      break;
    case 'M':
      v *= 1024 * 1024;
      break;
    default:
      break;
  }
  return v;
}

// Number of CPUs in a sysfs list such as "0-1,4".
int count_cpus(const std::string& list) {
  int n = 0;
  std::stringstream ss(list);
  for (std::string part; std::getline(ss, part, ',');) {
    const auto dash = part.find('-');
    if (part.empty()) continue;
    n += dash == std::string::npos
             ? 1
             : std::atoi(part.c_str() + dash + 1) - std::atoi(part.c_str()) + 1;
  }
  return n;
}

nlohmann::json caches() {
  nlohmann::json out = nlohmann::json::array();
  for (int k = 0; k < 16; ++k) {
    const std::string dir = "/sys/devices/system/cpu/cpu0/cache/index" + std::to_string(k) + "/";
    const std::string type = read_line(dir + "type");
    if (type.empty()) break;
    out.push_back({{"type", type == "Unified" ? "Unified" : type},
                   {"level", std::atoi(read_line(dir + "level").c_str())},
                   {"size", cache_bytes(read_line(dir + "size"))},
                   {"num_sharing", count_cpus(read_line(dir + "shared_cpu_list"))}});
  }
  return out;
}

// What bench's JSON and Google Benchmark's both carry: where, when and what was measured.
nlohmann::json context(const std::string& executable, const std::string& scene) {
  char host[256] = "";
  gethostname(host, sizeof host - 1);
  char date[64] = "";
  const std::time_t now = std::time(nullptr);
  std::tm tm{};
  localtime_r(&now, &tm);
  std::strftime(date, sizeof date, "%Y-%m-%dT%H:%M:%S%z", &tm);
  std::string d = date;  // Google Benchmark writes the offset as +hh:mm
  if (d.size() > 2) d.insert(d.size() - 2, ":");
  double load[3] = {0, 0, 0};
  getloadavg(load, 3);
  const std::string mhz = cpuinfo_field("cpu MHz");
  return {{"date", d},
          {"host_name", host},
          {"executable", executable},
          {"num_cpus", sysconf(_SC_NPROCESSORS_ONLN)},
          {"mhz_per_cpu", mhz.empty() ? 0 : int(std::lround(std::atof(mhz.c_str())))},
          {"cpu_scaling_enabled", false},
          {"caches", caches()},
          {"load_avg", {load[0], load[1], load[2]}},
#ifdef NDEBUG
          {"library_build_type", "release"},
#else
          {"library_build_type", "debug"},
#endif
          // lancer's own additions; readers of Google Benchmark's JSON ignore unknown keys.
          {"cpu_model", cpuinfo_field("model name")},
          {"git_commit", LANCER_GIT_COMMIT},
          {"lancer_version", api::version()},
          {"scene", scene}};
}

// Google Benchmark's units. Per row, the largest unit in which the row's median is at least 100,
// so that compare.py's whole-number columns keep three digits (0.8 ms: 800 us, not "1").
const char* pick_unit(double median_seconds, const std::string& fixed) {
  if (!fixed.empty() && fixed != "auto") return fixed.c_str();
  if (median_seconds >= 100) return "s";
  if (median_seconds >= 100e-3) return "ms";
  if (median_seconds >= 100e-6) return "us";
  return "ns";
}

double per_second(const std::string& unit) {
  return unit == "s" ? 1 : unit == "ms" ? 1e3 : unit == "us" ? 1e6 : 1e9;
}

}  // namespace

std::string bench_row_name(const BenchRow& r) {
  // lancer's rows of the same mode and width that differ in how they run (the ao and diffuse
  // modes' kernel rows) take a last part of their own.
  const std::string how =
      r.engine == "lancer" && !r.config.empty() ? "/" + r.config.substr(0, r.config.find(',')) : "";
  return r.engine + "/" + r.mode + how + "/" + r.precision + "/w" + std::to_string(r.width) +
         "/threads:" + std::to_string(r.threads);
}

std::string bench_context_json(const std::string& executable, const std::string& scene) {
  return context(executable, scene).dump();
}

std::string gbench_json(const BenchResult& result, const std::string& scene,
                        const std::string& executable, const std::string& time_unit) {
  nlohmann::json out;
  out["context"] = context(executable, scene);
  out["context"]["lancer_note"] =
      "real_time: wall clock, what items_per_second and the names' /real_time say the rows are "
      "timed by; cpu_time: the process's CPU time over the same runs, every thread. One "
      "iteration entry per repeat (time per render over that repeat's timed run), "
      "configurations interleaved within each repeat.";
  nlohmann::json& list = out["benchmarks"] = nlohmann::json::array();
  int family = 0;
  for (const BenchRow& r : result.rows) {
    // As Google Benchmark names a case timed with UseRealTime().
    const std::string name = bench_row_name(r) + "/real_time";
    const int n = int(r.samples.size());
    const Spread wall = spread(r.samples);
    const std::vector<double>& cpu_samples =
        r.cpu_samples.size() == r.samples.size() ? r.cpu_samples : r.samples;
    const Spread cpu = spread(cpu_samples);
    const std::string unit = pick_unit(wall.median, time_unit);
    const double scale = per_second(unit);
    auto entry = [&](const std::string& entry_name, double seconds, double cpu_seconds) {
      nlohmann::json e{{"name", entry_name},
                       {"family_index", family},
                       {"per_family_instance_index", 0},
                       {"run_name", name},
                       {"repetitions", n},
                       {"threads", r.threads},
                       {"real_time", seconds * scale},
                       {"cpu_time", cpu_seconds * scale},
                       {"time_unit", unit}};
      if (seconds > 0) e["items_per_second"] = double(r.rays) / seconds;
      e["label"] = r.isa;
      return e;
    };
    for (int k = 0; k < n; ++k) {
      nlohmann::json e = entry(name, r.samples[k], cpu_samples[k]);
      e["run_type"] = "iteration";
      e["repetition_index"] = k;
      e["iterations"] = 1;
      list.push_back(e);
    }
    const std::pair<const char*, std::pair<double, double>> aggregates[] = {
        {"mean", {wall.mean, cpu.mean}},
        {"median", {wall.median, cpu.median}},
        {"stddev", {wall.stddev, cpu.stddev}}};
    for (const auto& [agg, v] : aggregates) {
      nlohmann::json e = entry(name + "_" + agg, v.first, v.second);
      e["run_type"] = "aggregate";
      e["aggregate_name"] = agg;
      e["aggregate_unit"] = "time";
      e["iterations"] = n;
      // Google Benchmark takes the aggregate of each counter; items/s of the stddev is not a
      // rate, so it is left out there.
      if (agg[0] == 's') e.erase("items_per_second");
      list.push_back(e);
    }
    nlohmann::json cv = entry(name + "_cv", 0, 0);
    cv["real_time"] = wall.cv();  // a fraction, as Google Benchmark writes it
    cv["cpu_time"] = cpu.cv();
    cv.erase("items_per_second");
    cv["run_type"] = "aggregate";
    cv["aggregate_name"] = "cv";
    cv["aggregate_unit"] = "percentage";
    cv["iterations"] = n;
    list.push_back(cv);
    ++family;
  }
  return out.dump(2);
}

}  // namespace lancer
