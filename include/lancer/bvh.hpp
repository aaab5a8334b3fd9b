// A bounding volume hierarchy over a scene's spheres (planes are unbounded and stay outside it),
// built once per scene by prepare(). Binary, binned SAH (as madmann91/bvh v2), each node holding
// its two children's boxes structure-of-arrays, so a packet tests both children from one node.
// The spheres are copied in leaf order with their ORIGINAL object ids: materials and the tie
// rule (equal t goes to the lower id) stay those of the file. docs/accel.md.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace lancer {

// Which structure a scene gets: automatic picks the plain loop below kBvhMinSpheres spheres.
enum class Accel { automatic, none, bvh };
Accel parse_accel(const std::string& text, const std::string& option);
const char* to_string(Accel a);

// Spheres from which the hierarchy beats the plain loop (measured, docs/accel.md).
inline constexpr int kBvhMinSpheres = 16;

template <class T>
struct Bvh {
  // Child slot k of an inner node: count[k] < 0: child[k] is an inner node; else a leaf of
  // count[k] spheres from leaf-order index child[k] (count 0: the empty slot of a 1-sphere tree).
  // Child 0 lies on the lower side of `axis` (traversal visits it first for rays going up).
  // One 64-byte cache line for float (count in 16 bits: at most 8 spheres per leaf), aligned
  // so that a node never straddles two lines.
  struct alignas(64) Node {
    T lo_x[2], hi_x[2], lo_y[2], hi_y[2], lo_z[2], hi_z[2];
    std::int32_t child[2];
    std::int16_t count[2];
    std::int32_t axis;
  };
  std::vector<Node> nodes;  // nodes[0] is the root; empty: no hierarchy (plain loop)
  // The spheres in leaf order: centre, r^2, the eye's table (pinhole cameras) and object id.
  std::vector<T> cx, cy, cz, r2, eye_fx, eye_fy, eye_fz, eye_c;
  std::vector<std::int32_t> id;
  // Boxes are padded for the rounding of the sphere test of rays whose origin lies within this
  // max-norm of the camera: a packet with a lane beyond it uses the plain loop (exact either way).
  T origin_limit = T(0);
  int depth = 0;  // deepest inner node (the traversal stacks hold kMaxDepth entries)
  double build_seconds = 0;

  static constexpr int kMaxDepth = 96;
  // Rays from beyond origin_limit traverse boxes grown by kOriginPad |origin| (max-norm), up to
  // kFarLimit; beyond that they loop over all spheres. The slab products stay finite below it.
  static constexpr double kOriginPad = 1024.0 * (sizeof(T) == 4 ? 0x1p-24 : 0x1p-53);
  static constexpr double kFarLimit = 1e18;
  bool active() const { return !nodes.empty(); }
  std::size_t bytes() const;
};

// The hierarchy of spheres (centre, radius) in the camera's frame: nodes, origin_limit and
// `order` (leaf-order position -> sphere index). eye_reach: the camera's max-norm distance from
// the frame's origin (Frame::depth). Deterministic: a function of the input only.
template <class T>
Bvh<T> build_bvh(const std::vector<T>& cx, const std::vector<T>& cy, const std::vector<T>& cz,
                 const std::vector<T>& r, int n, std::vector<std::int32_t>& order,
                 double eye_reach = 0);

extern template Bvh<float> build_bvh<float>(const std::vector<float>&, const std::vector<float>&,
                                            const std::vector<float>&, const std::vector<float>&,
                                            int, std::vector<std::int32_t>&, double);
extern template Bvh<double> build_bvh<double>(const std::vector<double>&,
                                              const std::vector<double>&,
                                              const std::vector<double>&,
                                              const std::vector<double>&, int,
                                              std::vector<std::int32_t>&, double);

}  // namespace lancer
