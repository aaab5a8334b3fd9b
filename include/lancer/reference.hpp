// The scalar reference renderer: one ray at a time, recursive, SCENE-MODEL.md made executable.
// Every faster path is held to it bit for bit in exact mode.
#pragma once

#include <cstdint>
#include <vector>

#include "lancer/image.hpp"
#include "lancer/prepared.hpp"
#include "lancer/stats.hpp"
#include "lancer/vec3.hpp"

namespace lancer {
template <class T>
struct ShapeHit;  // lancer/shapes.hpp
}  // namespace lancer

namespace lancer::reference {

// Renders rows [row_begin, row_end) into `image` (already sized nx x ny).
template <class T>
void render_rows(const PreparedScene<T>& scene, Image& image, int row_begin, int row_end,
                 RayCounts& counts);

// The rays a render traced, as segments, for drawing them (lancer flux --diagram). Only
// render_rows_recorded fills one; render_rows pays a null-pointer test per ray for the hook.
struct PathLog {
  struct Segment {
    enum Kind { camera, reflected, light, refracted };
    Kind kind;
    Vec3<double> from, to;
    // camera, reflected, refracted: the ray hit an object (`to` is the hit point) or, when false,
    // nothing
    // (`to` is from + dir * miss_length). light: the ray to the light was blocked by an object
    // (the light was not counted); `to` is the light's position either way.
    bool hit;
    int depth;   // the recursion depth of the ray (light rays: of the ray whose hit they light)
    int pixel;   // j * nx + i of the camera ray the path started from
    int sample;  // b * s + a: its sub-sample
    int id;      // camera, reflected, refracted: the object hit (-1 on a miss); light: the light's
                 // index
  };
  // How far a ray that hits nothing is drawn: callers set it beyond the edge of their drawing.
  double miss_length = 1e3;
  std::vector<Segment> segments;
};

// render_rows, appending to `log` every camera and reflected ray traced and every light ray
// cast, in tracing order. Same image and counts as render_rows.
template <class T>
void render_rows_recorded(const PreparedScene<T>& scene, Image& image, int row_begin, int row_end,
                          RayCounts& counts, PathLog& log);

// Primary rays only: per pixel of rows [row_begin, row_end), the sum over its samples of the
// distance to the closest hit (infinity on a miss) into t_out[j * nx + i], and, if id_out is not
// null, the object id first hit by sample (0, 0) (-1 for none).
template <class T>
void primary_rows(const PreparedScene<T>& scene, float* t_out, std::int32_t* id_out, int row_begin,
                  int row_end, RayCounts& counts);

// The closest hit of one ray: its object id and distance, or id -1.
template <class T>
struct Hit {
  int id = -1;
  T t = 0;
};
template <class T>
Hit<T> closest_hit(const PreparedScene<T>& scene, const Vec3<T>& origin, const Vec3<T>& dir);
// The same with hits counted beyond tmin rather than the scene's epsilon: the nearest root of
// each object above tmin (the library API's per-ray tnear, with tmin = max(tnear, epsilon)).
template <class T>
Hit<T> closest_hit(const PreparedScene<T>& scene, const Vec3<T>& origin, const Vec3<T>& dir,
                   T tmin);

// The same, with the primitive hit where it is a triangle, mesh or cylinder (shape.object -1
// where the hit is a sphere, a plane or none): what shapes_surface and shapes_normals take.
template <class T>
Hit<T> closest_hit(const PreparedScene<T>& scene, const Vec3<T>& origin, const Vec3<T>& dir, T tmin,
                   ShapeHit<T>& shape);

extern template void render_rows<float>(const PreparedScene<float>&, Image&, int, int, RayCounts&);
extern template void render_rows<double>(const PreparedScene<double>&, Image&, int, int,
                                         RayCounts&);
extern template void render_rows_recorded<float>(const PreparedScene<float>&, Image&, int, int,
                                                 RayCounts&, PathLog&);
extern template void render_rows_recorded<double>(const PreparedScene<double>&, Image&, int, int,
                                                  RayCounts&, PathLog&);
extern template void primary_rows<float>(const PreparedScene<float>&, float*, std::int32_t*, int,
                                         int, RayCounts&);
extern template void primary_rows<double>(const PreparedScene<double>&, float*, std::int32_t*, int,
                                          int, RayCounts&);
extern template Hit<float> closest_hit<float>(const PreparedScene<float>&, const Vec3<float>&,
                                              const Vec3<float>&);
extern template Hit<double> closest_hit<double>(const PreparedScene<double>&, const Vec3<double>&,
                                                const Vec3<double>&);
extern template Hit<float> closest_hit<float>(const PreparedScene<float>&, const Vec3<float>&,
                                              const Vec3<float>&, float);
extern template Hit<double> closest_hit<double>(const PreparedScene<double>&, const Vec3<double>&,
                                                const Vec3<double>&, double);
extern template Hit<float> closest_hit<float>(const PreparedScene<float>&, const Vec3<float>&,
                                              const Vec3<float>&, float, ShapeHit<float>&);
extern template Hit<double> closest_hit<double>(const PreparedScene<double>&, const Vec3<double>&,
                                                const Vec3<double>&, double, ShapeHit<double>&);

}  // namespace lancer::reference
