// lancer: a ray tracer built to be measured.
#include <csignal>
#include <cstdio>
#include <exception>

#include "commands.hpp"
#include "lancer/error.hpp"
#include "lancer/image.hpp"

namespace {

// An interrupted render leaves no partial file: remove the temporary one, then die as asked.
extern "C" void on_signal(int sig) {
  lancer::remove_pending_outputs();
  std::signal(sig, SIG_DFL);
  std::raise(sig);
}

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
  app.set_version_flag("--version", "lancer 0.1.0");
  lancer::cli::add_render(app);
  lancer::cli::add_validate(app);
  lancer::cli::add_bench(app);
  lancer::cli::add_trade(app);
  lancer::cli::add_profile(app);
  lancer::cli::add_flux(app);
  lancer::cli::add_compare(app);
  lancer::cli::add_plot(app);

  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForAllHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForVersion& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    std::fprintf(stderr, "lancer: %s (see lancer --help)\n", e.what());
    return 2;
  } catch (const lancer::InputError& e) {
    std::fprintf(stderr, "lancer: %s\n", e.what());
    return 2;
  } catch (const std::bad_alloc&) {
    std::fprintf(stderr, "lancer: out of memory\n");
    return 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "lancer: error: %s\n", e.what());
    return 1;
  }
  return 0;
}
