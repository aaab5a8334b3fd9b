// What bench prints for others to read: Google Benchmark's JSON as compare.py wants it, the CSV
// that lancer plot reads, the context of --json, and the timing options' rounds and limits.
#include <gtest/gtest.h>

#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "lancer/bench.hpp"
#include "support/test_util.hpp"

namespace lancer {
namespace {

using testing::cli;
using testing::run_command;
using testing::slurp;
using testing::source_path;
using testing::TempDir;

// A bench of a tiny image: renders of microseconds.
std::string tiny_bench(const std::string& extra) {
  return cli() + " bench " + source_path("scenes/lorenzi-diffuse.json") +
         " --resolution 24x16 --mode primary " + extra;
}

BenchResult one_row(std::vector<double> wall, std::vector<double> cpu) {
  BenchResult r;
  BenchRow row;
  row.mode = "primary", row.isa = "scalar", row.rays = 1000;
  row.samples = wall;
  row.cpu_samples = cpu;
  row.seconds = median(wall);
  r.rows.push_back(row);
  return r;
}

// compare.py prints times as whole numbers of the row's unit: 0.8 ms as "1" told nothing. Each
// row gets the largest unit in which its median is at least 100.
TEST(BenchGbench, TimeUnitKeepsThreeDigits) {
  auto unit_of = [](double seconds) {
    const auto j = nlohmann::json::parse(
        gbench_json(one_row({seconds, seconds}, {seconds, seconds}), "s.json", "test"));
    return std::make_pair(j["benchmarks"][0]["time_unit"].get<std::string>(),
                          j["benchmarks"][0]["real_time"].get<double>());
  };
  EXPECT_EQ(unit_of(0.8e-3), std::make_pair(std::string("us"), 800.0));
  EXPECT_EQ(unit_of(0.25), std::make_pair(std::string("ms"), 250.0));
  EXPECT_EQ(unit_of(0.05).first, "us");
  EXPECT_EQ(unit_of(50e-9).first, "ns");
  EXPECT_EQ(unit_of(150.0).first, "s");
  const auto fixed =
      nlohmann::json::parse(gbench_json(one_row({0.8e-3}, {0.8e-3}), "s.json", "test", "ms"));
  EXPECT_EQ(fixed["benchmarks"][0]["time_unit"], "ms");
  EXPECT_DOUBLE_EQ(fixed["benchmarks"][0]["real_time"].get<double>(), 0.8);
}

// cpu_time is the CPU time measured, not a copy of real_time; the names say the rows are
// timed by the wall clock, as Google Benchmark's UseRealTime() does.
TEST(BenchGbench, CpuTimeIsItsOwnMeasurement) {
  const auto j = nlohmann::json::parse(
      gbench_json(one_row({2e-3, 4e-3, 3e-3}, {1e-3, 1e-3, 2e-3}), "s.json", "test"));
  const auto& b = j["benchmarks"];
  EXPECT_EQ(b[0]["name"], "lancer/primary/exact/w1/threads:1/real_time");
  EXPECT_DOUBLE_EQ(b[0]["real_time"].get<double>(), 2000);
  EXPECT_DOUBLE_EQ(b[0]["cpu_time"].get<double>(), 1000);
  EXPECT_EQ(b[4]["aggregate_name"], "median");
  EXPECT_DOUBLE_EQ(b[4]["cpu_time"].get<double>(), 1000);
}

// Without --repeat, --format gbench runs 9 repeats: compare.py's U test warns "Results
// unreliable! 9+ repetitions recommended" below that. The CPU time is measured (a primary
// render on one thread spends CPU time).
TEST(BenchGbench, DefaultRepeatsSatisfyCompare) {
  const auto r = run_command(tiny_bench("--width 1 --format gbench"));
  ASSERT_EQ(r.status, 0) << r.out;
  const auto j = nlohmann::json::parse(r.out.substr(r.out.find('{')));
  EXPECT_EQ(j["benchmarks"][0]["repetitions"], 9);
  EXPECT_GT(j["benchmarks"][0]["cpu_time"].get<double>(), 0);
  EXPECT_NE(j["benchmarks"][0]["time_unit"], "ms");  // microseconds a render
  const auto five = run_command(tiny_bench("--width 1 --format gbench --repeat 5"));
  ASSERT_EQ(five.status, 0) << five.out;
  EXPECT_EQ(
      nlohmann::json::parse(five.out.substr(five.out.find('{')))["benchmarks"][0]["repetitions"],
      5);
}

TEST(BenchJson, HasContext) {
  const auto r = run_command(tiny_bench("--width 1 --json --repeat 1"));
  ASSERT_EQ(r.status, 0) << r.out;
  const auto j = nlohmann::json::parse(r.out.substr(r.out.find('{')));
  for (const char* key :
       {"date", "host_name", "cpu_model", "num_cpus", "git_commit", "lancer_version"})
    EXPECT_TRUE(j["context"].contains(key)) << key;
  EXPECT_EQ(j["repeats"], 1);
}

// The CSV has a header and one line per row, and lancer plot draws it without jq.
TEST(BenchCsv, PlotReadsIt) {
  LANCER_SKIP_WITHOUT_PACKETS();
  TempDir dir;
  const auto r =
      run_command(tiny_bench("--width 1,4 --repeat 1 --format csv > " + dir.file("b.csv")));
  ASSERT_EQ(r.status, 0) << r.out;
  std::istringstream lines(slurp(dir.file("b.csv")));
  std::string header, row;
  std::getline(lines, header);
  EXPECT_EQ(
      header.rfind("scene,engine,mode,precision,width,isa,threads,rays,seconds,mrays_per_s", 0), 0u)
      << header;
  int rows = 0;
  while (std::getline(lines, row)) rows += !row.empty();
  EXPECT_EQ(rows, 2);
  const auto plot = run_command(cli() + " plot " + dir.file("b.csv") +
                                " --x width --y mrays_per_s -o " + dir.file("b.svg"));
  EXPECT_EQ(plot.status, 0) << plot.out;
  EXPECT_GT(slurp(dir.file("b.svg")).size(), 100u);
}

// Warm-up runs are untimed; --min-time adds rounds until each configuration has been timed that
// long; --repeat rounds at least.
TEST(BenchTiming, WarmupAndMinTime) {
  int calls = 0;
  const std::vector<std::function<double()>> run{[&calls] { return ++calls, 0.1; }};
  TimingPlan plan;
  plan.repeat = 2, plan.warmup = 3, plan.min_seconds = 0, plan.min_time = 0.55;
  const RoundSamples s = time_rounds(run, plan);
  EXPECT_EQ(s.wall[0].size(), 6u);  // 0.1 s a round: six rounds reach 0.55 s
  EXPECT_EQ(calls, 3 + 2 * 6);      // each timed run after an untimed one (hot)
  plan.hot = false, calls = 0;
  EXPECT_EQ(time_rounds(run, plan).wall[0].size(), 6u);
  EXPECT_EQ(calls, 3 + 6);
  EXPECT_EQ(s.cpu[0].size(), 6u);
  plan.min_time = 0, plan.warmup = 0, calls = 0;
  EXPECT_EQ(time_rounds(run, plan).wall[0].size(), 2u);
  EXPECT_EQ(calls, 2);
  plan.min_time = 1e9, plan.max_rounds = 7;  // bounded by max_rounds
  EXPECT_EQ(time_rounds(run, plan).wall[0].size(), 7u);
}

// Hot: every timed run directly follows a run of its own configuration, never another's; shared:
// interleaved runs follow each other's.
TEST(BenchTiming, HotRunsFollowTheirOwnConfiguration) {
  int last = -1;
  auto config = [&last](int k) {
    return [&last, k] {
      const double seconds = last == k ? 1.0 : 100.0;  // 1 s after its own run, else 100 s
      last = k;
      return seconds;
    };
  };
  const std::vector<std::function<double()>> run{config(0), config(1), config(2)};
  TimingPlan plan;
  plan.repeat = 4, plan.warmup = 1, plan.min_seconds = 0;
  for (const std::vector<double>& samples : time_rounds(run, plan).wall)
    EXPECT_EQ(samples, std::vector<double>(4, 1.0));
  plan.hot = false;
  for (const std::vector<double>& samples : time_rounds(run, plan).wall)
    EXPECT_EQ(samples, std::vector<double>(4, 100.0));
}

TEST(BenchTiming, OptionsAreBounded) {
  const std::string scene = " " + source_path("scenes/lorenzi-diffuse.json");
  for (const char* bad : {" --warmup -1", " --warmup 101", " --min-time -1", " --min-time 3601",
                          " --time-unit hours", " --format xml", " --repeat 0", " --cache cold"}) {
    const auto r = run_command(cli() + " bench" + scene + bad);
    EXPECT_EQ(r.status, 2) << bad << ": " << r.out;
  }
  const auto r = run_command(tiny_bench("--width 1 --repeat 1 --min-time 0.2 --json"));
  ASSERT_EQ(r.status, 0) << r.out;
  const auto j = nlohmann::json::parse(r.out.substr(r.out.find('{')));
  // Each timed run lasts at least 50 ms: 0.2 s takes four rounds at least, and the summary
  // counts what ran.
  EXPECT_GE(j["repeats"].get<int>(), 4);
  EXPECT_EQ(j["results"][0]["samples_seconds"].size(), j["repeats"].get<std::size_t>());
  EXPECT_EQ(j["timing"]["cache"], "hot");
  EXPECT_EQ(j["timing"]["min_time"], 0.2);
  const auto shared = run_command(tiny_bench("--width 1 --repeat 1 --cache shared --json"));
  ASSERT_EQ(shared.status, 0) << shared.out;
  EXPECT_EQ(nlohmann::json::parse(shared.out.substr(shared.out.find('{')))["timing"]["cache"],
            "shared");
}

// Tukey's fences, as hyperfine's outlier warning.
TEST(BenchSpread, Outliers) {
  EXPECT_EQ(outliers({1, 1.01, 0.99, 1.02, 1, 3}), 1);
  EXPECT_EQ(outliers({1, 1.01, 0.99, 1.02, 1}), 0);
  EXPECT_EQ(outliers({1, 5, 9}), 0);  // too few to tell
}

}  // namespace
}  // namespace lancer
