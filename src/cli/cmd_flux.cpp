#include <cstdio>
#include <filesystem>
#include <memory>

#include "commands.hpp"
#include "lancer/error.hpp"
#include "lancer/flux.hpp"
#include "lancer/plot.hpp"
#include "lancer/text.hpp"

namespace lancer::cli {

namespace {
struct FluxArgs {
  std::string scene, csv, plot, diagram;
  int size = 800;
  bool hits_only = false, show_blocked = false;
};

// A diagram draws every ray segment: about 56 bytes each in SVG, so this keeps a diagram under
// about 60 MB (docs/limits.md); a 65536-ray mirror scene would otherwise head for gigabytes.
constexpr std::size_t kMaxDiagramSegments = 1000000;

void run_flux(const FluxArgs& a) {
  const flux::FluxScene fs = flux::load_flux_scene(a.scene);
  // ray_plane names the key; the file is named here, as the loader names it.
  const flux::RayPlane plane = [&] {
    try {
      return flux::ray_plane(fs.scene, fs.names);
    } catch (const InputError& e) {
      throw InputError(shown_path(a.scene) + ": " + e.what());
    }
  }();
  // Every output checked before any work, and no two the same file.
  struct Output {
    const char* option;
    const std::string& path;
  };
  const Output outputs[] = {{"--csv", a.csv}, {"--plot", a.plot}, {"--diagram", a.diagram}};
  // `--csv -` is stdout, as everywhere a text output is named; the status lines then go to stderr.
  const bool csv_stdout = a.csv == "-";
  std::FILE* status = csv_stdout ? stderr : stdout;
  if (!a.csv.empty() && !csv_stdout) plot::check_text_path(a.csv, "--csv", a.scene);
  if (!a.plot.empty()) plot::check_drawing_path(a.plot, "--plot", a.scene);
  if (!a.diagram.empty()) plot::check_drawing_path(a.diagram, "--diagram", a.scene);
  for (const Output& p : outputs)
    for (const Output& q : outputs)
      if (&p < &q && !p.path.empty() && !q.path.empty() && p.path != "-" &&
          std::filesystem::absolute(p.path).lexically_normal() ==
              std::filesystem::absolute(q.path).lexically_normal())
        throw InputError(std::string(q.option) + " " + q.path + ": same file as " + p.option);
  if (a.size < 100 || a.size > 8192)
    throw InputError("--size: must be from 100 to 8192 (docs/limits.md)");

  const flux::Profile profile = flux::flux_profile(fs.scene);
  const bool any_file = !a.csv.empty() || !a.plot.empty() || !a.diagram.empty();
  if (!any_file) {
    std::fputs(flux::profile_csv(profile).c_str(), stdout);
    return;
  }
  if (csv_stdout) {
    std::fputs(flux::profile_csv(profile).c_str(), stdout);
  } else if (!a.csv.empty()) {
    plot::write_text_file(flux::profile_csv(profile), a.csv);
    std::fprintf(status, "lancer flux: %s -> %s (%zu rays)\n", a.scene.c_str(), a.csv.c_str(),
                 profile.x.size());
  }
  if (!a.plot.empty()) {
    plot::write_chart(flux::profile_plot(profile), a.plot);
    std::fprintf(status, "lancer flux: %s -> %s (flux against position x)\n", a.scene.c_str(),
                 a.plot.c_str());
  }
  if (!a.diagram.empty()) {
    const flux::Paths paths = flux::record_paths(fs.scene, plane);
    if (paths.log.segments.size() > kMaxDiagramSegments)
      throw InputError("--diagram " + a.diagram + ": the scene's rays make " +
                       std::to_string(paths.log.segments.size()) +
                       " segments; a diagram draws at most " + std::to_string(kMaxDiagramSegments) +
                       " (about 60 MB of SVG; docs/limits.md): trace fewer rays (resolution, "
                       "lights, max_depth)");
    flux::DiagramOptions o;
    o.size = a.size;
    o.hits_only = a.hits_only;
    o.show_blocked = a.show_blocked;
    plot::write_chart(flux::diagram(fs.scene, plane, paths.log, o), a.diagram);
    std::fprintf(status,
                 "lancer flux: %s -> %s (%zu ray segments: %llu camera, %llu reflected, "
                 "%llu light)\n",
                 a.scene.c_str(), a.diagram.c_str(), paths.log.segments.size(),
                 (unsigned long long)paths.rays.camera, (unsigned long long)paths.rays.reflected,
                 (unsigned long long)paths.rays.shadow);
  }
}
}  // namespace

void add_flux(CLI::App& app) {
  auto args = std::make_shared<FluxArgs>();
  CLI::App* cmd = app.add_subcommand(
      "flux",
      "2D flux of a one-row orthographic scene (seeds/002): flux of each ray against its "
      "position x, as CSV (stdout by default), a plot, or a diagram of every ray in the plane");
  cmd->add_option("scene", args->scene, "Scene file (JSON, see docs/scene-format.md)")->required();
  cmd->add_option("--csv", args->csv,
                  "Write the x,flux lines to this file instead of stdout (- is stdout)");
  cmd->add_option("--plot", args->plot,
                  "Plot flux against x: .png, .svg, .pdf (or another image format)");
  cmd->add_option("--diagram", args->diagram,
                  "Draw the plane of the rays: spheres, lights, camera and reflected rays (red), "
                  "light rays that reach their light (blue); .svg or .png");
  cmd->add_option("--size", args->size, "Diagram size in pixels along its longer side, 100 to 8192")
      ->capture_default_str();
  cmd->add_flag("--hits-only", args->hits_only,
                "Diagram: leave out rays that hit nothing (as the text's figure does)");
  cmd->add_flag("--show-blocked", args->show_blocked,
                "Diagram: draw blocked light rays too, thin and grey");
  cmd->callback([args] { run_flux(*args); });
}

}  // namespace lancer::cli
