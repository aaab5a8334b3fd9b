// Shading a packet's hits (contract steps 3 to 7): the hit point and its normal, the lights'
// ambient, Lambert and Blinn-Phong sums with their shadow rays, and the reflected and refracted
// rays that go on.
// Include only from code built for the batch's ISA (packet/kernel.hpp).
#pragma once

#include <cmath>
#include <limits>

#include "lancer/packet/queries.hpp"

namespace lancer::packet {

template <class Arch, class Real, class Mode>
struct Shading : Queries<Arch, Real, Mode> {
  using Q = Queries<Arch, Real, Mode>;
  using Prims = Primitives<Arch, Real, Mode>;
  using Q::closest_hit;
  using Q::count;
  using Q::gather;
  using Q::kFast;
  using Q::lap;
  using Q::occupancy;
  using Q::select3;
  using Q::to_m;
  using Q::to_mi;
  using Q::W;
  using typename Q::B;
  using typename Q::I;
  using typename Q::Id;
  using typename Q::M;
  using typename Q::Mth;
  using typename Q::Prepared;
  using typename Q::Shadow;
  using typename Q::T;
  using typename Q::V;

  // max(0, c)^shininess per lane: binary powering for whole exponents; std::pow lane by lane
  // for the rare fractional ones, exactly as the reference does for that material.
  [[gnu::always_inline]] static B power(const Prepared& s, const B& cos_nh, const B& shininess,
                                        const B& shininess_int) noexcept {
    // One whole exponent for every lane (one material's area, the common case): drive binary
    // powering from the exponent's bits as an integer, a chain of multiplications only.
    const T first = shininess.get(0);
    // Whole: the prepared flag (exact); fast tests the value itself and gathers no flag.
    const bool first_whole = kFast ? first == std::trunc(first) && first < T(4294967296.0)
                                   : shininess_int.get(0) != T(0);
    if (xsimd::all(shininess == B(first)) && first_whole)
      return power_uint(positive_part(cos_nh), static_cast<std::uint32_t>(first));
    if constexpr (kFast) return Mth::pow01(positive_part(cos_nh), shininess);
    const M whole = shininess_int != B(0);
    B p = specular_power(cos_nh, xsimd::select(whole, shininess, B(0)));
    if (!s.features.fractional_shininess || xsimd::all(whole)) return p;
    alignas(64) T pv[W], cv[W], sv[W], wv[W];
    p.store_aligned(pv);
    positive_part(cos_nh).store_aligned(cv);
    shininess.store_aligned(sv);
    shininess_int.store_aligned(wv);
    for (int k = 0; k < W; ++k)
      if (wv[k] == T(0)) pv[k] = std::pow(cv[k], sv[k]);
    return B::load_aligned(pv);
  }

  // v / |v|, and |v| in `length`. Exact: a square root and a division, as the reference.
  // Fast: one refined reciprocal square root for both. Where v = 0, length is 0 (exact) or NaN
  // (fast): callers test length > 0, false for both.
  static V unit(const V& v, B& length) noexcept {
    if constexpr (kFast) {
      const B len2 = Mth::dot(v, v);
      const B inv = Mth::rsqrt(len2);
      length = len2 * inv;
      return v * inv;
    } else {
      length = Mth::length(v);
      return Mth::div(v, length);
    }
  }

  // A cosine with the surface normal. Fast mode's sphere normals, (p - c) / r, are unit only as
  // far as p lies on the sphere: where float puts p far off a tiny sphere, capping at 1 keeps
  // cos^shininess and kd I cos finite.
  static B cosine(const B& c) noexcept {
    if constexpr (kFast)
      return xsimd::min(c, B(1.0f));
    else
      return c;
  }

  // One bounce level of a packet: what the recursion of the reference keeps on its stack.
  struct Level {
    B r, g, b;    // local colour (or background/environment where the ray missed)
    B reflect;    // the hit material's reflection coefficient
    M reflected;  // lanes that went on to a reflected ray
    // Scenes with refraction only: the lanes that went on to a refracted (or totally
    // reflected) ray, the material's transmit, and those rays, with `leaving` as for shade().
    M refracted;
    B transmit;
    V to, td;
    I t_leaving;
  };

  // A camera packet's closest hits found before it is shaded (render_rows' camera blocks):
  // shade() then takes them instead of tracing the packet's rays.
  struct GivenHit {
    B t;
    I id;
  };

  // Contract steps 4 and 5 for the lanes of `hit` over C channels of the lights (1: grey, the
  // colour then scales one sum; 3: coloured): shade[c] = (ambient + diffuse) + specular.
  // `here`: the sphere hit from outside (fast mode), which shadow rays leaving outwards skip.
  // kGlass false: grey opaque scenes, with no transparency code at all.
  struct Shade {
    B r, g, b;
  };
  // kSmooth: n is a smooth mesh's shading normal, and `side` the geometric normal facing the
  // ray, by whose side the shadow rays leave (the reference's n and side); else side is n.
  template <int C, bool kGlass, bool kOneRay = true, bool kSmooth = false>
  [[gnu::always_inline]] static Shade light_sums(const Prepared& s, const M& hit, const I& id,
                                                 const B& delta, const V& p, const V& n,
                                                 const V& view, const I& here, RayCounts& counts,
                                                 bool secondary, const V& side) noexcept {
    const B ka = gather(s, s.materials.ka, id), kd = gather(s, s.materials.kd, id);
    B ks(0), shininess(0), shininess_int(0);
    if (s.features.specular) {
      ks = gather(s, s.materials.ks, id);
      shininess = gather(s, s.materials.shininess, id);
      if constexpr (!kFast) shininess_int = gather(s, s.materials.shininess_int, id);
    }
    // Fast mode's shortcuts for shadow rays (below) assume opaque objects.
    const bool glass = kGlass && s.features.transparency;
    const bool shortcuts = kFast && !glass;
    B ambient[C], diffuse[C], specular[C];
    for (int c = 0; c < C; ++c) ambient[c] = diffuse[c] = specular[c] = B(0);
    for (int k = 0; k < s.num_lights; ++k) {
      for (int c = 0; c < C; ++c)
        ambient[c] = ambient[c] + ka * B(C == 1 ? s.lights.ambient[k] : s.lights.ambient_rgb[c][k]);
      const V to_light = V{B(s.lights.x[k]), B(s.lights.y[k]), B(s.lights.z[k])} - p;
      B dist;
      const V l = unit(to_light, dist);
      const M lit = hit & (dist > B(0));
      counts.shadow += count(lit);
      if (!xsimd::any(lit)) continue;
      const B cos_nl = Mth::dot(l, n);
      // Fast mode, opaque scenes: a light behind the surface is blocked by the surface itself
      // (the offset origin lies on the viewer's side), so its shadow ray is answered without
      // tracing; the rays traced all leave on the normal's side, and those leaving a sphere
      // from outside skip it. Through glass the surface passes part of the light: traced, and
      // only the rays leaving outwards skip their sphere.
      const M traced = shortcuts ? lit & (cos_nl > B(0)) : lit;
      const V from = kSmooth ? offset_origin(p, side, Mth::dot(l, side), delta)
                             : offset_origin(p, n, shortcuts ? B(1) : cos_nl, delta);
      I skip_sphere = here;
      if constexpr (kFast)
        if (!shortcuts) skip_sphere = xsimd::select(to_mi(cos_nl > B(0)), here, I(Id(-1)));
      lap(counts, kShading);
      occupancy(counts, secondary ? kSecondaryShadowRays : kShadowRays, traced);
      const Shadow sh = Q::template occluded<kGlass, kOneRay>(s, traced, from, l, dist, counts,
                                                              skip_sphere, secondary);
      const M unblocked = traced & sh.pending;
      lap(counts, secondary ? kSecondaryShadowRays : kShadowRays);
      if (!xsimd::any(unblocked)) continue;
      const B cos_term = positive_part(cosine(cos_nl));
      B spec_power(0);
      M spec_lanes(false);
      if (s.features.specular) {
        B half_len;
        const V h = unit(l + view, half_len);
        spec_lanes = unblocked & (half_len > B(0));
        spec_power = power(s, cosine(Mth::dot(n, h)), shininess, shininess_int);
      }
      for (int c = 0; c < C; ++c) {
        B intensity(C == 1 ? s.lights.intensity[k] : s.lights.intensity_rgb[c][k]);
        if (glass) intensity = intensity * sh.transmittance;
        diffuse[c] = xsimd::select(unblocked, diffuse[c] + (kd * intensity) * cos_term, diffuse[c]);
        if (s.features.specular)
          specular[c] =
              xsimd::select(spec_lanes, specular[c] + (ks * intensity) * spec_power, specular[c]);
      }
    }
    const B sum0 = (ambient[0] + diffuse[0]) + specular[0];
    if constexpr (C == 1)
      return {sum0, sum0, sum0};
    else
      return {sum0, (ambient[C - 2] + diffuse[C - 2]) + specular[C - 2],
              (ambient[C - 1] + diffuse[C - 1]) + specular[C - 1]};
  }

  // Coloured lights or transparency: out of line. Inlined beside the grey opaque sums they made
  // GCC stop inlining the intersection loops into render_rows, which cost grey opaque scenes
  // their speed (issue 13: a scene pays only for what it uses). Arguments by value: references
  // would give the hot path's vectors a home in memory.
  [[gnu::noinline]] static Shade general_light_sums(const Prepared& s, M hit, I id, B delta, V p,
                                                    V n, V view, I here, RayCounts& counts,
                                                    bool secondary, V side) noexcept {
    if (Prims::Meshes::smooth(s)) {
      if (s.features.coloured_lights)
        return light_sums<3, true, true, true>(s, hit, id, delta, p, n, view, here, counts,
                                               secondary, side);
      return light_sums<1, true, true, true>(s, hit, id, delta, p, n, view, here, counts, secondary,
                                             side);
    }
    if (s.features.coloured_lights)
      return light_sums<3, true>(s, hit, id, delta, p, n, view, here, counts, secondary, n);
    return light_sums<1, true>(s, hit, id, delta, p, n, view, here, counts, secondary, n);
  }

  // Shades the lanes of `active` at one level; returns the lanes that reflect further and sets
  // o, d to their reflected rays; in scenes with refraction, out.refracted, out.to, out.td to
  // the refracted ones. `stage`: the stage the ray's intersection is charged to.
  // `leaving` (fast mode): the sphere each lane's ray leaves from outside, -1 for none; set for
  // the reflected rays (out.t_leaving for the refracted ones).
  // kTree: the ray tree's levels (scenes with refraction); the chain's have no refraction code.
  template <bool kTree, bool kOneRay = true>
  [[gnu::always_inline]] static M shade(const Prepared& s, M active, int depth, int stage, V& o,
                                        V& d, I& leaving, Level& out, RayCounts& counts,
                                        const GivenHit* given = nullptr) noexcept {
    const B inf(std::numeric_limits<T>::infinity());
    B best_t = inf;
    I best_id(Id(-1));
    occupancy(counts, stage, active);
    M hit;
    if (given) {  // the camera blocks' hits: the same (t, id) as Q::template closest_hit<true>
                  // finds
      best_t = xsimd::select(active, given->t, inf);
      best_id = xsimd::select(to_mi(active), given->id, best_id);
      hit = active & (best_t < inf);
    } else {
      hit = depth == 0 && !s.camera.orthographic
                ? Q::template closest_hit<true>(s, active, o, d, best_t, best_id, counts)
                : closest_hit(s, active, o, d, best_t, best_id, counts, leaving, depth == 0);
    }
    lap(counts, stage);
    const T* miss_color = depth == 0 ? s.background : s.environment;
    out.r = B(miss_color[0]), out.g = B(miss_color[1]), out.b = B(miss_color[2]);
    out.reflected = M(false);
    out.refracted = M(false);
    if (!xsimd::any(hit)) return out.reflected;
    occupancy(counts, kShading, hit);

    // The hit point, its geometric normal and its secondary rays' offset (formulas.hpp):
    // p = o + t d, except on spheres small against |o|inf + t, where exact mode computes p
    // relative to the sphere, and huge ones, where it recomputes t accurately, as the reference.
    const B magnitude = hit_magnitude(o, best_t);
    V p = Mth::along(o, d, best_t);
    B delta = offset_delta<T>(magnitude);
    const I id = xsimd::select(to_mi(hit), Q::object_ids(s, best_id), I(0));
    V n{B(0), B(0), B(0)};
    Prims::All::each([&](auto kind) __attribute__((always_inline)) {
      using K = KindOf<decltype(kind)>;
      if (K::present(s)) K::surface(s, hit, best_id, id, o, d, best_t, magnitude, p, n, delta);
    });
    // The geometric normal's side: the ray enters the object where cos_in < 0 (step 7).
    // Smooth meshes shade with their blend of vertex normals, turned to the ray on its own;
    // rays leave by the geometric normal's side (the reference's n and side).
    V shading_n;
    const bool smooth = Prims::Meshes::smooth(s);
    if (smooth) {
      shading_n = Prims::Meshes::shading_normal(s, hit, best_id, o, d, n);
      shading_n = select3(Mth::dot(shading_n, d) > B(0), -shading_n, shading_n);
    }
    const B cos_in = Mth::dot(n, d);
    const M inside = cos_in > B(0);
    n = select3(inside, -n, n);
    if (!smooth) shading_n = n;
    const V view = -d;
    // The sphere hit from outside, which this level's shadow rays and reflections leave.
    I here(Id(-1));
    if constexpr (kFast)
      if (Prims::Bounded::present(s))
        here = Prims::Bounded::left_from_outside(s, hit & ~inside, best_id);

    const bool secondary = depth > 0;
    const Shade sum =
        s.features.coloured_lights || s.features.transparency || smooth
            ? general_light_sums(s, hit, id, delta, p, shading_n, view, here, counts, secondary, n)
            : light_sums<1, false, kOneRay>(s, hit, id, delta, p, n, view, here, counts, secondary,
                                            n);
    out.r = xsimd::select(hit, gather(s, s.materials.r, id) * sum.r, out.r);
    out.g = xsimd::select(hit, gather(s, s.materials.g, id) * sum.g, out.g);
    out.b = xsimd::select(hit, gather(s, s.materials.b, id) * sum.b, out.b);

    if (!(kTree || s.features.reflection) || depth >= s.max_depth) {
      lap(counts, kShading);
      return out.reflected;
    }
    // Refracted rays first, while o and d are still this level's rays; their term is added
    // after the reflection's all the same (radiance_tree).
    if constexpr (kTree) {
      refract_rays(s, hit, id, d, delta, p, n, shading_n, cos_in, here, out, counts);
      if (!s.features.reflection) {
        lap(counts, kShading);
        return out.reflected;
      }
    }
    out.reflect = gather(s, s.materials.reflect, id);
    out.reflected = hit & (out.reflect > B(0));
    if (xsimd::any(out.reflected)) {
      counts.reflected += count(out.reflected);
      // Normalised in fast mode too. Without it the error feeds back: the roots take |d| = 1,
      // so p lands off the sphere by about |t| (|d| - 1), (p - c) / r is off unit by as much
      // times t / r, and the next reflection's length by four times that: 1e-4 by the third
      // bounce inside a mirrored sphere, 2.4% of pixels off (FastMode.RaysInsideASphere...),
      // and 14 dB of PSNR lost on lorenzi-reflections, for 2.5% of speed.
      const V r = Mth::normalize(Mth::reflect(d, shading_n));
      // n faces the incoming ray, so the reflected one leaves on its side: r.n = -d.n >= 0.
      // Exact computes r.n as the reference does; fast takes the sign as known.
      const V from = offset_origin(p, n, kFast ? B(1) : Mth::dot(r, n), delta);
      o = select3(out.reflected, from, o);
      d = select3(out.reflected, r, d);
      if constexpr (kFast) leaving = here;
    }
    lap(counts, kShading);
    return out.reflected;
  }

  // Contract step 7 for the lanes of `hit` whose material transmits: out.refracted and their
  // rays out.to, out.td. eta is 1 / ior entering (cos_in < 0 for the geometric normal), ior
  // leaving; where k < 0 (total internal reflection) the ray takes the mirror direction. The
  // refracted ray leaves on the far side of the surface (t.n = -sqrt(k) <= 0), so its origin
  // moves there. Fast mode: a refracted ray may meet the sphere it crosses again, so it skips
  // nothing; a totally reflected one leaves on the near side like a reflection.
  [[gnu::always_inline]] static void refract_rays(const Prepared& s, const M& hit, const I& id,
                                                  const V& d, const B& delta, const V& p,
                                                  const V& n, const V& shading_n, const B& cos_in,
                                                  const I& here, Level& out,
                                                  RayCounts& counts) noexcept {
    out.transmit = gather(s, s.materials.transmit, id);
    out.refracted = hit & (out.transmit > B(0));
    if (!xsimd::any(out.refracted)) return;
    lap(counts, kShading);
    counts.refracted += count(out.refracted);
    const B eta = xsimd::select(cos_in < B(0), gather(s, s.materials.inv_ior, id),
                                gather(s, s.materials.ior, id));
    const Refraction<B> rf = refract<Mth>(d, shading_n, eta);
    const M through = rf.k >= B(0);
    V t = Mth::normalize(rf.dir);
    if (!xsimd::all(through | ~out.refracted))
      t = select3(through, t, Mth::normalize(Mth::reflect(d, shading_n)));
    const B side = kFast ? xsimd::select(through, B(T(-1)), B(T(1))) : Mth::dot(t, n);
    out.to = offset_origin(p, n, side, delta);
    out.td = t;
    out.t_leaving = xsimd::select(to_mi(through), I(Id(-1)), here);
    lap(counts, kRefraction);
  }
};

}  // namespace lancer::packet
