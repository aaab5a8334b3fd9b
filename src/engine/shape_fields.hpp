// The library API's hit fields on a triangle, mesh or cylinder whose primitive the packets found:
// what shape_hit, shapes_surface and shapes_normals give together, from one shear and one
// triangle test (the library API answers many such lanes per packet).
#pragma once

#include <cstdint>
#include <vector>

#include "lancer/shapes.hpp"

namespace lancer {

template <class T>
struct ShapeFields {
  ShapeSurface<T> surface;  // shapes_surface's
  Vec3<T> geometric;        // shapes_normals' geometric normal at p
};

// Per shape (object id - PreparedShapes::first_object), the index of its first triangle in the
// prepared order (triangles are stored in object order), -1 for a cylinder: what shapes_surface
// searches for.
template <class T>
std::vector<std::int32_t> first_triangles(const PreparedShapes<T>& s);

// Primitive `prim`'s fields for the ray o, d hitting it at t (object: its object id, as
// PreparedShapes::prim_object gives it; epsilon: the scene's, for a cylinder's part;
// first_triangle: first_triangles' table), bit for bit those of shapes_surface and
// shapes_normals on shape_hit's hit, a triangle's from its leaf (the walk's copy of its
// vertices). The hit point is computed for a cylinder alone: a triangle's normal does not
// depend on it.
template <class T>
ShapeFields<T> shape_fields(const PreparedShapes<T>& s, const std::int32_t* first_triangle,
                            const Vec3<T>& o, const Vec3<T>& d, T t, T epsilon, std::int64_t prim,
                            std::int32_t object);

// Before shape_fields on the n primitives prims[0 .. n): each one's leaf (through
// PreparedShapes::prim_leaf) fetched. Incoherent hits find those lines out of the cache; the
// lanes' loads do not depend on each other, so here all are under way at once, where lane by
// lane in shape_fields each would wait in turn.
template <class T>
void fetch_shape_fields(const PreparedShapes<T>& s, const std::int32_t* prims, int n) noexcept;

extern template std::vector<std::int32_t> first_triangles<float>(const PreparedShapes<float>&);
extern template std::vector<std::int32_t> first_triangles<double>(const PreparedShapes<double>&);
extern template ShapeFields<float> shape_fields<float>(const PreparedShapes<float>&,
                                                       const std::int32_t*, const Vec3<float>&,
                                                       const Vec3<float>&, float, float,
                                                       std::int64_t, std::int32_t);
extern template ShapeFields<double> shape_fields<double>(const PreparedShapes<double>&,
                                                         const std::int32_t*, const Vec3<double>&,
                                                         const Vec3<double>&, double, double,
                                                         std::int64_t, std::int32_t);

}  // namespace lancer
