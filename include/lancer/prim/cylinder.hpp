// Ray/cylinder: the side as a quadratic in the plane perpendicular to the axis, in the form the
// spheres use (formulas.hpp, after Ray Tracing Gems ch. 7), and the two end caps. Templated on
// the number type (float, double or an xsimd batch; S its scalar type), branch-free.
#pragma once

#include <cmath>
#include <limits>

#include "lancer/formulas.hpp"
#include "lancer/vec3.hpp"

namespace lancer::prim {

// The parts of a cylinder, as numbers so that batches carry them.
inline constexpr int kCylinderSide = 0, kCylinderBase = 1, kCylinderTop = 2;

// The nearest hit beyond epsilon and the part it lies on; t infinite where none.
template <class T>
struct CylinderHit {
  T t, part;
};

// One ray (origin o, unit direction d) against the cylinder of base A, unit axis `axis`,
// height h and squared radius r2. f = o - A. With fp, dp the parts of f and d perpendicular to
// the axis, the side is |fp + t dp|^2 = r2: t^2 + 2 b t + c = 0 with b = fp.dp / dp.dp and
// c = (|fp|^2 - r2) / dp.dp; its discriminant is formed as (r2 - |fp - b dp|^2) / dp.dp, without
// the cancellation of b^2 - c, and its roots as q = -b - sign(b) sqrt(disc) and c / q. A side root
// counts where s = f.a + t d.a lies in [0, h]; a cap at s = 0 (base) or s = h (top) where its
// point is within r of the axis. A ray along the axis (dp = 0) misses the side.
template <class Math = ExactMath, class T>
inline CylinderHit<T> cylinder_closest(const Vec3<T>& f, const Vec3<T>& d, const Vec3<T>& axis,
                                       const T& h, const T& r2, bool caps, const T& epsilon) {
  using std::sqrt;
  const T inf(std::numeric_limits<float>::infinity());
  const T fa = Math::dot(f, axis), da = Math::dot(d, axis);
  const Vec3<T> fp = Math::sub_scaled(f, axis, fa);
  const Vec3<T> dp = Math::sub_scaled(d, axis, da);
  const T qa = Math::dot(dp, dp);
  const auto side = qa > T(0);
  const T safe_qa = select(side, qa, T(1));
  const T b = Math::div(Math::dot(fp, dp), safe_qa);
  const Vec3<T> perp = Math::sub_scaled(fp, dp, b);
  const T disc = Math::div(r2 - Math::dot(perp, perp), safe_qa);
  const T c = Math::div(Math::dot(fp, fp) - r2, safe_qa);
  const T s = sqrt(positive_part(disc));
  const T q = select(b < T(0), s - b, -(b + s));
  const T t0 = Math::div(c, select(q == T(0), T(1), q));
  const T near_t = select(t0 < q, t0, q), far_t = select(t0 < q, q, t0);
  const auto real = side & (disc >= T(0)) & (q != T(0));
  auto within = [&](const T& t) {
    const T along = fa + t * da;
    return (along >= T(0)) & (along <= h);
  };
  T best = inf, part(kCylinderSide);
  auto take = [&](const auto& ok, const T& t, int which) {
    const auto better = ok & (t > epsilon) & (t < best);
    best = select(better, t, best);
    part = select(better, T(which), part);
  };
  take(real & within(near_t), near_t, kCylinderSide);
  take(real & within(far_t), far_t, kCylinderSide);
  if (caps) {
    const auto facing = da != T(0);
    const T safe_da = select(facing, da, T(1));
    const T t_base = Math::div(-fa, safe_da), t_top = Math::div(h - fa, safe_da);
    auto on_disc = [&](const T& t) {
      const Vec3<T> radial = fp + dp * t;
      return Math::dot(radial, radial) <= r2;
    };
    take(facing & on_disc(t_base), t_base, kCylinderBase);
    take(facing & on_disc(t_top), t_top, kCylinderTop);
  }
  return {best, part};
}

// The geometric normal at a hit point p of `part`: on the side normalize((p - A) - s a) with
// s = (p - A).a, on the caps -a (base) and +a (top).
template <class Math = ExactMath, class T>
inline Vec3<T> cylinder_normal(const Vec3<T>& p, const Vec3<T>& base, const Vec3<T>& axis,
                               const T& part) {
  const Vec3<T> q = p - base;
  const Vec3<T> radial = Math::normalize(Math::sub_scaled(q, axis, Math::dot(q, axis)));
  const auto is_base = part == T(kCylinderBase), is_top = part == T(kCylinderTop);
  auto pick = [&](const T& side, const T& a) {
    return select(is_top, a, select(is_base, -a, side));
  };
  return {pick(radial.x, axis.x), pick(radial.y, axis.y), pick(radial.z, axis.z)};
}

}  // namespace lancer::prim
