// The subcommands of the lancer CLI. Each registers itself on the app; its callback throws
// InputError on bad input, which main() turns into one line on stderr and exit status 2.
#pragma once

#include <CLI/CLI.hpp>

namespace lancer::cli {

void add_render(CLI::App& app);
void add_validate(CLI::App& app);
void add_bench(CLI::App& app);
void add_trade(CLI::App& app);
void add_profile(CLI::App& app);
void add_flux(CLI::App& app);
void add_compare(CLI::App& app);
void add_plot(CLI::App& app);

}  // namespace lancer::cli
