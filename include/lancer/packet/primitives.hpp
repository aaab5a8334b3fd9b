// The registration point of the packets' primitive modules (prim/*.hpp). A kind is bounded (in
// the hierarchy, whose leaves hold it) or unbounded (tested in a loop after the hierarchy); the
// object ids follow this order: the bounded kinds' first, then each unbounded kind's in turn.
// Adding a kind: its module, and one line here. Each module gives
//   present(scene)                       whether the scene has any of the kind;
//   surface(scene, hit, best_id, ...)    the geometric normal (and the point, where the kind
//                                        computes it more accurately) at its lanes' hits;
// and an unbounded kind closest(...) and any(...) over all of its objects.
// Hit ids are object ids except on meshes, whose hits carry their triangle (Meshes::object_of
// turns them into object ids before a material is read or an id leaves the kernels).
// Include only from code built for the batch's ISA (packet/kernel.hpp).
#pragma once

#include <type_traits>

#include "lancer/packet/prim/plane.hpp"
#include "lancer/packet/prim/shapes.hpp"
#include "lancer/packet/prim/sphere.hpp"

namespace lancer::packet {

// A list of kinds, visited in order.
template <class... Kinds>
struct KindList {
  // f(kind) for each kind, as a null pointer of its type.
  template <class F>
  [[gnu::always_inline]] static void each(F&& f) noexcept {
    (f(static_cast<const Kinds*>(nullptr)), ...);
  }
};

// Kernels built without the shapes (SpheresAndPlanes<Mode>): no hit carries a primitive number
// and every shading normal is the geometric one, known when the kernel is compiled.
template <class Arch, class Real, class Mode>
struct NoMeshes {
  using L = Lanes<Arch, Real, Mode>;
  static constexpr bool present(const typename L::Prepared&) noexcept { return false; }
  static constexpr bool smooth(const typename L::Prepared&) noexcept { return false; }
  static int first_id(const typename L::Prepared& s) noexcept {
    return s.num_spheres + s.num_planes;
  }
  template <class Id>
  static Id object_of(const typename L::Prepared&, const Id& hit_id) noexcept {
    return hit_id;
  }
  static typename L::V shading_normal(const typename L::Prepared&, const typename L::M&,
                                      const typename L::I&, const typename L::V&,
                                      const typename L::V&, const typename L::V& n) noexcept {
    return n;
  }
};

template <class Arch, class Real, class Mode>
struct Primitives {
  static constexpr bool kShapes = ModeTraits<Mode>::kShapes;
  using Spheres = SpherePackets<Arch, Real, Mode>;
  using Planes = PlanePackets<Arch, Real, Mode>;
  using Shapes = ShapePackets<Arch, Real, Mode>;
  using Bounded = Spheres;  // the hierarchy's leaves
  // Triangles, meshes and cylinders: bounded, in a hierarchy of their own walked after the
  // planes (their ids are higher), so listed with the unbounded kinds. With Accel::one it holds
  // the spheres too, and the spheres' own walk is skipped (Queries::spheres_alone).
  using Unbounded = std::conditional_t<kShapes, KindList<Planes, Shapes>, KindList<Planes>>;
  using All =
      std::conditional_t<kShapes, KindList<Spheres, Planes, Shapes>, KindList<Spheres, Planes>>;
  // The kind whose hits carry primitive numbers in their ids (object_of) and whose shading
  // normal may differ from the geometric one (smooth meshes).
  using Meshes = std::conditional_t<kShapes, Shapes, NoMeshes<Arch, Real, Mode>>;
};

// The kind a KindList::each visit names.
template <class P>
using KindOf = std::remove_const_t<std::remove_pointer_t<P>>;

}  // namespace lancer::packet
