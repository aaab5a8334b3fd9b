#include <chrono>
#include <cstdio>
#include <memory>

#include "commands.hpp"
#include "lancer/error.hpp"
#include "lancer/generate.hpp"
#include "lancer/plot.hpp"
#include "lancer/scene.hpp"

namespace lancer::cli {

namespace {
struct GenerateArgs {
  generate::Options o;
  std::string output, resolution;
  bool no_plane = false;
};

void run_generate(GenerateArgs a) {
  if (!a.resolution.empty()) {
    int nx = 0, ny = 0;
    char extra = 0;
    if (std::sscanf(a.resolution.c_str(), "%dx%d%c", &nx, &ny, &extra) != 2)
      throw InputError("--resolution: must be NXxNY, as 600x400");
    a.o.nx = nx, a.o.ny = ny;
  }
  a.o.plane = !a.no_plane;
  plot::check_text_path(a.output, "-o");
  const auto t0 = std::chrono::steady_clock::now();
  const std::string text = generate::scene_json(a.o);
  parse_scene(text, a.output);  // never write a scene lancer cannot load
  plot::write_text_file(text, a.output);
  const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::printf("lancer generate: %s (%lld spheres%s, seed %llu, %zu bytes, %.2f s)\n",
              a.output.c_str(), a.o.spheres, a.o.plane ? " and a ground plane" : "",
              (unsigned long long)a.o.seed, text.size(), s);
}
}  // namespace

void add_generate(CLI::App& app) {
  auto args = std::make_shared<GenerateArgs>();
  CLI::App* cmd = app.add_subcommand(
      "generate",
      "Write a reproducible random-sphere scene: N spheres in a box the camera sees, a ground "
      "plane, two lights (the same bytes on any machine for the same options)");
  cmd->add_option("--spheres", args->o.spheres, "Number of spheres, 0 to 2^25 - 1")->required();
  cmd->add_option("--seed", args->o.seed, "Seed of the generator (splitmix64)")
      ->capture_default_str();
  cmd->add_option("--reflect", args->o.reflect,
                  "Reflectivity of every sphere, 0 to 1 (above 0: max_depth 3)")
      ->capture_default_str();
  cmd->add_option("--transmit", args->o.transmit, "Transmission of every sphere, 0 to 1");
  cmd->add_option("--transmit-spread", args->o.transmit_spread,
                  "Material m of 16 transmits T * (1 - S * m / 15), so that shadow rays' products "
                  "of transmits depend on their order (validate checks it); 0 to 1, needs "
                  "--transmit");
  cmd->add_option("--ior", args->o.ior, "Index of refraction of every sphere");
  cmd->add_flag("--no-plane", args->no_plane, "No ground plane");
  cmd->add_option("--resolution", args->resolution, "Camera resolution NXxNY (default 600x400)");
  cmd->add_option("-o,--output", args->output, "Scene file to write (.json)")->required();
  cmd->callback([args] { run_generate(*args); });
}

}  // namespace lancer::cli
