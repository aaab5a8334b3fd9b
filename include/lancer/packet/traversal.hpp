// The packet traversals of the bounded primitives' hierarchy, one layer a file, each built on
// the one before:
//   walk_packet.hpp     one packet: slab tests, the closest-hit and any-hit walks;
//   walk_one_ray.hpp    lanes that go on alone, one ray at a time (the hybrid's step);
//   tile_intervals.hpp  the interval tests of camera blocks (per block, or per tile);
//   walk_camera.hpp     camera blocks: several tiles' packets walk the inner nodes together.
// The walks know no primitive: a leaf functor tests a leaf's primitives (queries.hpp).
// Include only from code built for the batch's ISA.
#pragma once

#include "lancer/packet/walk_camera.hpp"

namespace lancer::packet {

template <class Arch, class T>
using Traversal = CameraWalk<Arch, T>;

}  // namespace lancer::packet
