// The scalar reference renderer: one ray at a time, recursive, SCENE-MODEL.md made executable.
// Every faster path is held to it bit for bit in exact mode.
#pragma once

#include "lancer/image.hpp"
#include "lancer/prepared.hpp"
#include "lancer/stats.hpp"

namespace lancer::reference {

// Renders rows [row_begin, row_end) into `image` (already sized nx x ny).
template <class T>
void render_rows(const PreparedScene<T>& scene, Image& image, int row_begin, int row_end,
                 RayCounts& counts);

// Primary rays only: the distance to the closest hit of each camera ray (infinity on a miss),
// for sample 0 of each pixel of rows [row_begin, row_end), into t_out[j * nx + i].
template <class T>
void primary_rows(const PreparedScene<T>& scene, float* t_out, int row_begin, int row_end,
                  RayCounts& counts);

// The closest hit of one ray: its object id and distance, or id -1.
template <class T>
struct Hit {
  int id = -1;
  T t = 0;
};
template <class T>
Hit<T> closest_hit(const PreparedScene<T>& scene, const Vec3<T>& origin, const Vec3<T>& dir);

extern template void render_rows<float>(const PreparedScene<float>&, Image&, int, int, RayCounts&);
extern template void render_rows<double>(const PreparedScene<double>&, Image&, int, int,
                                         RayCounts&);
extern template void primary_rows<float>(const PreparedScene<float>&, float*, int, int,
                                         RayCounts&);
extern template void primary_rows<double>(const PreparedScene<double>&, float*, int, int,
                                          RayCounts&);
extern template Hit<float> closest_hit<float>(const PreparedScene<float>&, const Vec3<float>&,
                                              const Vec3<float>&);
extern template Hit<double> closest_hit<double>(const PreparedScene<double>&, const Vec3<double>&,
                                                const Vec3<double>&);

}  // namespace lancer::reference
