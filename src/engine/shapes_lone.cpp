// One ray's hierarchy over the shapes (PreparedShapes::lone): each wide node's subtree as a
// node of kLone children, built from the wide nodes alone (the same leaves, by index).
#include <algorithm>
#include <cstddef>
#include <limits>
#include <vector>

#include "lancer/shapes.hpp"

namespace lancer {

namespace {

template <class T>
struct Slot {
  T lo[3], hi[3];
  std::int32_t child;
  std::uint8_t count;
  double area() const {
    const double x = double(hi[0]) - lo[0], y = double(hi[1]) - lo[1], z = double(hi[2]) - lo[2];
    return x * y + y * z + z * x;
  }
};

// The children of wide node i as slots, their boxes as stored (padded).
template <class T>
void children(const PreparedShapes<T>& s, std::int32_t i, std::vector<Slot<T>>& out) {
  const auto& n = s.wide[std::size_t(i)];
  for (int k = 0; k < n.arity; ++k)
    out.push_back({{n.lo_x[k], n.lo_y[k], n.lo_z[k]},
                   {n.hi_x[k], n.hi_y[k], n.hi_z[k]},
                   n.child[k],
                   n.count[k]});
}

}  // namespace

template <class T>
void build_lone(PreparedShapes<T>& s) {
  using Shapes = PreparedShapes<T>;
  constexpr int kL = Shapes::kLone;
  s.lone.assign(s.wide.size(), typename Shapes::LoneNode{});
  std::vector<Slot<T>> slots;
  for (std::size_t i = 0; i < s.wide.size(); ++i) {
    slots.clear();
    children(s, std::int32_t(i), slots);
    // The inner slot of largest area opened into its children while they fit (the usual
    // collapse into wider nodes; one_ray_scene.cpp does the same for the spheres).
    for (;;) {
      int best = -1;
      for (int k = 0; k < int(slots.size()); ++k) {
        const Slot<T>& c = slots[std::size_t(k)];
        if (c.count != 0) continue;
        if (int(slots.size()) - 1 + s.wide[std::size_t(c.child)].arity > kL) continue;
        if (best < 0 || c.area() > slots[std::size_t(best)].area()) best = k;
      }
      if (best < 0) break;
      const std::int32_t opened = slots[std::size_t(best)].child;
      slots.erase(slots.begin() + best);
      children(s, opened, slots);
    }
    typename Shapes::LoneNode& n = s.lone[i];
    n.arity = int(slots.size());
    const T inf = std::numeric_limits<T>::infinity();
    for (int k = 0; k < kL; ++k) {
      const bool used = k < n.arity;
      const Slot<T> c =
          used ? slots[std::size_t(k)] : Slot<T>{{inf, inf, inf}, {-inf, -inf, -inf}, 0, 0};
      n.lo_x[k] = c.lo[0], n.lo_y[k] = c.lo[1], n.lo_z[k] = c.lo[2];
      n.hi_x[k] = c.hi[0], n.hi_y[k] = c.hi[1], n.hi_z[k] = c.hi[2];
      n.child[k] = used ? c.child : -1, n.count[k] = c.count;
    }
  }
}

template void build_lone<float>(PreparedShapes<float>&);
template void build_lone<double>(PreparedShapes<double>&);

}  // namespace lancer
