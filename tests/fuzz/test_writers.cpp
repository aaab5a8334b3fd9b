// Nothing lost: every output writer (images of every format, PDF/SVG/PNG figures, CSV, JSON) under
// a failed write, fsync, close or rename, and on a full disk, ends in exit status 4 with one line
// naming the user's path, the old file intact and no temporary file left. Nothing hung: inputs
// that are not regular files are refused, count options are bounded, bad output names are
// refused before the work, and a memory limit met while loading the image module is status 3.
#include <gtest/gtest.h>
#include <sys/mount.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <sstream>
#include <string>
#include <vector>

#include "support/test_util.hpp"

namespace {

using lancer::testing::slurp;

namespace fs = std::filesystem;
using lancer::testing::run_command;
using lancer::testing::TempDir;

void put(const std::string& path, const std::string& text) {
  std::ofstream(path, std::ios::binary) << text;
}
std::string src(const std::string& rel) { return lancer::testing::source_path(rel); }

// One output writer: the command (with OUT where its output path goes) and the file it writes.
struct Writer {
  std::string name, file, args;
};

// Inputs the writers need, made once per folder: two small renders and a CSV.
void make_inputs(const std::string& dir, int csv_rows, const std::string& res = "48x48") {
  const std::string cli = LANCER_CLI;
  ASSERT_EQ(run_command(cli + " render " + src("scenes/lorenzi-diffuse.json") + " -o " + dir +
                        "/a.png --resolution " + res)
                .status,
            0);
  ASSERT_EQ(run_command(cli + " render " + src("scenes/many-spheres.json") + " -o " + dir +
                        "/b.png --resolution " + res)
                .status,
            0);
  std::string csv = "x,y\n";
  for (int i = 1; i <= csv_rows; ++i)
    csv += std::to_string(i) + "," + std::to_string(i * 37 % 101 + 1) + "\n";
  put(dir + "/x.csv", csv);
}

// Every writer lancer has, small (`size` 1) or large enough to fill 10 kB (`size` 2).
std::vector<Writer> writers(const std::string& in, int size) {
  const std::string res = size == 1 ? "16x16" : "400x400";
  const std::string many = src("scenes/many-spheres.json");
  std::vector<Writer> w;
  for (const char* ext : {"png", "jpg", "ppm", "bmp", "tga", "exr", "tif", "hdr", "pfm"})
    w.push_back({std::string("render .") + ext, std::string("out.") + ext,
                 "render " + many + " --resolution " + res + " -o OUT"});
  const std::string fig = size == 1 ? "" : " --width 4000 --height 4000";
  for (const char* ext : {"pdf", "svg", "png"})
    w.push_back({std::string("plot .") + ext, std::string("fig.") + ext,
                 "plot " + in + "/x.csv --x x --y y -o OUT" + fig});
  w.push_back({"compare --diff", "diff.png",
               "compare " + in + "/a.png " + in + "/b.png --json --diff OUT"});
  w.push_back({"generate", "scene.json",
               "generate --spheres " + std::string(size == 1 ? "3" : "3000") + " -o OUT"});
  w.push_back({"flux --csv", "flux.csv", "flux " + src("scenes/flux2d.json") + " --csv OUT"});
  // A figure in an image format cairo does not write: drawn by cairo, written by OpenImageIO.
  w.push_back(
      {"flux --plot .bmp", "flux.bmp", "flux " + src("scenes/flux2d.json") + " --plot OUT"});
  return w;
}

std::string with_output(std::string args, const std::string& out) {
  args.replace(args.find("OUT"), 3, out);
  return args;
}

int lines(const std::string& text) {
  int n = 0;
  for (char c : text) n += c == '\n';
  return n;
}

// The failure's report: one line naming the path the user gave, not the temporary name.
void expect_lost_output(const lancer::testing::CommandResult& r, const std::string& out,
                        const std::string& what) {
  EXPECT_EQ(r.status, 4) << what << ": " << r.out;
  EXPECT_EQ(r.out.rfind("lancer: " + out + ": ", 0), 0u) << what << ": " << r.out;
  EXPECT_EQ(lines(r.out), 1) << what << ": " << r.out;
  EXPECT_EQ(r.out.find(".lancer-"), std::string::npos) << what << ": " << r.out;
}

// Names in `dir` other than `keep`.
std::vector<std::string> others(const std::string& dir, const std::vector<std::string>& keep) {
  std::vector<std::string> out;
  for (const auto& e : fs::directory_iterator(dir)) {
    const std::string n = e.path().filename().string();
    if (std::find(keep.begin(), keep.end(), n) == keep.end()) out.push_back(n);
  }
  return out;
}

#ifndef LANCER_TEST_UNDER_ASAN
// Each pwrite, fsync, close and rename of the temporary file made to fail in turn, one writer per
// test (so that ctest runs them side by side): every write up to the sixth (the small outputs
// here take few), the fsync, the close, the rename.
class EveryFailedCall : public ::testing::TestWithParam<int> {};

TEST_P(EveryFailedCall, KeepsTheOldFile) {
  TempDir in, dir;
  make_inputs(in.path(), 5);
  const Writer w = writers(in.path(), 1)[std::size_t(GetParam())];
  const std::string old = "the old file\n", out = dir.file(w.file), log = in.file("fault.log");
  for (const std::string call : {"pwrite", "fsync", "close", "rename"}) {
    for (int n = 1; n <= 6; ++n) {
      put(out, old);
      fs::remove(log);
      const std::string what = w.name + ", " + call + " " + std::to_string(n);
      // stdout away: the failure's line on stderr is all that is checked.
      const auto r = run_command("{ LD_PRELOAD=" LANCER_FAULT_SHIM " LANCER_FAULT=" + call + ":" +
                                 std::to_string(n) + " LANCER_FAULT_LOG=" + log + " " + LANCER_CLI +
                                 " " + with_output(w.args, out) + " >/dev/null; }");
      if (!fs::exists(log)) {  // fewer calls than n: the write went through
        EXPECT_TRUE(r.status == 0 || (r.status == 1 && w.name == "compare --diff"))
            << what << r.out;
        EXPECT_NE(slurp(out), old) << what;
        EXPECT_GT(n, 1) << what << ": never called";
        break;
      }
      expect_lost_output(r, out, what);
      EXPECT_EQ(slurp(out), old) << what;
      EXPECT_EQ(others(dir.path(), {w.file}), std::vector<std::string>{}) << what;
    }
  }
}

INSTANTIATE_TEST_SUITE_P(Writers, EveryFailedCall, ::testing::Range(0, int(writers("", 1).size())),
                         [](const ::testing::TestParamInfo<int>& p) {
                           std::string n = writers("", 1)[std::size_t(p.param)].name;
                           for (char& c : n)
                             if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
                           return n;
                         });
#endif

// A small file system nearly full: each writer's output does not fit.
TEST(Writers, FullDiskKeepsTheOldFile) {
  if (geteuid() != 0) GTEST_SKIP() << "mounting a small tmpfs needs root";
  TempDir in, dir;
  if (mount("tmpfs", dir.path().c_str(), "tmpfs", 0, "size=200k") != 0)
    GTEST_SKIP() << "cannot mount a tmpfs: " << std::strerror(errno);
  struct Unmount {
    std::string path;
    ~Unmount() { umount2(path.c_str(), MNT_DETACH); }
  } unmount{dir.path()};
  make_inputs(in.path(), 2000, "300x300");
  const std::string old = "the old file\n";
  put(dir.file("filler"), std::string(190000, '\0'));
  for (const Writer& w : writers(in.path(), 2)) {
    // Its output is under 10 kB and fits: the failed calls above cover it.
    if (w.name == "flux --csv") continue;
    const std::string out = dir.file(w.file);
    put(out, old);
    const auto r = run_command("{ " + std::string(LANCER_CLI) + " " + with_output(w.args, out) +
                               " >/dev/null; }");
    expect_lost_output(r, out, w.name);
    EXPECT_EQ(slurp(out), old) << w.name;
    EXPECT_EQ(others(dir.path(), {w.file, "filler"}), std::vector<std::string>{}) << w.name;
    fs::remove(out);
  }
}

// Inputs that are not regular files: refused at once, never read for ever or waited on.
TEST(Readers, NoInputHangs) {
  TempDir dir;
  make_inputs(dir.path(), 3);
  const std::string fifo = dir.file("fifo");
  ASSERT_EQ(mkfifo(fifo.c_str(), 0600), 0);
  const std::string cli = std::string("timeout 30 ") + LANCER_CLI;
  const std::string png = dir.file("a.png");
  for (const std::string& args :
       {"compare /dev/zero " + png, "compare " + png + " /dev/zero", "compare " + fifo + " " + png,
        "compare " + png + " " + fifo, "render " + fifo + " -o " + dir.file("o.png"),
        "validate " + fifo, "plot /dev/zero --x x --y y -o " + dir.file("p.svg"),
        "plot " + fifo + " --x x --y y -o " + dir.file("p.svg")}) {
    const auto r = run_command(cli + " " + args);
    EXPECT_EQ(r.status, 2) << args << ": " << r.out;
    EXPECT_NE(r.out.find("is not a regular file"), std::string::npos) << args << ": " << r.out;
    EXPECT_EQ(lines(r.out), 1) << args << ": " << r.out;
  }
}

TEST(Limits, RepeatIsBounded) {
  const std::string scene = src("scenes/lorenzi-diffuse.json");
  for (const char* cmd : {"bench", "trade"}) {
    const auto r = run_command(std::string("timeout 30 ") + LANCER_CLI + " " + cmd + " " + scene +
                               " --resolution 8x8 --repeat 2000000000");
    EXPECT_EQ(r.status, 2) << cmd << ": " << r.out;
    EXPECT_NE(r.out.find("--repeat: must be from 1 to 1000"), std::string::npos) << r.out;
  }
}

// A name longer than the file system takes is refused before the work, by every command.
TEST(Limits, LongOutputNameRefusedBeforeTheWork) {
  TempDir dir;
  make_inputs(dir.path(), 3);
  const std::string name = dir.file(std::string(300, 'n'));
  const std::string big = src("scenes/many-spheres.json") + " --resolution 4000x4000";
  for (const std::string& args :
       {"render " + big + " -o " + name + ".png",
        "compare " + dir.file("a.png") + " " + dir.file("b.png") + " --diff " + name + ".png",
        "plot " + dir.file("x.csv") + " --x x --y y -o " + name + ".svg",
        "flux " + src("scenes/flux2d.json") + " --csv " + name + ".csv",
        "flux " + src("scenes/flux2d.json") + " --diagram " + name + ".svg",
        "trade " + big + " --plot " + name + ".svg", "generate --spheres 3 -o " + name + ".json"}) {
    const auto r = run_command(std::string("timeout 20 ") + LANCER_CLI + " " + args);
    EXPECT_EQ(r.status, 2) << args << ": " << r.out;
    EXPECT_NE(r.out.find(": the file name is 30"), std::string::npos) << args << r.out;
    EXPECT_EQ(lines(r.out), 1) << args << ": " << r.out;
  }
}

#ifndef LANCER_TEST_UNDER_ASAN
// Under a memory limit the image module (OpenImageIO and its 260 libraries) cannot be mapped:
// that is out of memory, status 3, not an internal error about a missing module. The formats
// only the module reads and writes (BMP here): PNG no longer needs it.
TEST(Limits, ImageModuleOutOfMemoryIsStatusThree) {
  TempDir dir;
  for (const char* name : {"a.bmp", "b.bmp"}) {
    const auto made =
        run_command(std::string(LANCER_CLI) + " render " + src("scenes/lorenzi-diffuse.json") +
                    " --resolution 8x8 -o " + dir.file(name));
    ASSERT_EQ(made.status, 0) << made.out;
  }
  const std::string limit = "ulimit -v 300000; ";
  for (const std::string& args :
       {"render " + src("scenes/lorenzi-diffuse.json") + " --resolution 8x8 -o " +
            dir.file("m.bmp"),
        "compare " + dir.file("a.bmp") + " " + dir.file("b.bmp"),
        "trade " + src("scenes/lorenzi-diffuse.json") + " --resolution 8x8 --plot " +
            dir.file("t.bmp"),
        "flux " + src("scenes/flux2d.json") + " --plot " + dir.file("f.bmp")}) {
    const auto r = run_command(limit + LANCER_CLI + " " + args);
    EXPECT_EQ(r.status, 3) << args << ": " << r.out;
    EXPECT_NE(r.out.find("lancer: out of memory"), std::string::npos) << args << ": " << r.out;
    EXPECT_EQ(lines(r.out), 1) << args << ": " << r.out;
  }
}
#endif

// Malformed images given to compare: one line naming the file, status 2.
TEST(Readers, MalformedImagesAreOneLine) {
  TempDir dir;
  make_inputs(dir.path(), 3);
  const std::string png = slurp(dir.file("a.png"));
  put(dir.file("trunc.png"), png.substr(0, 100));
  put(dir.file("header.pfm"), "PF\n32 32\n-1.0\n");
  put(dir.file("huge.pfm"), "PF\n99999999 99999999\n-1.0\n");
  put(dir.file("negative.pfm"), "PF\n-5 32\n-1.0\n");
  put(dir.file("empty.png"), "");
  for (const char* bad : {"trunc.png", "header.pfm", "huge.pfm", "negative.pfm", "empty.png"}) {
    const std::string path = dir.file(bad);
    const auto r =
        run_command(std::string(LANCER_CLI) + " compare " + path + " " + dir.file("a.png"));
    EXPECT_EQ(r.status, 2) << bad << ": " << r.out;
    EXPECT_EQ(r.out.rfind("lancer: " + path + ": ", 0), 0u) << bad << ": " << r.out;
    EXPECT_EQ(lines(r.out), 1) << bad << ": " << r.out;
    EXPECT_GT(r.out.size(), ("lancer: " + path + ": \n").size()) << bad << ": no reason given";
    EXPECT_EQ(r.out.find("std::"), std::string::npos) << bad << ": " << r.out;
  }
}

}  // namespace
