// The subcommands of the lancer CLI. Each registers itself on the app; its callback throws
// InputError on bad input, which main() turns into one line on stderr and exit status 2.
#pragma once

#include <CLI/CLI.hpp>

namespace lancer::cli {

// lancer's exit statuses (README, `lancer --help`): one meaning each.
enum ExitStatus : int {
  kExitOk = 0,
  kExitDifferent = 1,    // validate: a width differs from the reference
  kExitBadInput = 2,     // bad scene, option or output path: nothing written
  kExitOutOfMemory = 3,  // an allocation failed: nothing written
  kExitOutputLost = 4,   // the work was done but stdout could not take its output
  kExitInternal = 5,     // a bug: an unexpected exception (a failed internal check aborts, 134)
};

// Set by a command whose answer is "no" (validate); main() returns it once stdout is flushed.
inline int g_exit_status = kExitOk;

void add_render(CLI::App& app);
void add_validate(CLI::App& app);
void add_bench(CLI::App& app);
void add_trade(CLI::App& app);
void add_profile(CLI::App& app);
void add_flux(CLI::App& app);
void add_generate(CLI::App& app);
void add_compare(CLI::App& app);
void add_plot(CLI::App& app);

}  // namespace lancer::cli
