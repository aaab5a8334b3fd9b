#include "lancer/render.hpp"

#include <tbb/info.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "lancer/error.hpp"
#include "lancer/packet/api.hpp"
#include "lancer/prepared.hpp"
#include "lancer/reference.hpp"
#include "lancer/shapes.hpp"
#include "lancer/tiles.hpp"

namespace lancer {

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
  if (widths.empty()) {
    // Only fast mode, which has no width 1, can have none: a CPU without SSE4.2, or the cap.
    const char* cap = std::getenv("LANCER_MAX_WIDTH");
    throw InputError(option + ": fast precision runs on packets of 4 lanes or more, which " +
                     (cap && std::atoi(cap) < 4
                          ? std::string("LANCER_MAX_WIDTH=") + cap + " leaves out"
                          : std::string("this CPU or OS does not run")) +
                     "; take exact or double precision");
  }
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
  // LANCER_MAX_WIDTH (valid: supported_widths() above refused anything else) caps the ISAs by
  // their float width: blame the cap, not the CPU, when it is what leaves this width out.
  const char* cap = std::getenv("LANCER_MAX_WIDTH");
  if (cap && std::atoi(cap) < (dbl ? 2 : 1) * requested)
    throw InputError(option + ": width " + w + " in " + to_string(precision) + " precision needs " +
                     isa + ", which LANCER_MAX_WIDTH=" + cap +
                     " leaves out (it caps the packets at " + cap + " float lanes)");
  throw InputError(option + ": width " + w + " in " + to_string(precision) + " precision needs " +
                   isa + ", which this CPU or OS does not run");
}

namespace {

// Every kind runs at every width: the packets model triangles, meshes and cylinders too
// (packet/prim/shapes.hpp).
int width_for(int requested, Precision precision) { return resolve_width(requested, precision); }

}  // namespace

// The float envelope, measured by the stability tests (tests/test_extremes.cpp, docs/precision.md):
// in camera-relative coordinates, float renders within a fraction of a percent of double while
// the smallest sphere is at least 5e-6 of the scene's extent seen from the camera (4e-5 with
// planes), and its
// shading stays finite while every intensity lies within [1e-30, 1e30].
// Returns double's reason, or an empty string where the scene's sizes lie inside; sets the
// extent it measured against and the smallest radius (infinity without spheres).
namespace {
std::string outside_sizes(const Scene& scene, const Frame& frame, double& extent,
                          double& smallest) {
  // Extent from the camera: prepare() computes relative to it.
  extent = 0;
  auto grow = [&](const Vec3<double>& world) {
    const Vec3<double> p = world - scene.camera.position;
    extent = std::max({extent, std::fabs(p.x), std::fabs(p.y), std::fabs(p.z)});
  };
  smallest = INFINITY;
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
        return "a light's intensity lies outside float's range [1e-30, 1e30]";
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
    return why;
  }
  if (std::isfinite(smallest) && extent > 0 && smallest < min_feature * extent) {
    std::snprintf(why, sizeof why, "the smallest sphere (radius %g) is below %g of %s (%g)%s",
                  smallest, min_feature, against, extent,
                  scene.planes.empty() ? "" : " with planes");
    return why;
  }
  return {};
}

// Camera rays along a plane (docs/precision.md, issue 39). A ray meets a plane at
// t = h / (d.n), h the eye's height above it; float's d.n for a camera ray is off double's by up
// to 3.1 ulps of 1 (measured over 614 000 rays of 200 random cameras and planes), so where a
// camera ray runs within that of parallel float cannot tell whether it meets the plane at all:
// a generated cloud at 600x475, its horizon on a pixel row, had 10 camera rays of that row hit
// the ground 3.4e8 away in float where double's miss it. The rays that do meet it that far
// leave points whose height above the plane float has lost in the turned frame. No formula on
// float's ray can get its sign right (the ray itself is off by that much), so auto takes double
// where a camera ray's cosine with a plane is below 2^-18, 20 times that error: a row within
// 4e-6 radians of the horizon.
constexpr double kGrazingCosine = 0x1p-18;

// The smallest |cos| between the camera's rays (every sub-sample of every pixel) and a plane of
// unit normal n, turned into the camera's basis (a, b, c) = (u.n, v.n, w.n). A pinhole ray
// through (x, y) is (x, y, -distance) in that basis: along a row its cosine is
// L(x) / |(x, y, -distance)| with L linear, whose one critical point is a largest |cos|, so the
// smallest lies next to L's zero or at the row's ends.
double smallest_camera_cosine(const Scene& scene, const Vec3<double>& n_cam) {
  const CameraSpec& cam = scene.camera;
  const double a = n_cam.x, b = n_cam.y, c = n_cam.z;
  if (cam.type == CameraType::orthographic) return std::fabs(c);
  const int s = std::max(1, scene.supersample);
  const long long columns = static_cast<long long>(cam.nx) * s;
  const long long rows = static_cast<long long>(cam.ny) * s;
  const double dx = (cam.xmax - cam.xmin) / double(columns);
  const double dy = (cam.ymax - cam.ymin) / double(rows);
  const double dist = cam.distance;
  double smallest = INFINITY;
  auto at = [&](long long k, double y, double lin) {
    k = std::min(std::max(k, 0LL), columns - 1);
    const double x = cam.xmin + (double(k) + 0.5) * dx;
    smallest = std::min(smallest, std::fabs(x * a + lin) / std::sqrt(x * x + y * y + dist * dist));
  };
  for (long long r = 0; r < rows; ++r) {
    const double y = cam.ymax - (double(r) + 0.5) * dy;
    const double lin = y * b - dist * c;
    at(0, y, lin);
    at(columns - 1, y, lin);
    if (a != 0 && dx != 0) {
      const double k = (-lin / a - cam.xmin) / dx - 0.5;
      if (k > -1 && k < double(columns)) {
        at(static_cast<long long>(std::floor(k)), y, lin);
        at(static_cast<long long>(std::floor(k)) + 1, y, lin);
      }
    }
  }
  return smallest;
}

std::string grazing_plane(const Scene& scene, const Frame& frame) {
  if (scene.planes.empty()) return {};
  Scene view;  // the camera alone: its frame is turned into its basis
  view.camera = scene.camera;
  const Frame basis = camera_frame<double>(view);
  for (std::size_t k = 0; k < scene.planes.size(); ++k) {
    const Plane& pl = scene.planes[k];
    const Vec3<double> n = normalize(pl.normal);
    if (scene.camera.type == CameraType::pinhole) {
      // An eye float puts in the plane meets it at t = 0 only: no hit, at any angle.
      const Vec3<float> eye{0.0f, 0.0f, float(frame.depth)};
      const Vec3<float> point = Vec3<float>::from(frame.point(pl.point));
      const Vec3<float> normal = Vec3<float>::from(frame.direction(n));
      if (dot(point - eye, normal) == 0.0f) continue;
    }
    // Turned into the camera's basis, an orthographic ray is (0, 0, -1) and d.n is -n.z, double's
    // rounded once: its sign and its size to an ulp, however small.
    if (scene.camera.type == CameraType::orthographic && frame.turned) continue;
    const double cosine = smallest_camera_cosine(scene, basis.direction(n));
    if (cosine < kGrazingCosine) {
      char why[200];
      std::snprintf(why, sizeof why,
                    "camera rays run along plane %zu (cosine %.3g, below 2^-18): float cannot "
                    "tell whether they meet it",
                    k, cosine);
      return why;
    }
  }
  return {};
}

using Clock = std::chrono::steady_clock;

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

// The kernels built for the prepared scene's kinds (packet/api.hpp float_kernels' `shapes`).
Rows<float> float_rows(const PreparedScene<float>& s, int width, Precision p) {
  return {width == 1 ? nullptr : packet::float_kernels(width, p, s.features.shapes)};
}
Rows<double> double_rows(const PreparedScene<double>& s, int width) {
  return {width == 1 ? nullptr : packet::double_kernels(width, s.features.shapes)};
}

template <class Fn>
double timed(Fn fn) {
  const auto start = Clock::now();
  fn();
  return std::chrono::duration<double>(Clock::now() - start).count();
}

// Multi-bounce chaos (docs/precision.md, issue 39). A ray that meets curved mirrors one after
// another turns float's rounding into a different path: each bounce off a sphere multiplies an
// angle's error by about twice the distance to the next over the radius. Sizes do not show it:
// one million reflective spheres (reflect 0.5, max_depth 3) put 0.55% of pixels more than 2/255
// off double, 1024 spheres at reflect 0.9 and max_depth 6 2.3%, where the same clouds at
// max_depth 2 stay below 0.1%. So where rays can bounce twice or more, auto measures: it renders
// a sample of rows, spread evenly over the image, in exact float and in double, and keeps float
// only if the share of sampled pixels off by more than 2/255 stays within the budget with a
// margin of two standard errors of the sample's estimate (none where the sample is the image).
constexpr int kSamplePixels = 8192;
constexpr double kOffBudget = 0.005, kOffLevel = 2.0 / 255.0;

bool bounces_twice(const Scene& scene) {
  if (scene.max_depth < 2) return false;
  for (const Material& m : scene.materials)
    if (m.reflect > 0 || m.transmit > 0) return true;
  return false;
}

// The sample's rows: `count` rows spread evenly, the k-th at floor((k + 1/2) ny / count).
int sample_row(int k, int count, int ny) {
  return static_cast<int>((2 * static_cast<long long>(k) + 1) * ny /
                          (2 * static_cast<long long>(count)));
}

// Renders the sample's rows, each into its own band image.
template <class T, class R>
void render_sample(const PreparedScene<T>& prepared, const R& rows, std::vector<Image>& bands,
                   int threads) {
  lancer::run_tiles(int(bands.size()), threads, [&](int k0, int k1, RayCounts& c) {
    for (int k = k0; k < k1; ++k)
      rows.render(prepared, bands[k], bands[k].first_row, bands[k].first_row + 1, c);
  });
}

struct SampleOff {
  long long off = 0, pixels = 0, total = 0;
  double seconds = 0;  // preparing both precisions and rendering the sample
  double share() const { return pixels ? double(off) / double(pixels) : 0; }
  // The share plus two standard errors of a sample drawn without replacement.
  double upper() const {
    const double p = share(), n = double(pixels);
    const double spread = std::max(p, 1 / n) * (1 - p) / n * (1 - n / double(total));
    return p + 2 * std::sqrt(std::max(0.0, spread));
  }
};

// The float scene it prepared goes to `keep` where given: a render that keeps float need not
// prepare it again.
// The widest packets of a precision.
int sample_width(const Scene& /*scene*/, Precision precision) {
  return packet::supported_widths(precision).front();
}

SampleOff measure_sample(const Scene& scene, int threads,
                         std::unique_ptr<PreparedScene<float>>* keep) {
  const int nx = scene.camera.nx, ny = scene.camera.ny;
  const int count = static_cast<int>(std::min<long long>(ny, (kSamplePixels + nx - 1) / nx));
  const auto start = Clock::now();
  std::vector<Image> dbl(count, Image(nx, 1)), flt(count, Image(nx, 1));
  for (int k = 0; k < count; ++k) dbl[k].first_row = flt[k].first_row = sample_row(k, count, ny);
  {
    // One precision prepared at a time: the peak memory of a double render, not of both.
    const PreparedScene<double> d = prepare<double>(scene);
    render_sample(d, double_rows(d, sample_width(scene, Precision::dbl)), dbl, threads);
  }
  auto f = std::make_unique<PreparedScene<float>>(prepare<float>(scene));
  render_sample(*f, float_rows(*f, sample_width(scene, Precision::exact), Precision::exact), flt,
                threads);
  if (keep) *keep = std::move(f);
  SampleOff s;
  s.seconds = std::chrono::duration<double>(Clock::now() - start).count();
  s.pixels = static_cast<long long>(count) * nx;
  s.total = static_cast<long long>(nx) * ny;
  auto shown = [](float v) { return std::min(1.0f, std::max(0.0f, v)); };
  for (int k = 0; k < count; ++k) {
    for (std::size_t i = 0; i < std::size_t(nx) * 3; i += 3) {
      const float *a = &flt[k].rgb[i], *b = &dbl[k].rgb[i];
      bool off = false;
      for (int c = 0; c < 3; ++c) off = off || std::fabs(shown(a[c]) - shown(b[c])) > kOffLevel;
      s.off += off;
    }
  }
  return s;
}

// choose_precision, measuring on `threads` threads and handing the float scene it prepared to
// measure to `keep` where it chose float. A `width` (not null) that neither precision runs fails
// before the measure, with the message float's would give.
PrecisionChoice choose(const Scene& scene, int threads, std::unique_ptr<PreparedScene<float>>* keep,
                       const int* width) {
  const Frame frame = camera_frame<float>(scene);
  double extent = 0, smallest = INFINITY;
  std::string why = outside_sizes(scene, frame, extent, smallest);
  if (why.empty()) why = grazing_plane(scene, frame);
  if (!why.empty()) return {Precision::dbl, why};
  char inside[300], measured[160] = "";
  if (bounces_twice(scene)) {
    if (width) {
      try {
        resolve_width(*width, Precision::dbl);
      } catch (const InputError&) {
        resolve_width(*width, Precision::exact);
      }
    }
    const SampleOff s = measure_sample(scene, threads, keep);
    if (s.upper() > kOffBudget) {
      if (keep) keep->reset();
      std::snprintf(inside, sizeof inside,
                    "rays bounce up to %d times: %lld of %lld sampled pixels (%.3f%%) rendered in "
                    "float are more than 2/255 off double, over 0.5%% with the sample's margin "
                    "(measured in %.3g s)",
                    scene.max_depth, s.off, s.pixels, 100 * s.share(), s.seconds);
      return {Precision::dbl, inside};
    }
    std::snprintf(measured, sizeof measured,
                  "; %lld of %lld sampled pixels (%.3f%%) more than 2/255 off double (measured "
                  "in %.3g s)",
                  s.off, s.pixels, 100 * s.share(), s.seconds);
  }
  std::snprintf(inside, sizeof inside,
                "the scene lies inside float's envelope (%s %g, smallest sphere %g)%s",
                frame.depth > 0 ? "spread" : "extent", extent,
                std::isfinite(smallest) ? smallest : 0.0, measured);
  return {Precision::exact, inside};
}

}  // namespace

PrecisionChoice choose_precision(const Scene& scene) {
  return choose(scene, hardware_threads(), nullptr, nullptr);
}

template <class T>
StructureInfo structure_of(const PreparedScene<T>& p) {
  StructureInfo info;
  auto kind = [&](bool present, const char* name) {
    if (!present) return;
    info.kinds += (info.kinds.empty() ? "" : ", ") + std::string(name);
  };
  kind(p.features.spheres, "spheres");
  kind(p.features.planes, "planes");
  if (p.shapes) {
    kind(p.shapes->triangles() > 0,
         p.shapes->tri_normals.empty() ? "triangles" : "triangles (smooth normals)");
    kind(!p.shapes->cyl_object.empty(), "cylinders");
  }
  if (info.kinds.empty()) info.kinds = "none (no object)";
  if (p.shapes) {
    info.shape_primitives = p.shapes->prim.size();
    info.shape_nodes = p.shapes->nodes.size();
    info.shape_bytes = p.shapes->bytes();
    info.shape_build_seconds = p.shapes->build_seconds;
    info.shape_spheres = p.shapes->spheres;
  }
  if (!p.bvh.active()) return info;
  info.kind = "bvh";
  info.spheres = p.num_spheres;
  info.nodes = p.bvh.nodes.size();
  // The hierarchy and the camera's tables in its leaf order, which the walks read beside it.
  const EyeSphere<T>& e = p.leaf_eye;
  info.bytes = p.bvh.bytes() +
               (e.fx.size() + e.fy.size() + e.fz.size() + e.c.size() + e.reach.size()) * sizeof(T);
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
  // (Bvh::coherent_spread), one whose rays leave one leaf box clustered (Bvh::leaf_diagonal).
  // Where only those go alone, the others stay packets.
  std::string packets;
  const bool clusters = clusters_at(st.clustered_lanes, st.one_ray_lanes, width);
  const std::string clustered = "one ray alone at " + std::to_string(st.clustered_lanes) +
                                " lanes or fewer where they leave one leaf box";
  if (st.one_ray_lanes > 0)
    packets = " (a packet whole where its rays stay together" +
              (clusters ? ", " + clustered : std::string()) + ")";
  else if (clusters)
    packets = " (" + clustered + ")";
  return "closest hits " + walk_of(st.one_ray_lanes, width) + packets + "; shadow rays " +
         walk_of(st.shadow_one_ray_lanes, width);
}

struct PreparedRun::State {
  RenderOptions opt;
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
  // Threads first: auto may render a sample to choose, on as many (choose_precision).
  const int threads = resolve_threads(opt.threads);
  if (st.precision == Precision::automatic) {
    // The float scene auto prepared to measure is this render's where it is the same: the
    // default structure and no model_everything.
    const bool reusable = opt.accel == Accel::automatic && !opt.model_everything;
    const PrecisionChoice c = choose(scene, threads, reusable ? &st.f : nullptr, &opt.width);
    st.precision = c.precision;
    st.reason = c.reason;
  }
  // Bad options fail before the work of preparing.
  width_for(opt.width, st.precision);
  st.nx = scene.camera.nx, st.ny = scene.camera.ny;
  if (st.precision == Precision::dbl)
    st.d = std::make_unique<PreparedScene<double>>(prepare_for<double>(scene, opt));
  else if (!st.f)
    st.f = std::make_unique<PreparedScene<float>>(prepare_for<float>(scene, opt));
}

PreparedRun::~PreparedRun() = default;

// One timed frame: body(prepared, rows, r0, r1, counts) over the image's row tiles at the
// resolved width and thread count; fills res's width, threads, structure, seconds and rays.
template <class Result, class Body>
void PreparedRun::frame(Result& res, int width, int threads, Body body) const {
  const State& st = *state_;
  res.width = width_for(width, st.precision);
  res.threads = resolve_threads(threads);
  auto run = [&](const auto& prepared, const auto& rows) {
    res.structure = structure_of(prepared);
    res.structure.built_for = rows.kernels ? rows.kernels->kinds : "every kind (the reference)";
    // Only exact float and double packets read it: the reference walks one ray anyway; fast
    // packets stay packets.
    const bool packets =
        (st.precision == Precision::exact || st.precision == Precision::dbl) && res.width > 1;
    res.structure.one_ray_lanes = packets ? prepared.walk.one_ray_lanes : 0;
    res.structure.clustered_lanes = packets ? prepared.walk.clustered_lanes : 0;
    res.structure.shadow_one_ray_lanes = packets ? prepared.walk.shadow_one_ray_lanes : 0;
    res.seconds = timed([&] {
      res.rays = run_tiles(st.ny, res.threads, st.opt,
                           [&](int r0, int r1, RayCounts& c) { body(prepared, rows, r0, r1, c); });
    });
  };
  if (st.d)
    run(*st.d, double_rows(*st.d, res.width));
  else
    run(*st.f, float_rows(*st.f, res.width, st.precision));
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
template PreparedScene<float> prepare_for<float>(const Scene&, const RenderOptions&);
template PreparedScene<double> prepare_for<double>(const Scene&, const RenderOptions&);

}  // namespace lancer
