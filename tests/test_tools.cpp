// The tools around the renderer: lancer compare, bench's spread and its Google Benchmark JSON.
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "lancer/bench.hpp"
#include "lancer/compare.hpp"
#include "lancer/diff_map.hpp"
#include "lancer/progress.hpp"
#include "support/test_util.hpp"

namespace lancer {
namespace {

using testing::cli;
using testing::run_command;
using testing::slurp;
using testing::source_path;
using testing::TempDir;

// Whether this run offers float packets of `width` lanes (the CPU's, under LANCER_MAX_WIDTH):
// tests that ask for one explicitly skip where the tools rightly refuse it.
bool has_width(int width) {
  const std::vector<int> w = testing::packet_widths();
  return std::find(w.begin(), w.end(), width) != w.end();
}

Image gradient(int nx, int ny) {
  Image im(nx, ny);
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i)
      for (int c = 0; c < 3; ++c) im.pixel(i, j)[c] = float(i + j + c) / float(nx + ny + 3);
  return im;
}

TEST(CompareImages, CountsThresholdsAndUlps) {
  const Image a = gradient(10, 4);
  Image b = a;
  b.pixel(3, 1)[0] = std::nextafter(b.pixel(3, 1)[0], 2.0f);  // one ulp
  b.pixel(7, 2)[2] += 1.5f / 255;                             // between 1/255 and 2/255
  b.pixel(8, 3)[1] += 3.0f / 255;                             // beyond both
  const ImageComparison c = compare_images(a, b, {1.0 / 255, 2.0 / 255});
  EXPECT_EQ(c.bits.differing_pixels, 3u);
  EXPECT_EQ(c.bits.first_i, 3);
  EXPECT_EQ(c.bits.first_j, 1);
  EXPECT_GT(c.bits.max_ulps, 1u);
  ASSERT_EQ(c.off_pixels.size(), 2u);
  EXPECT_EQ(c.off_pixels[0], 2u);
  EXPECT_EQ(c.off_pixels[1], 1u);
  EXPECT_DOUBLE_EQ(c.off_fractions[1], 1.0 / 40);
  EXPECT_NEAR(c.error.max_abs, 3.0 / 255, 1e-6);
  EXPECT_TRUE(std::isfinite(c.error.psnr_db));
  const Image d = difference_image(a, b, 2);
  EXPECT_NEAR(d.pixel(8, 3)[1], 6.0 / 255, 1e-6);
  EXPECT_EQ(d.pixel(0, 0)[0], 0.0f);
  const ImageComparison same = compare_images(a, a, {1.0 / 255});
  EXPECT_TRUE(same.bits.identical());
  EXPECT_TRUE(std::isinf(same.error.psnr_db));
}

// 64 pixels off by 1/255 beside one off by 0.5: on a linear scale the 64 were black. On the log
// map each differing pixel is bright, the smallest difference blue, the largest yellow.
TEST(CompareDiff, EveryDifferingPixelIsVisible) {
  const Image a = gradient(32, 16);
  Image b = a;
  for (int k = 0; k < 64; ++k) b.pixel(k % 32, 2 + k / 32)[0] += 1.0f / 255;
  b.pixel(10, 10)[2] += 0.5f;
  const DiffMap m = false_colour_difference(a, b);
  EXPECT_EQ(m.coloured, 65u);
  EXPECT_NEAR(m.low, 1.0 / 255, 1e-6);
  EXPECT_NEAR(m.high, 0.5, 1e-6);
  ASSERT_EQ(m.image.ny, 16 + 1 + m.bar_rows);
  int visible = 0;
  for (int j = 0; j < 16; ++j)
    for (int i = 0; i < 32; ++i) {
      const float* p = m.image.pixel(i, j);
      visible += std::max({p[0], p[1], p[2]}) >= 0.5f;
    }
  EXPECT_EQ(visible, 65);
  float low[3], high[3];
  diff_colour(0, low);
  diff_colour(1, high);
  EXPECT_EQ(m.image.pixel(0, 2)[2], low[2]);     // the smallest difference: the bar's left end
  EXPECT_EQ(m.image.pixel(10, 10)[0], high[0]);  // the largest: its right end
  EXPECT_EQ(m.image.pixel(31, 16 + 1)[0], high[0]);
  EXPECT_EQ(m.image.pixel(0, 16)[0], 0.0f);  // the black row above the bar
}

TEST(CompareCli, ExitStatusIdenticalDifferentBadInput) {
  TempDir dir;
  const Image a = gradient(16, 8);
  Image b = a;
  b.pixel(5, 5)[1] += 0.25f;
  write_image(a, dir.file("a.pfm"));
  write_image(b, dir.file("b.pfm"));
  write_image(gradient(8, 8), dir.file("c.pfm"));
  EXPECT_EQ(run_command(cli() + " compare " + dir.file("a.pfm") + " " + dir.file("a.pfm")).status,
            0);
  const auto diff = run_command(cli() + " compare " + dir.file("a.pfm") + " " + dir.file("b.pfm") +
                                " --diff " + dir.file("d.png"));
  EXPECT_EQ(diff.status, 1) << diff.out;
  EXPECT_NE(diff.out.find("differing pixels  1 of 128"), std::string::npos) << diff.out;
  const Image d = read_image(dir.file("d.png"));
  EXPECT_EQ(d.nx, 16);
  EXPECT_EQ(d.ny, 8 + 1 + 4);                         // a black row and the colour bar below
  EXPECT_NEAR(d.pixel(5, 5)[0], 1.0, 1.0 / 255);      // the largest difference: yellow
  EXPECT_EQ(d.pixel(0, 0)[0] + d.pixel(0, 0)[1], 0);  // identical: black
  EXPECT_NE(diff.out.find("log scale, blue 0.25 to yellow 0.25"), std::string::npos) << diff.out;
  // --diff-scale: |a - b| times the factor, linear, the inputs' size.
  ASSERT_EQ(run_command(cli() + " compare " + dir.file("a.pfm") + " " + dir.file("b.pfm") +
                        " --diff " + dir.file("s.pfm") + " --diff-scale 4")
                .status,
            1);
  const Image s = read_image(dir.file("s.pfm"));
  EXPECT_EQ(s.ny, 8);
  EXPECT_NEAR(s.pixel(5, 5)[1], 1.0, 1e-6);
  // Sizes differ: one line, exit 2.
  const auto size = run_command(cli() + " compare " + dir.file("a.pfm") + " " + dir.file("c.pfm"));
  EXPECT_EQ(size.status, 2);
  EXPECT_EQ(size.out, "lancer: " + dir.file("a.pfm") + " is 16x8, " + dir.file("c.pfm") +
                          " is 8x8: sizes differ\n");
  EXPECT_EQ(
      run_command(cli() + " compare " + dir.file("a.pfm") + " " + dir.file("nope.png")).status, 2);
  EXPECT_EQ(run_command(cli() + " compare " + dir.file("a.pfm") + " " + dir.file("b.pfm") +
                        " --threshold 1/0")
                .status,
            2);
  // JSON: the fields, PSNR null only when identical.
  ASSERT_EQ(run_command(cli() + " compare --json --threshold 0.1,0.3 " + dir.file("a.pfm") + " " +
                        dir.file("b.pfm") + " > " + dir.file("c.json"))
                .status,
            1);
  const auto j = nlohmann::json::parse(slurp(dir.file("c.json")));
  EXPECT_EQ(j["differing_pixels"], 1);
  EXPECT_EQ(j["identical"], false);
  EXPECT_TRUE(j["psnr_db"].is_number());
  ASSERT_EQ(j["off"].size(), 2u);
  EXPECT_EQ(j["off"][0]["pixels"], 1);
  EXPECT_EQ(j["off"][1]["pixels"], 0);
}

TEST(BenchSpread, MinMedianMaxCv) {
  const Spread s = spread({3, 1, 2});
  EXPECT_EQ(s.min, 1);
  EXPECT_EQ(s.median, 2);
  EXPECT_EQ(s.max, 3);
  EXPECT_DOUBLE_EQ(s.mean, 2);
  EXPECT_DOUBLE_EQ(s.stddev, 1);
  EXPECT_DOUBLE_EQ(s.cv(), 0.5);
  EXPECT_EQ(spread({}).cv(), 0);
}

// What Google Benchmark's tools/compare.py reads: benchmarks with name, run_type, real_time,
// cpu_time and time_unit; aggregates with aggregate_name; the context it prints.
TEST(BenchGbench, HasTheFieldsCompareNeeds) {
  TempDir dir;
  const auto r = run_command(cli() + " bench " + source_path("scenes/lorenzi-diffuse.json") +
                             " --resolution 24x16 --width 1 --repeat 3 --mode primary,full "
                             "--format gbench > " +
                             dir.file("g.json"));
  ASSERT_EQ(r.status, 0) << r.out;
  const auto j = nlohmann::json::parse(slurp(dir.file("g.json")));
  for (const char* key : {"date", "host_name", "num_cpus", "mhz_per_cpu", "caches",
                          "library_build_type", "cpu_model", "git_commit"})
    EXPECT_TRUE(j["context"].contains(key)) << key;
  const auto& b = j["benchmarks"];
  // Two rows, each 3 repetitions and 4 aggregates.
  ASSERT_EQ(b.size(), 14u);
  int iterations = 0;
  for (const auto& e : b) {
    for (const char* key : {"name", "run_name", "run_type", "repetitions", "real_time", "cpu_time",
                            "time_unit", "threads"})
      EXPECT_TRUE(e.contains(key)) << key << " in " << e.dump();
    EXPECT_EQ(e["repetitions"], 3);
    if (e["run_type"] == "iteration") {
      ++iterations;
      EXPECT_GT(e["real_time"].get<double>(), 0);
      EXPECT_GT(e["items_per_second"].get<double>(), 0);
      EXPECT_EQ(e["name"], e["run_name"]);
    } else {
      const std::string agg = e["aggregate_name"];
      EXPECT_EQ(e["name"].get<std::string>(), e["run_name"].get<std::string>() + "_" + agg);
      EXPECT_EQ(e["aggregate_unit"], agg == "cv" ? "percentage" : "time");
    }
  }
  EXPECT_EQ(iterations, 6);
  EXPECT_EQ(b[0]["name"], "lancer/primary/exact/w1/threads:1/real_time");
  // The median aggregate is the median of the three repetitions.
  std::vector<double> t{b[0]["real_time"], b[1]["real_time"], b[2]["real_time"]};
  std::sort(t.begin(), t.end());
  EXPECT_DOUBLE_EQ(b[4]["real_time"].get<double>(), t[1]);
  EXPECT_EQ(b[4]["aggregate_name"], "median");
}

// context.git_commit was the commit CMake last configured at, with no mark of uncommitted
// changes. Now cmake/git_commit.cmake writes it at every build: the commit, "-dirty" when tracked
// files differ from it, "unknown" outside git; the header is rewritten only when that changes,
// so that a build of the same commit recompiles nothing. Checked on a repository of its own.
TEST(BenchGbench, GitCommitIsTheCommitBuilt) {
  TempDir dir;
  const std::string repo = dir.file("repo"), header = dir.file("commit.hpp");
  std::filesystem::create_directories(repo);
  const std::string git = "git -C " + repo + " -c user.name=t -c user.email=t@t ";
  const std::string script = std::string(LANCER_CMAKE) + " -DGIT=git -DSOURCE_DIR=" + repo +
                             " -DOUTPUT=" + header + " -P " + source_path("cmake/git_commit.cmake");
  ASSERT_EQ(run_command(script).status, 0);
  EXPECT_NE(slurp(header).find("LANCER_GIT_COMMIT \"unknown\""), std::string::npos)
      << slurp(header);
  std::ofstream(repo + "/a.txt") << "a\n";
  ASSERT_EQ(run_command(git + "init -q && " + git + "add a.txt && " + git + "commit -qm a").status,
            0);
  const auto head = run_command(git + "rev-parse HEAD");
  ASSERT_EQ(head.status, 0) << head.out;
  const std::string commit = head.out.substr(0, head.out.find('\n'));
  ASSERT_EQ(run_command(script).status, 0);
  EXPECT_NE(slurp(header).find("LANCER_GIT_COMMIT \"" + commit + "\""), std::string::npos)
      << slurp(header);
  // The same commit again: the file is left alone (its time set back shows it).
  const auto before = std::filesystem::last_write_time(header) - std::chrono::hours(1);
  std::filesystem::last_write_time(header, before);
  ASSERT_EQ(run_command(script).status, 0);
  EXPECT_EQ(std::filesystem::last_write_time(header), before);
  // A change to a tracked file not committed; an untracked file alone is not one.
  std::ofstream(repo + "/b.txt") << "b\n";
  ASSERT_EQ(run_command(script).status, 0);
  EXPECT_EQ(std::filesystem::last_write_time(header), before);
  std::ofstream(repo + "/a.txt") << "changed\n";
  ASSERT_EQ(run_command(script).status, 0);
  EXPECT_NE(slurp(header).find("LANCER_GIT_COMMIT \"" + commit + "-dirty\""), std::string::npos)
      << slurp(header);

  // And bench reports what its build's header says (this checkout's commit when built from it;
  // the header, not `git rev-parse` now, so that a commit made since the build is no failure).
  const auto r = run_command(cli() + " bench " + source_path("scenes/lorenzi-diffuse.json") +
                             " --resolution 8x8 --width 1 --repeat 1 --warmup 0 --mode primary "
                             "--format gbench > " +
                             dir.file("g.json"));
  ASSERT_EQ(r.status, 0) << r.out;
  const std::string got = nlohmann::json::parse(slurp(dir.file("g.json")))["context"]["git_commit"];
  EXPECT_NE(slurp(LANCER_GIT_HEADER).find("LANCER_GIT_COMMIT \"" + got + "\""), std::string::npos)
      << got << " in " << slurp(LANCER_GIT_HEADER);
}

// Ratios between scenes are taken round by round, per ray: a round where the machine ran slow
// for both scenes gives the same ratio as a fast one.
TEST(BenchSideBySide, TimePerRayRoundByRound) {
  auto result = [](std::uint64_t rays, std::vector<std::vector<double>> samples) {
    BenchResult r;
    for (auto& s : samples) {
      BenchRow row;
      row.rays = rays;
      row.samples = s;
      r.rows.push_back(row);
    }
    return r;
  };
  // Scene 2 has twice the rays: its seconds per ray are half its seconds per render's share.
  const std::vector<BenchResult> results{result(100, {{1.0, 2.0, 1.0}, {4.0, 4.0, 4.0}}),
                                         result(200, {{6.0, 12.0, 8.0}, {8.0, 8.0, 16.0}}),
                                         result(100, {{1.0, 2.0, 1.0}, {4.0, 4.0, 4.0}})};
  const std::vector<SideBySide> s = bench_side_by_side(results);
  ASSERT_EQ(s.size(), 4u);
  EXPECT_EQ(s[0].scene, 1u);
  EXPECT_EQ(s[0].row, 0u);
  EXPECT_EQ(s[0].ratios, (std::vector<double>{3.0, 3.0, 4.0}));
  EXPECT_DOUBLE_EQ(s[0].median, 3.0);
  EXPECT_DOUBLE_EQ(s[0].min, 3.0);
  EXPECT_DOUBLE_EQ(s[0].max, 4.0);
  EXPECT_EQ(s[1].row, 1u);
  EXPECT_EQ(s[1].ratios, (std::vector<double>{1.0, 1.0, 2.0}));
  EXPECT_EQ(s[2].scene, 2u);
  EXPECT_DOUBLE_EQ(s[2].median, 1.0);
  EXPECT_TRUE(bench_side_by_side({results[0]}).empty());
}

// Several scenes in one run: each its own rows and structure, in the order given, and the
// side-by-side ratios those rows' own samples give.
TEST(BenchCliSeveralScenes, RowsPerSceneAndRatiosFromTheirSamples) {
  if (!has_width(4)) GTEST_SKIP() << "this run offers no packet width 4 (LANCER_MAX_WIDTH=1)";
  const std::string small = source_path("scenes/lorenzi-diffuse.json");
  const std::string large = source_path("scenes/many-spheres.json");
  const auto r = run_command(cli() + " bench " + small + " " + large +
                             " --resolution 24x16 --width 1,4 --repeat 3 --mode primary --json");
  ASSERT_EQ(r.status, 0) << r.out;
  const auto j = nlohmann::json::parse(r.out);
  ASSERT_EQ(j["scenes"].size(), 2u);
  EXPECT_EQ(j["scenes"][0]["scene"], small);
  EXPECT_EQ(j["scenes"][1]["scene"], large);
  EXPECT_LT(j["scenes"][0]["structure"]["objects"].get<int>(),
            j["scenes"][1]["structure"]["objects"].get<int>());
  ASSERT_EQ(j["side_by_side"].size(), 2u);
  for (int k = 0; k < 2; ++k) {
    const auto& a = j["scenes"][0]["results"][k];
    const auto& b = j["scenes"][1]["results"][k];
    const auto& s = j["side_by_side"][k];
    EXPECT_EQ(s["scene"], large);
    EXPECT_EQ(s["against"], small);
    EXPECT_EQ(s["width"], a["width"]);
    EXPECT_EQ(s["width"], b["width"]);
    ASSERT_EQ(s["ratios"].size(), 3u);
    for (int rep = 0; rep < 3; ++rep) {
      const double ta = a["samples_seconds"][rep].get<double>() / a["rays"].get<double>();
      const double tb = b["samples_seconds"][rep].get<double>() / b["rays"].get<double>();
      EXPECT_DOUBLE_EQ(s["ratios"][rep].get<double>(), tb / ta);
    }
  }
  // The table names both scenes and the side-by-side lines.
  const auto t = run_command(cli() + " bench " + small + " " + large +
                             " --resolution 24x16 --width 4 --repeat 1 --mode primary");
  ASSERT_EQ(t.status, 0) << t.out;
  EXPECT_NE(t.out.find("side by side"), std::string::npos) << t.out;
  EXPECT_NE(t.out.find(large), std::string::npos) << t.out;
}

TEST(BenchCliSeveralScenes, BadInputNamesItsPlace) {
  const std::string small = source_path("scenes/lorenzi-diffuse.json");
  const auto missing =
      run_command(cli() + " bench " + small + " /nonexistent/scene.json --repeat 1");
  EXPECT_EQ(missing.status, 2);
  EXPECT_NE(missing.out.find("/nonexistent/scene.json"), std::string::npos) << missing.out;
  const auto gbench =
      run_command(cli() + " bench " + small + " " + small + " --repeat 1 --format gbench");
  EXPECT_EQ(gbench.status, 2);
  EXPECT_NE(gbench.out.find("--format gbench"), std::string::npos) << gbench.out;
}

TEST(BenchCliFormat, BadFormatIsAnInputError) {
  const auto r =
      run_command(cli() + " bench " + source_path("scenes/lorenzi-diffuse.json") + " --format xml");
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.out.find("--format"), std::string::npos);
}

// --peak's flop model is the plain loop's (every camera ray against every object): through a
// hierarchy it reported 269% of the peak on many-spheres.json, so there it counts no flops.
TEST(BenchPeak, FlopsOnlyForThePlainLoop) {
  if (!has_width(4)) GTEST_SKIP() << "this run offers no packet width 4 (LANCER_MAX_WIDTH=1)";
  auto bench = [](const std::string& accel) {
    const auto r = run_command(cli() + " bench " + source_path("scenes/many-spheres.json") +
                               " --resolution 24x16 --width 4 --repeat 1 --mode primary,kernel "
                               "--peak --json --accel " +
                               accel);
    EXPECT_EQ(r.status, 0) << r.out;
    return nlohmann::json::parse(r.out);
  };
  const auto plain = bench("none");
  EXPECT_EQ(plain["structure"]["kind"], "none");
  for (const auto& row : plain["results"]) {
    ASSERT_TRUE(row.contains("gflops")) << row.dump();
    EXPECT_GT(row["gflops"].get<double>(), 0);
  }
  const auto bvh = bench("bvh");
  EXPECT_EQ(bvh["structure"]["kind"], "bvh");
  ASSERT_EQ(bvh["results"].size(), 2u);
  for (const auto& row : bvh["results"]) EXPECT_FALSE(row.contains("gflops")) << row.dump();
  EXPECT_FALSE(bvh["peak"].empty());  // the peak itself is still timed
}

// The progress line never wraps: at most columns - 1 characters at any width, the percentage
// kept to the narrowest.
TEST(Progress, NeverWiderThanTheTerminal) {
  for (int columns : {1, 5, 10, 20, 40, 60, 80, 120, 300})
    for (int done : {0, 1, 500, 999, 1000}) {
      const std::string line = progress_line(done, 1000, 2.5, columns);
      EXPECT_LE(int(line.size()), std::max(0, columns - 1)) << columns << " " << line;
      if (columns >= 10) {
        EXPECT_NE(line.find('%'), std::string::npos) << line;
      }
    }
  const std::string wide = progress_line(250, 1000, 2.0, 120);
  EXPECT_NE(wide.find(" 25%"), std::string::npos) << wide;
  EXPECT_NE(wide.find("6.0 s left"), std::string::npos) << wide;  // 750 rows at 125 rows/s
  EXPECT_NE(wide.find("2.0 s elapsed"), std::string::npos) << wide;
  EXPECT_NE(wide.find("125 rows/s"), std::string::npos) << wide;
  EXPECT_NE(progress_line(1000, 1000, 8, 80).find("done"), std::string::npos);
  EXPECT_EQ(format_duration(185), "3 min 05 s");
}

TEST(JsonSummaries, RenderValidateProfile) {
  if (!has_width(4)) GTEST_SKIP() << "this run offers no packet width 4 (LANCER_MAX_WIDTH=1)";
  TempDir dir;
  const std::string scene = source_path("scenes/lorenzi-diffuse.json");
  ASSERT_EQ(run_command(cli() + " render " + scene + " --resolution 32x20 --json -o " +
                        dir.file("r.png") + " > " + dir.file("r.json"))
                .status,
            0);
  const auto r = nlohmann::json::parse(slurp(dir.file("r.json")));
  EXPECT_EQ(r["resolution"], (nlohmann::json{32, 20}));
  EXPECT_EQ(r["rays"]["camera"], 640);
  EXPECT_GE(r["write_seconds"].get<double>(), 0);
  EXPECT_GT(r["render_seconds"].get<double>(), 0);
  EXPECT_GE(r["load_seconds"].get<double>(), 0);
  EXPECT_GT(r["peak_resident_bytes"].get<double>(), 1e6);
  EXPECT_EQ(read_image(dir.file("r.png")).nx, 32);

  ASSERT_EQ(run_command(cli() + " validate " + scene + " --resolution 32x20 --json > " +
                        dir.file("v.json"))
                .status,
            0);
  const auto v = nlohmann::json::parse(slurp(dir.file("v.json")));
  EXPECT_EQ(v["identical"], true);
  ASSERT_FALSE(v["widths"].empty());
  for (const auto& w : v["widths"]) {
    EXPECT_EQ(w["differing_pixels"], 0);
    EXPECT_TRUE(w["first_differing_pixel"].is_null());
  }

  ASSERT_EQ(run_command(cli() + " profile " + scene + " --resolution 32x20 --json > " +
                        dir.file("p.json"))
                .status,
            0);
  const auto p = nlohmann::json::parse(slurp(dir.file("p.json")));
  bool saw_null = false;
  for (const auto& st : p["stages"]) {
    if (st["name"] == "output") {
      EXPECT_TRUE(st["lane_occupancy"].is_null()) << st.dump();
      saw_null = true;
    } else if (st["lane_occupancy"].is_number()) {
      EXPECT_GT(st["lane_occupancy"].get<double>(), 0) << st.dump();
    }
    // Rays per second of the stage's own time, where it counted packets: rays / seconds.
    if (st["lane_occupancy"].is_null()) {
      EXPECT_TRUE(st["mrays_per_s"].is_null()) << st.dump();
    } else if (st["rays"].get<double>() > 0 && st["seconds"].get<double>() > 0) {
      EXPECT_NEAR(st["mrays_per_s"].get<double>(),
                  st["rays"].get<double>() / st["seconds"].get<double>() * 1e-6,
                  1e-9 * st["mrays_per_s"].get<double>())
          << st.dump();
    }
    // Leaf occupancy is measured only where leaves were visited: never a 0 standing for none.
    if (st["leaf_visits"] == 0)
      EXPECT_TRUE(st["leaf_occupancy"].is_null()) << st.dump();
    else
      EXPECT_GT(st["leaf_occupancy"].get<double>(), 0) << st.dump();
  }
  EXPECT_TRUE(saw_null);
}

TEST(PlotCli, CsvToSvgAndOneLineErrors) {
  TempDir dir;
  {
    std::ofstream csv(dir.file("s.csv"));
    csv << "engine,spheres,mrays_per_s\nlancer,1,300\nlancer,100,120\nembree,1,25\n"
           "embree,100,22\n";
  }
  const auto ok =
      run_command(cli() + " plot " + dir.file("s.csv") +
                  " --x spheres --y mrays_per_s --group engine --log xy -o " + dir.file("s.svg"));
  ASSERT_EQ(ok.status, 0) << ok.out;
  EXPECT_NE(ok.out.find("2 series, 4 points"), std::string::npos) << ok.out;
  EXPECT_EQ(slurp(dir.file("s.svg")).rfind("<?xml", 0), 0u);
  const auto bad = run_command(cli() + " plot " + dir.file("s.csv") + " --x spheres --y speed -o " +
                               dir.file("t.svg"));
  EXPECT_EQ(bad.status, 2);
  EXPECT_EQ(bad.out, "lancer: " + dir.file("s.csv") + ":1: no column 'speed' (for --y)\n");
  EXPECT_FALSE(std::filesystem::exists(dir.file("t.svg")));
  EXPECT_EQ(run_command(cli() + " plot " + dir.file("s.csv") + " --x spheres --y mrays_per_s " +
                        "--log z -o " + dir.file("t.svg"))
                .status,
            2);
}

// Every command that writes a file names it in its summary: trade --plot wrote its figure
// silently.
TEST(TradeCli, SummaryNamesTheFigure) {
  TempDir dir;
  const std::string scene = source_path("scenes/lorenzi-diffuse.json");
  const auto r = run_command(cli() + " trade " + scene + " --resolution 24x16 --repeat 1 --plot " +
                             dir.file("t.svg"));
  ASSERT_EQ(r.status, 0) << r.out;
  EXPECT_NE(r.out.find("lancer trade: wrote " + dir.file("t.svg")), std::string::npos) << r.out;
  EXPECT_TRUE(std::ifstream(dir.file("t.svg")).good());
}

}  // namespace
}  // namespace lancer
