// One ray's hierarchy over the shapes (PreparedShapes::lone): the binary tree collapsed into
// nodes of kLone children from the root, and where each wide node's subtree starts in it
// (PreparedShapes::lone_entry), so that a packet's lanes go on alone from any wide node.
#include <cstddef>
#include <cstdint>
#include <limits>
#include <vector>

#include "lancer/shapes.hpp"

namespace lancer {

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
    // The slots (binary nodes); bit q of under[k] set: slot k lies below the node opened q-th.
    std::uint32_t slots[kL], opened[kL];
    unsigned under[kL] = {};
    int q = 0;
    const int n = collapse<T>(s.nodes, job.binary, slots, kL, [&](int k, int count) {
      opened[q] = slots[k];
      const unsigned u = under[k] | 1u << q++;
      for (int j = count; j > k + 1; --j) under[j] = under[j - 1];
      under[k] = under[k + 1] = u;
    });
    entry_of[job.binary] = {job.lone, (1u << n) - 1u};
    for (int p = 0; p < q; ++p) {
      unsigned bits = 0;
      for (int k = 0; k < n; ++k) bits |= (under[k] >> p & 1u) << k;
      entry_of[opened[p]] = {job.lone, bits};
    }
    typename Shapes::LoneNode node{};
    node.arity = n;
    const T inf = std::numeric_limits<T>::infinity();
    for (int k = 0; k < kL; ++k) {
      T lo[3] = {inf, inf, inf}, hi[3] = {-inf, -inf, -inf};
      node.child[k] = -1;
      if (k < n) {
        const auto& b = s.nodes[slots[k]];
        padded_box<T>(b, lo, hi);
        if (b.count > 0) {
          node.child[k] = std::int32_t(leaf_of[slots[k]]);
          node.count[k] = std::uint8_t(b.count);
        } else {
          node.child[k] = std::int32_t(lone.size());
          jobs.push_back({slots[k], std::int32_t(lone.size())});
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
