// Meshes, scenes and packet helpers shared by the primitives' tests (tests/test_prims_*.cpp):
// an empty scene, tessellated spheres and boxes, log-uniform draws, and rays through one packet
// kernel (closest hits, blocked segments).
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <random>
#include <utility>
#include <vector>

#include "lancer/packet/api.hpp"
#include "lancer/prepared.hpp"
#include "lancer/reference.hpp"
#include "lancer/scene.hpp"

namespace lancer::prims_test {

// A scene with the camera at the origin looking down -z (its frame is the world's) and one
// default material; shapes are added by the tests.
inline Scene empty_scene() {
  Scene s;
  s.name = "t.json";
  s.camera.position = {0, 0, 0};
  s.camera.direction = {0, 0, -1};
  s.camera.nx = s.camera.ny = 1;
  s.materials.push_back(Material{});
  return s;
}

inline Shape mesh_shape(std::vector<Vec3<double>> v, std::vector<std::uint32_t> idx,
                        int material = 0) {
  Shape sh;
  sh.mesh.vertices = std::move(v);
  sh.mesh.indices = std::move(idx);
  sh.mesh.material = material;
  return sh;
}

// A UV sphere of `stacks` x `slices`, poles single vertices: closed and indexed.
inline Shape uv_sphere(Vec3<double> c, double r, int stacks, int slices) {
  std::vector<Vec3<double>> v{{c.x, c.y + r, c.z}};
  for (int i = 1; i < stacks; ++i)
    for (int j = 0; j < slices; ++j) {
      const double th = M_PI * i / stacks, ph = 2 * M_PI * j / slices;
      v.push_back({c.x + r * std::sin(th) * std::cos(ph), c.y + r * std::cos(th),
                   c.z + r * std::sin(th) * std::sin(ph)});
    }
  v.push_back({c.x, c.y - r, c.z});
  const std::uint32_t south = std::uint32_t(v.size() - 1);
  auto at = [&](int i, int j) { return std::uint32_t(1 + (i - 1) * slices + (j % slices)); };
  std::vector<std::uint32_t> idx;
  for (int j = 0; j < slices; ++j) {
    idx.insert(idx.end(), {0, at(1, j + 1), at(1, j)});
    for (int i = 1; i + 1 < stacks; ++i)
      idx.insert(idx.end(), {at(i, j), at(i, j + 1), at(i + 1, j + 1), at(i, j), at(i + 1, j + 1),
                             at(i + 1, j)});
    idx.insert(idx.end(), {at(stacks - 1, j), at(stacks - 1, j + 1), south});
  }
  return mesh_shape(v, idx);
}

// A box of n x n quads per face, vertices shared (deduplicated on the integer grid).
inline Shape grid_box(Vec3<double> lo, Vec3<double> hi, int n) {
  std::map<std::tuple<int, int, int>, std::uint32_t> ids;
  std::vector<Vec3<double>> v;
  auto vertex = [&](int a, int b, int c) {
    auto [it, added] = ids.emplace(std::make_tuple(a, b, c), std::uint32_t(v.size()));
    if (added)
      v.push_back({lo.x + (hi.x - lo.x) * a / n, lo.y + (hi.y - lo.y) * b / n,
                   lo.z + (hi.z - lo.z) * c / n});
    return it->second;
  };
  std::vector<std::uint32_t> idx;
  for (int axis = 0; axis < 3; ++axis)
    for (int side = 0; side < 2; ++side)
      for (int i = 0; i < n; ++i)
        for (int j = 0; j < n; ++j) {
          auto corner = [&](int di, int dj) {
            int p[3];
            p[axis] = side * n, p[(axis + 1) % 3] = i + di, p[(axis + 2) % 3] = j + dj;
            return vertex(p[0], p[1], p[2]);
          };
          const std::uint32_t q[4] = {corner(0, 0), corner(1, 0), corner(1, 1), corner(0, 1)};
          if (side == 1)
            idx.insert(idx.end(), {q[0], q[1], q[2], q[0], q[2], q[3]});
          else
            idx.insert(idx.end(), {q[0], q[2], q[1], q[0], q[3], q[2]});
        }
  return mesh_shape(v, idx);
}

inline Vec3<double> random_unit(std::mt19937_64& rng) {
  std::normal_distribution<double> g;
  return normalize(Vec3<double>{g(rng), g(rng), g(rng)});
}

inline double log_uniform(std::mt19937_64& rng, double lo, double hi) {
  std::uniform_real_distribution<double> u(std::log(lo), std::log(hi));
  return std::exp(u(rng));
}

// Lanes first .. first + w of `rays` (origin, direction pairs) as a packet kernel reads them:
// soa (6 rows of w), valid (the spare lanes past the end repeat the last ray, invalid).
template <class T>
void pack_lanes(const std::vector<std::pair<Vec3<T>, Vec3<T>>>& rays, std::size_t first, int w,
                T* soa, bool* valid) {
  for (int l = 0; l < w; ++l) {
    const std::size_t r = std::min(first + std::size_t(l), rays.size() - 1);
    valid[l] = first + std::size_t(l) < rays.size();
    const Vec3<T>& o = rays[r].first;
    const Vec3<T>& d = rays[r].second;
    const T v[6] = {o.x, o.y, o.z, d.x, d.y, d.z};
    for (int c = 0; c < 6; ++c) soa[c * w + l] = v[c];
  }
}

// The closest hits of `rays` through one packet kernel, width lanes at a time.
template <class T>
std::vector<reference::Hit<T>> packet_hits(const PreparedScene<T>& p,
                                           const packet::KernelTable<T>& k,
                                           const std::vector<std::pair<Vec3<T>, Vec3<T>>>& rays) {
  const int w = k.width;
  std::vector<reference::Hit<T>> out(rays.size());
  const std::size_t n = static_cast<std::size_t>(w);
  std::vector<T> soa(6 * n), t(n, std::numeric_limits<T>::infinity());
  std::vector<std::int32_t> id(n, -1);
  bool valid[16], hit[16];
  for (std::size_t first = 0; first < rays.size(); first += n) {
    pack_lanes(rays, first, w, soa.data(), valid);
    std::fill(t.begin(), t.end(), std::numeric_limits<T>::infinity());
    std::fill(id.begin(), id.end(), -1);
    k.closest_hit_packet(p, valid, soa.data(), t.data(), id.data(), hit, nullptr);
    for (int l = 0; l < w && first + std::size_t(l) < rays.size(); ++l)
      out[first + std::size_t(l)] = {id[std::size_t(l)], t[std::size_t(l)]};
  }
  return out;
}

// Whether each segment of `rays` up to tfar(ray index) is blocked, through one packet kernel's
// any-hit entry, width lanes at a time.
template <class T, class Tfar>
std::vector<char> packet_blocked(const PreparedScene<T>& p, const packet::KernelTable<T>& k,
                                 const std::vector<std::pair<Vec3<T>, Vec3<T>>>& rays,
                                 Tfar&& tfar) {
  const int w = k.width;
  std::vector<char> out(rays.size());
  const std::size_t n = static_cast<std::size_t>(w);
  std::vector<T> soa(6 * n), far(n);
  bool valid[16], blocked[16];
  for (std::size_t first = 0; first < rays.size(); first += n) {
    pack_lanes(rays, first, w, soa.data(), valid);
    for (int l = 0; l < w; ++l)
      far[std::size_t(l)] = tfar(std::min(first + std::size_t(l), rays.size() - 1));
    k.occluded_packet(p, valid, soa.data(), far.data(), blocked);
    for (int l = 0; l < w && first + std::size_t(l) < rays.size(); ++l)
      out[first + std::size_t(l)] = blocked[l];
  }
  return out;
}

template <class T>
const packet::KernelTable<T>* kernels_of(int width) {
  if constexpr (std::is_same_v<T, float>)
    return packet::float_kernels(width, Precision::exact);
  else
    return packet::double_kernels(width);
}

}  // namespace lancer::prims_test
