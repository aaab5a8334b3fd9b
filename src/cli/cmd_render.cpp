#include <sys/resource.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>

#include "commands.hpp"
#include "lancer/error.hpp"
#include "lancer/image.hpp"
#include "lancer/mpi.hpp"
#include "lancer/render.hpp"
#include "lancer/text.hpp"
#include "options.hpp"

namespace lancer::cli {

namespace {
struct RenderArgs {
  std::string scene, output, width = "auto", precision = "auto", accel = "auto";
  int threads = 0;
  bool json = false;
  SceneOverrides overrides;
};

// The process's peak resident set so far (getrusage: Linux reports kilobytes).
double peak_resident_bytes() {
  struct rusage u {};
  getrusage(RUSAGE_SELF, &u);
  return double(u.ru_maxrss) * 1024.0;
}

// load_seconds, write_seconds < 0: not this process's to time (MPI ranks report their own).
void print_summary(const RenderArgs& a, const Scene& scene, const RenderResult& r,
                   double load_seconds, double write_seconds) {
  const auto& c = scene.camera;
  std::printf("lancer: %s -> %s\n", shown_path(a.scene).c_str(), shown_path(a.output).c_str());
  if (load_seconds >= 0)
    std::printf("  load     %.4f s (reading and checking the scene file)\n", load_seconds);
  std::printf("  image    %d x %d, %d sample%s per pixel\n", c.nx, c.ny,
              scene.supersample * scene.supersample, scene.supersample > 1 ? "s" : "");
  const std::string capped =
      a.threads > r.threads
          ? " (" + std::to_string(a.threads) + " asked: this machine runs no more at once)"
          : "";
  std::printf("  engine   width %d (%s), %s precision, %d thread%s%s\n", r.width, r.isa.c_str(),
              to_string(r.precision), r.threads, r.threads > 1 ? "s" : "", capped.c_str());
  std::printf("  kinds    %s; the kernels are built for %s\n", r.structure.kinds.c_str(),
              r.structure.built_for.c_str());
  if (!scene.shapes.empty()) {
    std::size_t meshes = 0, cylinders = 0, dropped = 0;
    for (const Shape& sh : scene.shapes) {
      (sh.kind == Shape::Kind::cylinder ? cylinders : meshes) += 1;
      dropped += sh.mesh.dropped;
    }
    std::printf(
        "  shapes   %zu triangle%s in %zu mesh%s, %zu cylinder%s; %zu zero-area triangle%s "
        "dropped\n",
        scene.triangles(), scene.triangles() == 1 ? "" : "s", meshes, meshes == 1 ? "" : "es",
        cylinders, cylinders == 1 ? "" : "s", dropped, dropped == 1 ? "" : "s");
    const StructureInfo& st = r.structure;
    if (st.shape_spheres > 0)
      std::printf("           one hierarchy over them and the %d sphere%s (the packets walk it):",
                  st.shape_spheres, st.shape_spheres == 1 ? "" : "s");
    else
      std::printf("           their hierarchy:");
    const std::size_t items = st.shape_primitives + std::size_t(st.shape_spheres);
    std::printf(" %zu primitives, %zu nodes, built in %.1f ms, %zu bytes (%.1f per primitive)\n",
                items, st.shape_nodes, st.shape_build_seconds * 1e3, st.shape_bytes,
                items ? double(st.shape_bytes) / double(items) : 0.0);
  }
  if (!r.precision_reason.empty())
    std::printf("  auto     chose %s: %s\n", to_string(r.precision), r.precision_reason.c_str());
  const StructureInfo& st = r.structure;
  if (st.kind == "bvh") {
    std::printf("  structure  bvh (%d spheres, %zu nodes, built in %.1f ms, %zu bytes)%s\n",
                st.spheres, st.nodes, st.build_seconds * 1e3, st.bytes,
                st.shape_spheres > 0 ? ", the reference's; the packets walk the one above" : "");
    if (r.rays.reflected + r.rays.refracted > 0)
      std::printf("  secondary  rays from reflection and refraction points: %s\n",
                  secondary_walk(st, r.width).c_str());
  } else if (st.shape_spheres > 0) {
    std::printf("  structure  the spheres in the shapes' hierarchy (above)\n");
  } else {
    std::printf("  structure  none: plain loop\n");
  }
  std::printf("  rays     %llu camera, %llu shadow, %llu reflected, %llu refracted, %llu in all\n",
              (unsigned long long)r.rays.camera, (unsigned long long)r.rays.shadow,
              (unsigned long long)r.rays.reflected, (unsigned long long)r.rays.refracted,
              (unsigned long long)r.rays.total());
  std::printf("  time     %.4f s, %.2f Mrays/s", r.seconds,
              r.seconds > 0 ? r.rays.total() / r.seconds * 1e-6 : 0.0);
  std::printf("\n");
  if (write_seconds >= 0)
    std::printf(
        "  wrote    %s in %.4f s (checking the path, the format's library, encoding, "
        "writing to disk)\n",
        shown_path(a.output).c_str(), write_seconds);
  std::printf("  memory   peak %.1f MB resident (the whole process so far)\n",
              peak_resident_bytes() / 1e6);
}

// Under mpirun (ranks set): load and write times are not one process's; the ranks' own are given.
void print_json(const RenderArgs& a, const Scene& scene, const RenderResult& r, double load_seconds,
                double write_seconds, const mpi::RankStats* ranks = nullptr) {
  const auto& c = scene.camera;
  const StructureInfo& st = r.structure;
  nlohmann::json j{{"scene", a.scene},
                   {"output", a.output},
                   {"resolution", {c.nx, c.ny}},
                   {"samples_per_pixel", scene.supersample * scene.supersample},
                   {"width", r.width},
                   {"isa", r.isa},
                   {"precision", to_string(r.precision)},
                   {"threads", r.threads},
                   {"threads_asked", a.threads},
                   {"structure",
                    {{"kind", st.kind},
                     {"objects", st.spheres},
                     {"nodes", st.nodes},
                     {"bytes", st.bytes},
                     {"build_seconds", st.build_seconds},
                     {"secondary", st.kind == "bvh" ? secondary_walk(st, r.width) : "none"}}},
                   {"rays",
                    {{"camera", r.rays.camera},
                     {"shadow", r.rays.shadow},
                     {"reflected", r.rays.reflected},
                     {"refracted", r.rays.refracted},
                     {"total", r.rays.total()}}},
                   {"load_seconds", load_seconds},
                   {"render_seconds", r.seconds},
                   {"peak_resident_bytes", peak_resident_bytes()},
                   {"write_seconds", write_seconds},
                   {"mrays_per_s", r.seconds > 0 ? r.rays.total() / r.seconds * 1e-6 : 0.0}};
  if (!r.precision_reason.empty()) j["precision_reason"] = r.precision_reason;
  if (ranks) {
    j.erase("load_seconds");
    j.erase("write_seconds");
    j["mpi"] = {{"ranks", ranks->ranks},
                {"threads_per_rank", ranks->threads},
                {"load_prepare_seconds_slowest", ranks->load_seconds},
                {"compute_seconds_slowest", ranks->compute_seconds},
                {"compute_seconds_mean", ranks->compute_mean_seconds},
                {"gather_seconds", ranks->gather_seconds},
                {"gather_bytes", ranks->gather_bytes}};
  }
  j["kinds"] = r.structure.kinds;
  j["kernels_built_for"] = r.structure.built_for;
  if (!scene.shapes.empty()) {
    std::size_t meshes = 0, cylinders = 0, dropped = 0;
    for (const Shape& sh : scene.shapes) {
      (sh.kind == Shape::Kind::cylinder ? cylinders : meshes) += 1;
      dropped += sh.mesh.dropped;
    }
    j["shapes"] = {{"triangles", scene.triangles()},
                   {"meshes", meshes},
                   {"cylinders", cylinders},
                   {"dropped_zero_area", dropped},
                   {"primitives", st.shape_primitives},
                   {"spheres_in_hierarchy", st.shape_spheres},
                   {"nodes", st.shape_nodes},
                   {"bytes", st.shape_bytes},
                   {"build_seconds", st.shape_build_seconds}};
  }
  std::printf("%s\n", j.dump(2).c_str());
}

// Under mpirun: the same render across the ranks (src/mpi, docs/mpi.md).
void run_render_mpi(const RenderArgs& a) {
  mpi::RenderJob job;
  job.load = [&a] {
    Scene scene = load_scene(a.scene);
    apply_overrides(scene, a.overrides);
    return scene;
  };
  job.scene_path = a.scene;
  job.output = a.output;
  job.options.precision = Precision::automatic;
  job.options.width = 0;
  job.options.threads = a.threads;
  // An option error here, perhaps on this rank alone (MPMD, or -x for one rank), reaches main(),
  // which ends every rank with one line (mpi::end_job).
  job.options.precision = parse_precision(a.precision, "--precision");
  job.options.width = parse_width(a.width, "--width");
  mpi::render_command(job, [&](const Scene& scene, const RenderResult& r, const mpi::RankStats& s) {
    if (a.json) return print_json(a, scene, r, -1, -1, &s);
    print_summary(a, scene, r, -1, -1);
    std::printf(
        "  ranks    %d x %d thread%s; slowest rank: load+prepare %.4f s, render %.4f s "
        "(%.2fx the mean); gather %.4f s, %.2f MB\n",
        s.ranks, s.threads, s.threads > 1 ? "s" : "", s.load_seconds, s.compute_seconds,
        s.compute_mean_seconds > 0 ? s.compute_seconds / s.compute_mean_seconds : 1.0,
        s.gather_seconds, s.gather_bytes * 1e-6);
  });
}

void run_render(const RenderArgs& a) {
  if (mpi::launch_from_environment().size > 1) return run_render_mpi(a);
  const auto load_start = std::chrono::steady_clock::now();
  Scene scene = load_scene(a.scene);
  const double load_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - load_start).count();
  apply_overrides(scene, a.overrides);
  // Before rendering, not after; part of the write's time, since it loads the format's library
  // (OpenImageIO's 260 for the formats only it writes) and probes the folder.
  const auto check_start = std::chrono::steady_clock::now();
  check_output_path(a.output, a.scene);
  const double check_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - check_start).count();
  RenderOptions opt;
  opt.precision = parse_precision(a.precision, "--precision");
  opt.width = parse_width(a.width, "--width");
  opt.threads = a.threads;
  opt.accel = parse_accel(a.accel, "--accel");
  attach_progress(opt);
  const RenderResult r = render(scene, opt);
  // The write is part of what the user waits for (1.6 s of a 7 s 4K render): timed and shown,
  // with the check before the render.
  const auto write_start = std::chrono::steady_clock::now();
  write_image(r.image, a.output);
  const double write_s =
      check_s +
      std::chrono::duration<double>(std::chrono::steady_clock::now() - write_start).count();
  if (a.json) return print_json(a, scene, r, load_s, write_s);
  print_summary(a, scene, r, load_s, write_s);
}
}  // namespace

void add_render(CLI::App& app) {
  auto args = std::make_shared<RenderArgs>();
  CLI::App* cmd = app.add_subcommand("render", "Render a scene to an image file");
  cmd->add_option("scene", args->scene, "Scene file (JSON, see docs/scene-format.md)")->required();
  cmd->add_option(
         "-o,--output", args->output,
         "Output image; format from the extension: .png .jpg .jpeg .ppm .bmp .tga (8-bit), .exr "
         ".tif .tiff .hdr .pfm (float); a symbolic link's target is replaced, keeping its "
         "mode (docs/limits.md)")
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
  cmd->add_option(
         "--threads", args->threads,
         "Threads (0 = all cores; more than the cores is capped at the cores, at most 4096)")
      ->capture_default_str();
  cmd->add_option("--accel", args->accel,
                  "Structure over the spheres: auto (a BVH from 16 spheres on), none (plain loop), "
                  "bvh, or one (as auto, and one hierarchy over the spheres and the shapes)")
      ->capture_default_str();
  cmd->add_flag("--json", args->json,
                "Print one JSON object (what ran, rays, render and write times)");
  cmd->add_option("--supersample", args->overrides.supersample,
                  "Sub-samples per axis (overrides the scene)");
  cmd->add_option("--resolution", args->overrides.resolution,
                  "Image size NXxNY (overrides the scene)");
  cmd->callback([args] { run_render(*args); });
}

}  // namespace lancer::cli
