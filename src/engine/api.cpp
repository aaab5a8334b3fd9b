// The library API (include/lancer/lancer.hpp) over lancer's own machinery: the loader's rules,
// prepare(), the dispatch point's kernel tables, the reference, and run_tiles.
#include "lancer/packet/api.hpp"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstring>
#include <limits>

#include "api_checks.hpp"
#include "api_engine.hpp"
#include "lancer/formulas.hpp"
#include "lancer/image.hpp"
#include "lancer/lancer.hpp"
#include "lancer/packet/api_rays.hpp"
#include "lancer/packet/one_ray_api.hpp"
#include "lancer/prepared.hpp"
#include "lancer/reference.hpp"
#include "lancer/render.hpp"
#include "lancer/shapes.hpp"
#include "lancer/tiles.hpp"
#include "scene_rules.hpp"
#include "shape_fields.hpp"

namespace lancer {

// The precisions' names: the library's text for them (bindings, the CLI's --precision).
const char* to_string(Precision p) {
  switch (p) {
    case Precision::exact:
      return "exact";
    case Precision::dbl:
      return "double";
    case Precision::fast:
      return "fast";
    case Precision::automatic:
      return "auto";
  }
  return "?";
}

Precision parse_precision(const std::string& text, const std::string& option) {
  if (text == "exact") return Precision::exact;
  if (text == "double") return Precision::dbl;
  if (text == "fast") return Precision::fast;
  if (text == "auto") return Precision::automatic;
  throw InputError(option + ": must be exact, double, fast or auto, not '" + text + "'");
}

}  // namespace lancer

namespace lancer::api {

namespace {

using checks::check_ray;
using checks::check_rays;
using checks::ray_lanes;

// One chunk of a caller's packet at the kernel's width W, in the prepared frame. Each active
// lane is answered by the kernel (valid), by the reference alone from tmin (a tnear beyond
// epsilon), or by nothing (a mask that sees no object: a miss).
template <class T>
struct Chunk {
  alignas(64) T rays[6 * kMaxLanes];
  alignas(64) T t[kMaxLanes];
  alignas(64) std::int32_t id[kMaxLanes];
  T tmin[kMaxLanes];       // max(tnear, epsilon)
  bool active[kMaxLanes];  // answered
  bool valid[kMaxLanes];   // by the kernel
  bool alone[kMaxLanes];   // by the reference from tmin
  bool out[kMaxLanes];
  alignas(64) std::int32_t prim[kMaxLanes];  // the kernel's: a shape's primitive number, or -1
  // The triangle, mesh or cylinder primitive hit (object -1 for a sphere, a plane or none): the
  // reference's, or shape_hit's of the kernel's primitive. Left unconstructed (ShapeHit
  // initialises its members): fill sets them where the scene has shapes, and nothing reads them
  // where it has none.
  union Shapes {
    Shapes() {}
    ShapeHit<T> at[kMaxLanes];
  } shape;
};

// Lane k of the caller's packet in the prepared frame: moved there in double, rounded once to T.
template <class T, int N>
void to_frame(const PreparedScene<T>& s, const RayPacket<N>& r, int k, Vec3<T>& o, Vec3<T>& d) {
  const Vec3<double> po = s.frame.point({r.org_x[k], r.org_y[k], r.org_z[k]});
  const Vec3<double> pd = s.frame.direction({r.dir_x[k], r.dir_y[k], r.dir_z[k]});
  o = {T(po.x), T(po.y), T(po.z)}, d = {T(pd.x), T(pd.y), T(pd.z)};
}

// Lanes [c, c + w) of the caller's packet into a chunk of width w: origins moved to the
// prepared frame in double and rounded once to T; inactive lanes get a harmless ray. With
// `kernel` false every active lane goes to the reference. At a few objects, moving the rays
// cost the API more than tracing them: frame_rays does it in vectors, with the kernel's ISA.
template <class T, int N>
int fill(const PreparedScene<T>& s, const int* valid, const RayPacket<N>& r, int c, int w,
         const packet::KernelTable<T>* k, Chunk<T>& ch) {
  const bool kernel = k != nullptr;
  // n lanes from lane c of the caller's packet into the chunk's six arrays, from its lane l.
  const auto move = [&](int l, int n) {
    const auto f = k ? k->frame_rays : &packet::frame_rays<void, T>;
    const int i = c + l;
    f(s.frame, n, r.org_x + i, r.org_y + i, r.org_z + i, r.dir_x + i, r.dir_y + i, r.dir_z + i,
      ch.rays + l, ch.rays + w + l, ch.rays + 2 * w + l, ch.rays + 3 * w + l, ch.rays + 4 * w + l,
      ch.rays + 5 * w + l);
  };
  T* rays = ch.rays;
  const int n = std::min(w, N - c);  // fast mode's narrowest kernel is wider than N = 1
  int active = 0;
  for (int l = 0; l < w; ++l) {
    const int i = c + l;
    const bool on = i < N && (valid == nullptr || valid[i] != 0);
    const bool sees = on && (r.mask[i] & kAllObjects) != 0;
    const T tmin = on ? std::max(T(r.tnear[i]), s.epsilon) : s.epsilon;
    ch.active[l] = on;
    ch.tmin[l] = tmin;
    ch.alone[l] = sees && (!kernel || tmin > s.epsilon);
    ch.valid[l] = sees && !ch.alone[l];
    active += on;
    ch.t[l] = on ? T(r.tfar[i]) : std::numeric_limits<T>::infinity();
    ch.id[l] = -1;
    ch.out[l] = false;
  }
  // Mostly active: every lane at once, in vectors; a few: those lanes alone (Frame's own
  // functions, the same arithmetic). Inactive lanes get a harmless ray.
  const bool dense = 4 * active >= n;
  if (dense) move(0, n);
  if (!dense || active < w)
    for (int l = 0; l < w; ++l) {
      if (dense && ch.active[l]) continue;
      T o[3] = {0, 0, 0}, d[3] = {0, 0, 1};
      if (ch.active[l]) {
        Vec3<T> po, pd;
        to_frame(s, r, c + l, po, pd);
        o[0] = po.x, o[1] = po.y, o[2] = po.z;
        d[0] = pd.x, d[1] = pd.y, d[2] = pd.z;
      }
      for (int a = 0; a < 3; ++a) rays[a * w + l] = o[a], rays[(3 + a) * w + l] = d[a];
    }
  // Only the reference fills these (shape scenes' lone lanes).
  if (s.shapes)
    for (int l = 0; l < w; ++l) ch.shape.at[l] = ShapeHit<T>{};
  return active;
}

// Lane l's origin (first 0) or direction (first 3) from rays in six rows of w (packet/api.hpp).
template <class T>
Vec3<T> lane_vec(const T* rays, int w, int l, int first) {
  return {rays[first * w + l], rays[(first + 1) * w + l], rays[(first + 2) * w + l]};
}
template <class T>
Vec3<T> lane_vec(const Chunk<T>& ch, int w, int l, int first) {
  return lane_vec(ch.rays, w, l, first);
}

// Lanes i, i + 1, ... of a hit packet, as the kernels write them.
template <class Packet>
packet::HitLanes hit_lanes(Packet& p, int i) {
  return {p.t + i, p.ng_x + i, p.ng_y + i, p.ng_z + i, p.u + i, p.v + i, p.prim_id + i, p.id + i};
}

// The reference's nearest hit beyond tmin of each lane traced alone. It counts where it lies
// before tfar (ch.t), which it then replaces. With `one`, the one-ray kernels give the same
// answer (any: whether something lies before tfar, ch.t then unchanged).
template <class T>
void trace_alone(const Engine<T>& e, bool any, int w, Chunk<T>& ch) {
  const PreparedScene<T>& s = e.scene;
  const packet::OneRayTable<T>* one = e.one;
  const packet::OneRayScene<T>& spheres = e.one_scene;
  for (int l = 0; l < w; ++l) {
    if (!ch.alone[l]) continue;
    if (one && !s.shapes) {  // a shape's fields need the kernel's primitive or the reference's
      const T o[3] = {ch.rays[l], ch.rays[w + l], ch.rays[2 * w + l]};
      const T d[3] = {ch.rays[3 * w + l], ch.rays[4 * w + l], ch.rays[5 * w + l]};
      if (any)
        ch.out[l] = one->occluded(s, spheres, o, d, ch.tmin[l], ch.t[l]);
      else
        ch.out[l] = one->closest(s, spheres, o, d, ch.tmin[l], ch.t[l], ch.t[l], ch.id[l], nullptr);
      continue;
    }
    const reference::Hit<T> hit = reference::closest_hit(
        s, lane_vec(ch, w, l, 0), lane_vec(ch, w, l, 3), ch.tmin[l], ch.shape.at[l]);
    ch.out[l] = hit.id >= 0 && hit.t < ch.t[l];
    if (ch.out[l]) ch.t[l] = hit.t, ch.id[l] = hit.id;
  }
}

// The renderer's geometric normal at a hit (ray o, d; object id at t), before it is turned
// towards the ray, in world space.
template <class T>
Vec3<double> world_normal(const PreparedScene<T>& s, const Vec3<T>& o, const Vec3<T>& d, T t,
                          int id, const ShapeHit<T>& shape) {
  Vec3<T> n;
  if (id < s.num_spheres) {
    const Vec3<T> centre{s.spheres.cx[id], s.spheres.cy[id], s.spheres.cz[id]};
    const T r2 = s.spheres.r2[id], m = hit_magnitude(o, t);
    n = sphere_is_small(r2, m)   ? sphere_point_local<T>(o, d, t, centre, r2).normal
        : sphere_is_large(r2, m) ? sphere_point_large<T>(o, d, t, centre, r2, m).normal
                                 : sphere_point_along<T>(o, d, t, centre, m).normal;
  } else if (id < s.num_spheres + s.num_planes) {
    const int q = id - s.num_spheres;
    n = {s.planes.nx[q], s.planes.ny[q], s.planes.nz[q]};
  } else {
    // A triangle, mesh or cylinder, at the point the reference shades (reference.cpp).
    Vec3<T> shading;
    shapes_normals(*s.shapes, shape, o, d, along(o, d, t), n, shading);
  }
  return s.frame.world_direction({double(n.x), double(n.y), double(n.z)});
}

// Lane k of a hit packet: object id at t (id -1: a miss), its primitive, u, v and normal.
template <class T, int N>
void store_hit(const PreparedScene<T>& s, const Vec3<T>& o, const Vec3<T>& d, T t, int id,
               const ShapeHit<T>& shape, HitPacket<N>& h, int k) {
  h.id[k] = id;
  if (id < 0) {
    h.u[k] = h.v[k] = 0;
    h.t[k] = std::numeric_limits<float>::infinity();
    h.ng_x[k] = h.ng_y[k] = h.ng_z[k] = 0;
    h.prim_id[k] = -1;
    return;
  }
  h.t[k] = static_cast<float>(t);
  // A sphere or a plane is one primitive with no surface coordinates.
  ShapeSurface<T> at;
  if (s.shapes && shape.object >= 0) at = shapes_surface(*s.shapes, shape, o, d);
  h.prim_id[k] = at.prim_in_object;
  h.u[k] = static_cast<float>(at.u), h.v[k] = static_cast<float>(at.v);
  const Vec3<double> ng = world_normal(s, o, d, t, id, shape);
  h.ng_x[k] = float(ng.x), h.ng_y[k] = float(ng.y), h.ng_z[k] = float(ng.z);
}

// Lane k of a hit packet where the kernel's lane hit primitive `prim` of a triangle, mesh or
// cylinder (object id), its hits counted beyond tmin: store_hit's fields, from the primitive's
// number (shape_fields; a cylinder's part is that of its first root beyond tmin).
template <class T, int N>
void store_shape_hit(const Engine<T>& e, const Vec3<T>& o, const Vec3<T>& d, T t, T tmin, int id,
                     std::int64_t prim, HitPacket<N>& h, int k) {
  const PreparedScene<T>& s = e.scene;
  const ShapeFields<T> f =
      shape_fields(*s.shapes, e.first_triangle.data(), o, d, t, tmin, prim, id);
  h.id[k] = id;
  h.t[k] = static_cast<float>(t);
  h.prim_id[k] = f.surface.prim_in_object;
  h.u[k] = static_cast<float>(f.surface.u), h.v[k] = static_cast<float>(f.surface.v);
  const Vec3<T>& n = f.geometric;
  const Vec3<double> ng = s.frame.world_direction({double(n.x), double(n.y), double(n.z)});
  h.ng_x[k] = float(ng.x), h.ng_y[k] = float(ng.y), h.ng_z[k] = float(ng.z);
}

// Lanes [c, c + w) of a hit packet from a chunk on kernel k, every field by its ISA a packet at
// a time (packet/api_hits.hpp; the sphere and plane normals world_normal's bits), straight into
// the caller's packet where every lane is active, else through a packet of our own; then the
// lanes that hit a triangle, mesh or cylinder again by store_hit.
template <class T, int N>
void store_hits(const Engine<T>& e, const packet::KernelTable<T>& k, const Chunk<T>& ch, int w,
                int c, HitPacket<N>& h) {
  const PreparedScene<T>& s = e.scene;
  const int n = std::min(w, N - c);
  if (n == w && std::all_of(ch.active, ch.active + w, [](bool a) { return a; })) {
    k.hit_fields(s, ch.rays, ch.t, ch.id, hit_lanes(h, c));
  } else {
    HitPacket<kMaxLanes> own;
    k.hit_fields(s, ch.rays, ch.t, ch.id, hit_lanes(own, 0));
    for (int l = 0; l < n; ++l)
      if (ch.active[l]) {
        const int i = c + l;
        h.t[i] = own.t[l], h.u[i] = own.u[l], h.v[i] = own.v[l];
        h.ng_x[i] = own.ng_x[l], h.ng_y[i] = own.ng_y[l], h.ng_z[i] = own.ng_z[l];
        h.prim_id[i] = own.prim_id[l], h.id[i] = own.id[l];
      }
  }
  if (!s.shapes) return;
  const int first_shape = s.num_spheres + s.num_planes;
  std::int32_t prims[kMaxLanes];  // the kernel's lanes' primitives, fetched together
  int m = 0;
  for (int l = 0; l < n; ++l)
    if (ch.active[l] && ch.valid[l] && ch.id[l] >= first_shape) prims[m++] = ch.prim[l];
  fetch_shape_fields(*s.shapes, prims, m);
  for (int l = 0; l < n; ++l)
    if (ch.active[l] && ch.id[l] >= first_shape) {
      if (ch.valid[l])  // the kernel's: its primitive
        store_shape_hit(e, lane_vec(ch, w, l, 0), lane_vec(ch, w, l, 3), ch.t[l], s.epsilon,
                        ch.id[l], ch.prim[l], h, c + l);
      else  // the reference's: its whole hit
        store_hit(s, lane_vec(ch, w, l, 0), lane_vec(ch, w, l, 3), ch.t[l], ch.id[l],
                  ch.shape.at[l], h, c + l);
    }
}

// A query of one ray on the one-ray kernels, without a chunk: closest hit (hit non-null) or
// occlusion.
template <class T, int N>
void one_ray(const Engine<T>& e, const int* valid, const RayPacket<N>& r, HitPacket<N>* hit,
             int* blocked) {
  if (valid != nullptr && valid[0] == 0) return;
  check_ray(hit ? "intersect" : "occluded", r, 0);
  const PreparedScene<T>& s = e.scene;
  Vec3<T> o, d;
  to_frame(s, r, 0, o, d);
  const T tmin = std::max(T(r.tnear[0]), s.epsilon), tfar = T(r.tfar[0]);
  const T ov[3] = {o.x, o.y, o.z}, dv[3] = {d.x, d.y, d.z};
  const bool sees = (r.mask[0] & kAllObjects) != 0;
  if (!hit) {
    *blocked = sees && e.one->occluded(s, e.one_scene, ov, dv, tmin, tfar) ? 1 : 0;
    return;
  }
  T t = tfar;
  std::int32_t id = -1, prim = -1;
  if (!sees || !e.one->closest(s, e.one_scene, ov, dv, tmin, tfar, t, id, &prim)) id = -1;
  if (id >= 0 && prim >= 0)
    store_shape_hit(e, o, d, t, tmin, id, prim, *hit, 0);
  else
    store_hit(s, o, d, t, id, ShapeHit<T>{}, *hit, 0);
}

// A packet of whole chunks in a scene with triangles, meshes or cylinders, in one call of the
// kernel's ISA where it is plain, then the lanes that hit a shape rewritten from the kernel's
// primitive (store_shape_hit). Returns whether it answered.
template <class T, int N>
[[gnu::noinline]] bool intersect_whole_shapes(const Engine<T>& e, const int* valid,
                                              const RayPacket<N>& r, HitPacket<N>& h) {
  const PreparedScene<T>& s = e.scene;
  alignas(64) T rays[6 * N];
  alignas(64) T t[N];
  alignas(64) std::int32_t prim[N];
  const packet::ShapeLanes<T> shapes{rays, t, prim};
  if (e.query[query_slot(N)]->intersect_lanes(s, ray_lanes(valid, r), N, hit_lanes(h, 0),
                                              &shapes) != 2)
    return false;
  const int w = e.query_width[query_slot(N)], first_shape = s.num_spheres + s.num_planes;
  std::int32_t hit_prims[N];  // fetched together
  int m = 0;
  for (int l = 0; l < N; ++l)
    if (h.id[l] >= first_shape) hit_prims[m++] = prim[l];
  fetch_shape_fields(*s.shapes, hit_prims, m);
  for (int l = 0; l < N; ++l)
    if (h.id[l] >= first_shape) {
      const T* chunk = rays + 6 * (l - l % w);  // lane l's chunk
      store_shape_hit(e, lane_vec(chunk, w, l % w, 0), lane_vec(chunk, w, l % w, 3), t[l],
                      s.epsilon, h.id[l], prim[l], h, l);
    }
  return true;
}

// Any packet, chunk by chunk (Chunk, fill): what intersect_impl does not answer in one call.
template <class T, int N>
[[gnu::noinline]] void intersect_chunks(const Engine<T>& e, const int* valid, const RayPacket<N>& r,
                                        HitPacket<N>& h) {
  const PreparedScene<T>& s = e.scene;
  const int w = e.query_width[query_slot(N)];
  const packet::KernelTable<T>* k = e.query[query_slot(N)];
  const bool plain = check_rays("intersect", valid, r, s.epsilon, k);
  Chunk<T> ch;
  for (int c = 0; c < N; c += w) {
    if (fill(s, valid, r, c, w, k, ch) == 0) continue;
    if (k && std::any_of(ch.valid, ch.valid + w, [](bool v) { return v; }))
      k->closest_hit_packet(s, ch.valid, ch.rays, ch.t, ch.id, ch.out,
                            s.shapes ? ch.prim : nullptr);
    if (!(plain && k)) trace_alone(e, false, w, ch);  // a plain packet on a kernel: none alone
    if (k) {
      store_hits(e, *k, ch, w, c, h);
      continue;
    }
    for (int l = 0; l < w && c + l < N; ++l)
      if (ch.active[l])
        store_hit(s, lane_vec(ch, w, l, 0), lane_vec(ch, w, l, 3), ch.t[l], ch.id[l],
                  ch.shape.at[l], h, c + l);
  }
}

template <class T, int N>
[[gnu::noinline]] void occluded_chunks(const Engine<T>& e, const int* valid, const RayPacket<N>& r,
                                       int* out) {
  const PreparedScene<T>& s = e.scene;
  const int w = e.query_width[query_slot(N)];
  const packet::KernelTable<T>* k = e.query[query_slot(N)];
  const bool plain = check_rays("occluded", valid, r, s.epsilon, k);
  Chunk<T> ch;
  for (int c = 0; c < N; c += w) {
    if (fill(s, valid, r, c, w, k, ch) == 0) continue;
    if (k && std::any_of(ch.valid, ch.valid + w, [](bool v) { return v; }))
      k->occluded_packet(s, ch.valid, ch.rays, ch.t, ch.out);  // false where not valid
    // The reference answers by its closest hit: something lies in (tmin, tfar) exactly when
    // the nearest hit does, since both take each object's same nearest root.
    if (!(plain && k)) trace_alone(e, true, w, ch);  // a plain packet on a kernel: none alone
    for (int l = 0; l < w && c + l < N; ++l)
      if (ch.active[l]) out[c + l] = ch.out[l] ? 1 : 0;
  }
}

// A query: a plain packet of whole chunks checked, moved, traced and written out in one call
// of the kernel's ISA; else chunk by chunk. Kept small: the chunked path's frame and set-up
// cost more than the kernel's work on a small scene.
template <class T, int N>
void intersect_impl(const Engine<T>& e, const int* valid, const RayPacket<N>& r, HitPacket<N>& h) {
  if (N == 1 && e.one) return one_ray(e, valid, r, &h, nullptr);
  if (e.whole[query_slot(N)]) {
    if (e.scene.shapes) {
      if (intersect_whole_shapes(e, valid, r, h)) return;
    } else {
      if (e.query[query_slot(N)]->intersect_lanes(e.scene, ray_lanes(valid, r), N, hit_lanes(h, 0),
                                                  nullptr) == 2)
        return;
    }
  }
  intersect_chunks(e, valid, r, h);
}

template <class T, int N>
void occluded_impl(const Engine<T>& e, const int* valid, const RayPacket<N>& r, int* out) {
  if (N == 1 && e.one) return one_ray<T, N>(e, valid, r, nullptr, out);
  if (e.whole[query_slot(N)] &&
      e.query[query_slot(N)]->occluded_lanes(e.scene, ray_lanes(valid, r), N, out) == 2)
    return;
  occluded_chunks(e, valid, r, out);
}

double seconds_since(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

}  // namespace

struct Scene::Impl {
  SceneDescription desc;
  Info info;
  bool dbl = false;
  Engines<float> f;   // exact and fast
  Engines<double> d;  // double

  // fn on the render's engine.
  template <class Fn>
  decltype(auto) visit(Fn fn) const {
    return dbl ? fn(d.render) : fn(f.render);
  }
  // fn on the queries' engine (intersect, occluded).
  template <class Fn>
  decltype(auto) visit_query(Fn fn) const {
    return dbl ? fn(d.query(desc, info)) : fn(f.query(desc, info));
  }
};

namespace {

// Options a scene cannot be made with, refused before anything is read: an enumerator outside
// Precision (a cast integer) and thread counts the CLI refuses too.
void check_options(const Options& o) {
  switch (o.precision) {
    case Precision::exact:
    case Precision::dbl:
    case Precision::fast:
    case Precision::automatic:
      break;
    default:
      throw InputError("precision: must be exact, dbl, fast or automatic, not Precision(" +
                       std::to_string(static_cast<int>(o.precision)) + ")");
  }
  resolve_threads(o.threads, "threads");
}

}  // namespace

Scene::Scene(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
Scene::Scene(Scene&&) noexcept = default;
Scene& Scene::operator=(Scene&&) noexcept = default;
Scene::~Scene() = default;

Scene Scene::load(const std::string& path, const Options& options) {
  check_options(options);
  // The file loader has checked every rule: prepared as `lancer render` prepares it.
  return make(load_scene(path), options);
}

Scene Scene::from_description(SceneDescription description, const Options& options) {
  check_options(options);
  rules::check_description(description);
  return make(std::move(description), options);
}

Scene Scene::make(SceneDescription description, const Options& options) {
  auto impl = std::make_unique<Impl>();
  impl->desc = std::move(description);
  const SceneDescription& s = impl->desc;
  Info& info = impl->info;
  info.precision = options.precision;
  if (info.precision == Precision::automatic) {
    const PrecisionChoice c = choose_precision(s);
    info.precision = c.precision;
    info.precision_reason = c.reason;
  }
  info.width = resolve_width(options.width, info.precision, "width");
  info.isa = packet::isa_name(info.width, info.precision);
  info.threads = resolve_threads(options.threads, "threads");
  info.nx = s.camera.nx, info.ny = s.camera.ny, info.supersample = s.supersample;
  info.objects = static_cast<int>(s.num_objects());
  impl->dbl = info.precision == Precision::dbl;
  if (impl->dbl) {
    impl->d.render.scene = prepare<double>(s);
    choose_widths(impl->d.render, info);
    info.one_ray = one_ray_name(impl->d.render, info.precision);
  } else {
    impl->f.render.scene = prepare<float>(s);
    choose_widths(impl->f.render, info);
    info.one_ray = one_ray_name(impl->f.render, info.precision);
  }
  return Scene(std::move(impl));
}

const Info& Scene::info() const { return impl_->info; }
const SceneDescription& Scene::description() const { return impl_->desc; }

template <int N>
void Scene::intersect(const int* valid, const RayPacket<N>& rays, HitPacket<N>& hits) const {
  impl_->visit_query([&](const auto& e) { intersect_impl(e, valid, rays, hits); });
}

template <int N>
void Scene::occluded(const int* valid, const RayPacket<N>& rays, int* occluded) const {
  impl_->visit_query([&](const auto& e) { occluded_impl(e, valid, rays, occluded); });
}

template void Scene::intersect<1>(const int*, const Ray1&, Hit1&) const;
template void Scene::intersect<4>(const int*, const Ray4&, Hit4&) const;
template void Scene::intersect<8>(const int*, const Ray8&, Hit8&) const;
template void Scene::intersect<16>(const int*, const Ray16&, Hit16&) const;
template void Scene::occluded<1>(const int*, const Ray1&, int*) const;
template void Scene::occluded<4>(const int*, const Ray4&, int*) const;
template void Scene::occluded<8>(const int*, const Ray8&, int*) const;
template void Scene::occluded<16>(const int*, const Ray16&, int*) const;

void Scene::camera_ray(int i, int j, int a, int b, float org[3], float dir[3]) const {
  const Info& in = impl_->info;
  if (i < 0 || i >= in.nx || j < 0 || j >= in.ny)
    throw InputError("camera_ray: pixel (" + std::to_string(i) + ", " + std::to_string(j) +
                     ") outside the " + std::to_string(in.nx) + "x" + std::to_string(in.ny) +
                     " image");
  if (a < 0 || a >= in.supersample || b < 0 || b >= in.supersample)
    throw InputError("camera_ray: sub-sample (" + std::to_string(a) + ", " + std::to_string(b) +
                     ") outside 0 .. " + std::to_string(in.supersample - 1));
  impl_->visit([&](const auto& e) {
    using T = std::decay_t<decltype(e.scene.epsilon)>;
    const PreparedCamera<T>& cam = e.scene.camera;
    Vec3<T> o, d;
    // As reference::primary_rows makes it; the packets' screen tables hold the same values.
    lancer::camera_ray(cam, screen_x(cam, T(i), cam.sub_offset[a]),
                       screen_y(cam, T(j), cam.sub_offset[b]), o, d);
    const Frame& frame = e.scene.frame;
    const Vec3<double> wo = frame.world_point({double(o.x), double(o.y), double(o.z)});
    const Vec3<double> wd = frame.world_direction({double(d.x), double(d.y), double(d.z)});
    org[0] = float(wo.x), org[1] = float(wo.y), org[2] = float(wo.z);
    dir[0] = float(wd.x), dir[1] = float(wd.y), dir[2] = float(wd.z);
  });
}

RenderStats Scene::render_rows(int row_begin, int row_end, float* rgb,
                               std::size_t row_stride) const {
  const Info& in = impl_->info;
  if (row_begin < 0 || row_end < row_begin || row_end > in.ny)
    throw InputError("render_rows: rows [" + std::to_string(row_begin) + ", " +
                     std::to_string(row_end) + ") outside [0, " + std::to_string(in.ny) + ")");
  if (row_stride < std::size_t(3) * in.nx)
    throw InputError("render_rows: row_stride " + std::to_string(row_stride) +
                     " is below 3 x nx = " + std::to_string(3 * in.nx) + " floats");
  if (row_end > row_begin && rgb == nullptr) throw InputError("render_rows: rgb is null");
  RenderStats stats;
  const auto start = std::chrono::steady_clock::now();
  const RayCounts counts = impl_->visit([&](const auto& e) {
    // Tiles of the band over threads (run_tiles), each rendered into an image band by the
    // renderer `lancer render` runs, then copied to the caller's rows.
    return lancer::run_tiles(row_end - row_begin, in.threads, [&](int t0, int t1, RayCounts& c) {
      Image band(in.nx, t1 - t0);
      band.first_row = row_begin + t0;
      if (e.render)
        e.render->render_rows(e.scene, band, row_begin + t0, row_begin + t1, c);
      else
        reference::render_rows(e.scene, band, row_begin + t0, row_begin + t1, c);
      const std::size_t row_floats = std::size_t(3) * in.nx;
      for (int y = 0; y < t1 - t0; ++y)
        std::memcpy(rgb + std::size_t(t0 + y) * row_stride, band.rgb.data() + y * row_floats,
                    row_floats * sizeof(float));
    });
  });
  stats.seconds = seconds_since(start);
  stats.camera = counts.camera, stats.shadow = counts.shadow, stats.reflected = counts.reflected;
  return stats;
}

PrimaryHits Scene::primary_hits() const {
  const Info& in = impl_->info;
  PrimaryHits out;
  out.nx = in.nx, out.ny = in.ny;
  const std::size_t pixels = std::size_t(in.nx) * in.ny;
  out.t.assign(pixels, 0.0f);
  std::vector<std::int32_t> ids(pixels, -1);
  impl_->visit([&](const auto& e) {
    lancer::run_tiles(in.ny, in.threads, [&](int r0, int r1, RayCounts& c) {
      if (e.render)
        e.render->primary_rows(e.scene, out.t.data(), ids.data(), r0, r1, c);
      else
        reference::primary_rows(e.scene, out.t.data(), ids.data(), r0, r1, c);
    });
  });
  out.id.assign(ids.begin(), ids.end());
  return out;
}

const char* version() { return LANCER_VERSION; }

}  // namespace lancer::api
