// Ray/triangle, watertight: Woop, Benthin and Wald, "Watertight Ray/Triangle Intersection",
// JCGT 2(1), 2013. Templated on the number type: T is float, double, or an xsimd batch of either
// (S is its scalar type), with no data-dependent branch, so the reference and the packets get the
// same bits from the same source.
//
// The ray is sheared once: its largest direction component is axis kz, kx and ky the next two
// (swapped where dir[kz] < 0, keeping the winding), and in that space the ray is the +z axis. A
// triangle's vertices, relative to the origin and permuted into (kx, ky, kz), give three edge
// functions U, V, W (2D cross products of the projected vertices). The ray meets the triangle,
// edges and vertices included, where they do not have opposite signs. An edge shared by two
// triangles gets the same products in both, negated exactly, so a ray through it meets at least
// one of them (the test Prims.Watertight* fires rays at every shared edge and vertex). Where an
// edge function rounds to 0, it is recomputed with both products' rounding errors recovered
// (difference_of_products): the float difference of the two rounded products is 0 only when they
// are equal, and then the exact value is the difference of their errors, which is exact to the
// last bit in T. This replaces the paper's fallback to double and keeps batches of float in float.
#pragma once

#include <cstdint>

#include "lancer/formulas.hpp"
#include "lancer/vec3.hpp"

namespace lancer::prim {

// The ray's shear (scalar rays): the axes and the factors sx = d[kx]/d[kz], sy = d[ky]/d[kz],
// sz = 1/d[kz]. Packets whose lanes disagree on kz permute per lane (see permuted()).
template <class S>
struct RayShear {
  int kx = 0, ky = 1, kz = 2;
  S sx = 0, sy = 0, sz = 1;
};

template <class S>
inline S component(const Vec3<S>& v, int k) {
  return k == 0 ? v.x : k == 1 ? v.y : v.z;
}

// kz: the largest |d| component, ax > ay ? (ax > az ? 0 : 2) : (ay > az ? 1 : 2); kx, ky the next
// two in turn, swapped where d[kz] < 0 to keep the winding.
// The choices are made by arithmetic on the comparisons, not by branches: a ray's set-up runs
// before a walk of a few nodes, and random directions would mispredict them.
template <class S>
inline RayShear<S> ray_shear(const Vec3<S>& dir) {
  const S c[3] = {dir.x, dir.y, dir.z};
  const S ax = c[0] < S(0) ? -c[0] : c[0], ay = c[1] < S(0) ? -c[1] : c[1],
          az = c[2] < S(0) ? -c[2] : c[2];
  const int g01 = ax > ay, g02 = ax > az, g12 = ay > az;
  static constexpr int kNext[3] = {1, 2, 0};
  RayShear<S> r;
  r.kz = g01 * 2 * (1 - g02) + (1 - g01) * (2 - g12);
  r.kx = kNext[r.kz], r.ky = kNext[r.kx];
  const int swap = (r.kx ^ r.ky) & -int(c[r.kz] < S(0));
  r.kx ^= swap, r.ky ^= swap;
  const S dz = c[r.kz];
  r.sx = c[r.kx] / dz;
  r.sy = c[r.ky] / dz;
  r.sz = S(1) / dz;
  return r;
}

// v in the ray's axis order (kx, ky, kz).
template <class S>
inline Vec3<S> permuted(const Vec3<S>& v, const RayShear<S>& r) {
  return {component(v, r.kx), component(v, r.ky), component(v, r.kz)};
}

// The edge functions and the scaled distance of one ray against one triangle.
// u, v, w weight vertices 0, 1, 2; det = u + v + w; the hit is at t = t_scaled / det and its
// barycentric weights are (u, v, w) / det.
template <class T>
struct TriangleEdges {
  T u, v, w, det, t_scaled;
};

// a, b, c: the triangle's vertices minus the ray's origin, each permuted into (kx, ky, kz);
// sx, sy: the ray's shear. The edge functions u, v, w and det (t_scaled: triangle_depth).
template <class S, class T>
inline TriangleEdges<T> triangle_uvw(const Vec3<T>& a, const Vec3<T>& b, const Vec3<T>& c,
                                     const T& sx, const T& sy) {
  const T ax = a.x - sx * a.z, ay = a.y - sy * a.z;
  const T bx = b.x - sx * b.z, by = b.y - sy * b.z;
  const T cx = c.x - sx * c.z, cy = c.y - sy * c.z;
  T u = cx * by - cy * bx;
  T v = ax * cy - ay * cx;
  T w = bx * ay - by * ax;
  // The exact recomputation only where a product difference rounded to 0 (rare: a branch, so
  // that batches skip it when no lane needs it; the values are those of computing it always).
  if (any((u == T(0)) | (v == T(0)) | (w == T(0)))) {
    u = select(u == T(0), difference_of_products<S>(cx, by, cy, bx), u);
    v = select(v == T(0), difference_of_products<S>(ax, cy, ay, cx), v);
    w = select(w == T(0), difference_of_products<S>(bx, ay, by, ax), w);
  }
  const T det = (u + v) + w;
  return {u, v, w, det, T(0)};
}

// The scaled distance of triangle_uvw's edges e (sz: the ray's shear).
template <class T>
inline void triangle_depth(TriangleEdges<T>& e, const Vec3<T>& a, const Vec3<T>& b,
                           const Vec3<T>& c, const T& sz) {
  const T az = sz * a.z, bz = sz * b.z, cz = sz * c.z;
  e.t_scaled = (e.u * az + e.v * bz) + e.w * cz;
}

// a, b, c: the triangle's vertices minus the ray's origin, each permuted into (kx, ky, kz);
// sx, sy, sz: the ray's shear.
template <class S, class T>
inline TriangleEdges<T> triangle_edges(const Vec3<T>& a, const Vec3<T>& b, const Vec3<T>& c,
                                       const T& sx, const T& sy, const T& sz) {
  TriangleEdges<T> e = triangle_uvw<S>(a, b, c, sx, sy);
  triangle_depth(e, a, b, c, sz);
  return e;
}

// Inside, edges and vertices included: no two edge functions of opposite signs, and a
// non-degenerate projection (det != 0: a ray parallel to the triangle's plane misses it).
template <class T>
inline auto triangle_inside(const TriangleEdges<T>& e) {
  const auto nonneg = (e.u >= T(0)) & (e.v >= T(0)) & (e.w >= T(0));
  const auto nonpos = (e.u <= T(0)) & (e.v <= T(0)) & (e.w <= T(0));
  return (nonneg | nonpos) & (e.det != T(0));
}

// The distance along the ray: meaningful where triangle_inside.
template <class Math = ExactMath, class T>
inline T triangle_t(const TriangleEdges<T>& e) {
  return Math::div(e.t_scaled, e.det);
}

// The hit's barycentric weights of vertices 0, 1, 2 (smooth normals).
template <class Math = ExactMath, class T>
inline Vec3<T> triangle_barycentrics(const TriangleEdges<T>& e) {
  return {Math::div(e.u, e.det), Math::div(e.v, e.det), Math::div(e.w, e.det)};
}

// The geometric normal normalize((v1 - v0) x (v2 - v0)).
template <class Math = ExactMath, class T>
inline Vec3<T> triangle_normal(const Vec3<T>& v0, const Vec3<T>& v1, const Vec3<T>& v2) {
  return Math::normalize(cross(v1 - v0, v2 - v0));
}

// normalize(b0 n0 + b1 n1 + b2 n2), or `geometric` where that blend has zero length.
template <class Math = ExactMath, class T>
inline Vec3<T> smooth_normal(const Vec3<T>& bary, const Vec3<T>& n0, const Vec3<T>& n1,
                             const Vec3<T>& n2, const Vec3<T>& geometric) {
  const Vec3<T> blend = (n0 * bary.x + n1 * bary.y) + n2 * bary.z;
  const T len2 = Math::dot(blend, blend);
  const auto zero = len2 <= T(0);
  const Vec3<T> unit = Math::div(blend, select(zero, T(1), Math::length(blend)));
  return {select(zero, geometric.x, unit.x), select(zero, geometric.y, unit.y),
          select(zero, geometric.z, unit.z)};
}

}  // namespace lancer::prim
