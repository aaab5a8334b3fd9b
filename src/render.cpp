#include "lancer/render.hpp"

#include <tbb/info.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <thread>

#include "lancer/error.hpp"
#include "lancer/packet/api.hpp"
#include "lancer/prepared.hpp"
#include "lancer/reference.hpp"
#include "lancer/shapes.hpp"
#include "lancer/tiles.hpp"

namespace lancer {

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

// TBB's count: the CPUs this process may run on (affinity mask, cgroup quota), which is also the
// most threads a TBB arena ever runs at once.
int hardware_threads() { return std::max(1, tbb::info::default_concurrency()); }

int resolve_threads(int requested, const std::string& option) {
  if (requested < 0 || requested > kMaxThreads)
    throw InputError(option + ": must be from 0 (all cores) to " + std::to_string(kMaxThreads) +
                     ", not " + std::to_string(requested) + " (docs/limits.md)");
  const int cores = hardware_threads();
  return requested == 0 ? cores : std::min(requested, cores);
}

int resolve_width(int requested, Precision precision, const std::string& option) {
  LANCER_CHECK(precision != Precision::automatic);
  const std::vector<int> widths = packet::supported_widths(precision);
  if (requested == 0) return widths.front();
  if (std::find(widths.begin(), widths.end(), requested) != widths.end()) return requested;
  const std::string w = std::to_string(requested);
  if (requested == 1)  // only fast mode lacks width 1
    throw InputError(option + ": fast precision runs on packets only (width 4, 8 or 16)");
  const bool dbl = precision == Precision::dbl;
  const std::string isa = packet::isa_name(requested, precision);
  if (isa == "none")
    throw InputError(option + ": " + to_string(precision) + " precision takes width auto, 1, " +
                     (dbl ? "2, 4 or 8" : "4, 8 or 16") + ", not " + w);
  throw InputError(option + ": width " + w + " in " + to_string(precision) + " precision needs " +
                   isa + ", which this CPU or OS does not run");
}

namespace {

// Triangles, meshes and cylinders: the reference models them, the packets do not yet, so such a
// scene runs at width 1 (auto) and a packet width asked for is refused rather than rendered
// without them.
int width_for(int requested, Precision precision, bool shapes) {
  if (!shapes) return resolve_width(requested, precision);
  if (precision == Precision::fast)
    throw InputError(
        "--precision: fast runs on packets only, and the packets do not model triangles, meshes "
        "or cylinders yet: use exact or double");
  if (requested != 0 && requested != 1)
    throw InputError(
        "--width: scenes with triangles, meshes or cylinders run on the reference "
        "only (width 1) until the packets model them, not width " +
        std::to_string(requested));
  return 1;
}

}  // namespace

// The float envelope, measured by the stability tests (tests/test_extremes.cpp, docs/precision.md):
// in camera-relative coordinates, float renders within a fraction of a percent of double while
// the smallest sphere is at least 5e-6 of the scene's extent seen from the camera (4e-5 with
// planes), and its
// shading stays finite while every intensity lies within [1e-30, 1e30].
PrecisionChoice choose_precision(const Scene& scene) {
  // Extent from the camera: prepare() computes relative to it.
  double extent = 0;
  auto grow = [&](const Vec3<double>& world) {
    const Vec3<double> p = world - scene.camera.position;
    extent = std::max({extent, std::fabs(p.x), std::fabs(p.y), std::fabs(p.z)});
  };
  double smallest = INFINITY;
  for (const Sphere& s : scene.spheres) {
    grow(s.center);
    // A sphere reaches its radius beyond its centre: a huge one around the camera is a huge
    // scene, whatever its centre's distance.
    extent = std::max(extent, s.radius);
    smallest = std::min(smallest, s.radius);
  }
  for (const Plane& p : scene.planes) grow(p.point);
  for (const Light& l : scene.lights) {
    grow(l.position);
    for (double v :
         {l.intensity.r, l.intensity.g, l.intensity.b, l.ambient.r, l.ambient.g, l.ambient.b})
      if (v != 0 && (v > 1e30 || v < 1e-30))
        return {Precision::dbl, "a light's intensity lies outside float's range [1e-30, 1e30]"};
  }
  // Float's envelope (docs/precision.md, issue 17). Scenes are prepared in the camera's frame
  // (float's spacing across the view scales with the view, not the distance) and, where the
  // spheres lie far beyond the eye against their spread, with its origin moved to them
  // (Frame::depth); sphere hit points are computed relative to small spheres. What is left:
  // - Without planes: a sphere at 5e-6 of the extent (the largest coordinate: down to distance /
  //   sqrt(3)) puts no pixel more than 2/255 off double (FloatEnvelope.HoldsAtTheEnvelopesEdge,
  //   6 seeds; 0.39% before the depth), nor do tiny spheres down to 1e-7 of their distance.
  // - With planes (and no depth then): their hits are o + t d, off by ulps of the distance
  //   from the eye, and leave by 64 of them; a cloud of spheres on a ground plane seen from
  //   afar (FloatEnvelope.TelescopeViewsOfACloud) puts 0.94% of pixels off at 5.5e-6 of the
  //   extent, 0.19% at 4e-5: the bound stays 4e-5 there.
  // Epsilon is no longer part of it: offsets, not epsilon, keep secondary rays off their
  // surface, and an epsilon below float's spacing changed no pixel of the shipped scenes
  // (FloatEnvelope.TinyEpsilonChangesNothing).
  const double min_feature = scene.planes.empty() ? 5e-6 : 4e-5;
  // - With the frame moved to far spheres (Frame::depth), their coordinates span their spread,
  //   not their distance: the bound applies to that (a pair shadowing each other at 1e-8 of the
  //   extent, 6e-9 of their distance, put no pixel 2/255 off double; tiny spheres to 1e-7: none).
  const Frame frame = camera_frame<float>(scene);
  const char* against = "the scene's extent";
  if (frame.depth > 0) {
    extent = frame.spread;
    against = "the spheres' spread (the frame moved to them)";
  }
  char why[200];
  // The camera's scale: a pixel's step across the window (a sub-sample's, with supersampling) is
  // what separates neighbouring camera rays. Below 1e-18 its square is no normal float and float
  // steps the window in subnormals (a window of +-1e-40 has 2^-149 steps a few at a time): the
  // same bound the loader puts on radii and distances.
  const CameraSpec& cam = scene.camera;
  const double samples = std::max(1, scene.supersample);
  const double step = std::min(std::fabs(cam.xmax - cam.xmin) / (cam.nx * samples),
                               std::fabs(cam.ymax - cam.ymin) / (cam.ny * samples));
  constexpr double kMinCameraStep = 1e-18;
  if (step < kMinCameraStep) {
    std::snprintf(why, sizeof why,
                  "the camera's pixel step (%g) is below 1e-18, where float steps in subnormals",
                  step);
    return {Precision::dbl, why};
  }
  if (std::isfinite(smallest) && extent > 0 && smallest < min_feature * extent) {
    std::snprintf(why, sizeof why, "the smallest sphere (radius %g) is below %g of %s (%g)%s",
                  smallest, min_feature, against, extent,
                  scene.planes.empty() ? "" : " with planes");
    return {Precision::dbl, why};
  }
  std::snprintf(
      why, sizeof why, "the scene lies inside float's envelope (%s %g, smallest sphere %g)",
      frame.depth > 0 ? "spread" : "extent", extent, std::isfinite(smallest) ? smallest : 0.0);
  return {Precision::exact, why};
}

namespace {

using Clock = std::chrono::steady_clock;

template <class T>
PreparedScene<T> prepare_for(const Scene& scene, const RenderOptions& opt) {
  PreparedScene<T> p = prepare<T>(scene, opt.accel);
  if (opt.model_everything) {
    // The sphere and plane flags stay: a type the scene lacks has no data to gather normals
    // from, and its intersection loop is empty either way.
    Features& f = p.features;
    f.lights = f.specular = f.reflection = true;
    f.coloured_lights = f.transparency = f.refraction = true;
  }
  return p;
}

// Tiles over threads with the progress callback fed as rows complete.
template <class Body>
RayCounts run_tiles(int ny, int threads, const RenderOptions& opt, Body body) {
  std::atomic<int> rows_done{0};
  return lancer::run_tiles(ny, threads, body, [&](int rows) {
    const int done = rows_done += rows;
    if (opt.on_progress) opt.on_progress(done, ny);
  });
}

// The rows renderer of a resolved precision and width: the reference at width 1, else the
// packet kernels.
template <class T>
struct Rows {
  const packet::KernelTable<T>* kernels = nullptr;
  void render(const PreparedScene<T>& s, Image& im, int r0, int r1, RayCounts& c) const {
    if (kernels)
      kernels->render_rows(s, im, r0, r1, c);
    else
      reference::render_rows(s, im, r0, r1, c);
  }
  void primary(const PreparedScene<T>& s, float* t, std::int32_t* id, int r0, int r1,
               RayCounts& c) const {
    if (kernels)
      kernels->primary_rows(s, t, id, r0, r1, c);
    else
      reference::primary_rows(s, t, id, r0, r1, c);
  }
};

Rows<float> float_rows(int width, Precision p) {
  return {width == 1 ? nullptr : packet::float_kernels(width, p)};
}
Rows<double> double_rows(int width) {
  return {width == 1 ? nullptr : packet::double_kernels(width)};
}

template <class Fn>
double timed(Fn fn) {
  const auto start = Clock::now();
  fn();
  return std::chrono::duration<double>(Clock::now() - start).count();
}

}  // namespace

template <class T>
StructureInfo structure_of(const PreparedScene<T>& p) {
  StructureInfo info;
  if (p.shapes) {
    info.shape_primitives = p.shapes->prim.size();
    info.shape_nodes = p.shapes->nodes.size();
    info.shape_bytes = p.shapes->bytes();
    info.shape_build_seconds = p.shapes->build_seconds;
  }
  if (!p.bvh.active()) return info;
  info.kind = "bvh";
  info.spheres = p.num_spheres;
  info.nodes = p.bvh.nodes.size();
  info.bytes = p.bvh.bytes();
  info.build_seconds = p.bvh.build_seconds;
  return info;
}
template StructureInfo structure_of(const PreparedScene<float>&);
template StructureInfo structure_of(const PreparedScene<double>&);

namespace {
std::string walk_of(int lanes, int width) {
  if (lanes <= 0) return "packets";
  // A packet's lone lanes walk interleaved (Traversal::closest_one / any_one).
  if (lanes >= width) return "one ray at a time, " + std::to_string(width) + " walks interleaved";
  return "packets, one ray alone at " + std::to_string(lanes) +
         (lanes == 1 ? " lane" : " lanes or fewer, their walks interleaved");
}
}  // namespace

std::string secondary_walk(const StructureInfo& st, int width) {
  if (width <= 1) return "one ray at a time (the reference)";
  // Where closest hits go one ray at a time, a packet whose rays stay together walks whole
  // (Bvh::coherent_spread).
  return "closest hits " + walk_of(st.one_ray_lanes, width) +
         (st.one_ray_lanes > 0 ? " (a packet whole where its rays stay together)" : "") +
         "; shadow rays " + walk_of(st.shadow_one_ray_lanes, width);
}

struct PreparedRun::State {
  RenderOptions opt;
  bool shapes = false;  // triangles, meshes or cylinders: the reference only  // accel,
                        // model_everything and on_progress of every run
  Precision precision = Precision::exact;
  std::string reason;
  int nx = 0, ny = 0;
  std::unique_ptr<PreparedScene<float>> f;
  std::unique_ptr<PreparedScene<double>> d;
};

StructureInfo PreparedRun::structure() const {
  return state_->f ? structure_of(*state_->f) : structure_of(*state_->d);
}

PreparedRun::PreparedRun(const Scene& scene, const RenderOptions& opt)
    : state_(std::make_unique<State>()) {
  State& st = *state_;
  st.opt = opt;
  st.precision = opt.precision;
  if (st.precision == Precision::automatic) {
    const PrecisionChoice c = choose_precision(scene);
    st.precision = c.precision;
    st.reason = c.reason;
  }
  // Bad options fail before the work of preparing.
  st.shapes = !scene.shapes.empty();
  width_for(opt.width, st.precision, st.shapes);
  resolve_threads(opt.threads);
  st.nx = scene.camera.nx, st.ny = scene.camera.ny;
  if (st.precision == Precision::dbl)
    st.d = std::make_unique<PreparedScene<double>>(prepare_for<double>(scene, opt));
  else
    st.f = std::make_unique<PreparedScene<float>>(prepare_for<float>(scene, opt));
}

PreparedRun::~PreparedRun() = default;

// One timed frame: body(prepared, rows, r0, r1, counts) over the image's row tiles at the
// resolved width and thread count; fills res's width, threads, structure, seconds and rays.
template <class Result, class Body>
void PreparedRun::frame(Result& res, int width, int threads, Body body) const {
  const State& st = *state_;
  res.width = width_for(width, st.precision, st.shapes);
  res.threads = resolve_threads(threads);
  auto run = [&](const auto& prepared, const auto& rows) {
    res.structure = structure_of(prepared);
    // Only exact float packets read it: the reference walks one ray anyway; fast and double
    // packets stay packets.
    const bool packets = st.precision == Precision::exact && res.width > 1;
    res.structure.one_ray_lanes = packets ? prepared.bvh.one_ray_lanes : 0;
    res.structure.shadow_one_ray_lanes = packets ? prepared.bvh.shadow_one_ray_lanes : 0;
    res.seconds = timed([&] {
      res.rays = run_tiles(st.ny, res.threads, st.opt,
                           [&](int r0, int r1, RayCounts& c) { body(prepared, rows, r0, r1, c); });
    });
  };
  if (st.d)
    run(*st.d, double_rows(res.width));
  else
    run(*st.f, float_rows(res.width, st.precision));
}

RenderResult PreparedRun::render(int width, int threads) const {
  const State& st = *state_;
  RenderResult res;
  res.precision = st.precision;
  res.precision_reason = st.reason;
  res.image = Image(st.nx, st.ny);
  frame(res, width, threads,
        [&](const auto& prepared, const auto& rows, int r0, int r1, RayCounts& c) {
          rows.render(prepared, res.image, r0, r1, c);
        });
  res.isa = packet::isa_name(res.width, res.precision);
  if (st.shapes)
    res.width_reason =
        "triangles, meshes and cylinders: the reference only until the packets "
        "model them";
  return res;
}

PrimaryResult PreparedRun::primary(int width, int threads, bool ids) const {
  const State& st = *state_;
  PrimaryResult res;
  const std::size_t pixels = std::size_t(st.nx) * st.ny;
  res.t.assign(pixels, 0.0f);
  if (ids) res.id.assign(pixels, -1);
  std::int32_t* id = ids ? res.id.data() : nullptr;
  frame(res, width, threads,
        [&](const auto& prepared, const auto& rows, int r0, int r1, RayCounts& c) {
          rows.primary(prepared, res.t.data(), id, r0, r1, c);
        });
  return res;
}

RenderResult render(const Scene& scene, const RenderOptions& opt) {
  return PreparedRun(scene, opt).render(opt.width, opt.threads);
}

PrimaryResult render_primary(const Scene& scene, const RenderOptions& opt) {
  return PreparedRun(scene, opt).primary(opt.width, opt.threads, false);
}

PrimaryResult render_primary_with_ids(const Scene& scene, const RenderOptions& opt) {
  return PreparedRun(scene, opt).primary(opt.width, opt.threads, true);
}

struct PrimaryKernelRun::State {
  PreparedScene<float> scene;
  const packet::KernelTable<float>* kernels = nullptr;
  int threads = 1;
  std::vector<float> rays, t;  // the packets' rays and, per run, their lanes' t
  std::vector<int> lanes;
  std::vector<std::uint32_t> where;  // each lane's camera ray in the image's order
  std::size_t camera_rays = 0;
};

PrimaryKernelRun::PrimaryKernelRun(const Scene& scene, const RenderOptions& opt)
    : state_(std::make_unique<State>()) {
  if (opt.precision != Precision::exact && opt.precision != Precision::fast)
    throw InputError("--precision: the kernel alone runs float packets: exact or fast");
  if (!scene.shapes.empty())
    throw InputError("--mode kernel: the packets do not model triangles, meshes or cylinders yet");
  const int width = resolve_width(opt.width, opt.precision);
  if (width == 1) throw InputError("--width: the kernel alone runs packets: 4, 8 or 16, not 1");
  State& st = *state_;
  st.scene = prepare_for<float>(scene, opt);
  st.kernels = packet::float_kernels(width, opt.precision);
  st.threads = resolve_threads(opt.threads);
  const int ny = scene.camera.ny;
  const std::size_t packets = st.kernels->camera_packet_count(st.scene, 0, ny);
  st.rays.resize(packets * 6 * std::size_t(width));
  st.t.resize(packets * std::size_t(width));
  st.lanes.resize(packets);
  st.where.resize(packets * std::size_t(width));
  st.kernels->camera_packets(st.scene, 0, ny, st.rays.data(), st.lanes.data(), st.where.data());
  const int samples = st.scene.camera.samples;
  st.camera_rays =
      std::size_t(ny) * std::size_t(scene.camera.nx) * std::size_t(samples) * std::size_t(samples);
}

PrimaryKernelRun::~PrimaryKernelRun() = default;

PrimaryResult PrimaryKernelRun::run() {
  State& st = *state_;
  const int w = st.kernels->width;
  PrimaryResult res;
  res.width = w;
  res.threads = st.threads;
  res.structure = structure_of(st.scene);
  res.seconds = timed([&] {
    res.rays = lancer::run_tiles(st.scene.camera.ny, st.threads, [&](int r0, int r1, RayCounts& c) {
      const std::size_t first = st.kernels->camera_packet_count(st.scene, 0, r0);
      const std::size_t count = st.kernels->camera_packet_count(st.scene, r0, r1);
      st.kernels->intersect_camera_packets(st.scene, st.rays.data() + first * 6 * w,
                                           st.lanes.data() + first, count, st.t.data() + first * w,
                                           c);
    });
  });
  // Untimed: each camera ray's t to its place in the image's order.
  res.t.assign(st.camera_rays, 0.0f);
  for (std::size_t k = 0; k < st.where.size(); ++k)
    if (st.where[k] != packet::kNoCameraRay) res.t[st.where[k]] = st.t[k];
  return res;
}

}  // namespace lancer
