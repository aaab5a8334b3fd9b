// Input limits: documents too deep, numbers too big, scenes too large to render, and a scene of a
// million spheres, which must load in memory proportional to its text.
#include <gtest/gtest.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "lancer/error.hpp"
#include "lancer/scene.hpp"
#include "support/test_util.hpp"

#if defined(__SANITIZE_ADDRESS__)
#define LANCER_UNDER_ASAN 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define LANCER_UNDER_ASAN 1
#endif
#endif

namespace lancer {
namespace {

namespace fs = std::filesystem;

const std::string kCam =
    R"("camera":{"type":"pinhole","position":[0,0,0],"direction":[0,0,-1],"distance":1,)"
    R"("resolution":[4,4],"bounds":[-1,1,-1,1]})";

// `lancer render FILE -o OUT.png`: exit status, stderr.
struct CliResult {
  int status = -1;
  std::string err;
};
// `lancer render SCENE -o OUT`, its stderr kept in the file `err` (removed afterwards).
CliResult run_render(const std::string& scene, const std::string& out, const std::string& err) {
  const std::string cmd = std::string("'") + LANCER_CLI + "' render '" + scene + "' -o '" + out +
                          "' >/dev/null 2>'" + err + "'";
  const int st = std::system(cmd.c_str());
  CliResult r;
  r.status = WIFEXITED(st) ? WEXITSTATUS(st) : -1;
  std::ifstream in(err);
  std::ostringstream s;
  s << in.rdbuf();
  r.err = s.str();
  fs::remove(err);
  return r;
}

CliResult render_file(const std::string& text) {
  const std::string dir =
      (fs::temp_directory_path() / ("lancer-limits-" + std::to_string(getpid()))).string();
  fs::create_directories(dir);
  const std::string scene = dir + "/scene.json", out = dir + "/out.png";
  std::ofstream(scene, std::ios::binary) << text;
  const CliResult r = run_render(scene, out, dir + "/err.txt");
  EXPECT_FALSE(fs::exists(out)) << "an output file was written";
  fs::remove_all(dir);
  return r;
}

void expect_clean_refusal(const std::string& text, const std::string& must_mention) {
  const CliResult r = render_file(text);
  EXPECT_EQ(r.status, 2) << r.err;
  EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
  EXPECT_NE(r.err.find(must_mention), std::string::npos) << r.err;
  EXPECT_LT(r.err.size(), 400u) << r.err;
}

// 100000 '[' : the parser's depth callback stops it, no stack overflow, one line, exit 2.
TEST(Limits, DeepNestingIsRefusedByTheCli) {
  expect_clean_refusal(std::string(100000, '['), "nested deeper than 32 levels");
  expect_clean_refusal(std::string(100000, '{'), "syntax error");  // '{' wants a key first
  expect_clean_refusal("{\"a\":" + std::string(100000, '{'), "syntax error");
  std::string objects = "{" + kCam + ",\"objects\":[";
  for (int i = 0; i < 100000; ++i) objects += "{\"a\":";
  expect_clean_refusal(objects, "nested deeper than 32 levels");
  expect_clean_refusal(std::string(100000, '[') + std::string(100000, ']'),
                       "nested deeper than 32 levels");
}

TEST(Limits, NestingUpToTheLimitIsOnlyWrongTypes) {
  // 32 levels is allowed by the parser; the loader then says what is wrong with the value.
  const std::string deep = std::string(30, '[') + "1" + std::string(30, ']');
  EXPECT_EQ(testing::load_error("{\"camera\":" + deep + "}"), "s.json: camera: must be an object");
}

TEST(Limits, HugeNumbersAreRefusedByTheCli) {
  expect_clean_refusal("{\"camera\":1e99999999999}", "number overflow");
  expect_clean_refusal("{\"camera\":-1e400}", "number overflow");
  expect_clean_refusal("{\"camera\":1" + std::string(100000, '0') + "}", "number overflow");
  expect_clean_refusal("{" + kCam + ",\"objects\":[],\"max_depth\":1" + std::string(30, '0') + "}",
                       "max_depth: must be an integer");
  expect_clean_refusal("{" + kCam + ",\"objects\":[],\"max_depth\":18446744073709551615}",
                       "max_depth: must be an integer");
  expect_clean_refusal("{" + kCam + ",\"objects\":[],\"max_depth\":-9223372036854775808}",
                       "max_depth: must be an integer");
  // Underflow is no error: the number is 0.
  EXPECT_EQ(testing::load_error("{" + kCam + ",\"objects\":[],\"epsilon\":1e-99999}"),
            "(no error)");
}

// `lancer render` on things that are not scene files.
CliResult render_path(const std::string& scene) {
  return run_render(
      scene, "/proc/lancer-never.png",
      (fs::temp_directory_path() / ("lancer-limits-err-" + std::to_string(getpid()))).string());
}

TEST(Limits, FolderAsSceneFile) {
  const CliResult r = render_path(fs::temp_directory_path().string());
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find("is a folder, not a scene file"), std::string::npos) << r.err;
}

// An endless input is refused at once (not a regular file), never read until memory runs out.
TEST(Limits, EndlessSceneFileIsRefused) {
  const CliResult r = render_path("/dev/zero");
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find("/dev/zero: is not a regular file"), std::string::npos) << r.err;
}

// A regular file over the limit is refused by its size, before it is read (a sparse file here).
TEST(Limits, SceneFileOverOneGiB) {
  const std::string path =
      (fs::temp_directory_path() / ("lancer-limits-big-" + std::to_string(getpid()) + ".json"))
          .string();
  std::ofstream(path).put('{');
  fs::resize_file(path, (std::uintmax_t(1) << 30) + 1);
  const CliResult r = render_path(path);
  fs::remove(path);
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find(path + ": file larger than 1 GiB"), std::string::npos) << r.err;
}

TEST(Limits, ResolutionTimesSamplesIsCapped) {
  auto with = [](const std::string& res, int ss) {
    return testing::load_error(
        R"({"camera":{"type":"pinhole","position":[0,0,0],"direction":[0,0,-1],)"
        R"("distance":1,"resolution":)" +
        res +
        R"(,"bounds":[-1,1,-1,1]},)"
        R"("supersample":)" +
        std::to_string(ss) + R"(,"objects":[]})");
  };
  EXPECT_NE(with("[65536,65536]", 1).find("resolution x supersample^2 exceeds"), std::string::npos);
  EXPECT_NE(with("[65537,1]", 1).find("must be at most 65536 per axis"), std::string::npos);
  EXPECT_NE(with("[1,1]", 65).find("supersample: must be at most 64"), std::string::npos);
  EXPECT_NE(with("[1024,512]", 64).find("exceeds"), std::string::npos);
  EXPECT_EQ(with("[512,512]", 64), "(no error)");  // exactly 2^30 samples
  EXPECT_NE(testing::load_error("{" + kCam + R"(,"objects":[],"max_depth":65})").find("at most 64"),
            std::string::npos);
}

long peak_rss_kib() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return u.ru_maxrss;
}

// A million spheres: the text is built in memory and parsed. Memory is measured by the peak
// resident size, which the DOM of nlohmann::json dominates (about 11 times the text's 53 MB);
// nothing is timed. About 2.5 s in a Release build, 30 s under ASan (where the memory bound is
// not checked). It took minutes before parse_json stopped using json::parse's callback.
TEST(Limits, MillionSpheresLoad) {
  constexpr int kSpheres = 1000000;
  std::string text = "{" + kCam + R"(,"lights":[{"position":[0,10,0]}],"objects":[)";
  text.reserve(std::size_t(kSpheres) * 80);
  char buf[128];
  for (int i = 0; i < kSpheres; ++i) {
    std::snprintf(buf, sizeof buf, R"(%s{"type":"sphere","center":[%d,%d,%d],"radius":0.25})",
                  i ? "," : "", i % 100, (i / 100) % 100, -(i / 10000));
    text += buf;
  }
  text += "]}";
  const long before = peak_rss_kib();
  const Scene s = parse_scene(text, "million.json");
  const long after = peak_rss_kib();
  EXPECT_EQ(s.spheres.size(), std::size_t(kSpheres));
  EXPECT_EQ(s.spheres.back().center.z, -99);
  EXPECT_EQ(s.materials.size(), 1u);  // one default material shared by all
  // Proportional: the peak grew by less than 16 times the text (about 10 is what the DOM takes).
  const double text_kib = text.size() / 1024.0;
  RecordProperty("text_mib", std::to_string(text_kib / 1024));
  RecordProperty("peak_growth_mib", std::to_string((after - before) / 1024.0));
#ifdef LANCER_UNDER_ASAN
  // AddressSanitizer's redzones and quarantine about double the footprint: no bound to check.
  std::printf("text %.1f MiB, peak grew by %.1f MiB (ASan)\n", text_kib / 1024,
              (after - before) / 1024.0);
#else
  EXPECT_LT(after - before, 20 * text_kib)
      << "text " << text_kib / 1024 << " MiB, peak grew by " << (after - before) / 1024.0 << " MiB";
#endif
}

}  // namespace
}  // namespace lancer
