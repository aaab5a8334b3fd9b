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

template <class Arch, class Real, class Mode>
struct Primitives {
  using Bounded = SpherePackets<Arch, Real, Mode>;  // the hierarchy's leaves
  // Triangles, meshes and cylinders: bounded, in a hierarchy of their own walked after the
  // planes (their ids are higher), so listed with the unbounded kinds.
  using Unbounded = KindList<PlanePackets<Arch, Real, Mode>, ShapePackets<Arch, Real, Mode>>;
  using All = KindList<SpherePackets<Arch, Real, Mode>, PlanePackets<Arch, Real, Mode>,
                       ShapePackets<Arch, Real, Mode>>;
  // The kind whose hits carry primitive numbers in their ids (object_of) and whose shading
  // normal may differ from the geometric one (smooth meshes).
  using Meshes = ShapePackets<Arch, Real, Mode>;
};

// The kind a KindList::each visit names.
template <class P>
using KindOf = std::remove_const_t<std::remove_pointer_t<P>>;

}  // namespace lancer::packet
