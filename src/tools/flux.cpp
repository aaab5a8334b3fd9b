// The 2D flux view: profile, plane of the rays, diagram. See flux.hpp and docs/flux.md.
#include "lancer/flux.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <limits>

#include "lancer/error.hpp"
#include "lancer/prepared.hpp"
#include "lancer/render.hpp"

namespace lancer::flux {

namespace {

// objects[k] of each sphere and plane, from the file's order of objects.
ObjectNames names_from_order(const std::vector<bool>& is_plane) {
  ObjectNames n;
  for (std::size_t k = 0; k < is_plane.size(); ++k)
    (is_plane[k] ? n.planes : n.spheres).push_back("objects[" + std::to_string(k) + "]");
  return n;
}

std::string show(const Vec3<double>& v) {
  char buf[128];
  std::snprintf(buf, sizeof buf, "(%.6g, %.6g, %.6g)", v.x, v.y, v.z);
  return buf;
}
std::string show(double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.6g", v);
  return buf;
}

}  // namespace

FluxScene parse_flux_scene(const std::string& text, const std::string& name) {
  FluxScene f;
  std::vector<bool> is_plane;
  f.scene = parse_scene(text, name, &is_plane);
  // Flux diagrams section spheres and planes by a plane; other objects have no section there.
  if (!f.scene.shapes.empty())
    throw InputError(name +
                     ": lancer flux draws scenes of spheres and planes only, not "
                     "triangles, meshes or cylinders");
  f.names = names_from_order(is_plane);
  return f;
}

FluxScene load_flux_scene(const std::string& path) {
  return parse_flux_scene(read_scene_file(path), path);
}

RayPlane ray_plane(const Scene& scene, const ObjectNames& names) {
  const CameraSpec& c = scene.camera;
  if (c.type != CameraType::orthographic)
    throw InputError(
        "camera.type: lancer flux needs an orthographic camera (parallel rays in one plane), "
        "not pinhole");
  if (c.ny != 1)
    throw InputError("camera.resolution: lancer flux needs one row of rays (ny = 1), not ny = " +
                     std::to_string(c.ny));
  if (scene.supersample != 1)
    throw InputError("supersample: lancer flux needs one ray per pixel (supersample 1), not " +
                     std::to_string(scene.supersample));

  // The camera's basis and row exactly as the renderer computes them.
  const PreparedScene<double> p = prepare<double>(scene);
  const PreparedCamera<double>& cam = p.camera;
  // The camera's basis in world space (prepared in its frame, which may be turned onto it).
  const Frame& frame = p.frame;
  const Vec3<double> u = frame.world_direction(cam.u), v = frame.world_direction(cam.v),
                     w = frame.world_direction(cam.w);
  RayPlane plane;
  plane.along = u;
  plane.forward = -w;
  plane.normal = v;
  plane.origin = c.position + v * cam.screen_y[0];

  double size = std::max(std::abs(c.xmin), std::abs(c.xmax));
  for (const Sphere& s : scene.spheres)
    size = std::max(size, length(s.center - c.position) + s.radius);
  for (const Light& l : scene.lights) size = std::max(size, length(l.position - c.position));
  for (const Plane& q : scene.planes) size = std::max(size, length(q.point - c.position));
  plane.size = size;
  plane.tolerance = 1e-9 * size;

  const std::string where = " off the plane of the camera rays (through " + show(plane.origin) +
                            ", normal " + show(plane.normal) + " = the camera's v)";
  const std::string need =
      "; lancer flux needs every sphere centre, light and plane normal in that plane "
      "(or move the plane: camera.position, camera.direction)";
  for (std::size_t k = 0; k < scene.spheres.size(); ++k) {
    const double off = dot(scene.spheres[k].center - plane.origin, plane.normal);
    if (!(std::abs(off) <= plane.tolerance))
      throw InputError(names.spheres.at(k) + ".center: " + show(scene.spheres[k].center) + " is " +
                       show(std::abs(off)) + where + need);
  }
  for (std::size_t k = 0; k < scene.lights.size(); ++k) {
    const double off = dot(scene.lights[k].position - plane.origin, plane.normal);
    if (!(std::abs(off) <= plane.tolerance))
      throw InputError("lights[" + std::to_string(k) +
                       "].position: " + show(scene.lights[k].position) + " is " +
                       show(std::abs(off)) + where + need);
  }
  for (std::size_t k = 0; k < scene.planes.size(); ++k) {
    const Vec3<double> n = normalize(scene.planes[k].normal);
    const double cosine = dot(n, plane.normal);
    if (!(std::abs(cosine) <= 1e-9))
      throw InputError(names.planes.at(k) + ".normal: " + show(scene.planes[k].normal) +
                       " is not parallel to the plane of the camera rays (normal " +
                       show(plane.normal) + ", cosine " + show(cosine) +
                       "): mirrored rays would leave it" + need);
  }
  return plane;
}

Profile flux_profile(const Scene& scene) {
  RenderOptions opt;
  opt.width = 1;
  opt.precision = Precision::dbl;
  opt.threads = 1;
  const RenderResult r = render(scene, opt);
  const CameraSpec& c = scene.camera;
  Profile p;
  p.rays = r.rays;
  for (int i = 0; i < c.nx; ++i) {
    const float* px = r.image.pixel(i, 0);
    p.x.push_back(c.xmin + (i + 0.5) * (c.xmax - c.xmin) / c.nx);
    p.flux.push_back((double(px[0]) + double(px[1]) + double(px[2])) / 3);
  }
  return p;
}

std::string profile_csv(const Profile& profile) {
  // The shortest text that reads back as the same double (to_chars without a precision):
  // 0.05, not %.17g's 0.050000000000000003.
  std::string s = "x,flux\n";
  char buf[64];
  auto append = [&](double v, char after) {
    s.append(buf, std::to_chars(buf, buf + sizeof buf, v).ptr);
    s += after;
  };
  for (std::size_t i = 0; i < profile.x.size(); ++i) {
    append(profile.x[i], ',');
    append(profile.flux[i], '\n');
  }
  return s;
}

Paths record_paths(const Scene& scene, const RayPlane& plane) {
  const PreparedScene<double> p = prepare<double>(scene);
  Paths out;
  out.image = Image(scene.camera.nx, scene.camera.ny);
  // Beyond any drawing of the scene; diagram() extends misses to its edge anyway.
  out.log.miss_length = 4 * plane.size;
  reference::render_rows_recorded(p, out.image, 0, scene.camera.ny, out.rays, out.log);
  return out;
}

plot::Chart diagram(const Scene& scene, const RayPlane& plane, const reference::PathLog& log,
                    const DiagramOptions& o) {
  const CameraSpec& cam = scene.camera;

  // The region shown, in plane coordinates (a along the row, b along the rays): the camera's
  // row, the spheres, the lights, and where each plane passes nearest to all that.
  double a0 = std::min(cam.xmin, cam.xmax), a1 = std::max(cam.xmin, cam.xmax), b0 = 0, b1 = 0;
  auto include = [&](double a, double b, double r) {
    a0 = std::min(a0, a - r), a1 = std::max(a1, a + r);
    b0 = std::min(b0, b - r), b1 = std::max(b1, b + r);
  };
  for (const Sphere& s : scene.spheres) include(plane.a(s.center), plane.b(s.center), s.radius);
  for (const Light& l : scene.lights) include(plane.a(l.position), plane.b(l.position), 0);
  // Each plane crosses the ray plane in the line through q with in-plane normal n.
  struct PlaneLine {
    double qa, qb, na, nb;
  };
  std::vector<PlaneLine> plane_lines;
  for (const Plane& q : scene.planes) {
    const Vec3<double> n = normalize(q.normal);
    double na = dot(n, plane.along), nb = dot(n, plane.forward);
    const double len = std::hypot(na, nb);
    na /= len, nb /= len;
    plane_lines.push_back({plane.a(q.point), plane.b(q.point), na, nb});
  }
  {
    const double ca = (a0 + a1) / 2, cb = (b0 + b1) / 2;
    for (const PlaneLine& l : plane_lines) {
      // The point of the line nearest the centre.
      const double d = (ca - l.qa) * l.na + (cb - l.qb) * l.nb;
      include(ca - d * l.na, cb - d * l.nb, 0);
    }
  }
  double span_a = a1 - a0, span_b = b1 - b0;
  const double span = std::max(span_a, span_b);
  // Keep a flat scene visible: at least a tenth as tall as wide.
  if (span_a < span / 10) a0 -= (span / 10 - span_a) / 2, a1 = a0 + span / 10;
  if (span_b < span / 10) b0 -= (span / 10 - span_b) / 2, b1 = b0 + span / 10;
  const double margin = 0.04 * span;
  a0 -= margin, a1 += margin, b0 -= margin, b1 += margin;
  span_a = a1 - a0, span_b = b1 - b0;

  // A chart in plane coordinates, one unit as long on both axes; everything clipped to the
  // region above so that the axes show the scene, not the far ends of misses.
  plot::Chart d;
  d.equal_aspect = true;
  d.width = o.size;
  const double plot_w = o.size - 260.0;  // about what the axes and the legend take
  d.height = std::clamp(int(std::lround(plot_w * span_b / span_a)) + 120, 320, 2 * o.size);
  d.title = "Rays in the plane of the sphere centres";
  d.subtitle = scene.name;
  d.x.label = "a: along the camera row (scene units)";
  d.y.label = "b: along the rays (scene units)";
  auto series = [&](const std::string& name, plot::Color c, double width) {
    plot::Series s;
    s.name = name, s.color = c, s.mark = plot::Mark::segments, s.line_width = width;
    return s;
  };
  plot::Series row = series("camera row", plot::kGrey, 3);
  plot::Series planes = series("planes", plot::kBlack, 2);
  plot::Series rays = series("camera and reflected rays", plot::kRed, 1);
  plot::Series lit = series("rays that reach a light", plot::kBlue, 1);
  plot::Series blocked = series("blocked rays to lights", plot::kGrey, 0.6);
  blocked.dashed = true;
  d.x.min = a0, d.x.max = a1, d.y.min = b0, d.y.max = b1;
  // Segments clipped well beyond that region: the equal scale widens one axis, and rays should
  // run to the frame, which clips them.
  const double ca0 = a0 - 4 * span, ca1 = a1 + 4 * span, cb0 = b0 - 4 * span, cb1 = b1 + 4 * span;
  auto segment = [&](plot::Series& s, double pa, double pb, double qa, double qb) {
    if (!plot::clip_segment(pa, pb, qa, qb, ca0, cb0, ca1, cb1)) return;
    s.x.push_back(pa), s.y.push_back(pb), s.x.push_back(qa), s.y.push_back(qb);
  };

  segment(row, cam.xmin, 0, cam.xmax, 0);
  const double reach = 2 * (span_a + span_b);
  for (const PlaneLine& l : plane_lines) {
    const double ta = -l.nb, tb = l.na;  // along the line
    const double ca = (a0 + a1) / 2, cb = (b0 + b1) / 2;
    const double d0 = (ca - l.qa) * l.na + (cb - l.qb) * l.nb;
    const double pa = ca - d0 * l.na, pb = cb - d0 * l.nb;
    segment(planes, pa - reach * ta, pb - reach * tb, pa + reach * ta, pb + reach * tb);
  }
  // Rays, in tracing order.
  for (const auto& s : log.segments) {
    const double fa = plane.a(s.from), fb = plane.b(s.from);
    double ta = plane.a(s.to), tb = plane.b(s.to);
    if (s.kind == reference::PathLog::Segment::light) {
      if (s.hit && !o.show_blocked) continue;
      segment(s.hit ? blocked : lit, fa, fb, ta, tb);
      continue;
    }
    if (!s.hit) {
      if (o.hits_only) continue;
      // A miss goes on past the edge of the drawing, wherever it started.
      const double da = ta - fa, db = tb - fb, len = std::hypot(da, db);
      if (!(len > 0)) continue;
      const double far = std::hypot(fa - (a0 + a1) / 2, fb - (b0 + b1) / 2) + span_a + span_b;
      ta = fa + da / len * far, tb = fb + db / len * far;
    }
    segment(rays, fa, fb, ta, tb);
  }
  for (plot::Series* s : {&row, &planes, &rays, &lit, &blocked})
    if (!s->x.empty()) d.series.push_back(*s);
  for (const Sphere& s : scene.spheres) {
    // The circle the sphere cuts from the plane (its centre is in the plane within tolerance).
    const double off = dot(s.center - plane.origin, plane.normal);
    const double r = std::sqrt(std::max(0.0, s.radius * s.radius - off * off));
    d.circles.push_back(plot::Circle{plane.a(s.center), plane.b(s.center), r, plot::kBlack, 2});
  }
  if (!d.circles.empty()) d.legend_circles.push_back("spheres");
  plot::Series lights;
  lights.name = "lights", lights.color = plot::palette(1), lights.mark = plot::Mark::points;
  lights.marker_radius = 5;
  for (const Light& l : scene.lights)
    lights.x.push_back(plane.a(l.position)), lights.y.push_back(plane.b(l.position));
  if (!lights.x.empty()) d.series.push_back(lights);
  return d;
}

plot::Chart profile_plot(const Profile& profile, const std::string& title) {
  plot::Chart c;
  c.width = 760, c.height = 500;
  c.title = title.empty() ? "Flux against position" : title;
  c.x.label = "position x on the camera row (scene units)";
  c.y.label = "flux (radiance, linear)";
  c.y.from_zero = true;
  plot::Series s;
  s.name = "flux per pixel";
  s.color = plot::palette(0);
  s.mark = plot::Mark::line_points;
  s.marker_radius = 2.5;
  s.line_width = 1;
  s.x = profile.x, s.y = profile.flux;
  c.series.push_back(s);
  return c;
}

}  // namespace lancer::flux
