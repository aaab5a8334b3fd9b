// lancer.validate, lancer.bench, lancer.trade and lancer.flux: the CLI's measuring commands on a
// lancer.Scene, returning dicts (the keys of the commands' --json) and numpy arrays.
#include <pybind11/stl.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <variant>

#include "lancer/bench.hpp"
#include "lancer/compare.hpp"
#include "lancer/error.hpp"
#include "lancer/flux.hpp"
#include "lancer/packet/api.hpp"
#include "lancer/render.hpp"
#include "lancer/trade.hpp"
#include "scene_py.hpp"

namespace lancer::python {

namespace {

// One value or a list of them, as the CLI's comma lists: widths=8 or widths=[4, 8].
template <class T>
using OneOrMany = std::variant<T, std::vector<T>>;

template <class T>
std::vector<T> many(const OneOrMany<T>& v) {
  if (const T* one = std::get_if<T>(&v)) return {*one};
  return std::get<std::vector<T>>(v);
}

constexpr int kMaxRepeat = 1000;  // as the CLI's --repeat (docs/limits.md)

void check_repeat(int repeat) {
  if (repeat < 1 || repeat > kMaxRepeat)
    throw InputError("repeat: must be from 1 to " + std::to_string(kMaxRepeat) + ", not " +
                     std::to_string(repeat) + " (docs/limits.md)");
}

// None: every width this machine runs in `precision`; else each resolved as --width is.
std::vector<int> widths_of(const std::optional<OneOrMany<int>>& asked, Precision precision) {
  if (!asked) {
    const std::vector<int> all = packet::supported_widths(precision);
    // None only for fast precision without packets: one error naming the cause (the cap or the
    // CPU), not an empty list that runs nothing.
    if (all.empty()) resolve_width(0, precision, "widths");
    return all;
  }
  const std::vector<int> list = many(*asked);
  if (list.empty()) throw InputError("widths: no width given");
  std::vector<int> out;
  for (int w : list) out.push_back(resolve_width(w, precision, "widths"));
  return out;
}

py::object finite_or_none(double v) {
  return std::isfinite(v) ? py::object(py::float_(v)) : py::none();
}

py::dict validate(const PyScene& s, std::optional<OneOrMany<int>> asked,
                  const std::string& precision_text, int threads) {
  const Scene& scene = s.description();
  const Precision precision = parse_precision(precision_text, "precision");
  if (precision != Precision::exact && precision != Precision::dbl)
    throw InputError("precision: validate compares exact or double renders, not " + precision_text);
  std::vector<int> widths = widths_of(asked, precision);
  widths.erase(std::remove(widths.begin(), widths.end(), 1), widths.end());
  if (widths.empty())
    throw InputError(
        "widths: validate compares packet widths with the reference (width 1): "
        "give at least one of 4, 8, 16 (double: 2, 4, 8)");
  py::list rows;
  bool all = true;
  RenderResult ref;
  {
    py::gil_scoped_release nogil;
    RenderOptions o;
    o.width = 1, o.precision = precision, o.threads = threads;
    ref = render(scene, o);
  }
  PrimaryResult ref_hits;
  for (int w : widths) {
    RenderOptions o;
    o.width = w, o.precision = precision, o.threads = threads;
    RenderResult r;
    BitDiff d;
    std::uint64_t hits = 0;
    {
      py::gil_scoped_release nogil;
      if (ref_hits.t.empty()) {
        RenderOptions one = o;
        one.width = 1;
        ref_hits = render_primary_with_ids(scene, one);
      }
      r = render(scene, o);
      d = bit_diff(r.image, ref.image);
      const PrimaryResult h = render_primary_with_ids(scene, o);
      for (std::size_t k = 0; k < h.t.size(); ++k)
        hits +=
            std::memcmp(&h.t[k], &ref_hits.t[k], sizeof(float)) != 0 || h.id[k] != ref_hits.id[k];
    }
    const bool same_rays = r.rays == ref.rays;
    const bool identical = d.identical() && same_rays && hits == 0;
    all = all && identical;
    py::dict row;
    row["width"] = w, row["isa"] = r.isa, row["differing_pixels"] = d.differing_pixels;
    row["max_ulps"] = d.max_ulps, row["same_ray_counts"] = same_rays;
    row["camera_hits_differing"] = hits, row["identical"] = identical;
    row["first_differing_pixel"] =
        d.identical() ? py::object(py::none()) : py::object(py::make_tuple(d.first_i, d.first_j));
    rows.append(row);
  }
  py::dict out;
  out["scene"] = s.name();
  out["resolution"] = py::make_tuple(scene.camera.nx, scene.camera.ny);
  out["precision"] = to_string(precision);
  out["reference"] = py::dict(py::arg("width") = 1, py::arg("isa") = ref.isa);
  out["structure"] = ref.structure.kind;
  out["widths"] = rows;
  out["identical"] = all;
  return out;
}

py::dict bench_row(const BenchRow& r) {
  py::dict d;
  d["engine"] = r.engine, d["mode"] = r.mode, d["width"] = r.width, d["isa"] = r.isa;
  d["precision"] = r.precision, d["threads"] = r.threads, d["rays"] = r.rays;
  d["seconds"] = r.seconds, d["mrays_per_s"] = r.mrays_per_s();
  // What else names the row: "kernels, prepared frame" for the ao and diffuse modes' kernels
  // alone (else through the library API); empty for the others.
  d["config"] = r.config;
  d["samples"] = py::array_t<double>(py::ssize_t(r.samples.size()), r.samples.data());
  d["rays_by_kind"] = py::dict(
      py::arg("camera") = r.by_kind.camera, py::arg("shadow") = r.by_kind.shadow,
      py::arg("reflected") = r.by_kind.reflected, py::arg("refracted") = r.by_kind.refracted);
  return d;
}

py::dict bench(const PyScene& s, std::optional<OneOrMany<int>> widths,
               const std::string& precision_text, const OneOrMany<int>& thread_counts,
               const OneOrMany<std::string>& mode_names, int repeat) {
  const std::vector<int> threads = many(thread_counts);
  const std::vector<std::string> modes = many(mode_names);
  BenchOptions opt;
  const Precision precision = parse_precision(precision_text, "precision");
  if (precision == Precision::automatic)
    throw InputError("precision: bench measures exact, double or fast, not auto");
  opt.precisions = {precision};
  opt.widths = {widths_of(widths, precision)};
  if (threads.empty()) throw InputError("threads: no value given");
  opt.threads.clear();
  for (int t : threads) {
    const int ran = resolve_threads(t, "threads");
    if (std::find(opt.threads.begin(), opt.threads.end(), ran) == opt.threads.end())
      opt.threads.push_back(ran);
  }
  for (const std::string& m : modes)
    if (m != "primary" && m != "full" && m != "kernel" && m != "ao" && m != "diffuse")
      throw InputError("mode: must be primary, full, kernel, ao or diffuse, not '" + m + "'");
  if (modes.empty()) throw InputError("mode: no mode given");
  opt.modes = modes;
  check_repeat(repeat);
  opt.repeat = repeat;
  BenchResult result;
  {
    py::gil_scoped_release nogil;
    result = run_bench(s.description(), opt);
  }
  py::list rows;
  for (const BenchRow& r : result.rows) rows.append(bench_row(r));
  py::dict out;
  out["scene"] = s.name();
  out["structure"] = result.structure.kind;
  out["results"] = rows;
  return out;
}

py::dict trade(const PyScene& s, int repeat, int threads) {
  TradeOptions opt;
  check_repeat(repeat);
  opt.repeat = repeat;
  opt.threads = resolve_threads(threads, "threads");
  std::vector<TradeRow> rows;
  {
    py::gil_scoped_release nogil;
    rows = run_trade(s.description(), opt);
  }
  py::list results;
  for (const TradeRow& r : rows) {
    py::dict d;
    d["precision"] = to_string(r.precision), d["width"] = r.width, d["isa"] = r.isa;
    d["mrays_per_s"] = r.mrays_per_s, d["max_abs_diff"] = r.max_abs_diff;
    d["psnr_db"] = finite_or_none(r.psnr_db), d["off_pixel_frac"] = r.off_pixel_frac;
    d["hit_mismatch_frac"] = r.hit_mismatch_frac;
    results.append(d);
  }
  py::dict out;
  out["scene"] = s.name();
  out["results"] = results;
  return out;
}

// Segments of one kind as an (n, 2, 2) array of in-plane points (along, forward).
py::dict segments(const flux::RayPlane& plane, const reference::PathLog& log) {
  const char* names[] = {"camera", "reflected", "light", "refracted"};
  std::vector<double> pts[4];
  std::vector<std::uint8_t> hit[4];
  for (const auto& s : log.segments) {
    const int k = int(s.kind);
    pts[k].insert(pts[k].end(), {plane.a(s.from), plane.b(s.from), plane.a(s.to), plane.b(s.to)});
    hit[k].push_back(s.hit ? 1 : 0);
  }
  py::dict out;
  for (int k = 0; k < 4; ++k) {
    const py::ssize_t n = py::ssize_t(hit[k].size());
    py::dict d;
    d["points"] = to_array(std::move(pts[k]), {n, 2, 2});
    d["hit"] = py::array_t<bool>(n, reinterpret_cast<const bool*>(hit[k].data()));
    out[names[k]] = d;
  }
  return out;
}

// The scene's objects and lights in the plane's coordinates, for drawing beside the rays.
py::dict layout(const Scene& scene, const flux::RayPlane& plane) {
  py::list spheres, planes, lights;
  for (const Sphere& s : scene.spheres)
    spheres.append(py::make_tuple(plane.a(s.center), plane.b(s.center), s.radius));
  for (const Plane& p : scene.planes)
    planes.append(py::make_tuple(plane.a(p.point), plane.b(p.point), dot(p.normal, plane.along),
                                 dot(p.normal, plane.forward)));
  for (const Light& l : scene.lights)
    lights.append(py::make_tuple(plane.a(l.position), plane.b(l.position)));
  return py::dict(py::arg("spheres") = spheres, py::arg("planes") = planes,
                  py::arg("lights") = lights);
}

py::dict flux_of(const PyScene& s) {
  const flux::FluxScene fs = s.source_text() ? flux::parse_flux_scene(*s.source_text(), s.name())
                                             : flux::load_flux_scene(s.name());
  const flux::RayPlane plane = [&] {
    try {
      return flux::ray_plane(fs.scene, fs.names);
    } catch (const InputError& e) {
      throw InputError(s.name() + ": " + e.what());
    }
  }();
  flux::Profile profile;
  flux::Paths paths;
  {
    py::gil_scoped_release nogil;
    profile = flux::flux_profile(fs.scene);
    paths = flux::record_paths(fs.scene, plane);
  }
  py::dict out;
  const py::ssize_t n = py::ssize_t(profile.x.size());
  out["x"] = to_array(std::move(profile.x), {n});
  out["flux"] = to_array(std::move(profile.flux), {n});
  out["rays"] = segments(plane, paths.log);
  out["scene"] = layout(fs.scene, plane);
  return out;
}

}  // namespace

void bind_tools(py::module_& m) {
  m.def("validate", &validate, py::arg("scene"), py::kw_only(), py::arg("widths") = py::none(),
        py::arg("precision") = "exact", py::arg("threads") = 0,
        "Packets against the scalar reference, bit for bit (lancer validate --json's keys)");
  m.def("bench", &bench, py::arg("scene"), py::kw_only(), py::arg("widths") = py::none(),
        py::arg("precision") = "exact", py::arg("threads") = std::vector<int>{1},
        py::arg("modes") = std::vector<std::string>{"primary", "full"}, py::arg("repeat") = 5,
        "Rays per second, configurations interleaved per round (lancer bench --json's rows)");
  m.def("trade", &trade, py::arg("scene"), py::kw_only(), py::arg("repeat") = 5,
        py::arg("threads") = 1,
        "Speed against error for every precision and width (lancer trade --json's keys)");
  m.def("flux", &flux_of, py::arg("scene"),
        "The flux view of a one-row orthographic scene: x, flux, every ray traced as "
        "in-plane segments, and the objects and lights in the plane's coordinates");
}

}  // namespace lancer::python
