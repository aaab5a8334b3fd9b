// A 3-vector over any number type: float, double, or an xsimd batch (one vector per lane).
//
// The same source computes the reference's scalar maths and the packets' lane-wise maths, so
// every operation here is written out component by component in a fixed order: the order of
// floating-point operations is part of the contract between the two paths.
#pragma once

#include <cmath>

namespace lancer {

template <class T>
struct Vec3 {
  T x, y, z;

  Vec3() = default;
  constexpr Vec3(T x_, T y_, T z_) : x(x_), y(y_), z(z_) {}
  // Broadcast a vector of another number type (float -> batch<float>, double -> float).
  template <class U>
  static Vec3 from(const Vec3<U>& v) {
    return {T(v.x), T(v.y), T(v.z)};
  }
};

template <class T>
inline Vec3<T> operator+(const Vec3<T>& a, const Vec3<T>& b) {
  return {a.x + b.x, a.y + b.y, a.z + b.z};
}
template <class T>
inline Vec3<T> operator-(const Vec3<T>& a, const Vec3<T>& b) {
  return {a.x - b.x, a.y - b.y, a.z - b.z};
}
template <class T>
inline Vec3<T> operator-(const Vec3<T>& a) {
  return {-a.x, -a.y, -a.z};
}
// Vector times a number: each component times s.
template <class T>
inline Vec3<T> operator*(const Vec3<T>& a, const T& s) {
  return {a.x * s, a.y * s, a.z * s};
}
template <class T>
inline Vec3<T> operator*(const T& s, const Vec3<T>& a) {
  return {s * a.x, s * a.y, s * a.z};
}
template <class T>
inline Vec3<T> operator/(const Vec3<T>& a, const T& s) {
  return {a.x / s, a.y / s, a.z / s};
}

template <class T>
inline T dot(const Vec3<T>& a, const Vec3<T>& b) {
  return a.x * b.x + a.y * b.y + a.z * b.z;
}

template <class T>
inline Vec3<T> cross(const Vec3<T>& a, const Vec3<T>& b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}

template <class T>
inline T length(const Vec3<T>& v) {
  using std::sqrt;
  return sqrt(dot(v, v));
}

// Division, not multiplication by a reciprocal: correctly rounded on every ISA.
template <class T>
inline Vec3<T> normalize(const Vec3<T>& v) {
  return v / length(v);
}

// Mirror direction of d about the normal n: d - 2 (d.n) n.
template <class T>
inline Vec3<T> reflect(const Vec3<T>& d, const Vec3<T>& n) {
  const T k = T(2) * dot(d, n);
  return d - n * k;
}

// a + t b, the point at parameter t along a ray.
template <class T>
inline Vec3<T> along(const Vec3<T>& origin, const Vec3<T>& dir, const T& t) {
  return {origin.x + t * dir.x, origin.y + t * dir.y, origin.z + t * dir.z};
}

}  // namespace lancer
