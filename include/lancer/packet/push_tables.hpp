// The shuffle controls that push a 4-wide node's met children as one vector, in the order a walk
// visits them (the one-ray walks and the camera blocks' walk). Include only from code built for
// the batch's ISA.
#pragma once

#include <cstdint>

namespace lancer::packet {

// pshufb controls for pushing a 4-wide node's met children as one vector (closest_tiles).
struct PushTables {
  alignas(16) std::uint8_t reverse[256][16];  // per order byte: lane i = slot visited (3-i)th
  alignas(16) std::uint8_t compress[16][16];  // per 4-bit mask: its set lanes first, in order
  alignas(16) std::int32_t arity[5][4];       // lanes < arity set
  std::uint8_t reorder[256][16];  // per order byte and 4-bit mask by slot: that mask by lane
  std::int8_t count[16];          // set bits of a 4-bit mask
};
constexpr PushTables push_tables() {
  PushTables t{};
  for (int o = 0; o < 256; ++o)
    for (int i = 0; i < 4; ++i)
      for (int b = 0; b < 4; ++b)
        t.reverse[o][4 * i + b] = std::uint8_t(4 * ((o >> (2 * (3 - i))) & 3) + b);
  for (int m = 0; m < 16; ++m) {
    int n = 0;
    for (int i = 0; i < 4; ++i)
      if (m >> i & 1) {
        for (int b = 0; b < 4; ++b) t.compress[m][4 * n + b] = std::uint8_t(4 * i + b);
        ++n;
      }
    for (int i = n; i < 4; ++i)
      for (int b = 0; b < 4; ++b) t.compress[m][4 * i + b] = 0x80;  // zero
    t.count[m] = std::int8_t(n);
  }
  for (int a = 0; a <= 4; ++a)
    for (int i = 0; i < 4; ++i) t.arity[a][i] = i < a ? -1 : 0;
  for (int o = 0; o < 256; ++o)
    for (int m = 0; m < 16; ++m)
      for (int i = 0; i < 4; ++i)
        t.reorder[o][m] |= std::uint8_t((m >> ((o >> (2 * (3 - i))) & 3) & 1) << i);
  return t;
}
inline constexpr PushTables kPush = push_tables();

}  // namespace lancer::packet
