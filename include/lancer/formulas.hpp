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
inline SphereDisc<T> sphere_disc(const Vec3<T>& f, const Vec3<T>& d, const T& r2) {
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
// origin moves along the normal, to the side the ray leaves by, by 64 ulps of that magnitude:
// far above the error, far below any feature of the scene. `s` is OffsetScale of the scalar type.
template <class T, class S>
inline Vec3<T> offset_origin(const Vec3<T>& p, const Vec3<T>& n, const T& cos_dir_n,
                             const Vec3<T>& ray_origin, const T& t) {
  const T magnitude =
      max_of(max_of(abs_of(ray_origin.x), abs_of(ray_origin.y)), abs_of(ray_origin.z)) + t;
  const T delta = magnitude * T(OffsetScale<S>::value);
  return p + n * select(cos_dir_n < T(0), -delta, delta);
}

// The unit normal of a sphere at p, normalize(p - c): the contract's (p - c) / r where p lies on
// the sphere, and still unit length where float has put p off it (a small sphere hit from far
// away), where (p - c) / r is not and max(0, n.h)^shininess would overflow.
template <class Math = ExactMath, class T>
inline Vec3<T> sphere_normal(const Vec3<T>& p, const Vec3<T>& c) {
  return Math::normalize(p - c);
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
