#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstddef>
#include <type_traits>

#include "lancer/formulas.hpp"
#include "lancer/huge_pages.hpp"
#include "lancer/prepared.hpp"
#include "lancer/shapes.hpp"

namespace lancer {

namespace {

// The camera basis of the contract, in double: the axes of the frame a scene is prepared in.
void camera_basis(const CameraSpec& c, Vec3<double>& u, Vec3<double>& v, Vec3<double>& w) {
  w = normalize(-c.direction);
  Vec3<double> h{-w.z, 0.0, w.x};
  u = (h.x == 0 && h.z == 0) ? Vec3<double>{1, 0, 0} : normalize(h);
  v = cross(w, u);
  if (v.y < 0) {
    u = -u;
    v = -v;
  }
}

// Frame::depth: the nearest sphere surface's distance along the view, as a T, where every
// sphere lies beyond it, the spheres spread over less than 1/64 of it and there is no plane;
// else 0. Sets frame.spread along with it.
template <class T>
void set_view_depth(const Scene& scene, Frame& frame) {
  // Planes keep their hit points at o + t d and leave them by 64 ulps of |o| + t: an eye moved
  // away from the origin doubles both (measured: a cloud on a ground plane seen from afar,
  // FloatEnvelope.TelescopeViewsOfACloud, lost more pixels than it won).
  if (scene.spheres.empty() || !scene.planes.empty() || !scene.shapes.empty()) return;
  double nearest = INFINITY;
  for (const Sphere& s : scene.spheres)
    nearest = std::min(nearest, -frame.point(s.center).z - s.radius);
  if (!(nearest > 0)) return;
  const double depth = double(T(nearest));
  double spread = 0;
  for (const Sphere& s : scene.spheres) {
    const Vec3<double> c = frame.point(s.center);
    spread = std::max<double>({spread, std::fabs(c.x) + s.radius, std::fabs(c.y) + s.radius,
                               std::fabs(c.z + depth) + s.radius});
  }
  if (spread * 64 < depth) frame.depth = depth, frame.spread = spread;
}

}  // namespace

template <class T>
Frame camera_frame(const Scene& scene, FrameKind kind) {
  Frame frame;
  frame.origin = scene.camera.position;
  // A sphere larger than half its distance from the eye (a ground sphere of radius 1e6 a metre
  // below it) keeps the world's axes: turned, its centre below a pitched camera gets two large
  // coordinates off r's float grid, c = |o - centre|^2 - r^2 for rays leaving its surface then
  // carries ulps of r^2 far beyond their offset, and it shadowed itself in bands (19% to 21% of
  // pixels off); along a world axis its one large coordinate sits on r's grid.
  for (const Sphere& s : scene.spheres)
    if (s.radius > 0.5 * length(s.center - frame.origin)) return frame;
  Vec3<double> u, v, w;
  camera_basis(scene.camera, u, v, w);
  const bool axes = u.x == 1 && u.y == 0 && u.z == 0 && v.x == 0 && v.y == 1 && v.z == 0 &&
                    w.x == 0 && w.y == 0 && w.z == 1;
  // The API's queries off the axes: the world's axes at the eye (Frame::axes).
  if (kind == FrameKind::query && !axes) return frame;
  frame.turned = true;
  frame.axes = axes;
  frame.u = u, frame.v = v, frame.w = w;
  set_view_depth<T>(scene, frame);
  return frame;
}
template Frame camera_frame<float>(const Scene&, FrameKind);
template Frame camera_frame<double>(const Scene&, FrameKind);

Accel resolve_accel(const Scene& scene, Accel accel) {
  if (accel != Accel::automatic && accel != Accel::one) return accel;
  return scene.spheres.size() >= std::size_t(kBvhMinSpheres) ? Accel::bvh : Accel::none;
}

namespace {

// A sphere's reach for the camera tiles' cones (packet/cones.hpp): its radius plus a margin past
// which no ray's computed discriminant is >= 0. The exact test's r^2 - |f - b d|^2 rounds to a
// few ulps of |f| (RTG ch. 7): 2^-16 (|f| + r) is some 30 times that. Fast mode's textbook
// b^2 - c (where naive_spheres_hold) rounds to about 2^-20 |f|^2, which moves the sphere's edge
// by up to that over 2r: 2^-18 |f|^2 / r more, twice that bound.
float eye_reach(float fx, float fy, float fz, float r2, bool naive) {
  const double f = std::sqrt(double(fx) * fx + double(fy) * fy + double(fz) * fz);
  const double r = std::sqrt(double(r2));
  double margin = 0x1p-16 * (f + r);
  if (naive) margin += 0x1p-18 * f * f / r;
  return float(r + margin);
}

// The hierarchy, with the spheres copied in its leaf order (their original ids kept).
template <class T>
void add_bvh(PreparedScene<T>& p) {
  const auto start = std::chrono::steady_clock::now();
  std::vector<std::int32_t> order;
  Bvh<T>& h = p.bvh;
  EyeSphere<T>& le = p.leaf_eye;  // the eye's tables in leaf order
  h = build_bvh(p.spheres.cx, p.spheres.cy, p.spheres.cz, p.spheres.r, p.num_spheres, order,
                p.frame.depth);
  const bool eye = !p.eye.c.empty();
  const std::size_t n = order.size();
  p.walk = walk_settings<T>(p.num_spheres);
  // Fresh arrays, their pages huge and present before the first write (lancer/huge_pages.hpp):
  // at one million spheres, 15 ms instead of 55 for these nine arrays on a VM.
  for (auto* v : {&h.cx, &h.cy, &h.cz, &h.r2}) reserve_prepared(*v, n), v->resize(n);
  const bool cones = eye && std::is_same_v<T, float>;
  if (eye)
    for (auto* v : {&le.fx, &le.fy, &le.fz, &le.c}) reserve_prepared(*v, n), v->resize(n);
  if (cones) reserve_prepared(le.reach, n), le.reach.resize(n);
  reserve_prepared(h.id, n);
  h.id.assign(order.begin(), order.end());
  reserve_prepared(h.leaf_of, n), h.leaf_of.resize(n);
  // A gather: each entry written once from its own sphere, so any split over threads gives the
  // same arrays. In parallel, as the build: at 2^20 spheres its random reads were a tenth of it.
  tbb::parallel_for(
      tbb::blocked_range<std::size_t>(0, n, 16384), [&](const tbb::blocked_range<std::size_t>& r) {
        for (std::size_t j = r.begin(); j < r.end(); ++j) {
          const std::size_t k = std::size_t(order[j]);
          h.leaf_of[k] = std::int32_t(j);
          h.cx[j] = p.spheres.cx[k], h.cy[j] = p.spheres.cy[k];
          h.cz[j] = p.spheres.cz[k], h.r2[j] = p.spheres.r2[k];
          if (eye) {
            le.fx[j] = p.eye.fx[k], le.fy[j] = p.eye.fy[k];
            le.fz[j] = p.eye.fz[k], le.c[j] = p.eye.c[k];
          }
          if constexpr (std::is_same_v<T, float>)
            if (cones)
              le.reach[j] = eye_reach(le.fx[j], le.fy[j], le.fz[j], h.r2[j], p.naive_spheres_hold);
        }
      });
  // The build time covers the copy too: the structure is not usable before it.
  h.build_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

// The camera in the scene's frame, and its screen tables (the same formula as per ray, once).
template <class T>
void prepare_camera(const Scene& scene, PreparedScene<T>& p) {
  auto& pc = p.camera;
  const CameraSpec& c = scene.camera;
  const Frame& frame = p.frame;
  pc.orthographic = c.type == CameraType::orthographic;
  // In its own frame the camera sits on the w axis (at the origin unless depth) with the axes
  // as its basis; in the world's axes, at the origin with its basis rounded once.
  pc.position = Vec3<T>{T(0), T(0), T(frame.depth)};
  if (frame.turned) {
    pc.u = Vec3<T>{T(1), T(0), T(0)};
    pc.v = Vec3<T>{T(0), T(1), T(0)};
    pc.w = Vec3<T>{T(0), T(0), T(1)};
  } else {
    Vec3<double> u, v, w;
    camera_basis(c, u, v, w);
    pc.u = Vec3<T>::from(u);
    pc.v = Vec3<T>::from(v);
    pc.w = Vec3<T>::from(w);
  }
  pc.distance = T(c.distance);
  pc.nx = c.nx;
  pc.ny = c.ny;
  pc.samples = scene.supersample;
  pc.xmin = T(c.xmin);
  pc.ymax = T(c.ymax);
  pc.width = T(c.xmax) - T(c.xmin);
  pc.height = T(c.ymax) - T(c.ymin);
  pc.fnx = T(c.nx);
  pc.fny = T(c.ny);
  for (int a = 0; a < pc.samples; ++a) pc.sub_offset.push_back((T(a) + T(0.5)) / T(pc.samples));
  for (int a = 0; a < pc.samples; ++a)
    for (int i = 0; i < pc.nx; ++i)
      pc.screen_x.push_back(lancer::screen_x(pc, T(i), pc.sub_offset[a]));
  // Packets load whole batches from the last column on: pad so they stay inside the vector.
  pc.screen_x.resize(pc.screen_x.size() + kMaxLanes, T(0));
  for (int b = 0; b < pc.samples; ++b)
    for (int j = 0; j < pc.ny; ++j)
      pc.screen_y.push_back(lancer::screen_y(pc, T(j), pc.sub_offset[b]));
}

// One object's material, by object id, and what it asks of the features.
template <class T>
void add_material(const Scene& scene, const Material& m, PreparedScene<T>& p) {
  p.materials.r.push_back(T(m.color.r));
  p.materials.g.push_back(T(m.color.g));
  p.materials.b.push_back(T(m.color.b));
  p.materials.ka.push_back(T(m.ka));
  p.materials.kd.push_back(T(m.kd));
  p.materials.ks.push_back(T(m.ks));
  p.materials.shininess.push_back(T(m.shininess));
  p.materials.reflect.push_back(T(m.reflect));
  p.materials.transmit.push_back(T(m.transmit));
  p.materials.ior.push_back(T(m.ior));
  p.materials.inv_ior.push_back(T(1.0 / m.ior));
  if (m.transmit > 0) p.features.transparency = true;
  const bool whole = m.shininess == std::floor(m.shininess) && m.shininess <= kMaxIntegerShininess;
  p.materials.shininess_int.push_back(T(whole ? 1 : 0));
  if (m.ks > 0) {
    p.features.specular = true;
    if (!whole) p.features.fractional_shininess = true;
  }
  if (m.reflect > 0 && scene.max_depth > 0) p.features.reflection = true;
}

// The spheres (object ids 0 ..), with the eye's tables for pinhole cameras.
template <class T>
void prepare_spheres(const Scene& scene, PreparedScene<T>& p) {
  const Frame& frame = p.frame;
  const auto& pc = p.camera;
  p.num_spheres = static_cast<int>(scene.spheres.size());
  p.naive_spheres_hold = true;
  for (const Sphere& s : scene.spheres) {
    const Vec3<double> center = frame.point(s.center);
    p.spheres.cx.push_back(T(center.x));
    p.spheres.cy.push_back(T(center.y));
    p.spheres.cz.push_back(T(center.z));
    p.spheres.r.push_back(T(s.radius));
    p.spheres.r2.push_back(T(s.radius) * T(s.radius));
    p.spheres.inv_r.push_back(T(1.0 / s.radius));
    const double distance = length(center - Vec3<double>{0, 0, frame.depth});
    if (s.radius < kNaiveSphereRatio * distance || s.radius > 0.5 * distance)
      p.naive_spheres_hold = false;
    if (!pc.orthographic) {
      const Vec3<T> f =
          pc.position - Vec3<T>{p.spheres.cx.back(), p.spheres.cy.back(), p.spheres.cz.back()};
      p.eye.fx.push_back(f.x);
      p.eye.fy.push_back(f.y);
      p.eye.fz.push_back(f.z);
      p.eye.c.push_back(sphere_c(f, p.spheres.r2.back()));
    }
    add_material(scene, scene.materials[s.material], p);
  }
}

// The planes (ids after the spheres), then the shapes (after the planes).
// The shapes' hierarchy holds the spheres too where the scene has both kinds and Accel::one asks
// for one hierarchy over every bounded kind.
template <class T>
void prepare_planes_and_shapes(const Scene& scene, PreparedScene<T>& p, Accel accel) {
  const Frame& frame = p.frame;
  p.num_planes = static_cast<int>(scene.planes.size());
  for (const Plane& pl : scene.planes) {
    // Rotated after its normalisation: a rotation keeps it unit to double's rounding.
    const Vec3<double> n = frame.direction(normalize(pl.normal));
    const Vec3<double> point = frame.point(pl.point);
    p.planes.px.push_back(T(point.x));
    p.planes.py.push_back(T(point.y));
    p.planes.pz.push_back(T(point.z));
    p.planes.nx.push_back(T(n.x));
    p.planes.ny.push_back(T(n.y));
    p.planes.nz.push_back(T(n.z));
    add_material(scene, scene.materials[pl.material], p);
  }
  p.num_shapes = static_cast<int>(scene.shapes.size());
  for (const Shape& sh : scene.shapes)
    add_material(
        scene,
        scene.materials[sh.kind == Shape::Kind::mesh ? sh.mesh.material : sh.cylinder.material], p);
  const bool one_hierarchy = p.num_spheres > 0 && accel == Accel::one;
  if (p.num_shapes > 0)
    p.shapes = std::make_shared<const PreparedShapes<T>>(
        prepare_shapes<T>(scene, frame, p.num_spheres + p.num_planes,
                          one_hierarchy ? &p.spheres : nullptr, p.num_spheres));
}

template <class T>
void prepare_lights(const Scene& scene, PreparedScene<T>& p) {
  p.num_lights = static_cast<int>(scene.lights.size());
  for (const Light& l : scene.lights) {
    const Vec3<double> position = p.frame.point(l.position);
    p.lights.x.push_back(T(position.x));
    p.lights.y.push_back(T(position.y));
    p.lights.z.push_back(T(position.z));
    const double in[3] = {l.intensity.r, l.intensity.g, l.intensity.b};
    const double am[3] = {l.ambient.r, l.ambient.g, l.ambient.b};
    for (int ch = 0; ch < 3; ++ch) {
      p.lights.intensity_rgb[ch].push_back(T(in[ch]));
      p.lights.ambient_rgb[ch].push_back(T(am[ch]));
    }
    p.lights.intensity.push_back(T(in[0]));
    p.lights.ambient.push_back(T(am[0]));
    if (in[1] != in[0] || in[2] != in[0] || am[1] != am[0] || am[2] != am[0])
      p.features.coloured_lights = true;
  }
}

}  // namespace

template <class T>
PreparedScene<T> prepare(const Scene& scene, Accel accel, FrameKind kind) {
  PreparedScene<T> p;
  p.frame = camera_frame<T>(scene, kind);
  prepare_camera(scene, p);
  const Rgb& bg = scene.background;
  const Rgb& env = scene.environment;
  p.background[0] = T(bg.r), p.background[1] = T(bg.g), p.background[2] = T(bg.b);
  p.environment[0] = T(env.r), p.environment[1] = T(env.g), p.environment[2] = T(env.b);
  p.max_depth = scene.max_depth;
  p.epsilon = T(scene.epsilon);

  // Arrays of one entry per object (materials) or per sphere, each allocated once with its pages
  // huge and present (lancer/huge_pages.hpp): at one million spheres these 22 arrays grew by
  // doubling, each growth a copy into fresh pages, a fault per page.
  const std::size_t objects = scene.num_objects();
  const std::size_t spheres = scene.spheres.size();
  for (auto* v :
       {&p.materials.r, &p.materials.g, &p.materials.b, &p.materials.ka, &p.materials.kd,
        &p.materials.ks, &p.materials.shininess, &p.materials.reflect, &p.materials.transmit,
        &p.materials.ior, &p.materials.inv_ior, &p.materials.shininess_int})
    reserve_prepared(*v, objects);
  for (auto* v :
       {&p.spheres.cx, &p.spheres.cy, &p.spheres.cz, &p.spheres.r, &p.spheres.r2, &p.spheres.inv_r})
    reserve_prepared(*v, spheres);
  if (!p.camera.orthographic)
    for (auto* v : {&p.eye.fx, &p.eye.fy, &p.eye.fz, &p.eye.c}) reserve_prepared(*v, spheres);

  prepare_spheres(scene, p);
  prepare_planes_and_shapes(scene, p, accel);
  prepare_lights(scene, p);
  // Packets look per-object fields up a whole register at a time: pad with zeros.
  for (auto* field : {&p.spheres.cx,          &p.spheres.cy,        &p.spheres.cz,
                      &p.spheres.r,           &p.spheres.r2,        &p.spheres.inv_r,
                      &p.planes.nx,           &p.planes.ny,         &p.planes.nz,
                      &p.materials.r,         &p.materials.g,       &p.materials.b,
                      &p.materials.ka,        &p.materials.kd,      &p.materials.ks,
                      &p.materials.shininess, &p.materials.reflect, &p.materials.shininess_int,
                      &p.materials.transmit,  &p.materials.ior,     &p.materials.inv_ior})
    if (field->size() < std::size_t(kMaxLanes)) field->resize(kMaxLanes, T(0));
  p.features.spheres = p.num_spheres > 0;
  p.features.planes = p.num_planes > 0;
  p.features.shapes = p.num_shapes > 0;
  p.features.spheres_in_shapes = p.shapes && p.shapes->spheres > 0;
  p.features.lights = p.num_lights > 0;
  p.features.refraction = p.features.transparency && scene.max_depth > 0;
  if (resolve_accel(scene, accel) == Accel::bvh && p.num_spheres > 0) add_bvh(p);
  return p;
}

template PreparedScene<float> prepare<float>(const Scene&, Accel, FrameKind);
template PreparedScene<double> prepare<double>(const Scene&, Accel, FrameKind);

}  // namespace lancer
