// One ray's hierarchy over the shapes (PreparedShapes::lone): the binary tree collapsed into
// nodes of kLone children from the root, and where each wide node's subtree starts in it
// (PreparedShapes::lone_entry), so that a packet's lanes go on alone from any wide node.
#include <cstddef>
#include <cstdint>
#include <limits>
#include <vector>

#include "lancer/shapes.hpp"

namespace lancer {

namespace {

template <class T>
double area(const typename PreparedShapes<T>::Node& n) {
  const double x = double(n.hi[0]) - n.lo[0], y = double(n.hi[1]) - n.lo[1],
               z = double(n.hi[2]) - n.lo[2];
  return x * y + y * z + z * x;
}

}  // namespace

template <class T>
void build_lone(PreparedShapes<T>& s, const std::vector<std::uint32_t>& leaf_of,
                const std::vector<std::uint32_t>& wide_binary) {
  using Shapes = PreparedShapes<T>;
  using LoneEntry = typename Shapes::LoneEntry;
  constexpr int kL = Shapes::kLone;
  std::vector<typename Shapes::LoneNode> lone;
  s.lone.clear();
  s.lone_entry.clear();
  if (s.wide.empty()) return;
  // Each binary inner node either starts a lone node or is opened inside one: its entry.
  std::vector<LoneEntry> entry_of(s.nodes.size());
  struct Job {
    std::uint32_t binary;
    std::int32_t lone;
  };
  std::vector<Job> jobs{{0, 0}};
  lone.emplace_back();
  while (!jobs.empty()) {
    const Job job = jobs.back();
    jobs.pop_back();
    // The slots, in the binary tree's depth-first order; bit q of `under` set: the slot lies
    // below the node opened q-th.
    struct Slot {
      std::uint32_t binary;
      unsigned under;
    };
    Slot slots[kL];
    std::uint32_t opened[kL];
    int n = 0, q = 0;
    const auto& root = s.nodes[job.binary];
    if (root.count > 0) {
      slots[n++] = {job.binary, 0};  // a leaf root: itself, alone
    } else {
      slots[n++] = {root.first, 0}, slots[n++] = {root.first + 1, 0};
    }
    while (n < kL) {
      int open = -1;
      double best = -1;
      for (int k = 0; k < n; ++k) {
        const auto& b = s.nodes[slots[k].binary];
        if (b.count == 0 && area<T>(b) > best) best = area<T>(b), open = k;
      }
      if (open < 0) break;
      const Slot was = slots[open];
      opened[q] = was.binary;
      const unsigned under = was.under | 1u << q;
      ++q;
      for (int k = n; k > open + 1; --k) slots[k] = slots[k - 1];
      const std::uint32_t first = s.nodes[was.binary].first;
      slots[open] = {first, under}, slots[open + 1] = {first + 1, under};
      ++n;
    }
    entry_of[job.binary] = {job.lone, (1u << n) - 1u};
    for (int p = 0; p < q; ++p) {
      unsigned bits = 0;
      for (int k = 0; k < n; ++k) bits |= (slots[k].under >> p & 1u) << k;
      entry_of[opened[p]] = {job.lone, bits};
    }
    typename Shapes::LoneNode node{};
    node.arity = n;
    const T inf = std::numeric_limits<T>::infinity();
    for (int k = 0; k < kL; ++k) {
      T lo[3] = {inf, inf, inf}, hi[3] = {-inf, -inf, -inf};
      node.child[k] = -1;
      if (k < n) {
        const auto& b = s.nodes[slots[k].binary];
        padded_box<T>(b, lo, hi);
        if (b.count > 0) {
          node.child[k] = std::int32_t(leaf_of[slots[k].binary]);
          node.count[k] = std::uint8_t(b.count);
        } else {
          node.child[k] = std::int32_t(lone.size());
          jobs.push_back({slots[k].binary, std::int32_t(lone.size())});
          lone.emplace_back();
        }
      }
      node.lo_x[k] = lo[0], node.lo_y[k] = lo[1], node.lo_z[k] = lo[2];
      node.hi_x[k] = hi[0], node.hi_y[k] = hi[1], node.hi_z[k] = hi[2];
    }
    lone[std::size_t(job.lone)] = node;
  }
  s.lone.assign(lone.begin(), lone.end());
  s.lone_entry.resize(wide_binary.size());
  for (std::size_t j = 0; j < wide_binary.size(); ++j) s.lone_entry[j] = entry_of[wide_binary[j]];
}

template void build_lone<float>(PreparedShapes<float>&, const std::vector<std::uint32_t>&,
                                const std::vector<std::uint32_t>&);
template void build_lone<double>(PreparedShapes<double>&, const std::vector<std::uint32_t>&,
                                 const std::vector<std::uint32_t>&);

}  // namespace lancer
