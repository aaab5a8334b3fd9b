// lancer: a ray tracer built to be measured.
#include <cerrno>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <exception>
#include <string>

#include "commands.hpp"
#include "lancer/error.hpp"
#include "lancer/image.hpp"
#include "lancer/mpi.hpp"
#include "lancer/output_file.hpp"

namespace {

// An interrupted render leaves no partial file: remove the temporary one, then die as asked.
extern "C" void on_signal(int sig) {
  lancer::remove_pending_outputs();
  std::signal(sig, SIG_DFL);
  std::raise(sig);
}

// stdout is where validate's verdict, profile's JSON and flux's CSV go: output lost there (a full
// disk, a closed pipe) is a failure, not a success that printed nothing.
int flush_stdout(int status) {
  if (std::fflush(stdout) != 0 || std::ferror(stdout)) {
    const int err = errno;
    std::fprintf(stderr, "lancer: stdout: write failed: %s\n",
                 err ? std::strerror(err) : "output error");
    return lancer::cli::kExitOutputLost;
  }
  return status;
}

const char* const kFooter =
    "Exit status: 0 done; 1 validate found a width that differs from the reference; 2 bad input\n"
    "(scene, option or output path; one line on stderr, nothing written); 3 out of memory; 4\n"
    "output lost (stdout or an output file could not be written; any old file is kept); 5\n"
    "internal error. Limits: docs/limits.md.\n"
    "Environment: LANCER_MAX_WIDTH=1|4|8|16 caps the packet widths offered (to run as a CPU\n"
    "without AVX-512 or AVX2 would); any other value is refused (exit 2).";

}  // namespace

int main(int argc, char** argv) {
  std::signal(SIGINT, on_signal);
  std::signal(SIGTERM, on_signal);
  std::signal(SIGHUP, on_signal);  // the terminal went away

  CLI::App app{
      "lancer: a Whitted ray tracer built to be measured.\n"
      "A scalar reference and SIMD ray packets (4, 8, 16 lanes) over one scene model;\n"
      "exact mode is bit-identical across every width. Scene format: docs/scene-format.md."};
  app.require_subcommand(1);
  app.footer(kFooter);
  app.set_version_flag("--version", "lancer 0.1.0");
  lancer::cli::add_render(app);
  lancer::cli::add_validate(app);
  lancer::cli::add_bench(app);
  lancer::cli::add_trade(app);
  lancer::cli::add_profile(app);
  lancer::cli::add_flux(app);
  lancer::cli::add_generate(app);
  lancer::cli::add_compare(app);
  lancer::cli::add_plot(app);

  using namespace lancer::cli;
  // CLI11 takes an unknown first word for a missing subcommand: name it.
  if (argc > 1 && argv[1][0] != '-') {
    bool known = false;
    std::string names;
    for (const CLI::App* sub : app.get_subcommands({})) {
      known = known || sub->get_name() == argv[1];
      names += (names.empty() ? "" : ", ") + sub->get_name();
    }
    if (!known) {
      std::fprintf(stderr, "lancer: unknown command '%s' (commands: %s; see lancer --help)\n",
                   argv[1], names.c_str());
      return kExitBadInput;
    }
  }

  // Only render and bench are distributed (docs/mpi.md). Any other command started by mpirun
  // with N ranks would run N times over: N verdicts on stdout, N writers of one file.
  const lancer::mpi::Launch launch = lancer::mpi::launch_from_environment();
  if (launch.size > 1 && argc > 1 && argv[1][0] != '-' && std::strcmp(argv[1], "render") != 0 &&
      std::strcmp(argv[1], "bench") != 0) {
    if (launch.rank == 0)
      std::fprintf(stderr,
                   "lancer: %s: runs in one process, not across %d MPI ranks (%s); only render "
                   "and bench are distributed: run it without mpirun\n",
                   argv[1], launch.size, launch.variable);
    return kExitBadInput;
  }

  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return flush_stdout(app.exit(e));
  } catch (const CLI::CallForAllHelp& e) {
    return flush_stdout(app.exit(e));
  } catch (const CLI::CallForVersion& e) {
    return flush_stdout(app.exit(e));
  } catch (const CLI::ParseError& e) {
    std::fprintf(stderr, "lancer: %s (see lancer --help)\n", e.what());
    return kExitBadInput;
  } catch (const lancer::InputError& e) {
    std::fprintf(stderr, "lancer: %s\n", e.what());
    return kExitBadInput;
  } catch (const lancer::OutputError& e) {
    std::fprintf(stderr, "lancer: %s\n", e.what());
    return kExitOutputLost;
  } catch (const std::bad_alloc& e) {
    const std::string why = e.what();  // a reason of our own where there is one
    std::fprintf(stderr, "lancer: out of memory%s (limits: docs/limits.md)\n",
                 why == std::bad_alloc().what() ? "" : (": " + why).c_str());
    return kExitOutOfMemory;
  } catch (const std::length_error& e) {  // a size beyond what a container can hold
    std::fprintf(stderr, "lancer: out of memory: %s (limits: docs/limits.md)\n", e.what());
    return kExitOutOfMemory;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "lancer: internal error: %s\n", e.what());
    return kExitInternal;
  }
  return flush_stdout(g_exit_status);
}
