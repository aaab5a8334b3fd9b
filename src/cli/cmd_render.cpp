#include <cstdio>
#include <memory>

#include "commands.hpp"
#include "lancer/image.hpp"
#include "lancer/render.hpp"
#include "options.hpp"

namespace lancer::cli {

namespace {
struct RenderArgs {
  std::string scene, output, width = "auto", precision = "auto";
  int threads = 0;
  SceneOverrides overrides;
};

void run_render(const RenderArgs& a) {
  Scene scene = load_scene(a.scene);
  apply_overrides(scene, a.overrides);
  check_output_path(a.output, a.scene);  // before rendering, not after
  RenderOptions opt;
  opt.precision = parse_precision(a.precision, "--precision");
  opt.width = parse_width(a.width, "--width");
  opt.threads = a.threads;
  attach_progress(opt);
  const RenderResult r = render(scene, opt);
  write_image(r.image, a.output);
  const auto& c = scene.camera;
  std::printf("lancer: %s -> %s\n", a.scene.c_str(), a.output.c_str());
  std::printf("  image    %d x %d, %d sample%s per pixel\n", c.nx, c.ny,
              scene.supersample * scene.supersample, scene.supersample > 1 ? "s" : "");
  std::printf("  engine   width %d (%s), %s precision, %d thread%s\n", r.width, r.isa.c_str(),
              to_string(r.precision), r.threads, r.threads > 1 ? "s" : "");
  if (!r.precision_reason.empty())
    std::printf("  auto     chose %s: %s\n", to_string(r.precision), r.precision_reason.c_str());
  std::printf("  rays     %llu camera, %llu shadow, %llu reflected, %llu refracted, %llu in all\n",
              (unsigned long long)r.rays.camera, (unsigned long long)r.rays.shadow,
              (unsigned long long)r.rays.reflected, (unsigned long long)r.rays.refracted,
              (unsigned long long)r.rays.total());
  std::printf("  time     %.4f s, %.2f Mrays/s\n", r.seconds,
              r.seconds > 0 ? r.rays.total() / r.seconds * 1e-6 : 0.0);
}
}  // namespace

void add_render(CLI::App& app) {
  auto args = std::make_shared<RenderArgs>();
  CLI::App* cmd = app.add_subcommand("render", "Render a scene to an image file");
  cmd->add_option("scene", args->scene, "Scene file (JSON, see SCENE-MODEL.md)")->required();
  cmd->add_option("-o,--output", args->output,
                  "Output image; format from the extension: .png .exr .tif .jpg .ppm .pfm ...")
      ->required();
  cmd->add_option("--width", args->width,
                  "Lanes per packet: auto (widest this CPU runs), 1 (scalar reference), 4, 8, 16 "
                  "(float) or 2, 4, 8 (double)")
      ->capture_default_str();
  cmd->add_option("--precision", args->precision,
                  "auto (exact where the scene lies in float's envelope, else double), exact "
                  "(IEEE float, bit-identical at every width), double, or fast (FMA and refined "
                  "approximate reciprocals, packets only)")
      ->capture_default_str();
  cmd->add_option("--threads", args->threads, "Threads (0 = all cores)")->capture_default_str();
  cmd->add_option("--supersample", args->overrides.supersample,
                  "Sub-samples per axis (overrides the scene)");
  cmd->add_option("--resolution", args->overrides.resolution,
                  "Image size NXxNY (overrides the scene)");
  cmd->callback([args] { run_render(*args); });
}

}  // namespace lancer::cli
