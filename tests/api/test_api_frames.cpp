// The frames the library API traces its queries in (FrameKind::query; lancer/prepared.hpp's
// Frame::axes): which frame a scene gets, the vectorised move of rays into it against
// Frame::point and Frame::direction, bit for bit, and its accuracy against the camera's frame.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include "api/api_util.hpp"
#include "lancer/lancer.hpp"
#include "lancer/packet/api_rays.hpp"
#include "lancer/prepared.hpp"
#include "lancer/reference.hpp"
#include "lancer/scene.hpp"
#include "support/test_util.hpp"

namespace lancer {
namespace {

bool same_bits(float a, float b) { return std::memcmp(&a, &b, sizeof a) == 0; }
bool same_bits(double a, double b) { return std::memcmp(&a, &b, sizeof a) == 0; }

Scene course() { return load_scene(testing::source_path("scenes/lorenzi-reflections.json")); }

// A camera looking along -z keeps the world's axes in both frames (the render's turned, with
// its depth); one looking off them is turned for the render and gets the world's axes at the
// eye for the queries.
TEST(ApiFrames, WhichFrameEachSceneGets) {
  const Scene s = course();
  ASSERT_EQ(s.camera.direction.x, 0);
  ASSERT_EQ(s.camera.direction.y, 0);
  const Frame render = camera_frame<float>(s), query = camera_frame<float>(s, FrameKind::query);
  EXPECT_TRUE(render.turned && render.axes);
  EXPECT_TRUE(query.turned && query.axes);
  Scene pitched = s;
  pitched.camera.direction = {0, -0.12, -1};
  const Frame pr = camera_frame<float>(pitched);
  const Frame pq = camera_frame<float>(pitched, FrameKind::query);
  EXPECT_TRUE(pr.turned && !pr.axes);
  EXPECT_TRUE(!pq.turned && pq.axes);
  EXPECT_EQ(pq.depth, 0);
  EXPECT_EQ(pq.origin.z, pitched.camera.position.z);
  // The axes frame moves a point by a subtraction and leaves a direction as it is.
  const Vec3<double> p{0.25, -3, 7}, d{-0.0, 0.6, -0.8};
  EXPECT_EQ(pq.point(p).x, p.x - pq.origin.x);
  EXPECT_TRUE(same_bits(pq.direction(d).x, -0.0));
  EXPECT_TRUE(same_bits(pq.world_direction(d).x, -0.0));
}

// A float of log-uniform magnitude in [2^lo, 2^hi], either sign; now and then a signed zero, a
// subnormal or the largest float.
float log_uniform_float(std::mt19937_64& rng, int lo, int hi) {
  std::uniform_int_distribution<int> pick(0, 39);
  const int k = pick(rng);
  const float sign = rng() & 1 ? -1.0f : 1.0f;
  if (k == 0) return sign * 0.0f;
  if (k == 1) return sign * 1e-40f;
  if (k == 2) return sign * 3.4e38f;
  std::uniform_real_distribution<double> e(lo, hi);
  return sign * float(std::exp2(e(rng)));
}

// frame_rays and take_rays (the vectorised moves every kernel table instantiates) give, lane by
// lane, the bits of Frame::point and Frame::direction rounded once to T, in the three moves:
// turned, the axes at a float origin (float subtractions), the axes at an origin float cannot
// hold or with a depth (double).
template <class T>
void check_moves(const Frame& f, std::uint64_t seed) {
  constexpr int n = 16;
  std::mt19937_64 rng(seed);
  for (int round = 0; round < 400; ++round) {
    float ox[n], oy[n], oz[n], dx[n], dy[n], dz[n];
    for (int l = 0; l < n; ++l) {
      ox[l] = log_uniform_float(rng, -30, 30), oy[l] = log_uniform_float(rng, -30, 30);
      oz[l] = log_uniform_float(rng, -30, 30);
      // Directions: any floats (the move does not check them).
      dx[l] = log_uniform_float(rng, -20, 0), dy[l] = log_uniform_float(rng, -20, 0);
      dz[l] = log_uniform_float(rng, -20, 0);
    }
    T o[6][n];
    packet::frame_rays<void, T>(f, n, ox, oy, oz, dx, dy, dz, o[0], o[1], o[2], o[3], o[4], o[5]);
    T rays[6 * n];
    const float tnear[n] = {}, tfar[n] = {};
    const unsigned mask[n] = {};
    const int on[n] = {};
    packet::take_rays<n>(f, {ox, oy, oz, dx, dy, dz, tnear, tfar, mask, on, 0u}, T(0), rays);
    for (int l = 0; l < n; ++l) {
      const Vec3<double> p = f.point({ox[l], oy[l], oz[l]});
      const Vec3<double> d = f.direction({dx[l], dy[l], dz[l]});
      const T want[6] = {T(p.x), T(p.y), T(p.z), T(d.x), T(d.y), T(d.z)};
      for (int c = 0; c < 6; ++c) {
        ASSERT_TRUE(same_bits(o[c][l], want[c]))
            << "frame_rays, round " << round << " lane " << l << " coordinate " << c << ": "
            << o[c][l] << " for " << want[c];
        ASSERT_TRUE(same_bits(rays[c * n + l], want[c]))
            << "take_rays, round " << round << " lane " << l << " coordinate " << c;
      }
    }
  }
}

TEST(ApiFrames, VectorisedMovesGiveFramePointAndDirectionsBits) {
  Scene pitched = course();
  pitched.camera.direction = {0.3, -0.2, -1};
  for (const Vec3<double>& eye : {Vec3<double>{0, 2.5, 5}, Vec3<double>{1e5 + 0.3, -7, 0.1},
                                  Vec3<double>{-0.0, 1e-30, -3e7}}) {
    pitched.camera.position = eye;
    SCOPED_TRACE(std::to_string(eye.x) + " " + std::to_string(eye.y) + " " + std::to_string(eye.z));
    const Frame query = camera_frame<float>(pitched, FrameKind::query);
    check_moves<float>(query, 1);
    check_moves<double>(query, 2);
    check_moves<float>(camera_frame<float>(pitched), 3);  // turned
    Frame deep = query;                                   // the axes with a depth: in double
    deep.depth = 1024;
    check_moves<float>(deep, 4);
  }
}

// The queries' frame (FrameKind::query: the world's axes at the eye where the camera looks off
// them) against the render's turned one, on world-space rays of scenes whose cameras look off
// the axes: each frame's float hits against double's, the same rays. The queries' frame must
// lose nothing: as many rays on the double's object, t's error no larger.
TEST(ApiFrames, QueriesFrameIsAsAccurateAsTheCamerasFrame) {
  Scene pitched = load_scene(testing::source_path("scenes/many-spheres.json"));
  pitched.camera.direction = {0.2, -0.3, -1};
  for (const Scene& d : {load_scene(testing::source_path("scenes/glass-tir.json")), pitched}) {
    SCOPED_TRACE(d.name);
    const auto query = prepare<float>(d, Accel::automatic, FrameKind::query);
    const auto render = prepare<float>(d);
    const auto truth = prepare<double>(d);
    ASSERT_FALSE(render.frame.axes);
    ASSERT_TRUE(query.frame.axes);
    std::mt19937 rng(17);
    std::uniform_real_distribution<double> u(-1, 1);
    std::vector<double> err[2];
    std::size_t other[2] = {0, 0}, hits = 0;
    for (int i = 0; i < 20000; ++i) {
      // From around the eye or a sphere's surface, towards a point near another sphere.
      const Sphere& a = d.spheres[std::size_t(i) % d.spheres.size()];
      const Sphere& b = d.spheres[std::size_t(i / 3 + 1) % d.spheres.size()];
      const Vec3<double> from =
          i % 2 ? d.camera.position + Vec3<double>{u(rng), u(rng), u(rng)} * 0.1
                : a.center + normalize(Vec3<double>{u(rng), u(rng), u(rng)}) * (a.radius * 1.01);
      const Vec3<double> to = b.center + Vec3<double>{u(rng), u(rng), u(rng)} * b.radius;
      const Vec3<float> of = Vec3<float>::from(from);
      const Vec3<float> df = Vec3<float>::from(normalize(to - from));
      const Vec3<double> ow = Vec3<double>::from(of), dw = Vec3<double>::from(df);
      const auto exact =
          reference::closest_hit(truth, truth.frame.point(ow), truth.frame.direction(dw));
      if (exact.id < 0) continue;
      ++hits;
      const PreparedScene<float>* frames[2] = {&render, &query};
      for (int k = 0; k < 2; ++k) {
        const Frame& f = frames[k]->frame;
        const auto got = reference::closest_hit(*frames[k], Vec3<float>::from(f.point(ow)),
                                                Vec3<float>::from(f.direction(dw)));
        if (got.id != exact.id)
          ++other[k];
        else
          err[k].push_back(std::fabs(double(got.t) - exact.t) / exact.t);
      }
    }
    ASSERT_GT(hits, 5000u);
    double p99[2], worst[2];
    for (int k = 0; k < 2; ++k) {
      std::sort(err[k].begin(), err[k].end());
      p99[k] = err[k][err[k].size() * 99 / 100], worst[k] = err[k].back();
    }
    std::printf(
        "%s: %zu hits; camera's frame %zu other objects, t error p99 %.3g max %.3g; "
        "queries' frame %zu, p99 %.3g max %.3g\n",
        d.name.c_str(), hits, other[0], p99[0], worst[0], other[1], p99[1], worst[1]);
    EXPECT_LE(other[1], other[0] + 2);
    EXPECT_LE(p99[1], 1.5 * p99[0] + 1e-7);
  }
}

// The queries' scene of a camera off the axes is prepared by the first query: threads that all
// make their first query at once get one scene and the answers a lone thread gets.
TEST(ApiFrames, FirstQueriesFromManyThreadsShareOneQueriesScene) {
  Scene d = load_scene(testing::source_path("scenes/many-spheres.json"));
  d.camera.direction = {0.2, -0.3, -1};
  constexpr int kThreads = 4, kPackets = 64;
  std::vector<api::RayPacket<8>> rays(kPackets);
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> u(-1, 1);
  for (auto& r : rays)
    for (int k = 0; k < 8; ++k) {
      // Towards a sphere, near its centre: most rays hit.
      const Sphere& target = d.spheres[std::size_t(rng() % d.spheres.size())];
      const Vec3<double> dir =
          normalize(target.center + Vec3<double>{u(rng), u(rng), u(rng)} * (0.5 * target.radius) -
                    d.camera.position);
      r.org_x[k] = float(d.camera.position.x), r.org_y[k] = float(d.camera.position.y);
      r.org_z[k] = float(d.camera.position.z);
      r.dir_x[k] = float(dir.x), r.dir_y[k] = float(dir.y), r.dir_z[k] = float(dir.z);
      r.tnear[k] = 0, r.tfar[k] = 1e30f, r.mask[k] = api::kAllObjects;
    }
  const auto answer = [&](const api::Scene& scene, std::vector<float>& t, std::vector<int>& id) {
    t.resize(8 * kPackets), id.resize(8 * kPackets);
    for (int p = 0; p < kPackets; ++p) {
      api::HitPacket<8> h;
      scene.intersect(nullptr, rays[std::size_t(p)], h);
      for (int k = 0; k < 8; ++k)
        t[std::size_t(8 * p + k)] = h.t[k], id[std::size_t(8 * p + k)] = h.id[k];
    }
  };
  std::vector<float> want_t;
  std::vector<int> want_id;
  answer(api::Scene::from_description(d, testing::with(Precision::exact)), want_t, want_id);
  const api::Scene shared = api::Scene::from_description(d, testing::with(Precision::exact));
  std::vector<float> t[kThreads];
  std::vector<int> id[kThreads];
  std::vector<std::thread> threads;
  for (int k = 0; k < kThreads; ++k) threads.emplace_back([&, k] { answer(shared, t[k], id[k]); });
  for (std::thread& th : threads) th.join();
  std::size_t hits = 0;
  for (int k = 0; k < kThreads; ++k)
    for (std::size_t i = 0; i < want_t.size(); ++i) {
      ASSERT_EQ(id[k][i], want_id[i]) << "thread " << k << " ray " << i;
      ASSERT_TRUE(same_bits(t[k][i], want_t[i])) << "thread " << k << " ray " << i;
      hits += want_id[i] >= 0;
    }
  EXPECT_GT(hits, want_t.size() * kThreads / 2);  // most rays hit something
}

}  // namespace
}  // namespace lancer
