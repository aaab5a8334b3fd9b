#include <algorithm>
#include <cstdio>
#include <cstring>
#include <memory>
#include <nlohmann/json.hpp>

#include "commands.hpp"
#include "lancer/compare.hpp"
#include "lancer/error.hpp"
#include "lancer/packet/api.hpp"
#include "lancer/render.hpp"
#include "options.hpp"

namespace lancer::cli {

namespace {
struct ValidateArgs {
  std::string scene;
  std::vector<std::string> widths;
  std::string precision = "exact", accel = "auto";
  int threads = 0;
  bool json = false;
  SceneOverrides overrides;
};

// Exit status 0 iff every width gave exactly the reference's bits.
void run_validate(const ValidateArgs& a, int& status) {
  Scene scene = load_scene(a.scene);
  apply_overrides(scene, a.overrides);
  const Precision precision = parse_precision(a.precision, "--precision");
  if (precision != Precision::exact && precision != Precision::dbl)
    throw InputError("--precision: validate compares exact or double renders, not " + a.precision);
  std::vector<int> widths;
  if (a.widths.empty()) {
    for (int w : packet::supported_widths(precision))
      if (w > 1) widths.push_back(w);
  } else {
    widths = parse_width_list(a.widths, "--width", precision);
  }
  // A validate that compared no packet width proved nothing: it must not pass. With the default
  // or "all", the machine (or the cap) offers none: not the user's widths to blame.
  const std::vector<std::string> asked = split_list(a.widths);
  const bool every_width =
      std::all_of(asked.begin(), asked.end(), [](const std::string& w) { return w == "all"; });
  if (std::none_of(widths.begin(), widths.end(), [](int w) { return w > 1; }))
    throw InputError(every_width
                         ? "validate: no packet width to compare with the reference (this CPU "
                           "runs none, or LANCER_MAX_WIDTH=1)"
                         : "--width: validate compares packet widths with the reference (width "
                           "1): give at least one of 4, 8, 16 (double: 2, 4, 8)");
  const Accel accel = parse_accel(a.accel, "--accel");
  RenderOptions ref_opt;
  ref_opt.accel = accel;
  ref_opt.width = 1;
  ref_opt.precision = precision;
  ref_opt.threads = a.threads;
  const RenderResult ref = render(scene, ref_opt);
  // The camera rays' closest hits alone (bench --mode primary's path: square packets, and tiles
  // walking the hierarchy together), t bits and object id per pixel.
  const PrimaryResult ref_hits = render_primary_with_ids(scene, ref_opt);
  auto hits_differing = [&](const PrimaryResult& h) {
    std::uint64_t n = 0;
    for (std::size_t k = 0; k < ref_hits.t.size(); ++k)
      n += std::memcmp(&h.t[k], &ref_hits.t[k], sizeof(float)) != 0 || h.id[k] != ref_hits.id[k];
    return n;
  };
  if (!a.json) {
    std::printf("lancer validate: %s, %d x %d, %s precision, reference = width 1\n",
                a.scene.c_str(), scene.camera.nx, scene.camera.ny, to_string(precision));
    const bool one = ref.structure.shape_spheres > 0;
    std::printf("  structure %s%s\n",
                ref.structure.kind == "bvh"
                    ? (one ? "bvh (reference)" : "bvh (reference and packets)")
                    : "none: plain loop",
                one ? "; the packets: the spheres in the shapes' hierarchy" : "");
    std::printf("  %-6s %-8s %10s %10s %12s  %s\n", "width", "isa", "differing", "max ulps",
                "camera hits", "first differing pixel");
  }
  nlohmann::json rows = nlohmann::json::array();
  bool all_identical = true;
  for (int w : widths) {
    RenderOptions opt;
    opt.width = w;
    opt.accel = accel;
    opt.precision = precision;
    opt.threads = a.threads;
    const RenderResult r = render(scene, opt);
    const BitDiff d = bit_diff(r.image, ref.image);
    const bool same_rays = r.rays == ref.rays;
    const std::uint64_t hits = hits_differing(render_primary_with_ids(scene, opt));
    all_identical = all_identical && d.identical() && same_rays && hits == 0;
    if (a.json) {
      nlohmann::json row{{"width", w},
                         {"isa", r.isa},
                         {"differing_pixels", d.differing_pixels},
                         {"max_ulps", d.max_ulps},
                         {"same_ray_counts", same_rays},
                         {"camera_hits_differing", hits},
                         {"identical", d.identical() && same_rays && hits == 0}};
      row["first_differing_pixel"] =
          d.identical() ? nlohmann::json(nullptr) : nlohmann::json{d.first_i, d.first_j};
      rows.push_back(row);
      continue;
    }
    char first[64] = "-";
    if (!d.identical()) std::snprintf(first, sizeof first, "(%d, %d)", d.first_i, d.first_j);
    std::printf("  %-6d %-8s %10llu %10llu %12llu  %s%s\n", w, r.isa.c_str(),
                (unsigned long long)d.differing_pixels, (unsigned long long)d.max_ulps,
                (unsigned long long)hits, first, same_rays ? "" : "  (ray counts differ)");
  }
  if (a.json)
    std::printf("%s\n", nlohmann::json{{"scene", a.scene},
                                       {"resolution", {scene.camera.nx, scene.camera.ny}},
                                       {"precision", to_string(precision)},
                                       {"reference", {{"width", 1}, {"isa", ref.isa}}},
                                       {"structure", ref.structure.kind},
                                       {"widths", rows},
                                       {"identical", all_identical}}
                            .dump(2)
                            .c_str());
  else
    std::printf("%s\n", all_identical ? "identical" : "DIFFERENT");
  status = all_identical ? kExitOk : kExitDifferent;
}
}  // namespace

void add_validate(CLI::App& app) {
  auto args = std::make_shared<ValidateArgs>();
  CLI::App* cmd = app.add_subcommand(
      "validate",
      "Prove the packet path bit-identical to the scalar reference (exit 0 iff identical)");
  cmd->add_option("scene", args->scene, "Scene file")->required();
  cmd->add_option("--width", args->widths,
                  "Widths to check, e.g. 4,8,16 (default: every width this CPU runs)");
  cmd->add_option("--precision", args->precision,
                  "exact or double: the packets of that precision "
                  "against the reference of that precision")
      ->capture_default_str();
  cmd->add_option(
      "--threads", args->threads,
      "Threads (0 = all cores; more than the cores is capped at the cores, at most 4096)");
  cmd->add_option("--accel", args->accel, "auto, none, bvh or one: the structure both paths use")
      ->capture_default_str();
  cmd->add_flag("--json", args->json, "Print one JSON object (exit status as without it)");
  cmd->add_option("--supersample", args->overrides.supersample, "Override the scene's");
  cmd->add_option("--resolution", args->overrides.resolution, "Override the scene's, NXxNY");
  cmd->callback([args] {
    int status = 0;
    run_validate(*args, status);
    g_exit_status = status;
  });
}

}  // namespace lancer::cli
