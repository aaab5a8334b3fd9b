#include <cstdio>
#include <memory>
#include <nlohmann/json.hpp>

#include "commands.hpp"
#include "lancer/profile.hpp"
#include "options.hpp"

namespace lancer::cli {

namespace {
struct ProfileArgs {
  std::string scene, width = "auto", accel = "auto";
  bool json = false;
  SceneOverrides overrides;
};

// The profile as one JSON object.
void print_profile_json(const ProfileArgs& a, const ProfileResult& r) {
  nlohmann::json out;
  out["scene"] = a.scene;
  out["width"] = r.width;
  out["isa"] = r.isa;
  out["total_seconds"] = r.total_seconds;
  out["rays"] = {{"camera", r.camera_rays},
                 {"shadow", r.shadow_rays},
                 {"reflected", r.reflected_rays},
                 {"refracted", r.refracted_rays}};
  out["tests_per_ray"] = r.tests_per_ray;
  out["stages"] = nlohmann::json::array();
  for (const auto& st : r.stages) {
    // A stage with no packets counted (output) has no occupancy: null, not 0.
    bool measured = false;
    for (std::uint64_t h : st.histogram) measured = measured || h > 0;
    const auto or_null = [measured](const auto& v) {
      return measured ? nlohmann::json(v) : nlohmann::json();
    };
    out["stages"].push_back(
        {{"name", st.name},
         {"seconds", st.seconds},
         {"rays", st.rays},
         // Rays through the stage per second of its own (profiled) time.
         {"mrays_per_s", or_null(st.seconds > 0 ? double(st.rays) / st.seconds * 1e-6 : 0.0)},
         {"lane_occupancy", or_null(st.lane_occupancy)},
         {"leaf_visits", st.leaves},
         // No leaves visited (no hierarchy, or not this stage's): null.
         {"leaf_occupancy", st.leaves ? nlohmann::json(st.leaf_occupancy) : nlohmann::json()},
         {"packets_walked_whole", st.walked_whole},
         {"packets_walked_clustered", st.walked_clustered},
         {"packets_walked_apart", st.walked_apart},
         {"lane_histogram", or_null(st.histogram)}});
  }
  const auto& cb = r.camera_blocks;
  const auto& bt = cb.totals;
  out["camera_blocks"] = {
      {"seconds", cb.seconds},
      {"rays", cb.rays},
      {"block", bt.together + bt.alone ? nlohmann::json{bt.block_w, bt.block_h} : nlohmann::json()},
      {"walked_together", bt.together},
      {"walked_packet_by_packet", bt.alone},
      {"totals",
       {{"node_tests", bt.nodes},
        {"leaf_pops", bt.leaf_pops},
        {"tile_leaf_tests", bt.tile_tests},
        {"leaf_calls", bt.leaf_calls},
        {"leaf_call_lanes", bt.leaf_lanes},
        {"subtrees_walked_by_one_tile", bt.tiles_alone},
        {"tile_sphere_cone_tests", bt.cone_pairs},
        {"tile_sphere_pairs_kept", bt.cone_kept}}},
      {"per_block", bt.together ? nlohmann::json{{"node_tests", cb.nodes},
                                                 {"leaf_pops", cb.leaf_pops},
                                                 {"tile_leaf_tests", cb.tile_tests},
                                                 {"leaf_calls", cb.leaf_calls},
                                                 {"subtrees_walked_by_one_tile", cb.tiles_alone}}
                                : nlohmann::json()},
      {"leaf_occupancy", bt.leaf_calls ? nlohmann::json(cb.leaf_occupancy) : nlohmann::json()},
      {"cone_kept", bt.cone_pairs ? nlohmann::json(cb.cone_kept) : nlohmann::json()}};
  const auto& g = cb.shape_groups;
  out["camera_blocks"]["shape_groups"] = {
      {"group", g.groups ? nlohmann::json{g.group_w, g.group_h} : nlohmann::json()},
      {"groups", g.groups},
      {"walks_together", g.walks},
      {"tiles_alone", g.tiles_alone},
      {"totals",
       {{"nodes_entered", g.nodes},
        {"tile_child_box_tests", g.box_tests},
        {"leaves", g.leaves},
        {"leaf_calls", g.leaf_calls},
        {"leaf_call_lanes", g.leaf_lanes}}},
      {"leaf_occupancy",
       g.leaf_calls ? nlohmann::json(cb.shape_leaf_occupancy) : nlohmann::json()}};
  std::printf("%s\n", out.dump(2).c_str());
}

// The shapes' camera groups (the hierarchy of triangles and cylinders), per group.
void print_shape_groups(const ProfileResult::CameraBlocks& cb) {
  const auto& g = cb.shape_groups;
  if (g.groups == 0) return;
  const double n = double(g.groups);
  std::printf(
      "    shapes' camera groups of %dx%d pixels: %llu, walked the hierarchy in %llu walks "
      "together (one per set of tiles sharing direction signs), %llu tiles of mixed signs alone\n",
      g.group_w, g.group_h, (unsigned long long)g.groups, (unsigned long long)g.walks,
      (unsigned long long)g.tiles_alone);
  std::printf(
      "    per group: %.2f nodes entered, %.2f tile-child box tests, %.2f leaves, %.2f tile-leaf "
      "calls at %.1f%% lane occupancy\n",
      double(g.nodes) / n, double(g.box_tests) / n, double(g.leaves) / n, double(g.leaf_calls) / n,
      100 * cb.shape_leaf_occupancy);
}

// The camera blocks' part of the table: primary mode's path, which full renders do not use.
void print_camera_blocks(const ProfileResult& r) {
  const auto& cb = r.camera_blocks;
  const auto& bt = cb.totals;
  std::printf(
      "  camera rays alone, as bench --mode primary traces them: %.5f s (profiled), %llu rays\n",
      cb.seconds, (unsigned long long)cb.rays);
  // In id order: the spheres' blocks, then the shapes' groups.
  if (bt.together + bt.alone == 0) {
    if (cb.shape_groups.groups == 0)
      std::printf(
          "    camera blocks: none (no hierarchy, or not a pinhole camera: packets one by one)\n");
    print_shape_groups(cb);
    return;
  }
  std::printf(
      "    camera blocks of %dx%d pixels: %llu walked the hierarchy together, %llu packet by "
      "packet (on the image's centre lines)\n",
      bt.block_w, bt.block_h, (unsigned long long)bt.together, (unsigned long long)bt.alone);
  if (bt.together)
    std::printf(
        "    per block walked together: %.2f node tests, %.2f leaf pops, %.2f tile-leaf %s "
        "tests, %.2f leaf calls at %.1f%% lane occupancy; %.2f subtrees that one tile alone "
        "went on into, walked by it as its own packet\n",
        cb.nodes, cb.leaf_pops, cb.tile_tests, bt.cone_pairs ? "cone" : "box", cb.leaf_calls,
        100 * cb.leaf_occupancy, cb.tiles_alone);
  if (bt.cone_pairs)
    std::printf(
        "    the tiles' cones passed %.1f%% of tile-sphere pairs on to the per-lane sphere "
        "tests\n",
        100 * cb.cone_kept);
  print_shape_groups(cb);
}

// The profile as a table: per stage, then the hierarchy's leaves and the camera blocks.
void print_profile_table(const ProfileArgs& a, const ProfileResult& r) {
  double staged = 0;
  for (const auto& st : r.stages) staged += st.seconds;
  std::printf("lancer profile: %s, width %d (%s), exact precision, 1 thread\n", a.scene.c_str(),
              r.width, r.isa.c_str());
  std::printf(
      "  rays: %llu camera, %llu shadow, %llu reflected, %llu refracted; %.2f ray-object tests "
      "per ray\n",
      (unsigned long long)r.camera_rays, (unsigned long long)r.shadow_rays,
      (unsigned long long)r.reflected_rays, (unsigned long long)r.refracted_rays, r.tests_per_ray);
  std::printf("  %-22s %10s %7s %12s %9s %10s  %s\n", "stage", "seconds", "share", "rays",
              "Mrays/s", "occupancy", "packets by active lanes (0..W)");
  for (const auto& st : r.stages) {
    std::string hist;
    for (std::uint64_t h : st.histogram) hist += std::to_string(h) + " ";
    char occ[16] = "-", rate[24] = "-";
    if (!hist.empty() && st.lane_occupancy > 0)
      std::snprintf(occ, sizeof occ, "%.1f%%", 100 * st.lane_occupancy);
    else
      hist = "-";
    // Rays per second of the stage's own time; stages without packets (output) have none.
    if (hist != "-" && st.seconds > 0 && st.rays > 0)
      std::snprintf(rate, sizeof rate, "%.2f", double(st.rays) / st.seconds * 1e-6);
    std::printf("  %-22s %10.5f %6.1f%% %12llu %9s %10s  %s\n", st.name.c_str(), st.seconds,
                r.total_seconds > 0 ? 100 * st.seconds / r.total_seconds : 0.0,
                (unsigned long long)st.rays, rate, occ, hist.c_str());
  }
  bool leaves = false;
  for (const auto& st : r.stages)
    if (st.leaves) {
      if (!leaves)
        std::printf("  hierarchy leaves: visits and lane occupancy in them, per stage\n");
      leaves = true;
      std::printf("  %-22s %12llu leaves %6.1f%%\n", st.name.c_str(), (unsigned long long)st.leaves,
                  100 * st.leaf_occupancy);
    }
  bool apart = false;
  for (const auto& st : r.stages)
    if (st.walked_whole + st.walked_clustered + st.walked_apart) {
      if (!apart)
        std::printf(
            "  secondary packets by how they walked (lancer render's secondary line says when)\n");
      apart = true;
      std::printf("  %-22s %12llu whole %12llu clustered %12llu lane by lane\n", st.name.c_str(),
                  (unsigned long long)st.walked_whole, (unsigned long long)st.walked_clustered,
                  (unsigned long long)st.walked_apart);
    }
  std::printf("  %-22s %10.5f %6.1f%%   (stages add up to %.1f%% of the total)\n", "total",
              r.total_seconds, 100.0, r.total_seconds > 0 ? 100 * staged / r.total_seconds : 0);
  print_camera_blocks(r);
}

void run_profile(const ProfileArgs& a) {
  Scene scene = load_scene(a.scene);
  apply_overrides(scene, a.overrides);
  const ProfileResult r =
      profile_render(scene, parse_width(a.width, "--width"), parse_accel(a.accel, "--accel"));
  if (a.json)
    print_profile_json(a, r);
  else
    print_profile_table(a, r);
}
}  // namespace

void add_profile(CLI::App& app) {
  auto args = std::make_shared<ProfileArgs>();
  CLI::App* cmd = app.add_subcommand(
      "profile", "Where the time goes: per stage time, rays, tests per ray and lane occupancy");
  cmd->add_option("scene", args->scene, "Scene file")->required();
  cmd->add_option("--width", args->width, "auto (widest), 4, 8 or 16")->capture_default_str();
  cmd->add_option("--accel", args->accel, "auto, none, bvh or one")->capture_default_str();
  cmd->add_flag("--json", args->json, "Print one JSON object instead of a table");
  cmd->add_option("--supersample", args->overrides.supersample, "Override the scene's");
  cmd->add_option("--resolution", args->overrides.resolution, "Override the scene's, NXxNY");
  cmd->callback([args] { run_profile(*args); });
}

}  // namespace lancer::cli
