// Small formulas shared by the reference and the packets, templated on the number type: T is
// float, double, or an xsimd batch of either. Only formulas live here, never control flow
// (closest hit, shadows, recursion): those are written separately in each path so that
// validation compares two independent walks over the same arithmetic.
//
// Scalar code finds select/any/floor below; batch code finds xsimd's by argument lookup.
#pragma once

#include <cmath>
#include <cstdint>

#include "lancer/prepared.hpp"
#include "lancer/vec3.hpp"

namespace lancer {

// The arithmetic of the formulas below, as a policy: ExactMath is the contract's, correctly
// rounded operation by operation; the packets' fast mode substitutes FastMath (packet/kernel.hpp).
struct ExactMath {
  template <class T>
  static T dot(const Vec3<T>& a, const Vec3<T>& b) {
    return lancer::dot(a, b);
  }
  template <class T>
  static T div(const T& a, const T& b) {
    return a / b;
  }
  template <class T>
  static Vec3<T> div(const Vec3<T>& v, const T& s) {
    return v / s;
  }
  template <class T>
  static T length(const Vec3<T>& v) {
    return lancer::length(v);
  }
  template <class T>
  static Vec3<T> normalize(const Vec3<T>& v) {
    return lancer::normalize(v);
  }
  // a - b s, component by component.
  template <class T>
  static Vec3<T> sub_scaled(const Vec3<T>& a, const Vec3<T>& b, const T& s) {
    return a - b * s;
  }
  template <class T>
  static Vec3<T> along(const Vec3<T>& o, const Vec3<T>& d, const T& t) {
    return lancer::along(o, d, t);
  }
  template <class T>
  static Vec3<T> reflect(const Vec3<T>& d, const Vec3<T>& n) {
    return lancer::reflect(d, n);
  }
};

inline float select(bool m, float a, float b) { return m ? a : b; }
inline double select(bool m, double a, double b) { return m ? a : b; }
inline bool any(bool m) { return m; }

// max(0, x), with +0 for x <= 0 (and for NaN) in every path: _mm_max_ps and std::max disagree on
// the sign of zero, so neither is used.
template <class T>
inline T positive_part(const T& x) {
  return select(x > T(0), x, T(0));
}

// x^e for whole e >= 0 by binary powering: the same multiplications in the same order per lane
// whatever the other lanes' exponents are, so scalar and packets agree to the bit.
template <class T>
inline T power_int(T x, T e) {
  using std::floor;
  T result(1);
  T base = x;
  for (;;) {
    auto more = e > T(0);
    if (!any(more)) break;
    const T half = floor(e * T(0.5));
    const auto odd = e > half + half;
    result = select(odd, result * base, result);
    base = base * base;
    e = half;
  }
  return result;
}

// x^n for a whole n known to the caller as an integer: the same multiplications, in the same
// order, as power_int(x, n), without testing n's bits in T.
template <class T>
inline T power_uint(T x, std::uint32_t n) {
  T result(1);
  T base = x;
  for (; n != 0; n >>= 1) {
    if (n & 1u) result = result * base;
    base = base * base;
  }
  return result;
}

// Ray/sphere in the form of Ray Tracing Gems ch. 7 (Haines et al.): with f = origin - centre and
// unit d, b = f.d and disc = r^2 - |f - b d|^2, which keeps its precision when the sphere is
// small against its distance, where b^2 - c cancels catastrophically.
template <class T>
struct SphereDisc {
  T b, disc;
};

template <class Math = ExactMath, class T>
[[gnu::always_inline]] inline SphereDisc<T> sphere_disc(const Vec3<T>& f, const Vec3<T>& d,
                                                        const T& r2) {
  const T b = Math::dot(f, d);
  const Vec3<T> perp = Math::sub_scaled(f, d, b);
  return {b, r2 - Math::dot(perp, perp)};
}

// c = |f|^2 - r^2: the product of the two roots.
template <class Math = ExactMath, class T>
inline T sphere_c(const Vec3<T>& f, const T& r2) {
  return Math::dot(f, f) - r2;
}

// The two roots, near <= far, given disc >= 0. q = -b - sign(b) sqrt(disc) avoids cancellation;
// the roots are c/q and q.
template <class T>
struct SphereRoots {
  T near_t, far_t;
};

template <class Math = ExactMath, class T>
inline SphereRoots<T> sphere_roots(const SphereDisc<T>& sd, const T& c) {
  using std::sqrt;
  const T s = sqrt(sd.disc);
  const T q = select(sd.b < T(0), s - sd.b, -(sd.b + s));
  const T t0 = Math::div(c, q);
  return {select(t0 < q, t0, q), select(t0 < q, q, t0)};
}

// The nearest root beyond epsilon: near if it is beyond, else far (which may also be behind).
template <class T>
inline T sphere_first_root(const SphereRoots<T>& r, const T& epsilon) {
  return select(r.near_t > epsilon, r.near_t, r.far_t);
}

template <class T>
inline T abs_of(const T& x) {
  return select(x < T(0), -x, x);
}
template <class T>
inline T max_of(const T& a, const T& b) {
  return select(a > b, a, b);
}

// How far a secondary ray's origin moves off the surface, per unit of the magnitude below:
// 64 units in the last place of the number type (2^-18 for float, 2^-47 for double).
template <class T>
struct OffsetScale;
template <>
struct OffsetScale<float> {
  static constexpr float value = 1.0f / 262144.0f;
};
template <>
struct OffsetScale<double> {
  static constexpr double value = 1.0 / 140737488355328.0;
};

// The hit point p = o + t d carries a rounding error of a few ulps of |o|inf + t. A secondary ray
// started exactly at p may re-hit its own surface beyond epsilon (a plane lit at a grazing
// angle: t = tiny error / tiny cosine). After Wachter and Binder (Ray Tracing Gems ch. 6), its
// origin moves along the normal, to the side the ray leaves by, by `delta`: 64 ulps of that
// magnitude for p = o + t d (offset_delta), far above the error, far below any feature of the
// scene; fewer where p is computed relative to a sphere (SurfacePoint below).
template <class T>
inline T hit_magnitude(const Vec3<T>& ray_origin, const T& t) {
  return max_of(max_of(abs_of(ray_origin.x), abs_of(ray_origin.y)), abs_of(ray_origin.z)) + t;
}
template <class S, class T>
inline T offset_delta(const T& magnitude) {
  return magnitude * T(OffsetScale<S>::value);
}
template <class T>
inline Vec3<T> offset_origin(const Vec3<T>& p, const Vec3<T>& n, const T& cos_dir_n,
                             const T& delta) {
  return p + n * select(cos_dir_n < T(0), -delta, delta);
}
// The same from the ray's origin and t (`s` is OffsetScale's scalar type), for p = o + t d.
template <class T, class S>
inline Vec3<T> offset_origin(const Vec3<T>& p, const Vec3<T>& n, const T& cos_dir_n,
                             const Vec3<T>& ray_origin, const T& t) {
  return offset_origin(p, n, cos_dir_n, offset_delta<S>(hit_magnitude(ray_origin, t)));
}

// The unit normal of a sphere at p, normalize(p - c): the contract's (p - c) / r where p lies on
// the sphere, and still unit length where float has put p off it (a small sphere hit from far
// away), where (p - c) / r is not and max(0, n.h)^shininess would overflow.
template <class Math = ExactMath, class T>
inline Vec3<T> sphere_normal(const Vec3<T>& p, const Vec3<T>& c) {
  return Math::normalize(p - c);
}

// A hit where shading starts: the point, the geometric normal (before it faces the ray), and
// the offset of the secondary rays' origins (offset_origin).
template <class T>
struct SurfacePoint {
  Vec3<T> p, normal;
  T delta;
};

// A sphere hit as the contract writes it: p = o + t d, normal (p - c) normalised. p carries an
// ulp of the magnitude |o|inf + t, and p - c as much: nothing against a sphere of radius 1, 6% of
// the radius of a sphere 1e6 radii away, whose normals and shading it ruins (issue 17).
template <class S, class Math = ExactMath, class T>
inline SurfacePoint<T> sphere_point_along(const Vec3<T>& o, const Vec3<T>& d, const T& t,
                                          const Vec3<T>& c, const T& magnitude) {
  const Vec3<T> p = Math::along(o, d, t);
  return {p, sphere_normal<Math>(p, c), offset_delta<S>(magnitude)};
}

// a b - c e with both products' rounding errors recovered (Dekker's two-product on Veltkamp's
// splitting; no fused multiply-add, so the same bits on every ISA): accurate to about an ulp of
// the result where a b and c e cancel. Coordinates are at most 1e18 (docs/limits.md), so the
// split cannot overflow.
template <class S>
struct SplitFactor;
template <>
struct SplitFactor<float> {
  static constexpr float value = 4097.0f;  // 2^12 + 1
};
template <>
struct SplitFactor<double> {
  static constexpr double value = 134217729.0;  // 2^27 + 1
};
template <class S, class T>
inline T product_error(const T& a, const T& b, const T& ab) {
  const T sa = a * T(SplitFactor<S>::value), sb = b * T(SplitFactor<S>::value);
  const T ah = sa - (sa - a), bh = sb - (sb - b);
  const T al = a - ah, bl = b - bh;
  return ((ah * bh - ab) + ah * bl + al * bh) + al * bl;
}
template <class S, class T>
inline T difference_of_products(const T& a, const T& b, const T& c, const T& e) {
  const T ab = a * b, ce = c * e;
  return (ab - ce) + (product_error<S>(a, b, ab) - product_error<S>(c, e, ce));
}
// f x d, each component by difference_of_products: |f x d| is the ray's distance from the
// centre, at most r on a hit, from products of the order of |f|.
template <class S, class T>
inline Vec3<T> accurate_cross(const Vec3<T>& f, const Vec3<T>& d) {
  return {difference_of_products<S>(f.y, d.z, f.z, d.y),
          difference_of_products<S>(f.z, d.x, f.x, d.z),
          difference_of_products<S>(f.x, d.y, f.y, d.x)};
}

// Where a sphere is small against the magnitude of its hit point (r < magnitude / 64), p - c is
// computed relative to the sphere instead: the ray's closest approach to the centre,
// perp = d x (f x d) = f - (f.d) d for f = o - c, whose cross products cancel only as far as the
// geometry does (f - (f.d) d cancels along d, by an ulp of |f| whatever the geometry), then
// p - c = perp -+ sqrt(r^2 - |perp|^2) d, - for the near root. |p - c| is r to an ulp of r,
// whatever error perp carries: that error moves p along the sphere, not off it. So p = c + (p - c)
// lies off the sphere by its own rounding only, half an ulp of each |p_i|, of which the normal's
// share counts, and the origin's own rounding as much again (pbrt-v4's bound, Pharr et al. 2023,
// sec. 6.8.6): the origins move by 2^-22 (|n|.|p| + 4 |p - c|inf) (twice that bound), not 64 ulps
// of the magnitude. On a sphere 1e6 radii away that is a few hundredths of its radius instead of
// four radii, which put a neighbour's contact shadow and its reflection out of reach (issue 17).
template <class T>
inline auto sphere_is_small(const T& r2, const T& magnitude) {
  return r2 < (magnitude * magnitude) * T(1.0 / 4096);  // no overflow: magnitude <= 5e18
}
template <class S, class Math = ExactMath, class T>
inline SurfacePoint<T> sphere_point_local(const Vec3<T>& o, const Vec3<T>& d, const T& t,
                                          const Vec3<T>& c, const T& r2) {
  using std::sqrt;
  const Vec3<T> f = o - c;
  const Vec3<T> perp = cross(d, accurate_cross<S>(f, d));
  const T s = sqrt(positive_part(r2 - Math::dot(perp, perp)));
  // Which root t is: the nearer of the two, recomputed as the intersection did. (The sign of
  // t + f.d, t against the closest approach, carries an ulp of |f| and flips where s is below
  // it: a tenth of the radius at 1e-6.)
  const SphereRoots<T> roots =
      sphere_roots<Math>(sphere_disc<Math>(f, d, r2), sphere_c<Math>(f, r2));
  const auto near = abs_of(t - roots.near_t) <= abs_of(t - roots.far_t);
  const Vec3<T> local = perp + d * select(near, -s, s);
  const Vec3<T> p = c + local;
  const Vec3<T> n = Math::normalize(local);
  const T along_n =
      (abs_of(n.x) * abs_of(p.x) + abs_of(n.y) * abs_of(p.y)) + abs_of(n.z) * abs_of(p.z);
  const T radius = max_of(max_of(abs_of(local.x), abs_of(local.y)), abs_of(local.z));
  return {p, n, (along_n + T(4) * radius) * T(OffsetScale<S>::value * S(0.0625))};
}

// The rounding error of s = a + b (Knuth's two-sum): a + b = s + two_sum_error(a, b, s).
template <class T>
inline T two_sum_error(const T& a, const T& b, const T& s) {
  const T bb = s - a;
  return (a - (s - bb)) + (b - bb);
}

// Where a sphere is huge against the magnitude of its hit point (r > 64 magnitude: a ground
// sphere of radius 1e6 seen from a few units above it), c = |f|^2 - r^2 cancels: each square
// carries an ulp of r^2 (65536 for r = 1e6), c is 2 r h for an origin h above the surface, and
// the near root c / q moved the hit point by a few hundredths over a metre (issue 17). Here c
// is summed with every product's and sum's rounding error recovered, so the root keeps its own
// precision; the far root q had no cancellation. Which root t is: the nearer one, as above.
template <class T>
inline auto sphere_is_large(const T& r2, const T& magnitude) {
  return r2 * T(1.0 / 4096) > magnitude * magnitude;
}
template <class S, class T>
inline T accurate_sphere_c(const Vec3<T>& f, const T& r2) {
  const T xx = f.x * f.x, yy = f.y * f.y, zz = f.z * f.z;
  const T lo = (product_error<S>(f.x, f.x, xx) + product_error<S>(f.y, f.y, yy)) +
               product_error<S>(f.z, f.z, zz);
  const T s1 = xx + yy, s2 = s1 + zz, s3 = s2 - r2;
  const T e = (two_sum_error(xx, yy, s1) + two_sum_error(s1, zz, s2)) + two_sum_error(s2, -r2, s3);
  return s3 + (e + lo);
}
template <class S, class Math = ExactMath, class T>
inline SurfacePoint<T> sphere_point_large(const Vec3<T>& o, const Vec3<T>& d, const T& t,
                                          const Vec3<T>& c, const T& r2, const T& magnitude) {
  using std::sqrt;
  const Vec3<T> f = o - c;
  const SphereDisc<T> sd = sphere_disc<Math>(f, d, r2);
  const T s = sqrt(positive_part(sd.disc));
  const T q = select(sd.b < T(0), s - sd.b, -(sd.b + s));
  const T small_root = Math::div(sphere_c<Math>(f, r2), q);
  const T root =
      select(abs_of(t - small_root) <= abs_of(t - q), Math::div(accurate_sphere_c<S>(f, r2), q), q);
  return sphere_point_along<S, Math>(o, d, root, c, magnitude);
}

// Blinn-Phong's specular factor max(0, n.h)^shininess, exact for whole shininess.
template <class T>
inline T specular_power(const T& cos_nh, const T& shininess) {
  return power_int(positive_part(cos_nh), shininess);
}

// Snell-Descartes refraction (contract step 7) of unit d at a surface whose normal n faces the
// ray, with eta the ratio of indices (1 / ior entering, ior leaving): c = -d.n and
// k = 1 - eta^2 (1 - c^2). Where k >= 0 the refracted direction is eta d + (eta c - sqrt(k)) n,
// not yet unit (callers normalise); where k < 0 the light is totally reflected and `dir` is
// meaningless (callers take the mirror direction). sqrt of +0 there keeps every lane finite.
template <class T>
struct Refraction {
  Vec3<T> dir;
  T k;
};

template <class Math = ExactMath, class T>
inline Refraction<T> refract(const Vec3<T>& d, const Vec3<T>& n, const T& eta) {
  using std::sqrt;
  const T c = -Math::dot(d, n);
  const T k = T(1) - (eta * eta) * (T(1) - c * c);
  const T along_n = eta * c - sqrt(positive_part(k));
  return {d * eta + n * along_n, k};
}

// A shadow ray's transmittance after it meets one more object: T * transmit. Every path takes
// the product in object-id order (spheres, then planes, in file order): a float product of
// three or more factors depends on its order.
template <class T>
inline T attenuate(const T& transmittance, const T& transmit) {
  return transmittance * transmit;
}

// Screen coordinates of pixel column i (row j) at sub-sample offset (a + 0.5) / s, as in the
// contract: x = xmin + (i + (a+0.5)/s) * (xmax - xmin) / nx, y = ymax - (j + ...) * ... / ny.
template <class T, class S>
inline T screen_x(const PreparedCamera<S>& c, const T& i, const T& offset) {
  return T(c.xmin) + ((i + offset) * T(c.width)) / T(c.fnx);
}
template <class T, class S>
inline T screen_y(const PreparedCamera<S>& c, const T& j, const T& offset) {
  return T(c.ymax) - ((j + offset) * T(c.height)) / T(c.fny);
}

// x u + y v, component by component.
template <class T, class S>
inline Vec3<T> on_screen(const PreparedCamera<S>& c, const T& x, const T& y) {
  return {x * T(c.u.x) + y * T(c.v.x), x * T(c.u.y) + y * T(c.v.y), x * T(c.u.z) + y * T(c.v.z)};
}

// Camera ray through screen point (x, y): pinhole from the eye, orthographic along -w.
template <class Math = ExactMath, class T, class S>
inline void camera_ray(const PreparedCamera<S>& c, const T& x, const T& y, Vec3<T>& origin,
                       Vec3<T>& dir) {
  const Vec3<T> s = on_screen(c, x, y);
  if (c.orthographic) {
    origin = Vec3<T>::from(c.position) + s;
    dir = Vec3<T>::from(-c.w);
  } else {
    origin = Vec3<T>::from(c.position);
    dir = Math::normalize(s - Vec3<T>::from(c.w) * T(c.distance));
  }
}

}  // namespace lancer
