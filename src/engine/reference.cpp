// The scalar reference renderer. Read it beside SCENE-MODEL.md: each step is numbered as there.
#include "lancer/reference.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include "lancer/formulas.hpp"
#include "lancer/shapes.hpp"
#include "lancer/traverse.hpp"

namespace lancer::reference {

namespace {

template <class T>
using Color = std::array<T, 3>;

// Step 1 over every object; `shape` gets the primitive and part of a triangle, mesh or
// cylinder hit (object -1 otherwise).
template <class T>
Hit<T> closest_hit_detail(const PreparedScene<T>& s, const Vec3<T>& origin, const Vec3<T>& dir,
                          ShapeHit<T>& shape, T eps);

template <class T>
class Tracer {
 public:
  Tracer(const PreparedScene<T>& scene, RayCounts& counts, PathLog* log = nullptr)
      : s_(scene), counts_(counts), log_(log) {}

  // The camera ray traced next, for the log.
  void set_pixel(int pixel, int sample) {
    pixel_ = pixel;
    sample_ = sample;
  }

  // trace(origin, dir, depth) of the contract; dir is unit length. `kind` is what the ray is,
  // for the log.
  Color<T> trace(const Vec3<T>& origin, const Vec3<T>& dir, int depth,
                 PathLog::Segment::Kind kind = PathLog::Segment::camera) {
    // 1. The closest hit with t > epsilon.
    ShapeHit<T> shape;
    const Hit<T> hit = closest_hit_detail(s_, origin, dir, shape, s_.epsilon);
    if (log_) log_ray(origin, dir, depth, hit, kind);
    // 2. No hit: background for camera rays, environment for secondary ones.
    if (hit.id < 0) {
      const T* c = depth == 0 ? s_.background : s_.environment;
      return {c[0], c[1], c[2]};
    }
    // 3. The hit point and the normal facing the ray; the geometric normal's side tells
    // whether the ray enters the object (step 7).
    Vec3<T> shading;
    const SurfacePoint<T> at = surface_point(hit.id, shape, origin, dir, hit.t, shading);
    const Vec3<T>& p = at.p;
    const Vec3<T>& geometric = at.normal;
    const T cos_in = dot(geometric, dir);
    // The shading normal faces the ray (a smooth mesh's blend, else the geometric normal);
    // secondary rays leave by the side of the surface itself, the geometric normal's.
    const Vec3<T> n = dot(shading, dir) > T(0) ? -shading : shading;
    const Vec3<T> side = cos_in > T(0) ? -geometric : geometric;
    const Vec3<T> view = -dir;

    // 4 and 5. One shading sum scaled by the colour for grey lights, one per channel otherwise:
    // the same bits per channel when the channels are equal.
    const int m = hit.id;
    Color<T> local = s_.features.coloured_lights ? lights<3>(at.delta, p, n, side, view, m, depth)
                                                 : lights<1>(at.delta, p, n, side, view, m, depth);

    // 6. Mirror reflection, recursively.
    const T reflect_k = s_.materials.reflect[m];
    if (depth < s_.max_depth && reflect_k > T(0)) {
      ++counts_.reflected;
      const Vec3<T> r = normalize(reflect(dir, n));
      const Color<T> child = trace(offset_origin(p, side, dot(r, side), at.delta), r, depth + 1,
                                   PathLog::Segment::reflected);
      for (int c = 0; c < 3; ++c) local[c] = local[c] + reflect_k * child[c];
    }
    // 7. Refraction (Snell-Descartes), or the mirror direction where the light is totally
    // reflected; added after step 6's term. The refracted ray leaves on the far side of the
    // surface (t.n < 0), and offset_origin moves it there.
    const T transmit_k = s_.materials.transmit[m];
    if (depth < s_.max_depth && transmit_k > T(0)) {
      ++counts_.refracted;
      const T eta = cos_in < T(0) ? s_.materials.inv_ior[m] : s_.materials.ior[m];
      const Refraction<T> rf = refract(dir, n, eta);
      const Vec3<T> t = rf.k >= T(0) ? normalize(rf.dir) : normalize(reflect(dir, n));
      const Color<T> child = trace(offset_origin(p, side, dot(t, side), at.delta), t, depth + 1,
                                   PathLog::Segment::refracted);
      for (int c = 0; c < 3; ++c) local[c] = local[c] + transmit_k * child[c];
    }
    // 8.
    return local;
  }

 private:
  // Steps 4 and 5 over C channels of the lights (1: grey, 3: coloured): each light's ambient
  // always; diffuse and specular scaled by the light's transmittance where it is not 0.
  template <int C>
  // n: the shading normal facing the ray; side: the geometric one facing it, for the shadow
  // rays' origins (the same as n but on smooth meshes).
  [[gnu::always_inline]] Color<T> lights(const T& delta, const Vec3<T>& p, const Vec3<T>& n,
                                         const Vec3<T>& side, const Vec3<T>& view, int m,
                                         int depth) {
    const auto& in = s_.lights.intensity_rgb;
    const auto& am = s_.lights.ambient_rgb;
    T ambient[C], diffuse[C], specular[C];
    for (int c = 0; c < C; ++c) ambient[c] = diffuse[c] = specular[c] = T(0);
    for (int k = 0; k < s_.num_lights; ++k) {
      for (int c = 0; c < C; ++c)
        ambient[c] = ambient[c] + s_.materials.ka[m] * (C == 1 ? s_.lights.ambient[k] : am[c][k]);
      const Vec3<T> to_light = Vec3<T>{s_.lights.x[k], s_.lights.y[k], s_.lights.z[k]} - p;
      const T dist = length(to_light);
      if (!(dist > T(0))) continue;  // a light on the surface itself lights nothing
      ++counts_.shadow;
      const Vec3<T> l = to_light / dist;
      const Vec3<T> from = offset_origin(p, side, dot(l, side), delta);
      const T transmittance = s_.features.transparency ? shadow_transmittance<true>(from, l, dist)
                                                       : shadow_transmittance<false>(from, l, dist);
      if (log_) log_light(p, k, depth, transmittance == T(0));
      if (transmittance == T(0)) continue;
      const T cos_nl = positive_part(dot(n, l));
      T spec_power(0);
      bool spec = false;
      if (s_.features.specular) {
        const Vec3<T> half = l + view;
        const T half_len = length(half);
        if (half_len > T(0)) {
          spec = true;
          spec_power = power(dot(n, half / half_len), m);
        }
      }
      for (int c = 0; c < C; ++c) {
        T intensity = C == 1 ? s_.lights.intensity[k] : in[c][k];
        if (s_.features.transparency) intensity = intensity * transmittance;
        diffuse[c] = diffuse[c] + (s_.materials.kd[m] * intensity) * cos_nl;
        if (spec) specular[c] = specular[c] + (s_.materials.ks[m] * intensity) * spec_power;
      }
    }
    const T color[3] = {s_.materials.r[m], s_.materials.g[m], s_.materials.b[m]};
    Color<T> local;
    for (int c = 0; c < 3; ++c) {
      const int k = C == 1 ? 0 : c;
      local[c] = color[c] * ((ambient[k] + diffuse[k]) + specular[k]);
    }
    return local;
  }

  // Step 3's point and geometric normal, and the offset of the rays that leave it.
  // `shading` gets the normal shading uses (differs from the geometric one on smooth meshes).
  [[gnu::always_inline]] SurfacePoint<T> surface_point(int id, const ShapeHit<T>& shape,
                                                       const Vec3<T>& origin, const Vec3<T>& dir,
                                                       const T& t, Vec3<T>& shading) const {
    const T magnitude = hit_magnitude(origin, t);
    SurfacePoint<T> at;
    if (id < s_.num_spheres) {
      const Vec3<T> c{s_.spheres.cx[id], s_.spheres.cy[id], s_.spheres.cz[id]};
      const T r2 = s_.spheres.r2[id];
      if (sphere_is_small(r2, magnitude) || sphere_is_large(r2, magnitude))
        at = sphere_point_extreme(origin, dir, t, c, r2, magnitude);
      else
        at = sphere_point_along<T>(origin, dir, t, c, magnitude);
    } else if (id < s_.num_spheres + s_.num_planes) {
      const int k = id - s_.num_spheres;
      at = {along(origin, dir, t),
            {s_.planes.nx[k], s_.planes.ny[k], s_.planes.nz[k]},
            offset_delta<T>(magnitude)};
    } else {
      at.p = along(origin, dir, t);
      at.delta = offset_delta<T>(magnitude);
      shapes_normals(*s_.shapes, shape, origin, dir, at.p, at.normal, shading);
      return at;
    }
    shading = at.normal;
    return at;
  }

  // Spheres small or huge against the hit's magnitude: out of the hot path.
  [[gnu::noinline, gnu::cold]] static SurfacePoint<T> sphere_point_extreme(const Vec3<T>& origin,
                                                                           const Vec3<T>& dir, T t,
                                                                           const Vec3<T>& c, T r2,
                                                                           T magnitude) {
    if (sphere_is_small(r2, magnitude)) return sphere_point_local<T>(origin, dir, t, c, r2);
    return sphere_point_large<T>(origin, dir, t, c, r2, magnitude);
  }

  T power(const T& cos_nh, int m) const {
    const T shininess = s_.materials.shininess[m];
    if (s_.materials.shininess_int[m] != T(0)) return specular_power(cos_nh, shininess);
    return std::pow(positive_part(cos_nh), shininess);
  }

  // The transmittance towards a light at `dist` along unit l from p (contract step 4): the
  // product of transmit over the objects met (nearest hit beyond epsilon nearer than the light),
  // each once; 0 as soon as it is 0 (an opaque object). A float product of three or more factors
  // depends on their order, so the order is fixed: spheres through the hierarchy where there is
  // one (its fixed depth-first order, as the packets visit it), else in id order, and in id
  // order where the spheres are leaves of the shapes' hierarchy too (one hierarchy over every
  // bounded kind: the packets meet them in its walk and sort them); then planes.
  // kGlass: some object transmits, so the product of transmittances is taken; without it
  // (every scene before glass) the first object met blocks the light and the walk ends there,
  // as cheap as a plain occlusion test.
  template <bool kGlass>
  T shadow_transmittance(const Vec3<T>& p, const Vec3<T>& l, const T& dist) const {
    const T eps = s_.epsilon;
    T transmittance(1);
    const bool by_id = kGlass && s_.features.spheres_in_shapes;
    spheres_met_.clear();
    // Meets sphere (cx, cy, cz, r2), object `id`: returns true once the light is blocked.
    auto sphere = [&](const T& cx, const T& cy, const T& cz, const T& r2, int id) {
      const Vec3<T> f = p - Vec3<T>{cx, cy, cz};
      const SphereDisc<T> sd = sphere_disc(f, l, r2);
      if (!(sd.disc >= T(0))) return false;
      const T t = sphere_first_root(sphere_roots(sd, sphere_c(f, r2)), eps);
      if (!(t > eps && t < dist)) return false;
      if (by_id) {
        spheres_met_.push_back(id);
        return false;
      }
      transmittance = kGlass ? attenuate(transmittance, s_.materials.transmit[id]) : T(0);
      return transmittance == T(0);
    };
    const Bvh<T>& h = s_.bvh;
    if (h.active() && !RayTraversal<T>::beyond(h, p)) {
      const bool blocked = RayTraversal<T>(h, p, l).any(dist, [&](int first, int count) {
        for (int j = first; j < first + count; ++j)
          if (sphere(h.cx[j], h.cy[j], h.cz[j], h.r2[j], h.id[j])) return true;
        return false;
      });
      if (blocked) return transmittance;
    } else {
      for (int i = 0; i < s_.num_spheres; ++i)
        if (sphere(s_.spheres.cx[i], s_.spheres.cy[i], s_.spheres.cz[i], s_.spheres.r2[i], i))
          return transmittance;
    }
    std::sort(spheres_met_.begin(), spheres_met_.end());
    for (const int id : spheres_met_) {
      transmittance = attenuate(transmittance, s_.materials.transmit[id]);
      if (transmittance == T(0)) return transmittance;
    }
    for (int k = 0; k < s_.num_planes; ++k) {
      const Vec3<T> normal{s_.planes.nx[k], s_.planes.ny[k], s_.planes.nz[k]};
      const T denom = dot(l, normal);
      if (denom == T(0)) continue;
      const T t =
          dot(Vec3<T>{s_.planes.px[k], s_.planes.py[k], s_.planes.pz[k]} - p, normal) / denom;
      if (t > eps && t < dist) {
        if (!kGlass) return T(0);
        transmittance = attenuate(transmittance, s_.materials.transmit[s_.num_spheres + k]);
        if (transmittance == T(0)) return transmittance;
      }
    }
    // Triangles, meshes and cylinders last, each object once (a mesh is one), in id order.
    if (s_.shapes) {
      shapes_met(*s_.shapes, p, l, eps, dist, !kGlass, met_);
      for (const int id : met_) {
        if (!kGlass) return T(0);
        transmittance = attenuate(transmittance, s_.materials.transmit[id]);
        if (transmittance == T(0)) return transmittance;
      }
    }
    return transmittance;
  }

  // The path log's records: off the normal render's way, out of line.
  // A point or a direction of the prepared (camera) frame in world coordinates.
  Vec3<double> to_world(const Vec3<T>& a) const { return s_.frame.world_point(to_double(a)); }
  Vec3<double> to_world_direction(const Vec3<T>& a) const {
    return s_.frame.world_direction(to_double(a));
  }
  static Vec3<double> to_double(const Vec3<T>& a) {
    return {double(a.x), double(a.y), double(a.z)};
  }
  void log_ray(const Vec3<T>& origin, const Vec3<T>& dir, int depth, const Hit<T>& hit,
               PathLog::Segment::Kind kind) {
    PathLog::Segment seg;
    seg.kind = kind;
    seg.from = to_world(origin);
    seg.hit = hit.id >= 0;
    seg.to = seg.hit ? to_world(along(origin, dir, hit.t))
                     : along(seg.from, to_world_direction(dir), log_->miss_length);
    seg.depth = depth;
    seg.pixel = pixel_;
    seg.sample = sample_;
    seg.id = hit.id;
    log_->segments.push_back(seg);
  }
  void log_light(const Vec3<T>& p, int k, int depth, bool shadowed) {
    PathLog::Segment seg;
    seg.kind = PathLog::Segment::light;
    seg.from = to_world(p);
    seg.to = to_world(Vec3<T>{s_.lights.x[k], s_.lights.y[k], s_.lights.z[k]});
    seg.hit = shadowed;
    seg.depth = depth;
    seg.pixel = pixel_;
    seg.sample = sample_;
    seg.id = k;
    log_->segments.push_back(seg);
  }

  const PreparedScene<T>& s_;
  mutable std::vector<int> met_;          // shapes_met's list, kept between shadow rays
  mutable std::vector<int> spheres_met_;  // the spheres met, where taken in id order
  RayCounts& counts_;
  PathLog* log_ = nullptr;  // null but in render_rows_recorded
  int pixel_ = 0, sample_ = 0;
};

// render_rows and render_rows_recorded: the same loop, with a log or without.
template <class T>
void render_rows_impl(const PreparedScene<T>& s, Image& image, int row_begin, int row_end,
                      RayCounts& counts, PathLog* log) {
  const PreparedCamera<T>& cam = s.camera;
  const T samples = T(cam.samples * cam.samples);
  Tracer<T> tracer(s, counts, log);
  for (int j = row_begin; j < row_end; ++j) {
    for (int i = 0; i < cam.nx; ++i) {
      Color<T> sum{T(0), T(0), T(0)};
      for (int b = 0; b < cam.samples; ++b) {
        for (int a = 0; a < cam.samples; ++a) {
          const T x = screen_x(cam, T(i), cam.sub_offset[a]);
          const T y = screen_y(cam, T(j), cam.sub_offset[b]);
          Vec3<T> origin, dir;
          camera_ray(cam, x, y, origin, dir);
          ++counts.camera;
          if (log) tracer.set_pixel(j * cam.nx + i, b * cam.samples + a);
          const Color<T> c = tracer.trace(origin, dir, 0);
          for (int k = 0; k < 3; ++k) sum[k] = sum[k] + c[k];
        }
      }
      float* out = image.pixel(i, j);
      for (int k = 0; k < 3; ++k) out[k] = static_cast<float>(sum[k] / samples);
    }
  }
}

}  // namespace

template <class T>
Hit<T> closest_hit(const PreparedScene<T>& s, const Vec3<T>& origin, const Vec3<T>& dir) {
  ShapeHit<T> shape;
  return closest_hit_detail(s, origin, dir, shape, s.epsilon);
}

template <class T>
Hit<T> closest_hit(const PreparedScene<T>& s, const Vec3<T>& origin, const Vec3<T>& dir,
                   const T eps) {
  ShapeHit<T> shape;
  return closest_hit_detail(s, origin, dir, shape, eps);
}

template <class T>
Hit<T> closest_hit(const PreparedScene<T>& s, const Vec3<T>& origin, const Vec3<T>& dir,
                   const T eps, ShapeHit<T>& shape) {
  return closest_hit_detail(s, origin, dir, shape, eps);
}

namespace {

template <class T>
Hit<T> closest_hit_detail(const PreparedScene<T>& s, const Vec3<T>& origin, const Vec3<T>& dir,
                          ShapeHit<T>& shape, const T eps) {
  // A hit must be nearer than infinity: a plane hit whose t overflows is no hit.
  Hit<T> best{-1, std::numeric_limits<T>::infinity()};
  const Bvh<T>& h = s.bvh;
  if (h.active() && !RayTraversal<T>::beyond(h, origin)) {
    // The same spheres in another order: the lexicographic minimum of (t, id) is the loop's.
    RayTraversal<T>(h, origin, dir).closest(best.t, [&](int first, int count) {
      for (int j = first; j < first + count; ++j) {
        const Vec3<T> f = origin - Vec3<T>{h.cx[j], h.cy[j], h.cz[j]};
        const SphereDisc<T> sd = sphere_disc(f, dir, h.r2[j]);
        if (!(sd.disc >= T(0))) continue;
        const T t = sphere_first_root(sphere_roots(sd, sphere_c(f, h.r2[j])), eps);
        if (t > eps && (t < best.t || (t == best.t && h.id[j] < best.id))) best = {h.id[j], t};
      }
    });
  } else {
    // The definition: every sphere in id order, a nearer t wins (so an equal t keeps the lower id).
    for (int i = 0; i < s.num_spheres; ++i) {
      const T r2 = s.spheres.r2[i];
      const Vec3<T> f = origin - Vec3<T>{s.spheres.cx[i], s.spheres.cy[i], s.spheres.cz[i]};
      const SphereDisc<T> sd = sphere_disc(f, dir, r2);
      if (!(sd.disc >= T(0))) continue;
      const T t = sphere_first_root(sphere_roots(sd, sphere_c(f, r2)), eps);
      if (t > eps && t < best.t) best = {i, t};
    }
  }
  for (int k = 0; k < s.num_planes; ++k) {
    const Vec3<T> normal{s.planes.nx[k], s.planes.ny[k], s.planes.nz[k]};
    const T denom = dot(dir, normal);
    if (denom == T(0)) continue;
    const T t =
        dot(Vec3<T>{s.planes.px[k], s.planes.py[k], s.planes.pz[k]} - origin, normal) / denom;
    if (t > eps && t < best.t) best = {s.num_spheres + k, t};
  }
  // Triangles, meshes and cylinders: strictly nearer than the spheres' and planes' hit (those
  // come first), ties among them to the lower primitive.
  shape = ShapeHit<T>{};
  if (s.shapes) {
    shape = shapes_closest(*s.shapes, origin, dir, eps, best.t);
    if (shape.object >= 0) best = {shape.object, shape.t};
  }
  return best;
}

}  // namespace

template <class T>
void render_rows(const PreparedScene<T>& s, Image& image, int row_begin, int row_end,
                 RayCounts& counts) {
  render_rows_impl<T>(s, image, row_begin, row_end, counts, nullptr);
}

template <class T>
void render_rows_recorded(const PreparedScene<T>& s, Image& image, int row_begin, int row_end,
                          RayCounts& counts, PathLog& log) {
  render_rows_impl<T>(s, image, row_begin, row_end, counts, &log);
}

template <class T>
void primary_rows(const PreparedScene<T>& s, float* t_out, std::int32_t* id_out, int row_begin,
                  int row_end, RayCounts& counts) {
  const PreparedCamera<T>& cam = s.camera;
  for (int j = row_begin; j < row_end; ++j) {
    for (int i = 0; i < cam.nx; ++i) {
      T sum(0);
      for (int b = 0; b < cam.samples; ++b) {
        for (int a = 0; a < cam.samples; ++a) {
          Vec3<T> origin, dir;
          camera_ray(cam, screen_x(cam, T(i), cam.sub_offset[a]),
                     screen_y(cam, T(j), cam.sub_offset[b]), origin, dir);
          ++counts.camera;
          const Hit<T> hit = closest_hit(s, origin, dir);
          sum = sum + hit.t;
          if (id_out && a == 0 && b == 0) id_out[std::size_t(j) * cam.nx + i] = hit.id;
        }
      }
      t_out[std::size_t(j) * cam.nx + i] = static_cast<float>(sum);
    }
  }
}

template void render_rows<float>(const PreparedScene<float>&, Image&, int, int, RayCounts&);
template void render_rows<double>(const PreparedScene<double>&, Image&, int, int, RayCounts&);
template void render_rows_recorded<float>(const PreparedScene<float>&, Image&, int, int, RayCounts&,
                                          PathLog&);
template void render_rows_recorded<double>(const PreparedScene<double>&, Image&, int, int,
                                           RayCounts&, PathLog&);
template void primary_rows<float>(const PreparedScene<float>&, float*, std::int32_t*, int, int,
                                  RayCounts&);
template void primary_rows<double>(const PreparedScene<double>&, float*, std::int32_t*, int, int,
                                   RayCounts&);
template Hit<float> closest_hit<float>(const PreparedScene<float>&, const Vec3<float>&,
                                       const Vec3<float>&, float);
template Hit<double> closest_hit<double>(const PreparedScene<double>&, const Vec3<double>&,
                                         const Vec3<double>&, double);
template Hit<float> closest_hit<float>(const PreparedScene<float>&, const Vec3<float>&,
                                       const Vec3<float>&, float, ShapeHit<float>&);
template Hit<double> closest_hit<double>(const PreparedScene<double>&, const Vec3<double>&,
                                         const Vec3<double>&, double, ShapeHit<double>&);
template Hit<float> closest_hit<float>(const PreparedScene<float>&, const Vec3<float>&,
                                       const Vec3<float>&);
template Hit<double> closest_hit<double>(const PreparedScene<double>&, const Vec3<double>&,
                                         const Vec3<double>&);

}  // namespace lancer::reference
