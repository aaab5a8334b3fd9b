// The 2D flux view of a scene (the second course text, seeds/002): parallel rays in one plane,
// the flux of each ray (its pixel's value) against its position along the camera's row, and a
// diagram of the plane with every ray the reference traced. `lancer flux` is its command.
#pragma once

#include <string>
#include <vector>

#include "lancer/plot.hpp"
#include "lancer/reference.hpp"
#include "lancer/scene.hpp"
#include "lancer/stats.hpp"
#include "lancer/vec3.hpp"

namespace lancer::flux {

// How the scene file names its objects, for messages: "objects[3]" for the file's fourth
// object, by sphere index and by plane index.
struct ObjectNames {
  std::vector<std::string> spheres, planes;
};

struct FluxScene {
  Scene scene;
  ObjectNames names;
};
// load_scene / parse_scene plus the objects' names in file order. Throws InputError.
FluxScene load_flux_scene(const std::string& path);
FluxScene parse_flux_scene(const std::string& text, const std::string& name);

// The plane every ray of a flux scene stays in.
//
// A one-row orthographic camera (ny = 1, supersample 1) shoots its rays from
// position + x u + y0 v along -w, where y0 is the screen y of the row's centre: they fill the
// plane through origin = position + y0 v spanned by u and -w, whose unit normal is v. The
// rays and every ray they spawn stay in that plane when
//   - every sphere centre C is in it: |(C - origin) . v| <= tolerance (so are the normals at
//     the hit points, and the mirrored rays);
//   - every light position L is in it: |(L - origin) . v| <= tolerance (so are the light rays);
//   - every plane's unit normal N is parallel to it: |N . v| <= 1e-9 (the plane crosses it in
//     a line, and the normals there lie in it).
// tolerance = 1e-9 * size, size being the largest of |xmin|, |xmax| and, from the camera
// position, the distance to each sphere's far side, light and plane point.
struct RayPlane {
  Vec3<double> origin;   // where the ray of screen x = 0 starts
  Vec3<double> along;    // u: screen x grows along it
  Vec3<double> forward;  // -w: the rays' direction
  Vec3<double> normal;   // v
  double size = 1, tolerance = 1e-9;

  // In-plane coordinates of p: (along, forward) components of p - origin.
  double a(const Vec3<double>& p) const { return dot(p - origin, along); }
  double b(const Vec3<double>& p) const { return dot(p - origin, forward); }
};

// Checks that `scene` is a flux scene and returns its plane. Throws InputError naming the place:
// camera.type (not orthographic), camera.resolution (ny != 1), supersample (not 1), or the first
// object or light off the plane (objects[k].center, objects[k].normal, lights[k].position).
RayPlane ray_plane(const Scene& scene, const ObjectNames& names);

// The flux of each camera ray: the mean of its pixel's r, g, b, rendered by the reference in
// double precision, against x = xmin + (i + 0.5) (xmax - xmin) / nx.
struct Profile {
  std::vector<double> x, flux;
  RayCounts rays;
};
Profile flux_profile(const Scene& scene);

// "x,flux" and one line per ray, each value the shortest text that reads back the same double.
std::string profile_csv(const Profile& profile);

// Every ray the reference traces for the scene's row (double precision), and the image it made.
struct Paths {
  reference::PathLog log;
  Image image;
  RayCounts rays;
};
Paths record_paths(const Scene& scene, const RayPlane& plane);

struct DiagramOptions {
  int size = 800;             // the figure's width in points (PNG pixels)
  bool hits_only = false;     // leave out camera and reflected rays that hit nothing
  bool show_blocked = false;  // draw blocked light rays too, thin and grey
};

// The plane of the rays seen from its normal, as a chart with axes in scene units (one unit as
// long on both) and a legend: the camera's row (grey) at b = 0 and the rays going up the page,
// spheres as black circles, planes as black lines, lights as orange points, camera and reflected
// rays in red up to their hit point (or the edge of the figure), light rays that reach their
// light in blue. One series per kind of ray, each holding segments.
plot::Chart diagram(const Scene& scene, const RayPlane& plane, const reference::PathLog& log,
                    const DiagramOptions& options = {});

// The flux against position, as the text's figure.
plot::Chart profile_plot(const Profile& profile, const std::string& title = "");

}  // namespace lancer::flux
