#include "lancer/profile.hpp"

#include <chrono>
#include <cstdlib>
#include <string>

#include "lancer/cycles.hpp"
#include "lancer/error.hpp"
#include "lancer/packet/api.hpp"
#include "lancer/prepared.hpp"
#include "lancer/render.hpp"

namespace lancer {

const char* stage_name(int stage) {
  static const char* const names[kStageCount] = {
      "ray generation",        "primary intersection", "shading",    "shadow rays",
      "secondary shadow rays", "reflection",           "refraction", "output"};
  return stage >= 0 && stage < kStageCount ? names[stage] : "?";
}

ProfileResult profile_render(const Scene& scene, int width, Accel accel) {
  ProfileResult res;
  res.width = resolve_width(width, Precision::exact);
  if (res.width == 1) {
    std::string why = "width 4, 8 or 16";
    // Width auto fell back to 1: no packet width runs here, and the cause is not the user's.
    if (width == 0) {
      const char* cap = std::getenv("LANCER_MAX_WIDTH");
      why += cap && std::atoi(cap) < 4
                 ? std::string(", which LANCER_MAX_WIDTH=") + cap + " leaves out"
                 : std::string(", which this CPU or OS does not run");
    }
    throw InputError("--width: profile instruments the packet kernels: " + why);
  }
  const packet::KernelTable<float>* k = packet::profiled_kernels(res.width);
  LANCER_CHECK(k != nullptr);
  res.isa = k->isa;
  const PreparedScene<float> prepared = prepare<float>(scene, accel);
  Image image(scene.camera.nx, scene.camera.ny);
  StageProfile prof;
  RayCounts counts;
  counts.profile = &prof;

  // The TSC's rate, from the same run: cycles and seconds of the whole render.
  const auto t0 = std::chrono::steady_clock::now();
  const std::uint64_t c0 = ticks();
  k->render_rows(prepared, image, 0, scene.camera.ny, counts);
  const std::uint64_t c1 = ticks();
  res.total_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const double seconds_per_cycle = c1 > c0 ? res.total_seconds / double(c1 - c0) : 0;

  res.camera_rays = counts.camera;
  res.shadow_rays = counts.shadow;
  res.reflected_rays = counts.reflected;
  res.refracted_rays = counts.refracted;
  const std::uint64_t rays = counts.total();
  res.tests_per_ray = rays ? double(prof.sphere_tests + prof.plane_tests) / double(rays) : 0;
  // Shadow rays by where they leave from: the lanes each shadow stage traced (exact mode traces
  // every lit lane, so the two add up to counts.shadow).
  const std::uint64_t stage_rays[kStageCount] = {counts.camera,
                                                 counts.camera,
                                                 counts.camera,
                                                 prof.active_lanes[kShadowRays],
                                                 prof.active_lanes[kSecondaryShadowRays],
                                                 counts.reflected,
                                                 counts.refracted,
                                                 counts.camera};
  for (int st = 0; st < kStageCount; ++st) {
    ProfileResult::StageRow row;
    row.name = stage_name(st);
    row.seconds = double(prof.cycles[st]) * seconds_per_cycle;
    row.rays = stage_rays[st];
    row.lane_occupancy =
        prof.packets[st] ? double(prof.active_lanes[st]) / (double(prof.packets[st]) * res.width)
                         : 0;
    row.leaves = prof.leaf_packets[st];
    row.leaf_occupancy =
        row.leaves ? double(prof.leaf_lanes[st]) / (double(row.leaves) * res.width) : 0;
    row.walked_whole = prof.walked_whole[st], row.walked_apart = prof.walked_apart[st];
    row.walked_clustered = prof.walked_clustered[st];
    row.histogram.assign(prof.histogram[st].begin(), prof.histogram[st].begin() + res.width + 1);
    res.stages.push_back(row);
  }

  // Camera rays and closest hits alone, as bench --mode primary traces them (in blocks that walk
  // the hierarchy together, as full renders now find their camera hits), counted per block.
  StageProfile primary;
  primary.current = kPrimaryIntersection;  // its leaf visits, if it counts any
  RayCounts primary_counts;
  primary_counts.profile = &primary;
  std::vector<float> t(std::size_t(scene.camera.nx) * std::size_t(scene.camera.ny));
  const auto p0 = std::chrono::steady_clock::now();
  k->primary_rows(prepared, t.data(), nullptr, 0, scene.camera.ny, primary_counts);
  ProfileResult::CameraBlocks& cb = res.camera_blocks;
  cb.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - p0).count();
  cb.rays = primary_counts.camera;
  cb.totals = primary.blocks;
  cb.shape_groups = primary.shape_groups;
  if (const auto& g = cb.shape_groups; g.leaf_calls)
    cb.shape_leaf_occupancy = double(g.leaf_lanes) / (double(g.leaf_calls) * double(res.width));
  if (const double n = double(cb.totals.together); n > 0) {
    cb.nodes = double(cb.totals.nodes) / n;
    cb.leaf_pops = double(cb.totals.leaf_pops) / n;
    cb.tile_tests = double(cb.totals.tile_tests) / n;
    cb.leaf_calls = double(cb.totals.leaf_calls) / n;
    cb.tiles_alone = double(cb.totals.tiles_alone) / n;
  }
  if (cb.totals.cone_pairs)
    cb.cone_kept = double(cb.totals.cone_kept) / double(cb.totals.cone_pairs);
  if (cb.totals.leaf_calls)
    cb.leaf_occupancy =
        double(cb.totals.leaf_lanes) / (double(cb.totals.leaf_calls) * double(res.width));
  return res;
}

}  // namespace lancer
