// Issue 14's edges, each a regression case: thread counts, output formats, memory, lost stdout,
// validate with nothing to compare, replacing an existing output, auto precision and the camera's
// scale, unknown commands and the exit-status table.
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <climits>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <regex>
#include <sstream>
#include <string>

#include "lancer/image.hpp"
#include "lancer/render.hpp"
#include "lancer/scene.hpp"
#include "support/test_util.hpp"

namespace lancer {
namespace {

using testing::slurp;

namespace fs = std::filesystem;
using testing::CommandResult;
using testing::TempDir;

std::string scene(const char* name) { return testing::source_path(std::string("scenes/") + name); }

// `lancer ARGS` through the shell (so that ARGS may redirect), stdout and stderr together.
CommandResult lancer(const std::string& args) {
  return testing::run_command("'" + testing::cli() + "' " + args);
}

// Exit status 2 and exactly one line that mentions `what`.
void expect_refused(const CommandResult& r, const std::string& what) {
  EXPECT_EQ(r.status, 2) << r.out;
  EXPECT_EQ(std::count(r.out.begin(), r.out.end(), '\n'), 1) << r.out;
  EXPECT_NE(r.out.find(what), std::string::npos) << r.out;
}

const std::string kSmall = " --resolution 24x16 ";

// --- 2. threads ---------------------------------------------------------------------------------

TEST(Threads, AbsurdCountsAreRefusedNotCrashed) {
  LANCER_SKIP_WITHOUT_PACKETS();
  TempDir dir;
  for (const char* t : {"2147483647", "99999999", "4097", "-1"}) {
    SCOPED_TRACE(t);
    const std::string tail = kSmall + "--threads " + t;
    expect_refused(
        lancer("render " + scene("lorenzi-shadows.json") + " -o " + dir.file("x.png") + tail),
        "--threads");
    expect_refused(lancer("validate " + scene("lorenzi-shadows.json") + tail), "--threads");
    expect_refused(lancer("bench " + scene("lorenzi-shadows.json") + tail + " --repeat 1"),
                   "--threads");
    EXPECT_TRUE(fs::is_empty(dir.path()));
  }
}

TEST(Threads, SummaryReportsTheThreadsThatRan) {
  TempDir dir;
  const int cores = hardware_threads();
  const int asked = cores + 6;
  const CommandResult r = lancer("render " + scene("lorenzi-shadows.json") + " -o " +
                                 dir.file("x.png") + kSmall + "--threads " + std::to_string(asked));
  ASSERT_EQ(r.status, 0) << r.out;
  const std::string ran = std::to_string(cores) + " thread";
  EXPECT_NE(r.out.find(", " + ran), std::string::npos) << r.out;
  EXPECT_EQ(r.out.find(std::to_string(asked) + " threads"), std::string::npos) << r.out;
  EXPECT_EQ(render(load_scene(scene("lorenzi-shadows.json")),
                   [&] {
                     RenderOptions o;
                     o.threads = asked;
                     o.width = 1;
                     return o;
                   }())
                .threads,
            cores);
}

// bench's 0 means all cores, as render's does, and its rows say what ran.
TEST(Threads, BenchZeroIsAllCoresAndRowsSayWhatRan) {
  const int cores = hardware_threads();
  const CommandResult r = lancer("bench " + scene("lorenzi-shadows.json") + kSmall +
                                 "--width 1 --mode primary --repeat 1 --json --threads 0," +
                                 std::to_string(cores + 3) + " 2>/dev/null");
  ASSERT_EQ(r.status, 0) << r.out;
  const std::regex threads_field("\"threads\": ([0-9]+)");
  int rows = 0;
  for (std::sregex_iterator it(r.out.begin(), r.out.end(), threads_field), end; it != end; ++it) {
    EXPECT_EQ(std::stoi((*it)[1]), cores) << r.out;
    ++rows;
  }
  EXPECT_EQ(rows, 1) << "0 and more than the cores both ran on every core: one row\n" << r.out;
}

// --- 3. output formats --------------------------------------------------------------------------

// The first bytes a file of each format starts with (TGA has none: its 18-byte header says
// uncompressed or RLE true colour, image type 2 or 10, 24 bits).
bool looks_like(const std::string& ext, const std::string& b) {
  auto starts = [&](const std::string& m) { return b.compare(0, m.size(), m) == 0; };
  if (ext == ".png") return starts("\x89PNG\r\n\x1a\n");
  if (ext == ".jpg" || ext == ".jpeg") return starts("\xff\xd8\xff");
  if (ext == ".ppm") return starts("P6");
  if (ext == ".bmp") return starts("BM");
  if (ext == ".tga") return b.size() > 18 && (b[2] == 2 || b[2] == 10) && b[16] == 24;
  if (ext == ".exr") return starts(std::string("\x76\x2f\x31\x01", 4));
  if (ext == ".tif" || ext == ".tiff")
    return starts(std::string("II*\0", 4)) || starts(std::string("MM\0*", 4));
  if (ext == ".hdr") return starts("#?");
  if (ext == ".pfm") return starts("PF\n");
  return false;
}

TEST(Formats, EveryAcceptedFormatWritesAFileOfItsKindThatReadsBack) {
  TempDir dir;
  Image im(5, 3);
  for (int j = 0; j < 3; ++j)
    for (int i = 0; i < 5; ++i) {
      im.pixel(i, j)[0] = 0.2f + 0.02f * i;  // gentle: JPEG's chroma subsampling smears edges
      im.pixel(i, j)[1] = 0.5f + 0.03f * j;
      im.pixel(i, j)[2] = 0.75f;
    }
  ASSERT_GE(image_formats().size(), 9u);
  for (const ImageFormat& f : image_formats()) {
    SCOPED_TRACE(f.extension);
    const std::string path = dir.file(std::string("x") + f.extension);
    write_image(im, path);
    const std::string bytes = slurp(path);
    ASSERT_GT(bytes.size(), 15u * 3);
    EXPECT_TRUE(looks_like(f.extension, bytes)) << "not a " << f.extension << " file";
    const Image back = read_image(path);
    ASSERT_EQ(back.nx, 5);
    ASSERT_EQ(back.ny, 3);
    // 8-bit rounding and Radiance's shared exponent stay within 0.01; JPEG is lossy.
    const bool jpeg = std::string(f.oiio_name) == "jpeg";
    double sum = 0;
    for (std::size_t k = 0; k < im.rgb.size(); ++k) {
      EXPECT_NEAR(back.rgb[k], im.rgb[k], jpeg ? 0.05 : 0.01);
      sum += std::fabs(back.rgb[k] - im.rgb[k]);
    }
    EXPECT_LT(sum / im.rgb.size(), jpeg ? 0.02 : 0.005);
  }
}

TEST(Formats, OthersAreRefusedBeforeAnyWork) {
  TempDir dir;
  for (const char* ext : {".jp2", ".j2k", ".term", ".null", ".avif", ".gif", ".sgi", ".xyz"}) {
    SCOPED_TRACE(ext);
    const std::string out = dir.file(std::string("x") + ext);
    // A render that would take minutes: refused at once.
    expect_refused(lancer("render " + scene("lorenzi-reflections.json") + " -o " + out +
                          " --resolution 8000x8000 --supersample 4 --threads 1"),
                   "does not write");
    expect_refused(lancer("flux " + scene("flux2d.json") + " --plot " + out), "--plot");
    expect_refused(lancer("flux " + scene("flux2d.json") + " --diagram " + out), "--diagram");
    expect_refused(lancer("trade " + scene("lorenzi-shadows.json") + " --plot " + out), out);
  }
  EXPECT_TRUE(fs::is_empty(dir.path()));
}

// .pgm and .pbm hold grey and bits: colour would be written under their name.
TEST(Formats, GreyAndBitmapNetpbmAreRefused) {
  TempDir dir;
  for (const char* ext : {".pgm", ".pbm", ".PGM"}) {
    expect_refused(
        lancer("render " + scene("lorenzi-shadows.json") + " -o " + dir.file("x") + ext + kSmall),
        "use .ppm");
  }
  EXPECT_TRUE(fs::is_empty(dir.path()));
}

TEST(Formats, ImagesAreNeverStdout) {
  expect_refused(lancer("render " + scene("lorenzi-shadows.json") + " -o -" + kSmall), "stdout");
  expect_refused(lancer("flux " + scene("flux2d.json") + " --diagram -"), "stdout");
}

// --- 5. memory ----------------------------------------------------------------------------------

TEST(Memory, AnImageBeyondTheProcessMemoryIsRefusedBeforeWork) {
#ifdef LANCER_TEST_UNDER_ASAN
  GTEST_SKIP() << "caps the address space, which AddressSanitizer's shadow memory needs";
#endif
  TempDir dir;
  const CommandResult r = testing::run_command(
      "ulimit -v 2000000; '" + testing::cli() + "' render " + scene("lorenzi-shadows.json") +
      " -o " + dir.file("x.png") + " --resolution 16384x16384");
  expect_refused(r, "the image needs 4.0 GB");
  EXPECT_TRUE(fs::is_empty(dir.path()));
}

// An allocation that fails anyway (bench's kernel mode holds 24 bytes of ray per sample) is one
// line and exit status 3, not std::bad_alloc's abort.
TEST(Memory, AllocationFailureIsACleanError) {
  LANCER_SKIP_WITHOUT_PACKETS();
#ifdef LANCER_TEST_UNDER_ASAN
  GTEST_SKIP() << "caps the address space, which AddressSanitizer's shadow memory needs";
#endif
  const CommandResult r = testing::run_command(
      "ulimit -v 1000000; '" + testing::cli() + "' bench " + scene("lorenzi-shadows.json") +
      " --mode kernel --resolution 2048x2048 --supersample 8 --width " +
      std::to_string(testing::packet_widths().front()) + " --repeat 1");
  EXPECT_EQ(r.status, 3) << r.out;
  EXPECT_EQ(r.out, "lancer: out of memory (limits: docs/limits.md)\n");
}

// A ray diagram draws every segment: 1000 rays to 2000 lights make 1.5 million, refused.
TEST(Memory, RayDiagramIsBounded) {
  TempDir dir;
  nlohmann::json j = nlohmann::json::parse(slurp(scene("flux2d.json")));
  j["camera"]["resolution"] = {1000, 1};
  j["lights"] = nlohmann::json::array();
  for (int k = 0; k < 2000; ++k)
    j["lights"].push_back({{"position", {0.005 * k, -1, 0}}, {"intensity", 0.001}});
  const std::string text = j.dump();
  std::ofstream(dir.file("s.json")) << text;
  expect_refused(lancer("flux " + dir.file("s.json") + " --diagram " + dir.file("d.svg")),
                 "a diagram draws at most 1000000");
  EXPECT_FALSE(fs::exists(dir.file("d.svg")));
}

// --- 6. lost output -----------------------------------------------------------------------------

TEST(Stdout, WritesToAFullDeviceFail) {
  LANCER_SKIP_WITHOUT_PACKETS();
  for (const std::string& args :
       {"validate " + scene("lorenzi-shadows.json") + kSmall,
        "profile " + scene("lorenzi-shadows.json") + kSmall + "--json",
        "flux " + scene("flux2d.json"), "flux " + scene("flux2d.json") + " --csv -"}) {
    SCOPED_TRACE(args);
    const CommandResult r =
        testing::run_command("{ '" + testing::cli() + "' " + args + " >/dev/full; }");
    EXPECT_EQ(r.status, 4) << r.out;
    EXPECT_NE(r.out.find("stdout: write failed"), std::string::npos) << r.out;
  }
}

TEST(Stdout, CsvDashIsStdout) {
  TempDir dir;
  // stdout alone (run_command adds stderr after the braces, where it has gone already).
  auto stdout_of = [](const std::string& args) {
    return testing::run_command("{ '" + testing::cli() + "' " + args + " 2>/dev/null; }");
  };
  const CommandResult plain = stdout_of("flux " + scene("flux2d.json"));
  const CommandResult dash =
      stdout_of("flux " + scene("flux2d.json") + " --csv - --plot " + dir.file("p.png"));
  ASSERT_EQ(plain.status, 0);
  ASSERT_EQ(dash.status, 0) << dash.out;
  EXPECT_EQ(dash.out, plain.out);  // the CSV alone: status lines went to stderr
  EXPECT_EQ(plain.out.rfind("x,flux\n", 0), 0u);
  EXPECT_FALSE(fs::exists("-"));
  EXPECT_TRUE(fs::exists(dir.file("p.png")));
}

// --- 7. validate that compares nothing ----------------------------------------------------------

TEST(Validate, NoPacketWidthIsNoPass) {
  const CommandResult capped = testing::run_command("LANCER_MAX_WIDTH=1 '" + testing::cli() +
                                                    "' validate " + scene("lorenzi-shadows.json"));
  expect_refused(capped, "no packet width");
  expect_refused(lancer("validate " + scene("lorenzi-shadows.json") + " --width 1"), "--width");
  const CommandResult bad = testing::run_command("LANCER_MAX_WIDTH=abc '" + testing::cli() +
                                                 "' validate " + scene("lorenzi-shadows.json"));
  EXPECT_EQ(bad.status, 2) << bad.out;
  EXPECT_EQ(bad.out.find("identical"), std::string::npos) << bad.out;
  EXPECT_NE(lancer("--help").out.find("LANCER_MAX_WIDTH=1|4|8|16"), std::string::npos);
}

// --- 8. replacing an existing output ------------------------------------------------------------

void render_to(const std::string& out) {
  const CommandResult r = lancer("render " + scene("lorenzi-shadows.json") + " -o '" + out + "'" +
                                 kSmall + "--threads 1");
  ASSERT_EQ(r.status, 0) << r.out;
}

TEST(Replace, ModeIsKept) {
  TempDir dir;
  const std::string out = dir.file("x.png");
  std::ofstream(out) << "old";
  ASSERT_EQ(chmod(out.c_str(), 0640), 0);
  render_to(out);
  struct stat st;
  ASSERT_EQ(stat(out.c_str(), &st), 0);
  EXPECT_EQ(st.st_mode & 07777, 0640u);
  EXPECT_NE(slurp(out), "old");
  // And the owner, where permitted (root may give a file to anyone).
  if (getuid() == 0) {
    ASSERT_EQ(chown(out.c_str(), 65534, 65534), 0);
    render_to(out);
    ASSERT_EQ(stat(out.c_str(), &st), 0);
    EXPECT_EQ(st.st_uid, 65534u);
    EXPECT_EQ(st.st_gid, 65534u);
    EXPECT_EQ(st.st_mode & 07777, 0640u);
  }
  // A new file gets the umask's permissions, not mkstemp's 0600.
  const mode_t mask = umask(022);
  render_to(dir.file("new.png"));
  umask(mask);
  ASSERT_EQ(stat(dir.file("new.png").c_str(), &st), 0);
  EXPECT_EQ(st.st_mode & 07777, 0644u);
}

TEST(Replace, SymlinkIsFollowedAndKept) {
  TempDir dir;
  fs::create_directory(dir.file("real"));
  const std::string target = dir.file("real/x.png");
  std::ofstream(target) << "old";
  fs::create_symlink("real/x.png", dir.file("link.png"));
  render_to(dir.file("link.png"));
  EXPECT_TRUE(fs::is_symlink(dir.file("link.png")));
  EXPECT_EQ(slurp(target).compare(1, 3, "PNG"), 0);
  // Nothing left beside either name.
  EXPECT_EQ(std::distance(fs::directory_iterator(dir.file("real")), fs::directory_iterator()), 1);
  // A dangling link: its target is created.
  fs::create_symlink("real/y.png", dir.file("dangling.png"));
  render_to(dir.file("dangling.png"));
  EXPECT_TRUE(fs::is_regular_file(dir.file("real/y.png")));
}

TEST(Replace, HardLinkedTargetIsRefused) {
  TempDir dir;
  std::ofstream(dir.file("x.png")) << "old";
  fs::create_hard_link(dir.file("x.png"), dir.file("other.png"));
  expect_refused(
      lancer("render " + scene("lorenzi-shadows.json") + " -o " + dir.file("x.png") + kSmall),
      "hard links");
  EXPECT_EQ(slurp(dir.file("x.png")), "old");
}

TEST(Replace, LongestLegalNamesWork) {
  TempDir dir;
  for (std::size_t len : {std::size_t(235), std::size_t(250), std::size_t(NAME_MAX)}) {
    const std::string name = std::string(len - 4, 'n') + ".png";
    render_to(dir.file(name));
    EXPECT_TRUE(fs::is_regular_file(dir.file(name))) << len;
  }
  EXPECT_EQ(std::distance(fs::directory_iterator(dir.path()), fs::directory_iterator()), 3);
}

// The new file reaches the disk before the rename, and the rename after it (the folder fsynced),
// as strace sees the system calls.
TEST(Replace, FileIsSyncedBeforeTheRenameAndTheFolderAfter) {
  if (testing::run_command("strace -V").status != 0) GTEST_SKIP() << "no strace";
  TempDir dir;
  const std::string log = dir.file("trace.log");
  const CommandResult r = testing::run_command(
      "strace -f -e trace=fsync,rename,renameat,renameat2 -o '" + log + "' '" + testing::cli() +
      "' render " + scene("lorenzi-shadows.json") + " -o " + dir.file("x.png") + kSmall);
  if (r.status != 0 && r.out.find("ptrace") != std::string::npos)
    GTEST_SKIP() << "strace cannot trace here: " << r.out;
  ASSERT_EQ(r.status, 0) << r.out;
  std::string calls;  // the sequence: f for fsync, r for rename
  std::istringstream lines(slurp(log));
  for (std::string line; std::getline(lines, line);) {
    if (line.find("fsync(") != std::string::npos && line.find("= 0") != std::string::npos)
      calls += 'f';
    if (line.find("rename") != std::string::npos && line.find("x.png") != std::string::npos)
      calls += 'r';
  }
  EXPECT_EQ(calls, "frf");
}

// --- 9. auto precision covers the camera's scale ------------------------------------------------

Scene orthographic_window(double half) {
  Scene s = load_scene(scene("lorenzi-reflections.json"));
  s.camera.type = CameraType::orthographic;
  s.camera.position = {0, 0, 5};
  s.camera.direction = {0, 0, -1};
  s.camera.nx = s.camera.ny = 20;
  s.camera.xmin = s.camera.ymin = -half;
  s.camera.xmax = s.camera.ymax = half;
  return s;
}

float max_diff(const Image& a, const Image& b) {
  float m = 0;
  for (std::size_t k = 0; k < a.rgb.size(); ++k) m = std::max(m, std::fabs(a.rgb[k] - b.rgb[k]));
  return m;
}

// A window of +-1e-40 rendered every pixel 0.0225 off in float: auto must pick double there, and
// wherever it picks exact, exact stays within half an 8-bit level of double.
TEST(AutoPrecision, CameraScaleIsInTheEnvelope) {
  const Scene tiny = orthographic_window(1e-40);
  const Image ex = testing::render_with(tiny, 1, Precision::exact);
  const Image db = testing::render_with(tiny, 1, Precision::dbl);
  EXPECT_GT(max_diff(ex, db), 0.01f) << "the case that showed the defect";
  EXPECT_EQ(choose_precision(tiny).precision, Precision::dbl);
  for (int e = -40; e <= 2; e += 2) {
    const Scene s = orthographic_window(std::pow(10.0, e));
    SCOPED_TRACE(e);
    if (choose_precision(s).precision != Precision::exact) continue;
    EXPECT_LT(max_diff(testing::render_with(s, 1, Precision::exact),
                       testing::render_with(s, 1, Precision::dbl)),
              0.5f / 255);
  }
}

// --- 11. commands and exit statuses -------------------------------------------------------------

TEST(ExitStatus, UnknownCommandIsNamed) {
  const CommandResult r = lancer("bogus");
  expect_refused(r, "unknown command 'bogus'");
}

TEST(ExitStatus, TableIsInHelpAndValidatePassesWithZero) {
  LANCER_SKIP_WITHOUT_PACKETS();
  std::string help = lancer("--help").out;
  std::replace(help.begin(), help.end(), '\n', ' ');
  for (const char* s : {"0 done", "1 validate", "2 bad input", "3 out of memory", "4 output lost",
                        "5 internal error"})
    EXPECT_NE(help.find(s), std::string::npos) << s << "\n" << help;
  EXPECT_EQ(lancer("validate " + scene("lorenzi-shadows.json") + kSmall).status, 0);
}

}  // namespace
}  // namespace lancer
