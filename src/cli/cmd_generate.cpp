#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <memory>

#include "commands.hpp"
#include "lancer/error.hpp"
#include "lancer/generate.hpp"
#include "lancer/plot.hpp"
#include "lancer/scene.hpp"
#include "lancer/text.hpp"
#include "options.hpp"

namespace lancer::cli {

namespace {
// Taken as text and parsed here: CLI11 reads "nan" as a number and wraps "-1" into an unsigned
// seed, and generate::Options' "not given" sentinel (-1) must not be a value the user can pass.
struct GenerateArgs {
  generate::Options o;
  std::string output, resolution, seed, transmit, ior;
  CLI::Option *resolution_opt = nullptr, *seed_opt = nullptr, *transmit_opt = nullptr,
              *ior_opt = nullptr;
  bool no_plane = false;
  long long mesh_triangles = 0;
};

// A decimal whole number from 0 to 2^64 - 1, digits only (no sign, no spaces, no wrap-around).
std::uint64_t parse_seed(const std::string& text) {
  const bool digits = !text.empty() && text.find_first_not_of("0123456789") == std::string::npos;
  errno = 0;
  const unsigned long long v = digits ? std::strtoull(text.c_str(), nullptr, 10) : 0;
  if (!digits || errno == ERANGE)
    throw InputError("--seed: must be a whole number from 0 to 18446744073709551615, not '" + text +
                     "'");
  return v;
}

// A finite number from lo to hi, the whole text.
double parse_in(const std::string& text, const std::string& option, double lo, double hi) {
  char* end = nullptr;
  errno = 0;
  const double v = text.empty() || std::isspace(static_cast<unsigned char>(text[0]))
                       ? NAN
                       : std::strtod(text.c_str(), &end);
  if (!(end && *end == '\0' && errno == 0 && v >= lo && v <= hi)) {
    char range[64];
    std::snprintf(range, sizeof range, "from %g to %g", lo, hi);
    throw InputError(option + ": must be a number " + range + ", not '" + text + "'");
  }
  return v;
}

void run_generate(GenerateArgs a) {
  if (a.resolution_opt->count()) parse_size(a.resolution, "--resolution", a.o.nx, a.o.ny);
  if (a.seed_opt->count()) a.o.seed = parse_seed(a.seed);
  if (a.transmit_opt->count()) a.o.transmit = parse_in(a.transmit, "--transmit", 0, 1);
  if (a.ior_opt->count()) a.o.ior = parse_in(a.ior, "--ior", 1, 10);
  a.o.plane = !a.no_plane;
  plot::check_text_path(a.output, "-o");
  const auto t0 = std::chrono::steady_clock::now();
  std::string mesh;
  long long triangles = 0;
  std::string mesh_path;
  if (a.mesh_triangles != 0) {
    // The mesh beside the scene, named after it: scene.json -> scene.ply.
    if (a.output == "-") throw InputError("--mesh-triangles: needs a scene file (-o), not stdout");
    mesh = generate::sphere_ply(a.mesh_triangles, &triangles);
    const std::filesystem::path out(a.output);
    mesh_path = std::filesystem::path(out).replace_extension(".ply").string();
    a.o.mesh_file = std::filesystem::path(mesh_path).filename().string();
    plot::check_text_path(mesh_path, "-o");
  }
  const std::string text = generate::scene_json(a.o);
  if (!mesh.empty()) plot::write_text_file(mesh, mesh_path);
  try {
    // Never write a scene lancer cannot load (it reads the mesh just written).
    parse_scene(text, a.output);
    plot::write_text_file(text, a.output);
  } catch (...) {
    // No mesh left behind without its scene.
    std::error_code ec;
    if (!mesh.empty()) std::filesystem::remove(mesh_path, ec);
    throw;
  }
  const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::printf("lancer generate: %s (%lld spheres%s, seed %llu, %zu bytes, %.2f s)\n",
              shown_path(a.output).c_str(), a.o.spheres, a.o.plane ? " and a ground plane" : "",
              (unsigned long long)a.o.seed, text.size(), s);
  if (a.o.cylinders > 0) std::printf("  and %lld cylinders\n", a.o.cylinders);
  if (!mesh.empty())
    std::printf("  mesh %s: %lld triangles, %zu bytes\n", mesh_path.c_str(), triangles,
                mesh.size());
}
}  // namespace

void add_generate(CLI::App& app) {
  auto args = std::make_shared<GenerateArgs>();
  CLI::App* cmd = app.add_subcommand(
      "generate",
      "Write a reproducible random-sphere scene: N spheres in a box the camera sees, a ground "
      "plane, two lights (the same bytes on any machine for the same options)");
  cmd->add_option("--spheres", args->o.spheres, "Number of spheres, 0 to 2^25 - 1")->required();
  args->seed_opt =
      cmd->add_option("--seed", args->seed, "Seed of the generator (splitmix64; default 1)");
  cmd->add_option("--reflect", args->o.reflect,
                  "Reflectivity of every sphere, 0 to 1 (above 0: max_depth 3)")
      ->capture_default_str();
  args->transmit_opt =
      cmd->add_option("--transmit", args->transmit, "Transmission of every sphere, 0 to 1");
  cmd->add_option("--transmit-spread", args->o.transmit_spread,
                  "Material m of 16 transmits T * (1 - S * m / 15), so that shadow rays' products "
                  "of transmits depend on their order (validate checks it); 0 to 1, needs "
                  "--transmit");
  args->ior_opt =
      cmd->add_option("--ior", args->ior, "Index of refraction of every sphere, 1 to 10");
  cmd->add_flag("--no-plane", args->no_plane, "No ground plane");
  cmd->add_option("--mesh-triangles", args->mesh_triangles,
                  "Also a tessellated sphere of at least N triangles, written beside the scene as "
                  "binary PLY (scene.json -> scene.ply)");
  cmd->add_option("--cylinders", args->o.cylinders, "Also N cylinders in the box");
  args->resolution_opt = cmd->add_option("--resolution", args->resolution,
                                         "Camera resolution NXxNY (default 600x400)");
  cmd->add_option("-o,--output", args->output, "Scene file to write (.json)")->required();
  cmd->callback([args] { run_generate(*args); });
}

}  // namespace lancer::cli
