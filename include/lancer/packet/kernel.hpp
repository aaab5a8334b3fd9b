// The packet kernels, one source for every width: Kernel<Arch> works on W = batch<float,Arch>
// lanes at once, structure-of-arrays. Include only from src/isa/*.cpp (built with that ISA's
// flags) and instantiate explicitly there.
//
// Conventions (after Embree's intersectors): a kernel takes a `valid` mask, narrows it test by
// test, and never writes a lane outside it. Kernels are noexcept; they report through masks.
// Exact mode: every formula comes from formulas.hpp, as in the reference, in the same order.
#pragma once

#include <array>
#include <cmath>
#include <limits>
#include <type_traits>
#include <vector>
#include <xsimd/xsimd.hpp>

#include "lancer/formulas.hpp"
#include "lancer/packet/api.hpp"

namespace lancer::packet {

template <class Arch>
struct Kernel {
  using T = float;
  using B = xsimd::batch<T, Arch>;
  using M = xsimd::batch_bool<T, Arch>;
  using I = xsimd::batch<std::int32_t, Arch>;
  using V = Vec3<B>;
  static constexpr int W = static_cast<int>(B::size);
  using Scene = PreparedScene<T>;
  static_assert(W <= kMaxLanes, "camera tables are padded for kMaxLanes lanes");

  static B iota() noexcept {
    alignas(64) T v[W];
    for (int k = 0; k < W; ++k) v[k] = T(k);
    return B::load_aligned(v);
  }

  // The mask as one bit per lane. xsimd 8.1 has no mask(), so per ISA: AVX-512 masks already
  // are bits; SSE and AVX masks are vectors whose sign bits movemask collects.
  static unsigned bits(const M& m) noexcept {
    const auto r = static_cast<typename M::register_type>(m);
    if constexpr (std::is_same_v<Arch, xsimd::avx512f>)
      return static_cast<unsigned>(r);
    else if constexpr (W == 8)
      return static_cast<unsigned>(_mm256_movemask_ps(r));
    else
      return static_cast<unsigned>(_mm_movemask_ps(r));
  }

  // Active lanes of a mask.
  static std::uint64_t count(const M& m) noexcept {
    return static_cast<std::uint64_t>(__builtin_popcount(bits(m)));
  }

  // Object ids are carried as floats (exact below 2^24) so that they blend with the same masks
  // as the distances; converted to integers only to gather.
  static B gather(const std::vector<T>& field, const I& index) noexcept {
    return B::gather(field.data(), index);
  }

  // Closest hit over all objects for the lanes in `valid`. Updates t and id only where a nearer
  // hit is found; returns the lanes whose t is now finite (hit by something).
  // kFromEye: every ray leaves the pinhole eye, so f and c per sphere come precomputed.
  template <bool kFromEye = false>
  static M closest_hit(const Scene& s, M valid, const V& o, const V& d, B& best_t,
                       B& best_id) noexcept {
    const B eps(s.epsilon);
    if (s.features.spheres) {
      for (int i = 0; i < s.num_spheres; ++i) {
        const B r2(s.sphere_r2[i]);
        const V f = kFromEye ? V{B(s.eye.fx[i]), B(s.eye.fy[i]), B(s.eye.fz[i])}
                             : o - V{B(s.sphere_cx[i]), B(s.sphere_cy[i]), B(s.sphere_cz[i])};
        const SphereDisc<B> sd = sphere_disc(f, d, r2);
        M m = valid & (sd.disc >= B(0));
        if (!xsimd::any(m)) continue;
        const B c = kFromEye ? B(s.eye.c[i]) : sphere_c(f, r2);
        const B t = sphere_first_root(sphere_roots(sd, c), eps);
        m = m & (t > eps) & (t < best_t);
        best_t = xsimd::select(m, t, best_t);
        best_id = xsimd::select(m, B(T(i)), best_id);
      }
    }
    if (s.features.planes) {
      for (int k = 0; k < s.num_planes; ++k) {
        const V n{B(s.plane_nx[k]), B(s.plane_ny[k]), B(s.plane_nz[k])};
        const B denom = dot(d, n);
        const B t = dot(V{B(s.plane_px[k]), B(s.plane_py[k]), B(s.plane_pz[k])} - o, n) / denom;
        const M m = valid & (denom != B(0)) & (t > eps) & (t < best_t);
        best_t = xsimd::select(m, t, best_t);
        best_id = xsimd::select(m, B(T(s.num_spheres + k)), best_id);
      }
    }
    return valid & (best_t < B(std::numeric_limits<T>::infinity()));
  }

  // Any-hit for shadow rays from p along unit l: the lanes of `valid` blocked before `dist`.
  // Stops as soon as every lane of `valid` is blocked.
  static M occluded(const Scene& s, M valid, const V& p, const V& l, const B& dist) noexcept {
    const B eps(s.epsilon);
    M pending = valid;
    for (int i = 0; i < s.num_spheres; ++i) {
      const V f = p - V{B(s.sphere_cx[i]), B(s.sphere_cy[i]), B(s.sphere_cz[i])};
      const B r2(s.sphere_r2[i]);
      const SphereDisc<B> sd = sphere_disc(f, l, r2);
      M m = pending & (sd.disc >= B(0));
      if (!xsimd::any(m)) continue;
      const B t = sphere_first_root(sphere_roots(sd, sphere_c(f, r2)), eps);
      m = m & (t > eps) & (t < dist);
      pending = pending & ~m;
      if (!xsimd::any(pending)) return valid;
    }
    for (int k = 0; k < s.num_planes; ++k) {
      const V n{B(s.plane_nx[k]), B(s.plane_ny[k]), B(s.plane_nz[k])};
      const B denom = dot(l, n);
      const B t = dot(V{B(s.plane_px[k]), B(s.plane_py[k]), B(s.plane_pz[k])} - p, n) / denom;
      const M m = pending & (denom != B(0)) & (t > eps) & (t < dist);
      pending = pending & ~m;
      if (!xsimd::any(pending)) return valid;
    }
    return valid & ~pending;
  }

  // max(0, c)^shininess per lane: binary powering for whole exponents; std::pow lane by lane
  // for the rare fractional ones, exactly as the reference does for that material.
  static B power(const Scene& s, const B& cos_nh, const B& shininess,
                 const B& shininess_int) noexcept {
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

  // One bounce level of a packet: what the recursion of the reference keeps on its stack.
  struct Level {
    B r, g, b;      // local colour (or background/environment where the ray missed)
    B reflect;      // the hit material's reflection coefficient
    M reflected;    // lanes that went on to a reflected ray
  };

  // Shades the lanes of `active` at one level; returns the lanes that reflect further and sets
  // o, d to their reflected rays.
  static M shade(const Scene& s, M active, int depth, V& o, V& d, Level& out,
                 RayCounts& counts) noexcept {
    B best_t(std::numeric_limits<T>::infinity());
    B best_id(T(-1));
    const M hit = depth == 0 && !s.camera.orthographic
                      ? closest_hit<true>(s, active, o, d, best_t, best_id)
                      : closest_hit(s, active, o, d, best_t, best_id);
    const T* miss_color = depth == 0 ? s.background : s.environment;
    out.r = B(miss_color[0]), out.g = B(miss_color[1]), out.b = B(miss_color[2]);
    out.reflected = M(false);
    if (!xsimd::any(hit)) return out.reflected;

    const V p = along(o, d, best_t);
    const I id = xsimd::batch_cast<std::int32_t>(xsimd::select(hit, best_id, B(0)));
    V n{B(0), B(0), B(0)};
    if (s.features.spheres) {
      const I sid = xsimd::min(id, I(s.num_spheres - 1));
      const B r = gather(s.sphere_r, sid);
      n = V{(p.x - gather(s.sphere_cx, sid)) / r, (p.y - gather(s.sphere_cy, sid)) / r,
            (p.z - gather(s.sphere_cz, sid)) / r};
    }
    if (s.features.planes) {
      const I pid = xsimd::max(id - I(s.num_spheres), I(0));
      const V pn{gather(s.plane_nx, pid), gather(s.plane_ny, pid), gather(s.plane_nz, pid)};
      if (s.features.spheres) {
        const M on_sphere = best_id < B(T(s.num_spheres));
        n = V{xsimd::select(on_sphere, n.x, pn.x), xsimd::select(on_sphere, n.y, pn.y),
              xsimd::select(on_sphere, n.z, pn.z)};
      } else {
        n = pn;
      }
    }
    const M flip = dot(n, d) > B(0);
    n = V{xsimd::select(flip, -n.x, n.x), xsimd::select(flip, -n.y, n.y),
          xsimd::select(flip, -n.z, n.z)};
    const V view = -d;

    const B ka = gather(s.mat_ka, id), kd = gather(s.mat_kd, id);
    B ks(0), shininess(0), shininess_int(0);
    if (s.features.specular) {
      ks = gather(s.mat_ks, id);
      shininess = gather(s.mat_shininess, id);
      shininess_int = gather(s.mat_shininess_int, id);
    }
    B ambient(0), diffuse(0), specular(0);
    for (int k = 0; k < s.num_lights; ++k) {
      ambient = ambient + ka * B(s.light_ambient[k]);
      const V to_light = V{B(s.light_x[k]), B(s.light_y[k]), B(s.light_z[k])} - p;
      const B dist = length(to_light);
      const M lit = hit & (dist > B(0));
      counts.shadow += count(lit);
      if (!xsimd::any(lit)) continue;
      const V l = to_light / dist;
      const V from = offset_origin<B, T>(p, n, dot(l, n), o, best_t);
      const M unblocked = lit & ~occluded(s, lit, from, l, dist);
      if (!xsimd::any(unblocked)) continue;
      const B intensity(s.light_intensity[k]);
      diffuse = xsimd::select(unblocked, diffuse + (kd * intensity) * positive_part(dot(n, l)),
                              diffuse);
      if (s.features.specular) {
        const V half = l + view;
        const B half_len = length(half);
        const M m = unblocked & (half_len > B(0));
        const V h = half / half_len;
        const B term = (ks * intensity) * power(s, dot(n, h), shininess, shininess_int);
        specular = xsimd::select(m, specular + term, specular);
      }
    }
    const B shade_k = (ambient + diffuse) + specular;
    out.r = xsimd::select(hit, gather(s.mat_r, id) * shade_k, out.r);
    out.g = xsimd::select(hit, gather(s.mat_g, id) * shade_k, out.g);
    out.b = xsimd::select(hit, gather(s.mat_b, id) * shade_k, out.b);

    if (!s.features.reflection || depth >= s.max_depth) return out.reflected;
    out.reflect = gather(s.mat_reflect, id);
    out.reflected = hit & (out.reflect > B(0));
    if (xsimd::any(out.reflected)) {
      counts.reflected += count(out.reflected);
      const V r = normalize(reflect(d, n));
      const V from = offset_origin<B, T>(p, n, dot(r, n), o, best_t);
      o = V{xsimd::select(out.reflected, from.x, o.x), xsimd::select(out.reflected, from.y, o.y),
            xsimd::select(out.reflected, from.z, o.z)};
      d = V{xsimd::select(out.reflected, r.x, d.x), xsimd::select(out.reflected, r.y, d.y),
            xsimd::select(out.reflected, r.z, d.z)};
    }
    return out.reflected;
  }

  // The radiance of a packet of camera rays. Reflection is an iterative loop over levels with
  // an active mask; the levels are then folded from the deepest up, local + reflect * child,
  // which is the order the reference's recursion adds in (a running weight would not be).
  static void radiance(const Scene& s, M active, V o, V d, std::vector<Level>& levels, B& r,
                       B& g, B& b, RayCounts& counts) noexcept {
    int depth = 0;
    for (;;) {
      active = shade(s, active, depth, o, d, levels[depth], counts);
      if (!xsimd::any(active)) break;
      ++depth;
    }
    r = levels[depth].r, g = levels[depth].g, b = levels[depth].b;
    for (int k = depth - 1; k >= 0; --k) {
      const Level& lv = levels[k];
      r = xsimd::select(lv.reflected, lv.r + lv.reflect * r, lv.r);
      g = xsimd::select(lv.reflected, lv.g + lv.reflect * g, lv.g);
      b = xsimd::select(lv.reflected, lv.b + lv.reflect * b, lv.b);
    }
  }

  // Camera rays of columns i0 .. i0+W-1 of row j at sub-sample (a, b); screen coordinates come
  // from the camera's tables, computed once by the same formula.
  static void camera_packet(const Scene& s, int i0, int j, int a, int b, V& o, V& d) noexcept {
    const PreparedCamera<T>& cam = s.camera;
    const B x = B::load_unaligned(&cam.screen_x[std::size_t(a) * cam.nx + i0]);
    const B y(cam.screen_y[std::size_t(b) * cam.ny + j]);
    camera_ray(cam, x, y, o, d);
  }

  static void render_rows(const Scene& s, Image& image, int row_begin, int row_end,
                          RayCounts& counts) noexcept {
    const PreparedCamera<T>& cam = s.camera;
    const B lane = iota();
    const B samples = B(T(cam.samples * cam.samples));
    std::vector<Level> levels(static_cast<std::size_t>(s.max_depth) + 1);
    alignas(64) T out[3][W];
    for (int j = row_begin; j < row_end; ++j) {
      for (int i0 = 0; i0 < cam.nx; i0 += W) {
        const int lanes = std::min(W, cam.nx - i0);
        const M valid = lane < B(T(lanes));
        B sr(0), sg(0), sb(0);
        for (int b = 0; b < cam.samples; ++b) {
          for (int a = 0; a < cam.samples; ++a) {
            V o, d;
            camera_packet(s, i0, j, a, b, o, d);
            counts.camera += lanes;
            B r, g, bl;
            radiance(s, valid, o, d, levels, r, g, bl, counts);
            sr = sr + r, sg = sg + g, sb = sb + bl;
          }
        }
        (sr / samples).store_aligned(out[0]);
        (sg / samples).store_aligned(out[1]);
        (sb / samples).store_aligned(out[2]);
        for (int k = 0; k < lanes; ++k) {
          float* px = image.pixel(i0 + k, j);
          px[0] = out[0][k], px[1] = out[1][k], px[2] = out[2][k];
        }
      }
    }
  }

  static void primary_rows(const Scene& s, float* t_out, int row_begin, int row_end,
                           RayCounts& counts) noexcept {
    const PreparedCamera<T>& cam = s.camera;
    const B lane = iota();
    alignas(64) T out[W];
    for (int j = row_begin; j < row_end; ++j) {
      for (int i0 = 0; i0 < cam.nx; i0 += W) {
        const int lanes = std::min(W, cam.nx - i0);
        const M valid = lane < B(T(lanes));
        B sum(0);
        for (int b = 0; b < cam.samples; ++b) {
          for (int a = 0; a < cam.samples; ++a) {
            V o, d;
            camera_packet(s, i0, j, a, b, o, d);
            counts.camera += lanes;
            B t(std::numeric_limits<T>::infinity()), id(T(-1));
            if (cam.orthographic)
              closest_hit(s, valid, o, d, t, id);
            else
              closest_hit<true>(s, valid, o, d, t, id);
            sum = sum + t;
          }
        }
        float* row = t_out + std::size_t(j) * cam.nx + i0;
        if (lanes == W) {
          sum.store_unaligned(row);
        } else {
          sum.store_aligned(out);
          for (int k = 0; k < lanes; ++k) row[k] = out[k];
        }
      }
    }
  }

  static void closest_hit_packet(const Scene& s, const bool* valid, const float* rays, float* t,
                                 float* id, bool* hit_out) noexcept {
    const M v = M::load_unaligned(valid);
    const V o{B::load_unaligned(rays), B::load_unaligned(rays + W),
              B::load_unaligned(rays + 2 * W)};
    const V d{B::load_unaligned(rays + 3 * W), B::load_unaligned(rays + 4 * W),
              B::load_unaligned(rays + 5 * W)};
    B bt = B::load_unaligned(t), bid = B::load_unaligned(id);
    const M hit = closest_hit(s, v, o, d, bt, bid);
    bt.store_unaligned(t);
    bid.store_unaligned(id);
    const unsigned hb = bits(hit);
    for (int k = 0; k < W; ++k) hit_out[k] = (hb >> k) & 1u;
  }
};

template <class Arch>
void render_rows(Arch, const PreparedScene<float>& scene, Image& image, int row_begin,
                 int row_end, RayCounts& counts) {
  Kernel<Arch>::render_rows(scene, image, row_begin, row_end, counts);
}

template <class Arch>
void primary_rows(Arch, const PreparedScene<float>& scene, float* t_out, int row_begin,
                  int row_end, RayCounts& counts) {
  Kernel<Arch>::primary_rows(scene, t_out, row_begin, row_end, counts);
}

template <class Arch>
void closest_hit_packet(Arch, const PreparedScene<float>& scene, const bool* valid,
                        const float* rays, float* t, float* id, bool* hit_out) {
  Kernel<Arch>::closest_hit_packet(scene, valid, rays, t, id, hit_out);
}

}  // namespace lancer::packet
