// The packet path's entry points, declared without any SIMD type so that code built for the
// baseline ISA can call them. Each is defined in packet/kernel.hpp and instantiated only in
// src/isa/<isa>.cpp, which alone is built with that ISA's flags.
#pragma once

#include <string>
#include <vector>

#include "lancer/image.hpp"
#include "lancer/prepared.hpp"
#include "lancer/stats.hpp"

namespace lancer::packet {

// Whole render of rows [row_begin, row_end), bit-identical to reference::render_rows in float.
template <class Arch>
void render_rows(Arch, const PreparedScene<float>& scene, Image& image, int row_begin,
                 int row_end, RayCounts& counts);

// Camera rays and closest hit only; output as reference::primary_rows.
template <class Arch>
void primary_rows(Arch, const PreparedScene<float>& scene, float* t_out, int row_begin,
                  int row_end, RayCounts& counts);

// One packet through the closest-hit kernel, for tests: rays in SoA arrays of `width` lanes
// (origin xyz then direction xyz, each `width` floats), lanes with valid[k] false must come back
// untouched in t and id. Returns the lanes hit, as bools in hit_out.
template <class Arch>
void closest_hit_packet(Arch, const PreparedScene<float>& scene, const bool* valid,
                        const float* rays, float* t, float* id, bool* hit_out);

// One width's kernels: a row of function pointers filled by the dispatcher.
struct Kernels {
  int width;        // float lanes
  const char* isa;  // "sse4.2", "avx2", "avx512f"
  void (*render_rows)(const PreparedScene<float>&, Image&, int, int, RayCounts&);
  void (*primary_rows)(const PreparedScene<float>&, float*, int, int, RayCounts&);
  void (*closest_hit_packet)(const PreparedScene<float>&, const bool*, const float*, float*,
                             float*, bool*);
};

// The kernels of a packet width (4, 8 or 16) if this CPU and OS run them, else nullptr.
const Kernels* kernels_for(int width);

// Widths this machine runs, widest first; 1 (the reference) is always last.
std::vector<int> supported_widths();

// Every width lancer knows, whether or not this machine runs it.
inline const std::vector<int>& known_widths() {
  static const std::vector<int> w{1, 4, 8, 16};
  return w;
}

// The ISA name of a width on this machine ("scalar" for 1).
std::string isa_name(int width);

}  // namespace lancer::packet
