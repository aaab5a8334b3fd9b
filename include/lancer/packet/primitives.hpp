// The registration point of the packets' primitive modules (prim/*.hpp). A kind is bounded (in
// the hierarchy, whose leaves hold it) or unbounded (tested in a loop after the hierarchy); the
// object ids follow this order: the bounded kinds' first, then each unbounded kind's in turn.
// Adding a kind: its module, and one line here. Each module gives
//   present(scene)                       whether the scene has any of the kind;
//   surface(scene, hit, best_id, ...)    the geometric normal (and the point, where the kind
//                                        computes it more accurately) at its lanes' hits;
// and an unbounded kind closest(...) and any(...) over all of its objects.
// Include only from code built for the batch's ISA (packet/kernel.hpp).
#pragma once

#include "lancer/packet/prim/plane.hpp"
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
  using Unbounded = KindList<PlanePackets<Arch, Real, Mode>>;
  using All = KindList<SpherePackets<Arch, Real, Mode>, PlanePackets<Arch, Real, Mode>>;
};

// The kind a KindList::each visit names.
template <class P>
using KindOf = std::remove_const_t<std::remove_pointer_t<P>>;

}  // namespace lancer::packet
