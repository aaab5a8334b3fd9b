// Bad input and its one line: messages that blame the right thing and name the right file, file
// names that cannot break the one-line rule, garbage options refused rather than taken for the
// defaults, and signals ignored at start left ignored. Each case failed before its fix.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <fstream>
#include <nlohmann/json.hpp>
#include <thread>

#include "lancer/peer.hpp"
#include "lancer/text.hpp"
#include "support/test_util.hpp"

namespace lancer::testing {
namespace {

using nlohmann::json;

const std::string kScene = source_path("scenes/lorenzi-diffuse.json");

// One line on stderr (run_command merges it with stdout: these commands print nothing else).
void expect_one_line(const CommandResult& r, int status, const std::string& text) {
  EXPECT_EQ(r.status, status) << r.out;
  EXPECT_EQ(std::count(r.out.begin(), r.out.end(), '\n'), 1) << r.out;
  EXPECT_NE(r.out.find(text), std::string::npos) << "wanted '" << text << "' in: " << r.out;
}

std::string read_text(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

TEST(Messages, WidthLeftOutByLancerMaxWidthBlamesIt) {
  const std::vector<int> widths = packet_widths();
  if (widths.empty() || widths.front() != 16) GTEST_SKIP() << "this CPU lacks width 16";
  TempDir dir;
  const CommandResult r = run_command("LANCER_MAX_WIDTH=8 " + cli() + " render " + kScene + " -o " +
                                      dir.file("x.png") + " --width 16");
  expect_one_line(r, 2, "LANCER_MAX_WIDTH=8 leaves out");
  EXPECT_EQ(r.out.find("this CPU"), std::string::npos) << r.out;
  EXPECT_FALSE(std::filesystem::exists(dir.file("x.png")));
}

// Fast mode has no width 1: with the packets capped at 1 lane (or a CPU without SSE4.2) it has
// no width at all, and render crashed reading the first of none (a segmentation fault). Now one
// line naming the cap; the library refuses the scene the same way.
TEST(Messages, FastPrecisionWithoutPacketsIsOneLine) {
  TempDir dir;
  const CommandResult r = run_command("LANCER_MAX_WIDTH=1 " + cli() + " render " + kScene +
                                      " --precision fast -o " + dir.file("x.png"));
  expect_one_line(r, 2, "fast precision runs on packets of 4 lanes or more");
  expect_one_line(r, 2, "LANCER_MAX_WIDTH=1 leaves out");
  EXPECT_FALSE(std::filesystem::exists(dir.file("x.png")));
}

// bench, profile, trade and validate under the same cap. bench's default widths ("all") came out
// empty and said "--width: no width given", blaming a width nobody gave; profile's auto width
// fell back to 1 and asked for 4, 8 or 16; trade left its fast rows out without a word; validate
// --width all asked for "at least one of 4, 8, 16".
TEST(Messages, ToolsWithoutPacketsNameTheCap) {
  const std::string cap = "LANCER_MAX_WIDTH=1 ";
  const CommandResult bench =
      run_command(cap + cli() + " bench " + kScene + " --precision fast --resolution 8x8");
  expect_one_line(bench, 2, "--width: fast precision runs on packets of 4 lanes or more");
  expect_one_line(bench, 2, "LANCER_MAX_WIDTH=1 leaves out");
  const CommandResult mixed = run_command(cap + cli() + " bench " + kScene +
                                          " --precision exact,fast --width all --resolution 8x8");
  expect_one_line(mixed, 2, "LANCER_MAX_WIDTH=1 leaves out");
  const CommandResult profile = run_command(cap + cli() + " profile " + kScene);
  expect_one_line(profile, 2, "profile instruments the packet kernels");
  expect_one_line(profile, 2, "LANCER_MAX_WIDTH=1 leaves out");
  const CommandResult validate =
      run_command(cap + cli() + " validate " + kScene + " --width all --resolution 8x8");
  expect_one_line(validate, 2, "LANCER_MAX_WIDTH=1");
  EXPECT_EQ(validate.out.find("give at least one"), std::string::npos) << validate.out;
  const CommandResult trade =
      run_command(cap + cli() + " trade " + kScene + " --repeat 1 --resolution 8x8");
  EXPECT_EQ(trade.status, 0) << trade.out;
  EXPECT_NE(trade.out.find("lancer trade: no fast rows: fast precision runs on packets of 4 "
                           "lanes or more, which LANCER_MAX_WIDTH=1 leaves out"),
            std::string::npos)
      << trade.out;
}

// The ao and diffuse modes trace through the library API, which has no packets of 2 rays: double
// precision's width 2 was dropped from their rows without a word, and with nothing else asked for
// the run was refused as if --mode kernel had been given.
TEST(Messages, RaySetWidthWithoutApiPacketsIsSaid) {
  const std::vector<int> dbl = packet_widths(Precision::dbl);
  if (std::find(dbl.begin(), dbl.end(), 2) == dbl.end()) GTEST_SKIP() << "no double width 2";
  const std::string bench = cli() + " bench " + kScene + " --precision double --repeat 1 " +
                            "--warmup 0 --resolution 8x8 --mode ";
  const CommandResult none = run_command(bench + "ao,diffuse --width 2");
  expect_one_line(none, 2,
                  "--width 2: the ao and diffuse modes trace through the library API, whose "
                  "packets are 1, 4, 8 or 16 rays: nothing to run");
  EXPECT_EQ(none.out.find("--mode kernel"), std::string::npos) << none.out;
  const CommandResult some = run_command(bench + "ao --width 1,2");
  EXPECT_EQ(some.status, 0) << some.out;
  EXPECT_NE(some.out.find("lancer: --width 2: the ao mode traces through the library API, whose "
                          "packets are 1, 4, 8 or 16 rays: no ao row at width 2 (double "
                          "precision)\n"),
            std::string::npos)
      << some.out;
  EXPECT_NE(some.out.find("  lancer   ao       double        1 "), std::string::npos) << some.out;
}

// A deep bound that overflows to infinity: 0 x infinity was NaN for the material that reflects
// nothing, which then won the comparison and took the blame ("objects[1] ...: -nan").
TEST(Messages, RadianceBoundBlamesTheReflectingObject) {
  json j = json::parse(read_text(kScene));
  j["max_depth"] = 12;
  j["objects"][0]["material"] = {{"reflect", 1e30}};
  const std::string why = load_error(j.dump());
  EXPECT_NE(why.find("s.json: objects[0].material: "), std::string::npos) << why;
  EXPECT_EQ(why.find("objects[1]"), std::string::npos) << why;
  EXPECT_EQ(why.find("nan"), std::string::npos) << why;
}

TEST(Messages, CompareDiffOntoAnInputSaysSo) {
  TempDir dir;
  for (const char* name : {"a.png", "c.png"})
    ASSERT_EQ(
        run_command(cli() + " render " + kScene + " -o " + dir.file(name) + " --resolution 8x6")
            .status,
        0);
  const auto before = std::filesystem::last_write_time(dir.file("a.png"));
  CommandResult r = run_command(cli() + " compare " + dir.file("a.png") + " " + dir.file("c.png") +
                                " --diff " + dir.file("a.png"));
  expect_one_line(r, 2, "would overwrite the first input image");
  EXPECT_EQ(r.out.find("scene"), std::string::npos) << r.out;
  r = run_command(cli() + " compare " + dir.file("a.png") + " " + dir.file("c.png") + " --diff " +
                  dir.file("c.png"));
  expect_one_line(r, 2, "would overwrite the second input image");
  EXPECT_EQ(std::filesystem::last_write_time(dir.file("a.png")), before);
}

TEST(Messages, FluxOnAPinholeSceneNamesTheFile) {
  const CommandResult r = run_command(cli() + " flux " + kScene);
  expect_one_line(r, 2, "lancer: " + kScene + ": camera.type: ");
}

TEST(Messages, DrawingFormatsListSvgAndPdf) {
  TempDir dir;
  const CommandResult r = run_command(cli() + " trade " + kScene + " --plot " + dir.file("t.xyz"));
  expect_one_line(r, 2, "--plot " + dir.file("t.xyz") + ": lancer does not draw '.xyz' files");
  EXPECT_NE(r.out.find(".svg .pdf .png"), std::string::npos) << r.out;
}

TEST(Messages, ShownPathQuotesOnlyWhatNeedsIt) {
  EXPECT_EQ(shown_path("scenes/a b.json"), "scenes/a b.json");
  EXPECT_EQ(shown_path("caf\xc3\xa9.json"), "caf\xc3\xa9.json");  // UTF-8 text as is
  EXPECT_EQ(shown_path("a\nb.json"), "\"a\\nb.json\"");
  EXPECT_EQ(shown_path("\x1b[31mred\\\".json"), "\"\\x1b[31mred\\\\\\\".json\"");
  EXPECT_EQ(shown_path("x\xc2\x9b"
                       "2J"),
            "\"x\\u009b2J\"");  // C1 CSI
}

// A file name holding a newline or a terminal escape: still one line, the name quoted, nothing
// for the terminal to obey.
TEST(Messages, FileNamesWithControlCharactersKeepOneLine) {
  TempDir dir;
  for (const std::string name : {"new\nline.json", "esc\x1b[2Jape.json"}) {
    setenv("LANCER_TEST_NAME", dir.file(name).c_str(), 1);
    for (const std::string& command :
         {cli() + " render \"$LANCER_TEST_NAME\" -o " + dir.file("x.png"),   // missing scene
          cli() + " render " + kScene + " -o \"$LANCER_TEST_NAME.xyz\""}) {  // not an image
      const CommandResult r = run_command(command);
      EXPECT_EQ(r.status, 2) << r.out;
      EXPECT_EQ(std::count(r.out.begin(), r.out.end(), '\n'), 1) << r.out;
      EXPECT_EQ(r.out.find('\x1b'), std::string::npos) << r.out;
    }
    std::ofstream(dir.file(name)) << "{";  // a syntax error, named by the loader
    CommandResult r = run_command(cli() + " validate \"$LANCER_TEST_NAME\"");
    EXPECT_EQ(r.status, 2) << r.out;
    EXPECT_EQ(std::count(r.out.begin(), r.out.end(), '\n'), 1) << r.out;
    EXPECT_NE(r.out.find(shown_path(dir.file(name))), std::string::npos) << r.out;
    // A render's summary names its output as the messages do.
    r = run_command(cli() + " render " + kScene + " -o \"$LANCER_TEST_NAME.png\" --resolution 4x4");
    EXPECT_EQ(r.status, 0) << r.out;
    EXPECT_EQ(
        r.out.rfind("lancer: " + kScene + " -> " + shown_path(dir.file(name + ".png")) + "\n", 0),
        0u)
        << r.out;
    EXPECT_EQ(r.out.find('\x1b'), std::string::npos) << r.out;
  }
  unsetenv("LANCER_TEST_NAME");
}

TEST(Garbage, GenerateRefusesBadNumbers) {
  TempDir dir;
  const std::string out = " -o " + dir.file("g.json");
  for (const auto& [args, option] :
       std::vector<std::pair<std::string, std::string>>{{"--ior -1", "--ior"},
                                                        {"--ior nan", "--ior"},
                                                        {"--ior ''", "--ior"},
                                                        {"--transmit nan", "--transmit"},
                                                        {"--transmit -0.5", "--transmit"},
                                                        {"--seed -1", "--seed"},
                                                        {"--seed 18446744073709551616", "--seed"},
                                                        {"--seed ' 5'", "--seed"},
                                                        {"--resolution ' 5x5'", "--resolution"},
                                                        {"--resolution '5x5 '", "--resolution"}}) {
    SCOPED_TRACE(args);
    expect_one_line(run_command(cli() + " generate --spheres 2 " + args + out), 2, option + ":");
    EXPECT_FALSE(std::filesystem::exists(dir.file("g.json")));
  }
  // The extremes of the ranges still pass.
  EXPECT_EQ(run_command(cli() +
                        " generate --spheres 2 --seed 18446744073709551615 --ior 10 "
                        "--transmit 0" +
                        out)
                .status,
            0);
}

TEST(Garbage, EmptyOrSpacedValuesAreNotTheDefaults) {
  TempDir dir;
  const std::string render = cli() + " render " + kScene + " -o " + dir.file("x.png") + " ";
  for (const auto& [args, option] :
       std::vector<std::pair<std::string, std::string>>{{"--threads ''", "--threads"},
                                                        {"--resolution ''", "--resolution"},
                                                        {"--resolution=", "--resolution"},
                                                        {"--resolution ' 5x5'", "--resolution"},
                                                        {"--resolution '+5x5'", "--resolution"},
                                                        {"--supersample ''", "--supersample"},
                                                        {"--precision ''", "--precision"},
                                                        {"--accel kd", "--accel"}}) {
    SCOPED_TRACE(args);
    expect_one_line(run_command(render + args), 2, option + ":");
    EXPECT_FALSE(std::filesystem::exists(dir.file("x.png")));
  }
  expect_one_line(run_command(cli() + " bench " + kScene + " --threads ''"), 2, "--threads:");
}

TEST(Garbage, EmbreeConfigRefusesWhatEmbreeWouldIgnore) {
  EXPECT_NO_THROW(peer::check_embree_config(""));
  EXPECT_NO_THROW(peer::check_embree_config("isa=avx2,threads=1, verbose=1"));
  EXPECT_NO_THROW(peer::check_embree_config("max_isa=sse4.2,frequency_level=simd256"));
  for (const char* bad : {"isa=zzz", "isa=", "threads=two", "thread=1", "max_isa=avx3"}) {
    try {
      peer::check_embree_config(bad);
      ADD_FAILURE() << bad << " accepted";
    } catch (const InputError& e) {
      EXPECT_EQ(std::string(e.what()).rfind("LANCER_EMBREE_CONFIG: ", 0), 0u) << e.what();
    }
  }
  if (!peer::embree_available()) return;
  const CommandResult r = run_command("LANCER_EMBREE_CONFIG=isa=zzz " + cli() + " bench " + kScene +
                                      " --peer embree --repeat 1 --resolution 8x8");
  expect_one_line(r, 2, "LANCER_EMBREE_CONFIG: isa must be");
}

// The Embree peer's width check blamed "this CPU or OS" when LANCER_MAX_WIDTH was what left the
// width out. The cap is read once per process: without it set, this test runs itself again in a
// child with LANCER_MAX_WIDTH=4.
TEST(Messages, EmbreePeerWidthLeftOutByLancerMaxWidthBlamesIt) {
  if (!peer::embree_available()) GTEST_SKIP() << "built without Embree";
  const char* cap = std::getenv("LANCER_MAX_WIDTH");
  if (!cap) {
    const std::string self = std::filesystem::read_symlink("/proc/self/exe").string();
    const CommandResult r =
        run_command("LANCER_MAX_WIDTH=4 " + self +
                    " --gtest_filter=Messages.EmbreePeerWidthLeftOutByLancerMaxWidthBlamesIt");
    EXPECT_EQ(r.status, 0) << r.out;
    EXPECT_NE(r.out.find("[  PASSED  ] 1 test"), std::string::npos) << r.out;
    return;
  }
  if (std::atoi(cap) >= 16) GTEST_SKIP() << "LANCER_MAX_WIDTH=" << cap << " leaves no width out";
  const peer::EmbreeScene embree(load_scene(kScene));
  try {
    embree.primary(16, 1);
    ADD_FAILURE() << "width 16 ran under LANCER_MAX_WIDTH=" << cap;
  } catch (const InputError& e) {
    const std::string what = e.what();
    EXPECT_EQ(what.rfind("--peer embree: width 16 needs ", 0), 0u) << what;
    EXPECT_NE(what.find("which LANCER_MAX_WIDTH=" + std::string(cap) + " leaves out"),
              std::string::npos)
        << what;
    EXPECT_EQ(what.find("this CPU"), std::string::npos) << what;
  }
}

// docs/scene-format.md: camera.type defaults to "pinhole".
TEST(Docs, CameraTypeDefaultsToPinhole) {
  json j = json::parse(read_text(kScene));
  const Scene with = parse_scene(j.dump(), "s.json");
  j["camera"].erase("type");
  const Scene without = parse_scene(j.dump(), "s.json");
  EXPECT_EQ(without.camera.type, CameraType::pinhole);
  EXPECT_EQ(render_with(without, 1).rgb, render_with(with, 1).rgb);
}

TEST(Docs, PlotLogOfNonPositiveDataSaysWhatWasLeftOut) {
  TempDir dir;
  std::ofstream(dir.file("some.csv")) << "a,b\n1,0\n2,-1\n3,5\n4,6\n";
  std::ofstream(dir.file("none.csv")) << "a,b\n1,0\n2,-1\n";
  CommandResult r = run_command(cli() + " plot " + dir.file("some.csv") + " -o " +
                                dir.file("p.svg") + " --x a --y b --log xy");
  EXPECT_EQ(r.status, 0) << r.out;
  EXPECT_NE(r.out.find("2 points (2 with a value <= 0 on the log axis left out)"),
            std::string::npos)
      << r.out;
  r = run_command(cli() + " plot " + dir.file("none.csv") + " -o " + dir.file("q.svg") +
                  " --x a --y b --log y");
  expect_one_line(r, 2, "--log y: every point has a value <= 0");
  EXPECT_FALSE(std::filesystem::exists(dir.file("q.svg")));
}

// Under nohup (SIGHUP ignored) a render must outlive its terminal: lancer catches SIGHUP only if
// it was not ignored at start. Checked in /proc once the handlers are in (SIGTERM caught), then
// by the signal itself.
TEST(Signals, IgnoredAtStartStayIgnored) {
  TempDir dir;
  const std::string out = dir.file("x.pfm");
  const pid_t pid = fork();
  ASSERT_GE(pid, 0);
  if (pid == 0) {
    signal(SIGHUP, SIG_IGN);
    const std::string exe = cli();
    execl(exe.c_str(), exe.c_str(), "render", kScene.c_str(), "-o", out.c_str(), "--resolution",
          "2000x1500", "--supersample", "2", "--threads", "1", static_cast<char*>(nullptr));
    _exit(127);
  }
  auto mask = [&](const std::string& field) {
    std::ifstream in("/proc/" + std::to_string(pid) + "/status");
    for (std::string line; std::getline(in, line);)
      if (line.rfind(field + ":", 0) == 0)
        return std::stoull(line.substr(field.size() + 1), nullptr, 16);
    return 0ull;
  };
  const auto bit = [](int sig) { return 1ull << (sig - 1); };
  bool caught = false;
  for (int i = 0; i < 2000 && !caught; ++i) {
    caught = (mask("SigCgt") & bit(SIGTERM)) != 0;
    if (!caught) std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  ASSERT_TRUE(caught) << "lancer never installed its SIGTERM handler";
  EXPECT_NE(mask("SigIgn") & bit(SIGHUP), 0u) << "SIGHUP no longer ignored";
  EXPECT_EQ(mask("SigCgt") & bit(SIGHUP), 0u) << "SIGHUP caught";
  int status = 0;
  ASSERT_EQ(waitpid(pid, &status, WNOHANG), 0) << "the render ended before the signal";
  kill(pid, SIGHUP);
  ASSERT_EQ(waitpid(pid, &status, 0), pid);
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0)
      << "status " << status << (WIFSIGNALED(status) ? " (killed by a signal)" : "");
  EXPECT_TRUE(std::filesystem::exists(out));
}

}  // namespace
}  // namespace lancer::testing
