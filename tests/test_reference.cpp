// The scalar reference against values worked out by hand from SCENE-MODEL.md.
#include <gtest/gtest.h>

#include <cmath>
#include <nlohmann/json.hpp>

#include "lancer/compare.hpp"
#include "lancer/prepared.hpp"
#include "lancer/reference.hpp"
#include "support/test_util.hpp"

namespace lancer {
namespace {

using nlohmann::json;

// An orthographic camera of one pixel whose ray leaves `position` along `direction`.
json one_pixel_camera(json position, json direction) {
  return {{"type", "orthographic"},
          {"position", position},
          {"direction", direction},
          {"resolution", {1, 1}},
          {"bounds", {-0.5, 0.5, -0.5, 0.5}}};
}

// The single pixel of a scene rendered by the reference in precision T.
template <class T>
std::array<double, 3> pixel_of(const json& j) {
  const Scene s = parse_scene(j.dump(), "test.json");
  const Image im =
      testing::render_with(s, 1, std::is_same_v<T, float> ? Precision::exact : Precision::dbl);
  return {im.rgb[0], im.rgb[1], im.rgb[2]};
}

template <class T>
class ReferenceTest : public ::testing::Test {
 protected:
  // Images store floats: double renders agree with the hand value to float rounding, float
  // renders to a few float roundings more.
  static double tol() { return std::is_same_v<T, float> ? 2e-6 : 1e-7; }
};
using Precisions = ::testing::Types<float, double>;
TYPED_TEST_SUITE(ReferenceTest, Precisions);

TEST(CameraBasis, LookingDownMinusZ) {
  const auto p = prepare<double>(parse_scene(
      json{{"camera", one_pixel_camera({0, 0, 5}, {0, 0, -1})}, {"objects", json::array()}}.dump(),
      "t"));
  EXPECT_EQ(p.frame.u.x, 1);
  EXPECT_EQ(p.frame.v.y, 1);
  EXPECT_EQ(p.frame.w.z, 1);
}

TEST(CameraBasis, LookingStraightDownUsesUnitX) {
  // w = (0, 1, 0) makes (-w.z, 0, w.x) zero: u = (1, 0, 0), v = w x u = (0, 0, -1).
  const auto p = prepare<double>(parse_scene(
      json{{"camera", one_pixel_camera({0, 5, 0}, {0, -3, 0})}, {"objects", json::array()}}.dump(),
      "t"));
  EXPECT_EQ(p.frame.w.y, 1);
  EXPECT_EQ(p.frame.u.x, 1);
  EXPECT_EQ(p.frame.u.y, 0);
  EXPECT_EQ(p.frame.u.z, 0);
  EXPECT_EQ(p.frame.v.x, 0);
  EXPECT_EQ(p.frame.v.y, 0);
  EXPECT_EQ(p.frame.v.z, -1);
}

TEST(CameraBasis, FlipsSoThatVPointsUp) {
  // Looking along +z: u = (1,0,0) gives v = (0,-1,0), so both are negated.
  const auto p = prepare<double>(parse_scene(
      json{{"camera", one_pixel_camera({0, 0, 0}, {0, 0, 2})}, {"objects", json::array()}}.dump(),
      "t"));
  EXPECT_EQ(p.frame.u.x, -1);
  EXPECT_EQ(p.frame.v.y, 1);
  EXPECT_EQ(p.frame.w.z, -1);
}

// Scenes are prepared in the camera's frame: the camera's basis becomes the axes exactly, world
// points map there and back (in double, to its rounding), and where the spheres lie far beyond
// the eye against their spread the origin moves along the view to them (Frame::depth).
TEST(CameraFrame, PointsMapThereAndBack) {
  json j{{"camera", one_pixel_camera({3, -2, 7}, {0.3, -0.4, -1})},
         {"lights", {{{"position", {1, 9, -4}}, {"intensity", 1}}}},
         {"objects",
          {{{"type", "sphere"}, {"center", {1, -1, -3}}, {"radius", 1}},
           {{"type", "plane"}, {"point", {0, -2, 0}}, {"normal", {0, 1, 0}}}}}};
  j["camera"]["type"] = "pinhole";
  j["camera"]["distance"] = 1;
  const Scene scene = parse_scene(j.dump(), "t");
  const auto p = prepare<double>(scene);
  EXPECT_EQ(p.frame.depth, 0);  // the sphere is near: no depth
  EXPECT_EQ(p.camera.u.x, 1);
  EXPECT_EQ(p.camera.v.y, 1);
  EXPECT_EQ(p.camera.w.z, 1);
  EXPECT_EQ(p.camera.u.y, 0);
  EXPECT_EQ(p.camera.w.x, 0);
  const Vec3<double> c = p.frame.world_point({p.spheres.cx[0], p.spheres.cy[0], p.spheres.cz[0]});
  EXPECT_NEAR(c.x, 1, 1e-14);
  EXPECT_NEAR(c.y, -1, 1e-14);
  EXPECT_NEAR(c.z, -3, 1e-14);
  // The camera's forward direction is -w: in the frame, -z.
  const Vec3<double> ahead = p.frame.direction(normalize(Vec3<double>{0.3, -0.4, -1}));
  EXPECT_NEAR(ahead.x, 0, 1e-15);
  EXPECT_NEAR(ahead.y, 0, 1e-15);
  EXPECT_NEAR(ahead.z, -1, 1e-15);
  // Lengths and angles are kept: the plane's normal stays unit, the light where it was.
  EXPECT_NEAR(p.planes.nx[0] * p.planes.nx[0] + p.planes.ny[0] * p.planes.ny[0] +
                  p.planes.nz[0] * p.planes.nz[0],
              1, 1e-15);
  const Vec3<double> l = p.frame.world_point({p.lights.x[0], p.lights.y[0], p.lights.z[0]});
  EXPECT_NEAR(length(l - Vec3<double>{1, 9, -4}), 0, 1e-13);
}

TEST(CameraFrame, DepthMovesTheOriginToFarSpheres) {
  // Two spheres of radius 1e-3 about 1e4 ahead: the origin moves to the nearer one's surface.
  json j{{"camera", one_pixel_camera({0, 0, 0}, {1, 1, -1})},
         {"objects",
          {{{"type", "sphere"}, {"center", {5773.5, 5773.5, -5773.5}}, {"radius", 1e-3}},
           {{"type", "sphere"}, {"center", {5773.501, 5773.5, -5773.5}}, {"radius", 1e-3}}}}};
  j["camera"]["type"] = "pinhole";
  j["camera"]["distance"] = 1;
  const auto p = prepare<float>(parse_scene(j.dump(), "t"));
  EXPECT_GT(p.frame.depth, 9999);
  EXPECT_LT(p.frame.depth, 10000.1);
  EXPECT_EQ(double(float(p.frame.depth)), p.frame.depth);  // the eye sits on a float
  EXPECT_EQ(p.camera.position.z, float(p.frame.depth));
  EXPECT_EQ(p.camera.position.x, 0);
  // The spheres sit near the origin, where float keeps their 1e-3 apart to its own spacing.
  EXPECT_LT(std::fabs(p.spheres.cz[0]), 0.01f);
  EXPECT_NEAR(double(p.spheres.cx[1]) - double(p.spheres.cx[0]) +
                  (double(p.spheres.cy[1]) - double(p.spheres.cy[0])),
              0, 2e-3);
  const Vec3<double> c1 = p.frame.world_point({p.spheres.cx[1], p.spheres.cy[1], p.spheres.cz[1]});
  EXPECT_NEAR(c1.x - 5773.501, 0, 1e-6);
  // Not with a plane (its hits would carry ulps of the eye's distance twice over).
  j["objects"].push_back({{"type", "plane"}, {"point", {0, -2, 0}}, {"normal", {0, 1, 0}}});
  EXPECT_EQ(prepare<float>(parse_scene(j.dump(), "t")).frame.depth, 0);
}

TEST(CameraRays, PixelCentresFollowTheContract) {
  // 4 x 2 pixels over [-2, 2] x [-1, 1]: pixel (i, j) centre x = -2 + (i + 0.5), y = 1 - (j + .5).
  const auto p = prepare<double>(parse_scene(json{{"camera",
                                                   {{"type", "orthographic"},
                                                    {"position", {0, 0, 0}},
                                                    {"direction", {0, 0, -1}},
                                                    {"resolution", {4, 2}},
                                                    {"bounds", {-2, 2, -1, 1}}}},
                                                  {"supersample", 2},
                                                  {"objects", json::array()}}
                                                 .dump(),
                                             "t"));
  // Sub-sample a = 1 of 2 sits at 0.75 of the pixel.
  EXPECT_DOUBLE_EQ(p.camera.screen_x[1 * 4 + 3], -2 + 3.75);
  EXPECT_DOUBLE_EQ(p.camera.screen_y[0 * 2 + 1], 1 - 1.25);
}

json head_on_scene(double ks) {
  // The ray hits the unit sphere at P = (0, 0, 1), n = (0, 0, 1); the light at (0, 3, 5) gives
  // L - P = (0, 3, 4), l = (0, 0.6, 0.8), cos = 0.8.
  return {
      {"camera", one_pixel_camera({0, 0, 10}, {0, 0, -1})},
      {"lights", {{{"position", {0, 3, 5}}, {"intensity", 0.9}, {"ambient", 0.5}}}},
      {"objects",
       {{{"type", "sphere"},
         {"center", {0, 0, 0}},
         {"radius", 1},
         {"material",
          {{"color", {1, 0.5, 0.25}}, {"ka", 0.2}, {"kd", 0.7}, {"ks", ks}, {"shininess", 10}}}}}}};
}

TYPED_TEST(ReferenceTest, SphereLitHeadOnIsAmbientPlusKdICos) {
  const auto px = pixel_of<TypeParam>(head_on_scene(0));
  const double shade = 0.2 * 0.5 + 0.7 * 0.9 * 0.8;
  EXPECT_NEAR(px[0], shade, this->tol());
  EXPECT_NEAR(px[1], 0.5 * shade, this->tol());
  EXPECT_NEAR(px[2], 0.25 * shade, this->tol());
}

TYPED_TEST(ReferenceTest, BlinnPhongSpecular) {
  // h = normalize(l + view) = normalize(0, 0.6, 1.8); n.h = 1.8 / sqrt(3.6), whose square is 0.9:
  // (n.h)^10 = 0.9^5.
  const auto px = pixel_of<TypeParam>(head_on_scene(0.5));
  const double shade = 0.2 * 0.5 + 0.7 * 0.9 * 0.8 + 0.5 * 0.9 * std::pow(0.9, 5);
  EXPECT_NEAR(px[0], shade, this->tol());
}

json ground_scene() {
  // Looking straight down from (0, 5, 0) onto the plane y = 0: P = (0, 0, 0), n = (0, 1, 0);
  // the light at (3, 4, 0) is at distance 5 with cos = 0.8.
  return {{"camera", one_pixel_camera({0, 5, 0}, {0, -1, 0})},
          {"lights", {{{"position", {3, 4, 0}}, {"intensity", 1}, {"ambient", 0.5}}}},
          {"objects",
           {{{"type", "plane"},
             {"point", {0, 0, 0}},
             {"normal", {0, 2, 0}},
             {"material", {{"ka", 0.2}, {"kd", 1}}}}}}};
}

TYPED_TEST(ReferenceTest, PlaneAtKnownDistance) {
  const auto px = pixel_of<TypeParam>(ground_scene());
  EXPECT_NEAR(px[0], 0.2 * 0.5 + 0.8, this->tol());
}

TYPED_TEST(ReferenceTest, PointInShadowKeepsOnlyAmbient) {
  json j = ground_scene();
  // A ball on the segment from P to the light, out of the camera ray's way.
  j["objects"].push_back({{"type", "sphere"}, {"center", {1.5, 2, 0}}, {"radius", 0.5}});
  const auto px = pixel_of<TypeParam>(j);
  EXPECT_NEAR(px[0], 0.2 * 0.5, this->tol());
}

TYPED_TEST(ReferenceTest, LightBeyondTheBlockerIsNotBlockedByObjectsBehindIt) {
  json j = ground_scene();
  // On the line P -> light, but past the light (t > |L - P| = 5): no shadow.
  j["objects"].push_back({{"type", "sphere"}, {"center", {4.5, 6, 0}}, {"radius", 0.5}});
  const auto px = pixel_of<TypeParam>(j);
  EXPECT_NEAR(px[0], 0.2 * 0.5 + 0.8, this->tol());
}

json mirror_scene(int max_depth) {
  // The camera ray hits the mirror z = 0 at the origin and comes back along +z to the sphere at
  // z = 20 (radius 1), whose ambient-only shade is ka * Ia = 1 * 0.5.
  return {{"camera", one_pixel_camera({0, 0, 10}, {0, 0, -1})},
          {"max_depth", max_depth},
          {"environment", 0.3},
          {"lights", {{{"position", {100, 0, 10}}, {"intensity", 0}, {"ambient", 0.5}}}},
          {"objects",
           {{{"type", "plane"},
             {"point", {0, 0, 0}},
             {"normal", {0, 0, 1}},
             {"material", {{"ka", 0}, {"kd", 0}, {"reflect", 0.8}}}},
            {{"type", "sphere"},
             {"center", {0, 0, 20}},
             {"radius", 1},
             {"material", {{"color", {1, 0.5, 0.25}}, {"ka", 1}, {"kd", 0}}}}}}};
}

TYPED_TEST(ReferenceTest, MirrorBounceAddsReflectTimesWhatItSees) {
  const auto px = pixel_of<TypeParam>(mirror_scene(1));
  EXPECT_NEAR(px[0], 0.8 * 0.5, this->tol());
  EXPECT_NEAR(px[1], 0.8 * 0.25, this->tol());
  EXPECT_NEAR(px[2], 0.8 * 0.125, this->tol());
}

TYPED_TEST(ReferenceTest, NoBounceAtDepthZero) {
  const auto px = pixel_of<TypeParam>(mirror_scene(0));
  EXPECT_EQ(px[0], 0);
}

TYPED_TEST(ReferenceTest, ReflectedMissSeesTheEnvironmentNotTheBackground) {
  json j = mirror_scene(1);
  j["objects"].erase(1);
  j["background"] = 0.9;
  const auto px = pixel_of<TypeParam>(j);
  EXPECT_NEAR(px[0], 0.8 * 0.3, this->tol());
}

TYPED_TEST(ReferenceTest, PrimaryMissSeesTheBackground) {
  json j = mirror_scene(1);
  j["objects"] = json::array();
  j["background"] = {0.1, 0.2, 0.3};
  const auto px = pixel_of<TypeParam>(j);
  EXPECT_NEAR(px[2], 0.3, this->tol());
}

// Intersections, through the reference's closest-hit.
template <class T>
reference::Hit<T> hit_of(const json& objects, Vec3<T> origin, Vec3<T> dir, double eps = 1e-4) {
  // The camera at the world's origin: prepared coordinates are camera-relative.
  json j{
      {"camera", one_pixel_camera({0, 0, 0}, {0, 0, -1})}, {"epsilon", eps}, {"objects", objects}};
  const auto p = prepare<T>(parse_scene(j.dump(), "t"));
  return reference::closest_hit(p, origin, dir);
}

TYPED_TEST(ReferenceTest, FromInsideASphereHitsTheFarSide) {
  using T = TypeParam;
  const auto h = hit_of<T>({{{"type", "sphere"}, {"center", {1, 0, 0}}, {"radius", 2}}},
                           Vec3<T>{1, 0, 0}, Vec3<T>{0, 1, 0});
  EXPECT_EQ(h.id, 0);
  EXPECT_NEAR(h.t, 2.0, this->tol());
}

TYPED_TEST(ReferenceTest, SphereBehindTheRayIsMissed) {
  using T = TypeParam;
  const auto h = hit_of<T>({{{"type", "sphere"}, {"center", {0, 0, -5}}, {"radius", 1}}},
                           Vec3<T>{0, 0, 0}, Vec3<T>{0, 0, 1});
  EXPECT_EQ(h.id, -1);
}

TYPED_TEST(ReferenceTest, RayParallelToAPlaneMisses) {
  using T = TypeParam;
  const auto h = hit_of<T>({{{"type", "plane"}, {"point", {0, -1, 0}}, {"normal", {0, 1, 0}}}},
                           Vec3<T>{0, 0, 0}, Vec3<T>{1, 0, 0});
  EXPECT_EQ(h.id, -1);
}

TYPED_TEST(ReferenceTest, HitExactlyAtEpsilonIsNoHitJustBeyondIsOne) {
  using T = TypeParam;
  // Plane z = -1/16 seen along -z from the origin: t = 1/16 exactly, in float and double.
  const json plane = {{{"type", "plane"}, {"point", {0, 0, -0.0625}}, {"normal", {0, 0, 1}}}};
  EXPECT_EQ(hit_of<T>(plane, Vec3<T>{0, 0, 0}, Vec3<T>{0, 0, -1}, 0.0625).id, -1);
  const auto h = hit_of<T>(plane, Vec3<T>{0, 0, 0}, Vec3<T>{0, 0, -1}, 0.0624);
  EXPECT_EQ(h.id, 0);
  EXPECT_EQ(h.t, T(0.0625));
}

TYPED_TEST(ReferenceTest, NearerObjectWinsWhateverItsType) {
  using T = TypeParam;
  const json objects = {{{"type", "sphere"}, {"center", {0, 0, -10}}, {"radius", 1}},
                        {{"type", "plane"}, {"point", {0, 0, -3}}, {"normal", {0, 0, 1}}}};
  const auto h = hit_of<T>(objects, Vec3<T>{0, 0, 0}, Vec3<T>{0, 0, -1});
  EXPECT_EQ(h.id, 1) << "the plane (object id 1, after the spheres) at t = 3";
  EXPECT_NEAR(h.t, 3.0, this->tol());
}

// Float against double on every shipped scene: at most 0.1% of pixels off by more than 2/255 once
// clamped (a shadow edge may fall on the other side of a pixel centre), PSNR above 50 dB
// (measured: 59 dB on lorenzi-shadows, the lowest, from a few such edge pixels).
TEST(FloatAgainstDouble, EveryShippedScene) {
  for (const std::string& path : testing::shipped_scenes()) {
    SCOPED_TRACE(path);
    const Scene s = load_scene(path);
    const Image f = testing::render_with(s, 1, Precision::exact, 2);
    const Image d = testing::render_with(s, 1, Precision::dbl, 2);
    const ErrorStats e = error_stats(f, d, 2.0 / 255.0);
    EXPECT_LE(e.off_fraction, 0.001) << "max abs diff " << e.max_abs;
    EXPECT_GE(e.psnr_db, 50.0);
  }
}

TEST(Threads, ImageBitsDoNotDependOnTheThreadCount) {
  const Scene s = load_scene(testing::source_path("scenes/lorenzi-reflections.json"));
  for (int width : {1, 0}) {
    const Image one = testing::render_with(s, width, Precision::exact, 1);
    const Image two = testing::render_with(s, width, Precision::exact, 2);
    const Image five = testing::render_with(s, width, Precision::exact, 5);
    EXPECT_TRUE(bit_diff(one, two).identical());
    EXPECT_TRUE(bit_diff(one, five).identical());
  }
}

}  // namespace
}  // namespace lancer
