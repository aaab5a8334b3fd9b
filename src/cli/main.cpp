// lancer: a ray tracer built to be measured.
#include <signal.h>

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
#include "lancer/text.hpp"

namespace {

// An interrupted render leaves no partial file: remove the temporary one, then die as asked, at
// once. The handler may run on a worker thread while the writing thread goes on: the signal is
// raised unblocked (a handler's own signal is blocked until it returns), so that the writer does
// not reach its rename, find its file gone and report a lost output instead of the signal.
extern "C" void on_signal(int sig) {
  lancer::remove_pending_outputs();
  std::signal(sig, SIG_DFL);
  sigset_t own;
  sigemptyset(&own);
  sigaddset(&own, sig);
  pthread_sigmask(SIG_UNBLOCK, &own, nullptr);
  std::raise(sig);
}

// A signal ignored when lancer started stays ignored (POSIX asks this of programs that catch
// signals): nohup ignores SIGHUP so that a render outlives its terminal, and a script's `&`
// ignores SIGINT so that the terminal's ^C ends the script, not its background jobs.
void catch_signal(int sig) {
  struct sigaction now {};
  if (sigaction(sig, nullptr, &now) == 0 && now.sa_handler == SIG_IGN) return;
  std::signal(sig, on_signal);
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

// One line on stderr and the status. Under mpirun, the other ranks must learn of it too, or
// they wait for this one forever: mpi::end_job ends them all with the line printed once.
// Control characters are escaped whatever named them (a file name, a key, an option's value):
// the message stays one line and a terminal shows it rather than obeying it.
int fail(int status, const std::string& what) {
  const std::string message = lancer::escape_controls(what);
  lancer::mpi::end_job(status, message);
  std::fprintf(stderr, "lancer: %s\n", message.c_str());
  return status;
}

// An empty value ("--threads ''", "--resolution=") is a mistake, not the default: CLI11 reads it
// as 0, and a string option as not given. The chart's text labels are exempt (empty: the default
// label).
void refuse_empty_values(CLI::App& app) {
  const CLI::Validator non_empty(
      [](std::string& v) { return v.empty() ? std::string("empty value") : std::string(); }, "");
  for (CLI::App* sub : app.get_subcommands({}))
    for (CLI::Option* o : sub->get_options({})) {
      const std::string name = o->get_name();
      if (o->get_type_size() != 0 && name != "--title" && name != "--x-label" &&
          name != "--y-label")
        o->check(non_empty);
    }
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
  catch_signal(SIGINT);
  catch_signal(SIGTERM);
  catch_signal(SIGHUP);  // the terminal went away

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

  refuse_empty_values(app);

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
      return fail(kExitBadInput, "unknown command '" + std::string(argv[1]) +
                                     "' (commands: " + names + "; see lancer --help)");
    }
  }

  // Only render and bench are distributed (docs/mpi.md). Any other command started by mpirun
  // with N ranks would run N times over: N verdicts on stdout, N writers of one file.
  const lancer::mpi::Launch launch = lancer::mpi::launch_from_environment();
  if (launch.size > 1 && argc > 1 && argv[1][0] != '-' && std::strcmp(argv[1], "render") != 0 &&
      std::strcmp(argv[1], "bench") != 0) {
    // Through fail(): said once, and ranks that run render or bench beside it are told.
    return fail(kExitBadInput, std::string(argv[1]) + ": runs in one process, not across " +
                                   std::to_string(launch.size) + " MPI ranks (" + launch.variable +
                                   "); only render and bench are distributed: run it without "
                                   "mpirun");
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
    return fail(kExitBadInput, std::string(e.what()) + " (see lancer --help)");
  } catch (const lancer::InputError& e) {
    return fail(kExitBadInput, e.what());
  } catch (const lancer::OutputError& e) {
    return fail(kExitOutputLost, e.what());
  } catch (const std::bad_alloc& e) {
    const std::string why = e.what();  // a reason of our own where there is one
    return fail(kExitOutOfMemory, "out of memory" +
                                      (why == std::bad_alloc().what() ? "" : ": " + why) +
                                      " (limits: docs/limits.md)");
  } catch (const std::length_error& e) {  // a size beyond what a container can hold
    return fail(kExitOutOfMemory,
                std::string("out of memory: ") + e.what() + " (limits: docs/limits.md)");
  } catch (const std::exception& e) {
    return fail(kExitInternal, std::string("internal error: ") + e.what());
  }
  return flush_stdout(g_exit_status);
}
