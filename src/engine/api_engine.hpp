// The library API's engines (src/engine/api.cpp): a prepared scene with the kernels that answer
// each query width, one for `lancer render`'s frame and, where the camera looks off the world's
// axes, one for the queries' (FrameKind::query), prepared on the first query.
#pragma once

#include <memory>
#include <mutex>
#include <string>
#include <type_traits>
#include <vector>

#include "lancer/lancer.hpp"
#include "lancer/packet/api.hpp"
#include "lancer/packet/one_ray_api.hpp"
#include "lancer/prepared.hpp"
#include "lancer/shapes.hpp"

namespace lancer::api {

template <class T>
const packet::OneRayTable<T>* one_ray_of() {
  if constexpr (std::is_same_v<T, double>)
    return packet::one_ray_double();
  else
    return packet::one_ray_float();
}

// The kernels of a width built for the prepared scene's kinds.
template <class T>
const packet::KernelTable<T>* kernels_of(const PreparedScene<T>& s, int width, Precision p) {
  if (width == 1) return nullptr;  // the reference
  if constexpr (std::is_same_v<T, double>)
    return packet::double_kernels(width, s.features.shapes);
  else
    return packet::float_kernels(width, p, s.features.shapes);
}

constexpr int kQueryWidths[] = {1, 4, 8, 16};
constexpr int query_slot(int n) { return n == 1 ? 0 : n == 4 ? 1 : n == 8 ? 2 : 3; }

template <class T>
struct Engine {
  PreparedScene<T> scene;
  const packet::KernelTable<T>* render = nullptr;  // null: the reference
  // Per RayPacket<N> (by query_slot): the kernel's lanes and table (null: the reference).
  int query_width[4] = {1, 1, 1, 1};
  const packet::KernelTable<T>* query[4] = {};
  // Per RayPacket<N>: whether a kernel answers it in whole chunks (N a multiple of its width).
  bool whole[4] = {};
  // The lanes answered one ray at a time (Chunk::alone): the one-ray kernels, or null: the
  // reference.
  const packet::OneRayTable<T>* one = nullptr;
  packet::OneRayScene<T> one_scene;          // packet::one_ray_scene(scene.bvh), where `one` is set
  std::vector<std::int32_t> first_triangle;  // first_triangles(*scene.shapes), where it has shapes
};

// The kernels of a prepared scene: its render width, and per query width N the widest kernel
// up to min(N, render width) (the narrowest packet where none is: fast mode has no width 1).
template <class T>
void choose_widths(Engine<T>& e, const Info& info) {
  const std::vector<int> widths = packet::supported_widths(info.precision);
  for (int n : kQueryWidths) {
    int w = widths.back();  // the narrowest (fast mode has no width 1)
    for (int cand : widths)
      if (cand <= n && cand <= info.width) {
        w = cand;
        break;
      }
    e.query_width[query_slot(n)] = w;
    e.query[query_slot(n)] = kernels_of<T>(e.scene, w, info.precision);
  }
  for (int n : kQueryWidths)
    e.whole[query_slot(n)] = e.query[query_slot(n)] && n % e.query_width[query_slot(n)] == 0;
  e.render = kernels_of<T>(e.scene, info.width, info.precision);
  // One ray at a time: the one-ray kernels, unless the scene asked for the reference (width 1).
  // Fast mode has no lone lanes. Where the CPU has no one-ray kernels (SSE4.2 alone), scenes
  // with triangles, meshes or cylinders answer Ray1 on the narrowest packet kernel instead, whose
  // lone lane walks the shapes' hierarchy one ray at a time (packet/prim/shapes_lone.hpp); a
  // ray with its own tnear there stays with the reference.
  if (info.width > 1 && info.precision != Precision::fast) e.one = one_ray_of<T>();
  if (!e.one && info.width > 1 && e.scene.shapes && e.query_width[query_slot(1)] == 1) {
    int w = 1;
    for (int cand : widths)
      if (cand > 1 && cand <= info.width) w = cand;  // widest first: the last is the narrowest
    e.query_width[query_slot(1)] = w;
    e.query[query_slot(1)] = kernels_of<T>(e.scene, w, info.precision);
  }
  if (e.one) e.one_scene = packet::one_ray_scene(e.scene.bvh);
  if (e.scene.shapes) e.first_triangle = first_triangles(*e.scene.shapes);
}

// What answers Ray1 (Info::one_ray): the one-ray kernels' ISA, or, in a scene with shapes, the
// narrowest packet kernel's ("sse4.2 packet"), or the reference ("scalar").
template <class T>
std::string one_ray_name(const Engine<T>& e, Precision p) {
  if (e.one) return e.one->isa;
  const int w = e.query_width[query_slot(1)];
  if (e.scene.shapes && w > 1 && e.query[query_slot(1)])
    return std::string(packet::isa_name(w, p)) + " packet";
  return "scalar";
}

// A precision's engines: the render's, and the queries' (the render's where its frame keeps the
// world's axes). Where it needs its own, the queries' scene is prepared once, on the first query
// (a scene only rendered never pays for it), from any thread.
template <class T>
struct Engines {
  Engine<T> render;

  const Engine<T>& query(const SceneDescription& desc, const Info& info) const {
    if (render.scene.frame.axes) return render;
    std::call_once(once_, [&] {
      auto e = std::make_unique<Engine<T>>();
      e->scene = prepare<T>(desc, Accel::automatic, FrameKind::query);
      choose_widths(*e, info);
      query_ = std::move(e);
    });
    return *query_;
  }

 private:
  mutable std::once_flag once_;
  mutable std::unique_ptr<Engine<T>> query_;
};

}  // namespace lancer::api
