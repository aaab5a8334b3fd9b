// lancer profile: the profiled kernels render the same image, and their stages account for the
// whole render.
#include <gtest/gtest.h>

#include "lancer/compare.hpp"
#include "lancer/packet/api.hpp"
#include "lancer/prepared.hpp"
#include "lancer/profile.hpp"
#include "support/test_util.hpp"

namespace lancer {
namespace {

using testing::packet_widths;

TEST(Profile, StagesAddUpToTheTotal) {
  Scene s = load_scene(testing::source_path("scenes/lorenzi-reflections.json"));
  for (int width : packet_widths()) {
    const ProfileResult r = profile_render(s, width);
    double sum = 0;
    for (const auto& st : r.stages) sum += st.seconds;
    EXPECT_NEAR(sum / r.total_seconds, 1.0, 0.05) << "width " << width;
    EXPECT_EQ(r.stages.size(), std::size_t(kStageCount));
    EXPECT_GT(r.tests_per_ray, 0);
  }
}

TEST(Profile, CountsRaysAndTestsAsTheRenderDoes) {
  const Scene s = load_scene(testing::source_path("scenes/lorenzi-shadows.json"));
  for (int width : packet_widths()) {
    RenderOptions opt;
    opt.width = width, opt.threads = 1;
    const RenderResult plain = render(s, opt);
    const ProfileResult r = profile_render(s, width);
    EXPECT_EQ(r.camera_rays, plain.rays.camera);
    EXPECT_EQ(r.shadow_rays, plain.rays.shadow);
    EXPECT_EQ(r.reflected_rays, plain.rays.reflected);
    // Every camera ray is tested against every object (3 spheres and a plane); shadow rays stop
    // early, so fewer than 4 tests each.
    const double rays = double(r.camera_rays + r.shadow_rays);
    EXPECT_GT(r.tests_per_ray * rays, 4.0 * r.camera_rays);
    EXPECT_LT(r.tests_per_ray * rays, 4.0 * rays);
  }
}

// Refraction is its own stage: its rays are the render's refracted rays, its packets are the
// refracted packets' intersections, and they are partly empty (rays of a packet diverge).
TEST(Profile, RefractionIsItsOwnStage) {
  const Scene s = load_scene(testing::source_path("scenes/lorenzi-glass.json"));
  for (int width : packet_widths()) {
    RenderOptions opt;
    opt.width = width, opt.threads = 1;
    const RenderResult plain = render(s, opt);
    const ProfileResult r = profile_render(s, width);
    ASSERT_GT(plain.rays.refracted, 0u);
    EXPECT_EQ(r.refracted_rays, plain.rays.refracted);
    EXPECT_EQ(r.reflected_rays, plain.rays.reflected);
    EXPECT_EQ(r.stages[kRefraction].name, "refraction");
    EXPECT_EQ(r.stages[kRefraction].rays, plain.rays.refracted);
    EXPECT_GT(r.stages[kRefraction].lane_occupancy, 0.0);
    EXPECT_LT(r.stages[kRefraction].lane_occupancy, 1.0);
    std::uint64_t lanes = 0;
    const auto& h = r.stages[kRefraction].histogram;
    for (std::size_t k = 0; k < h.size(); ++k) lanes += k * h[k];
    EXPECT_EQ(lanes, plain.rays.refracted) << "every refracted ray in one packet's lanes";
  }
}

TEST(Profile, ProfiledKernelsRenderTheExactImage) {
  for (const std::string& path : testing::shipped_scenes()) {
    const Scene s = load_scene(path);
    const auto prepared = prepare<float>(s);
    for (int width : packet_widths()) {
      SCOPED_TRACE(path);
      Image a(s.camera.nx, s.camera.ny), b(s.camera.nx, s.camera.ny);
      RayCounts ca, cb;
      StageProfile prof;
      cb.profile = &prof;
      packet::kernels_for(width)->render_rows(prepared, a, 0, s.camera.ny, ca);
      packet::profiled_kernels(width)->render_rows(prepared, b, 0, s.camera.ny, cb);
      EXPECT_TRUE(bit_diff(a, b).identical()) << "width " << width;
    }
  }
}

TEST(Profile, LaneOccupancyIsFullForPrimaryRaysOfAFullRow) {
  // 64 pixels a row: every packet of camera rays is full at widths 4, 8 and 16.
  Scene s = load_scene(testing::source_path("scenes/lorenzi-diffuse.json"));
  s.camera.nx = 64, s.camera.ny = 8;
  for (int width : packet_widths()) {
    const ProfileResult r = profile_render(s, width);
    EXPECT_DOUBLE_EQ(r.stages[kRayGeneration].lane_occupancy, 1.0);
    EXPECT_EQ(r.stages[kRayGeneration].histogram.back(), std::uint64_t(64 / width * 8));
  }
}

}  // namespace
}  // namespace lancer
