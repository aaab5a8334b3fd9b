// Built with -DLANCER_FP_TRAPS=ON: renders every scene in scenes/ through the reference (float
// and double) with the floating-point exceptions invalid, divide-by-zero and overflow trapping
// (glibc's feenableexcept). A trap is caught (SIGFPE), reported with the scene, precision, row,
// kind of exception and the faulting instruction (function, and file+offset for addr2line -f -C
// -i -e FILE), and the render goes on with the next row. LANCER_FP_TRAPS_SCENES=a.json:b.json
// adds scenes of one's own.
//
// Underflow and inexact are not trapped: both are routine in a ray tracer.
#include <dlfcn.h>
#include <fenv.h>
#include <gtest/gtest.h>
#include <setjmp.h>
#include <signal.h>
#include <ucontext.h>

#include <algorithm>
#include <cctype>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <sstream>
#include <string>
#include <vector>

#include "lancer/image.hpp"
#include "lancer/prepared.hpp"
#include "lancer/reference.hpp"
#include "lancer/scene.hpp"

namespace lancer {
namespace {

constexpr int kTraps = FE_INVALID | FE_DIVBYZERO | FE_OVERFLOW;

sigjmp_buf g_jump;
volatile sig_atomic_t g_code = 0;
volatile std::uintptr_t g_address = 0;

extern "C" void on_fpe(int, siginfo_t* info, void* context) {
  g_code = info->si_code;
  g_address = reinterpret_cast<std::uintptr_t>(info->si_addr);
#if defined(__x86_64__)
  if (!g_address && context)
    g_address = static_cast<ucontext_t*>(context)->uc_mcontext.gregs[REG_RIP];
#else
  (void)context;
#endif
  siglongjmp(g_jump, 1);
}

const char* code_name(int code) {
  switch (code) {
    case FPE_FLTINV:
      return "invalid (FE_INVALID)";
    case FPE_FLTDIV:
      return "divide by zero (FE_DIVBYZERO)";
    case FPE_FLTOVF:
      return "overflow (FE_OVERFLOW)";
    case FPE_FLTUND:
      return "underflow";
    case FPE_FLTRES:
      return "inexact";
    case FPE_INTDIV:
      return "integer divide by zero";
    default:
      return "other";
  }
}

// scenes/*.json, plus any files in LANCER_FP_TRAPS_SCENES (colon-separated), to locate a trap
// in a scene of one's own.
std::vector<std::string> scene_files() {
  std::vector<std::string> out;
  if (const char* extra = std::getenv("LANCER_FP_TRAPS_SCENES")) {
    std::stringstream list(extra);
    std::string path;
    while (std::getline(list, path, ':'))
      if (!path.empty()) out.push_back(path);
  }
  for (const auto& e :
       std::filesystem::directory_iterator(std::string(LANCER_SOURCE_DIR) + "/scenes"))
    if (e.path().extension() == ".json") out.push_back(e.path().string());
  std::sort(out.begin(), out.end());
  return out;
}

// "function (file+0xoffset)" for a code address: the offset is what addr2line -f -C -i -e FILE
// takes.
std::string where(std::uintptr_t address) {
  std::ostringstream s;
  Dl_info info{};
  if (address && dladdr(reinterpret_cast<void*>(address), &info) && info.dli_fname) {
    s << (info.dli_sname ? info.dli_sname : "?") << " (" << info.dli_fname << "+0x" << std::hex
      << address - reinterpret_cast<std::uintptr_t>(info.dli_fbase) << ")";
  } else {
    s << "0x" << std::hex << address;
  }
  return s.str();
}

// Renders row by row with traps on; returns one line per trapping row.
template <class T>
std::vector<std::string> traps_in(const Scene& scene) {
  const PreparedScene<T> prepared = prepare<T>(scene);
  Image image(scene.camera.nx, scene.camera.ny);
  std::vector<std::string> found;
  struct sigaction action {
  }, previous{};
  action.sa_sigaction = on_fpe;
  action.sa_flags = SA_SIGINFO;
  sigemptyset(&action.sa_mask);
  sigaction(SIGFPE, &action, &previous);
  for (volatile int j = 0; j < scene.camera.ny; j = j + 1) {
    RayCounts counts;
    if (sigsetjmp(g_jump, 1) == 0) {
      feclearexcept(FE_ALL_EXCEPT);
      feenableexcept(kTraps);
      reference::render_rows(prepared, image, j, j + 1, counts);
      fedisableexcept(FE_ALL_EXCEPT);
    } else {
      // Back from the handler: the trap state is not to be trusted; reset it.
      fedisableexcept(FE_ALL_EXCEPT);
      feclearexcept(FE_ALL_EXCEPT);
      std::ostringstream s;
      s << "row " << j << ": " << code_name(g_code) << " at " << where(g_address);
      found.push_back(s.str());
      if (found.size() >= 10) {
        found.push_back("(stopped after 10 trapping rows)");
        break;
      }
    }
  }
  sigaction(SIGFPE, &previous, nullptr);
  return found;
}

class FpTraps : public ::testing::TestWithParam<std::string> {};

TEST_P(FpTraps, ReferenceRendersWithoutFloatingPointExceptions) {
  const Scene scene = load_scene(GetParam());
  for (const std::string& t : traps_in<float>(scene)) ADD_FAILURE() << "float " << t;
  for (const std::string& t : traps_in<double>(scene)) ADD_FAILURE() << "double " << t;
}

INSTANTIATE_TEST_SUITE_P(Scenes, FpTraps, ::testing::ValuesIn(scene_files()),
                         [](const ::testing::TestParamInfo<std::string>& param) {
                           std::string n = std::filesystem::path(param.param).stem().string();
                           for (char& c : n)
                             if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
                           return n;
                         });

// The handler itself works: a division by zero traps and is reported.
TEST(FpTrapsSelfCheck, DivisionByZeroTraps) {
  struct sigaction action {
  }, previous{};
  action.sa_sigaction = on_fpe;
  action.sa_flags = SA_SIGINFO;
  sigemptyset(&action.sa_mask);
  sigaction(SIGFPE, &action, &previous);
  volatile double zero = 0, one = 1, result = 0;
  bool trapped = false;
  if (sigsetjmp(g_jump, 1) == 0) {
    feenableexcept(kTraps);
    result = one / zero;
    fedisableexcept(FE_ALL_EXCEPT);
  } else {
    fedisableexcept(FE_ALL_EXCEPT);
    feclearexcept(FE_ALL_EXCEPT);
    trapped = g_code == FPE_FLTDIV;
  }
  sigaction(SIGFPE, &previous, nullptr);
  EXPECT_TRUE(trapped) << result;
}

}  // namespace
}  // namespace lancer
