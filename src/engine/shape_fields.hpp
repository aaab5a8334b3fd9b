// The library API's hit fields on a triangle, mesh or cylinder whose primitive the packets found:
// what shape_hit, shapes_surface and shapes_normals give together, from one shear and one
// triangle test (the library API answers many such lanes per packet).
#pragma once

#include <cstdint>

#include "lancer/shapes.hpp"

namespace lancer {

template <class T>
struct ShapeFields {
  ShapeSurface<T> surface;  // shapes_surface's
  Vec3<T> geometric;        // shapes_normals' geometric normal at p
};

// Primitive `prim`'s fields for the ray o, d hitting it at p (epsilon: the scene's, for a
// cylinder's part), bit for bit those of shapes_surface and shapes_normals on shape_hit's hit.
template <class T>
ShapeFields<T> shape_fields(const PreparedShapes<T>& s, const Vec3<T>& o, const Vec3<T>& d,
                            const Vec3<T>& p, T epsilon, std::int64_t prim);

extern template ShapeFields<float> shape_fields<float>(const PreparedShapes<float>&,
                                                       const Vec3<float>&, const Vec3<float>&,
                                                       const Vec3<float>&, float, std::int64_t);
extern template ShapeFields<double> shape_fields<double>(const PreparedShapes<double>&,
                                                         const Vec3<double>&, const Vec3<double>&,
                                                         const Vec3<double>&, double, std::int64_t);

}  // namespace lancer
