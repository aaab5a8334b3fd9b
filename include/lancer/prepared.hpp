// A scene converted once to the number type T a render computes in (float or double), laid out
// structure-of-arrays, plus the features it uses. The reference and the packets read the same
// prepared values, so they start from the same bits; each walks them with its own control flow.
#pragma once

#include <algorithm>
#include <cstdint>
#include <memory>
#include <vector>

#include "lancer/bvh.hpp"
#include "lancer/scene.hpp"
#include "lancer/vec3.hpp"

namespace lancer {

// What a scene needs modelled. Decided once per scene; a path skips the work a scene lacks.
struct Features {
  bool spheres = false;  // any sphere
  bool planes = false;   // any plane
  bool shapes = false;   // any triangle, mesh or cylinder (lancer/shapes.hpp)
  // Spheres and shapes both, in one hierarchy (PreparedShapes::spheres): the packets meet the
  // spheres in the shapes' walk, not in the spheres' own hierarchy or loop.
  bool spheres_in_shapes = false;
  bool lights = false;                // any light (else no shadow rays and no diffuse/specular)
  bool specular = false;              // any material with ks > 0
  bool reflection = false;            // max_depth > 0 and any material with reflect > 0
  bool fractional_shininess = false;  // a specular material whose shininess needs std::pow
  // A light whose intensity or ambient is not grey: shading per channel. Grey lights shade one
  // channel and scale it by the colour, the same bits as three equal channels.
  bool coloured_lights = false;
  // Any object with transmit > 0: shadow rays multiply transmittances instead of stopping at the
  // first object, and fast mode's convexity shortcuts no longer hold for every ray.
  bool transparency = false;
  // transparency and max_depth > 0: rays split (refracted children), the packets trace a tree.
  bool refraction = false;
};

template <class T>
struct PreparedShapes;  // lancer/shapes.hpp

template <class T>
struct PreparedCamera {
  bool orthographic = false;
  Vec3<T> position, u, v, w;
  T distance;
  int nx, ny, samples;  // samples per axis (supersample)
  T xmin, ymax, width, height, fnx, fny;
  std::vector<T> sub_offset;  // (a + 0.5) / s for a = 0 .. s-1
  // screen_x() of column i at sub-sample a, at [a * nx + i]; screen_y() of row j at sub-sample b,
  // at [b * ny + j]. The same formula as computing them per ray, done once.
  std::vector<T> screen_x, screen_y;
};

// Per-object fields are padded with zeros to at least kMaxLanes entries (packets look them up
// a whole register at a time): use the counts.
template <class T>
struct SphereBlock {
  std::vector<T> cx, cy, cz, r, r2;
  std::vector<T> inv_r;  // 1 / r, rounded once (fast mode's normals)
};

// Normals are unit.
template <class T>
struct PlaneBlock {
  std::vector<T> px, py, pz, nx, ny, nz;
};

// The material of each object, by object id (one gather per field).
template <class T>
struct MaterialBlock {
  std::vector<T> r, g, b, ka, kd, ks, shininess, reflect;
  // transmit, ior and 1 / ior (rounded once: eta of a ray entering the object).
  std::vector<T> transmit, ior, inv_ior;
  // 1 where the shininess is a whole number that power_int() raises to exactly, else 0.
  std::vector<T> shininess_int;
};

template <class T>
struct LightBlock {
  std::vector<T> x, y, z;
  // Grey lights (features.coloured_lights false): intensity and ambient, one value per light.
  std::vector<T> intensity, ambient;
  // Per channel r, g, b: [c][light]. Filled for every scene; read when coloured_lights.
  std::vector<T> intensity_rgb[3], ambient_rgb[3];
};

// How the packets walk the hierarchy (set by prepare() from the scene; read by exact float and
// double packets, not by fast ones).
template <class T>
struct WalkSettings {
  // Secondary packets' lanes go on one ray at a time into a subtree at most this many of them
  // enter (0: packets only; 16 or more: every lane alone from the root), from the sphere count
  // (kOneRayMinSpheres: 0 or kMaxLanes).
  int one_ray_lanes = 0;
  // The same for secondary packets whose lanes leave from within one leaf box of each other
  // (kClusteredLanes from kClusteredMinSpheres below kClusteredMaxSpheres, else one_ray_lanes).
  int clustered_lanes = 0;
  // The same for the shadow rays from secondary hits (kOneRayShadowMinSpheres).
  int shadow_one_ray_lanes = 0;
};

// For camera rays that all leave one point (pinhole): per sphere, f = eye - centre and
// c = |f|^2 - r^2, the same values every camera ray would compute.
// In leaf order (leaf_eye), for float pinhole cameras, also each sphere's radius plus the margin
// the camera tiles' cones keep (packet/cones.hpp; prepare.cpp's eye_reach).
template <class T>
struct EyeSphere {
  std::vector<T> fx, fy, fz, c, reach;
};

// The camera's frame, in which a scene is prepared: origin the camera's position, axes its basis
// u, v, w (the contract's, computed in double). A world point p is (u.(p - o), v.(p - o),
// w.(p - o)) there, computed in double and rounded once to T. Two things follow (see
// docs/precision.md): a scene far from the world's origin keeps T's full precision near the eye,
// and across the view float's spacing scales with what the view spans, not with the distance:
// a camera ray is (x, y, -distance) before its normalisation, exactly, and a small sphere in the
// middle of the view has small x and y, whatever its direction in the world.
// `depth`: where every sphere lies far beyond the eye, against its own spread (a tiny sphere 1e6
// radii away and its neighbours), the frame's origin moves along the view to the nearest
// sphere's surface: the eye sits at (0, 0, depth) and the spheres near 0, so that float's
// spacing between neighbours is that of their spread, not of their distance. The eye's own
// rounding (none: depth is a float) would move every camera ray alike.
// `turned` false: the world's axes (a scene with a sphere larger than half its distance from the
// eye: see camera_frame; the library API's queries where the camera looks off the axes), moved
// to the eye only.
// `axes`: u, v, w are the world's x, y, z (a frame that is not turned, or a camera looking
// along -z with y up): a direction is then the world's own and a point is only moved, with no
// product by the axes (which would give the same numbers but for the sign of a zero). The
// library API's rays and normals cross such a frame in a copy and three subtractions.
struct Frame {
  Vec3<double> origin{0, 0, 0};  // the eye
  Vec3<double> u{1, 0, 0}, v{0, 1, 0}, w{0, 0, 1};
  bool turned = false;
  bool axes = true;
  double depth = 0;
  double spread = 0;  // with depth: the spheres' largest coordinate + radius in this frame

  Vec3<double> point(const Vec3<double>& world) const {
    const Vec3<double> d = direction(world - origin);
    return {d.x, d.y, d.z + depth};
  }
  Vec3<double> direction(const Vec3<double>& world) const {
    if (axes) return world;
    return {dot(world, u), dot(world, v), dot(world, w)};
  }
  Vec3<double> world_point(const Vec3<double>& p) const {
    return origin + world_direction({p.x, p.y, p.z - depth});
  }
  Vec3<double> world_direction(const Vec3<double>& d) const {
    if (axes) return d;
    return u * d.x + v * d.y + w * d.z;
  }
};

// Which frame prepare<T>() puts a scene in. `render`: the camera's (camera_frame), in which
// `lancer render` traces. `query`: the one the library API traces its world-space rays in: the
// camera's where that keeps the world's axes, else the world's axes moved to the eye (no
// rotation of each ray and normal, the same resolution near the eye; docs/api.md).
enum class FrameKind { render, query };

template <class T>
struct PreparedScene {
  Frame frame;  // every coordinate below is in it
  PreparedCamera<T> camera;
  Features features;
  T background[3], environment[3];
  int max_depth;
  T epsilon;

  // Spheres: object ids 0 .. num_spheres-1.
  int num_spheres = 0;
  SphereBlock<T> spheres;
  // Every sphere's radius is at least kNaiveSphereRatio of its distance from the camera and at
  // most half of it: fast mode may use the textbook discriminant b^2 - c and roots -b -+ sqrt,
  // which float keeps there (docs/precision.md). Beyond the first bound b^2 - c cancels; beyond
  // the second the roots carry ulps of |b|, the distance to the centre, which for a huge sphere
  // seen from near its surface (a ground of radius 1e6) far exceed the hit's own distance.
  bool naive_spheres_hold = false;
  // Planes: object ids num_spheres .. num_objects-1.
  int num_planes = 0;
  PlaneBlock<T> planes;
  MaterialBlock<T> materials;  // by object id

  EyeSphere<T> eye;       // pinhole cameras: per sphere in id order
  EyeSphere<T> leaf_eye;  // the same in the hierarchy's leaf order, with reach (float pinhole)

  // The hierarchy over the spheres, when the scene gets one (bvh.active()); else every path
  // loops over all objects. How the packets walk it: `walk`.
  Bvh<T> bvh;
  WalkSettings<T> walk;

  int num_lights = 0;
  LightBlock<T> lights;

  // Triangles, meshes and cylinders (lancer/shapes.hpp): object ids num_spheres + num_planes on.
  int num_shapes = 0;
  std::shared_ptr<const PreparedShapes<T>> shapes;

  int num_objects() const { return num_spheres + num_planes + num_shapes; }
};

// Radius over distance from the camera above which b^2 - c still classifies >= 99.6% of rays
// near a sphere's edge as double does (test Extremes.RobustSphereTestAgainstNaive's method).
inline constexpr double kNaiveSphereRatio = 1.0 / 256.0;

// The widest packet, in lanes: tables that packets read whole batches from are padded by this.
inline constexpr int kMaxLanes = 16;

// How a scene of n spheres walks its hierarchy (kOneRayMinSpheres, kClusteredMinSpheres,
// kClusteredMaxSpheres, kOneRayShadowMinSpheres).
template <class T>
WalkSettings<T> walk_settings(int spheres) noexcept {
  WalkSettings<T> w;
  w.one_ray_lanes = spheres >= kOneRayMinSpheres ? kMaxLanes : 0;
  w.clustered_lanes = spheres >= kClusteredMinSpheres && spheres < kClusteredMaxSpheres
                          ? kClusteredLanes
                          : w.one_ray_lanes;
  w.shadow_one_ray_lanes = spheres >= kOneRayShadowMinSpheres ? kOneRayShadowLanes : 0;
  return w;
}

// Whether clustered packets walk otherwise than the rest at this packet width: their lanes go
// on alone at fewer lanes than the packet has (at 4 lanes of 4, every lane alone: apart), and
// fewer than the other secondary packets' lanes do (one_ray_lanes; 0: those stay packets).
inline bool clusters_at(int clustered_lanes, int one_ray_lanes, int width) noexcept {
  return clustered_lanes > 0 && clustered_lanes < width &&
         (one_ray_lanes <= 0 || clustered_lanes < one_ray_lanes);
}

// Shininess at or below this, and whole, is raised by repeated squaring (power_int).
inline constexpr double kMaxIntegerShininess = 1 << 20;

// Which structure `accel` resolves to for a scene: automatic takes the hierarchy from
// kBvhMinSpheres spheres on.
Accel resolve_accel(const Scene& scene, Accel accel);

// The frame prepare<T>() puts a scene in (depth rounded to T).
template <class T>
Frame camera_frame(const Scene& scene, FrameKind kind = FrameKind::render);
extern template Frame camera_frame<float>(const Scene&, FrameKind);
extern template Frame camera_frame<double>(const Scene&, FrameKind);

template <class T>
PreparedScene<T> prepare(const Scene& scene, Accel accel = Accel::automatic,
                         FrameKind kind = FrameKind::render);

extern template PreparedScene<float> prepare<float>(const Scene&, Accel, FrameKind);
extern template PreparedScene<double> prepare<double>(const Scene&, Accel, FrameKind);

}  // namespace lancer
