// The one-ray kernels' entry points (packet/one_ray.hpp), declared without any SIMD type so that
// code built for the baseline ISA (the library API) can call them. Instantiated only in
// src/isa/one_ray_<isa>.cpp, which alone are built with that ISA's flags; dispatch.cpp hands
// them out after the CPU check.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "lancer/prepared.hpp"

namespace lancer::packet {

// An 8-wide node, the 4-wide hierarchy's nodes collapsed (one_ray_scene), for float and double
// rays: its children's boxes structure-of-arrays, eight in one ymm per plane (float's those of
// the 4-wide nodes, padded alike; double's rounded outward to float and padded for the float
// slab test). Slot k: count[k] < 0, child[k] is a node; else a leaf of count[k] spheres
// (OneRayScene::leaves from block child[k]). Unused slots have empty boxes (lo +inf, hi -inf):
// never met.
struct alignas(64) OneRayNode8 {
  float lo_x[8], hi_x[8], lo_y[8], hi_y[8], lo_z[8], hi_z[8];
  std::int32_t child[8], count[8];
};

// A leaf's spheres (up to kLanes; a larger leaf takes consecutive blocks), structure of arrays,
// one vector a field (float: eight in a ymm; double: four): one test for the leaf's spheres, no
// transposes. Unused lanes have NaN centres (never met). Their object ids:
// OneRayScene::ids[kLanes * block + lane].
template <class Real>
struct alignas(64) OneRayLeaf {
  static constexpr int kLanes = sizeof(Real) == 4 ? 8 : 4;
  Real cx[kLanes], cy[kLanes], cz[kLanes], r2[kLanes];
};

// What the one-ray kernels read beside the prepared scene: the 8-wide nodes (nodes8[0] the root;
// empty without a hierarchy) and the leaves as blocks (leaves, ids), in the order the collapse
// meets them.
template <class Real>
struct OneRayScene {
  std::vector<OneRayNode8> nodes8;
  std::vector<OneRayLeaf<Real>> leaves;
  std::vector<std::int32_t> ids;
};
OneRayScene<float> one_ray_scene(const Bvh<float>& h);
OneRayScene<double> one_ray_scene(const Bvh<double>& h);

// One ray in the prepared frame (origin o, unit direction d), its hits counted at
// tmin < t < tfar (tmin at least the scene's epsilon). Every kind: the triangles, meshes and
// cylinders by the walk a packet's lone lanes take (packet/prim/shapes_lone.hpp).
template <class Real>
struct OneRayTable {
  const char* isa;  // "avx2", "avx512f"
  // The reference's closest hit (reference::closest_hit from tmin), bit for bit, where it lies
  // before tfar: returns true and sets t and id (the object id, ties to the lower id), and
  // where prim is non-null, *prim to the primitive number of a triangle, mesh or cylinder hit
  // (PreparedShapes::prim's index), -1 for a sphere or plane; else leaves them.
  // `one`: one_ray_scene(scene.bvh).
  bool (*closest)(const PreparedScene<Real>&, const OneRayScene<Real>& one, const Real* o,
                  const Real* d, Real tmin, Real tfar, Real& t, std::int32_t& id,
                  std::int32_t* prim);
  // Whether some object lies at tmin < t < tfar: exactly where closest would return true.
  // Stops at the first such object.
  bool (*occluded)(const PreparedScene<Real>&, const OneRayScene<Real>& one, const Real* o,
                   const Real* d, Real tmin, Real tfar);
};

// Defined in packet/one_ray.hpp; instantiated per ISA in src/isa/one_ray_*.cpp. Call only after
// the CPU check (dispatch.cpp): it runs that ISA's instructions.
template <class Arch, class Real>
const OneRayTable<Real>* one_ray_table();

// The one-ray kernels on the widest ISA this CPU and OS run (within LANCER_MAX_WIDTH), or
// nullptr where there is none (SSE4.2 only, a cap of 1 or 4, aarch64): the reference then.
const OneRayTable<float>* one_ray_float();
const OneRayTable<double>* one_ray_double();

}  // namespace lancer::packet
