// lancer.Scene: the library API (include/lancer/lancer.hpp) over numpy arrays. Rays are read
// from the caller's arrays where they lie (any strides, float32 or float64) into packets of 16,
// and the results written straight into the arrays returned: no intermediate copy of the rays.
#include "scene_py.hpp"

#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <type_traits>
#include <utility>
#include <vector>

#include "lancer/error.hpp"
#include "lancer/image.hpp"
#include "lancer/image_formats.hpp"
#include "transpose.hpp"

namespace lancer::python {

namespace {

constexpr int kLanes = 16;

std::string shape_text(const py::array& a) {
  std::string s = "(";
  for (py::ssize_t k = 0; k < a.ndim(); ++k) s += (k ? ", " : "") + std::to_string(a.shape(k));
  return s + (a.ndim() == 1 ? ",)" : ")");
}

std::string dtype_text(const py::array& a) { return py::str(a.dtype()).cast<std::string>(); }

// A float32 or float64 array's element, by byte strides: any layout numpy makes is read in
// place, and nothing outside the array's extent (shape times strides) is touched.
struct Floats {
  const char* data = nullptr;
  py::ssize_t stride0 = 0, stride1 = 0;
  bool f64 = false;
  template <class T>
  float get(py::ssize_t i, py::ssize_t c, py::ssize_t s0, py::ssize_t s1) const {
    T v;
    std::memcpy(&v, data + i * s0 + c * s1, sizeof v);
    return float(v);
  }
  template <class T>
  float get(py::ssize_t i, py::ssize_t c) const {
    return get<T>(i, c, stride0, stride1);
  }
  float at(py::ssize_t i, py::ssize_t c = 0) const {
    return f64 ? get<double>(i, c) : get<float>(i, c);
  }
};

bool is_float_array(const py::array& a) {
  return a.dtype().is(py::dtype::of<float>()) || a.dtype().is(py::dtype::of<double>());
}

// An (n, 3) array of rays' origins or directions: refused unless it is exactly that.
Floats vectors(const py::array& a, const char* what) {
  if (a.ndim() != 2 || a.shape(1) != 3)
    throw InputError(std::string(what) + ": must have shape (n, 3), not " + shape_text(a));
  if (!is_float_array(a))
    throw InputError(std::string(what) + ": must be float32 or float64, not " + dtype_text(a));
  return {static_cast<const char*>(a.data()), a.strides(0), a.strides(1),
          a.dtype().is(py::dtype::of<double>())};
}

// tnear or tfar: None (the default), a number (every ray) or an (n,) array.
struct PerRay {
  Floats array;
  float value = 0;
  bool per_ray = false;
  py::array held;
  float at(py::ssize_t i) const { return per_ray ? array.at(i) : value; }
};

PerRay per_ray(const py::object& v, float fallback, py::ssize_t n, const char* what) {
  PerRay r;
  r.value = fallback;
  if (v.is_none()) return r;
  if (py::isinstance<py::float_>(v) || py::isinstance<py::int_>(v)) {
    r.value = v.cast<float>();
    return r;
  }
  if (!py::isinstance<py::array>(v))
    throw InputError(std::string(what) + ": must be None, a number or an array of shape (n,)");
  r.held = v.cast<py::array>();
  if (r.held.ndim() != 1 || r.held.shape(0) != n)
    throw InputError(std::string(what) + ": must have shape (" + std::to_string(n) + ",), not " +
                     shape_text(r.held));
  if (!is_float_array(r.held))
    throw InputError(std::string(what) + ": must be float32 or float64, not " + dtype_text(r.held));
  r.array = {static_cast<const char*>(r.held.data()), r.held.strides(0), 0,
             r.held.dtype().is(py::dtype::of<double>())};
  r.per_ray = true;
  return r;
}

struct Rays {
  Floats org, dir;
  PerRay tnear, tfar;
  py::ssize_t n = 0;
};

Rays rays_of(const py::array& origins, const py::array& directions, const py::object& tnear,
             const py::object& tfar) {
  Rays r;
  r.org = vectors(origins, "origins");
  r.dir = vectors(directions, "directions");
  if (origins.shape(0) != directions.shape(0))
    throw InputError("directions: " + std::to_string(directions.shape(0)) + " rays, origins " +
                     std::to_string(origins.shape(0)));
  r.n = origins.shape(0);
  r.tnear = per_ray(tnear, 0.0f, r.n, "tnear");
  r.tfar = per_ray(tfar, std::numeric_limits<float>::infinity(), r.n, "tfar");
  return r;
}

// Rays [first, first + count) into a packet; lanes past count inactive (a copy of the first).
// TO, TD: the element types of origins and directions, and Packed: both are rows of 3
// contiguous elements (C order), fixed per call so that the lanes are read without a branch
// or a run-time stride per element.
template <class TO, class TD, bool Packed>
int fill(const Rays& r, py::ssize_t first, api::Ray16& p, int valid[kLanes]) {
  const int count = int(std::min<py::ssize_t>(kLanes, r.n - first));
  const auto org = [&](py::ssize_t i, int c) {
    return Packed ? r.org.get<TO>(i, c, 3 * sizeof(TO), sizeof(TO)) : r.org.get<TO>(i, c);
  };
  const auto dir = [&](py::ssize_t i, int c) {
    return Packed ? r.dir.get<TD>(i, c, 3 * sizeof(TD), sizeof(TD)) : r.dir.get<TD>(i, c);
  };
  if constexpr (Packed && std::is_same_v<TO, float> && std::is_same_v<TD, float>) {
    if (count == kLanes) {
      const float* o = reinterpret_cast<const float*>(r.org.data) + 3 * first;
      const float* d = reinterpret_cast<const float*>(r.dir.data) + 3 * first;
      for (int k = 0; k < kLanes; k += 4) {
        rows_to_lanes4(o + 3 * k, p.org_x + k, p.org_y + k, p.org_z + k);
        rows_to_lanes4(d + 3 * k, p.dir_x + k, p.dir_y + k, p.dir_z + k);
      }
      for (int k = 0; k < kLanes; ++k) p.mask[k] = api::kAllObjects, valid[k] = -1;
    }
  }
  if (!(Packed && std::is_same_v<TO, float> && std::is_same_v<TD, float>) || count < kLanes) {
    for (int k = 0; k < kLanes; ++k) {
      const py::ssize_t i = first + (k < count ? k : 0);
      p.org_x[k] = org(i, 0), p.org_y[k] = org(i, 1), p.org_z[k] = org(i, 2);
      p.dir_x[k] = dir(i, 0), p.dir_y[k] = dir(i, 1), p.dir_z[k] = dir(i, 2);
      p.mask[k] = api::kAllObjects;
      valid[k] = k < count ? -1 : 0;
    }
  }
  for (int k = 0; k < kLanes; ++k) p.tnear[k] = r.tnear.value, p.tfar[k] = r.tfar.value;
  if (r.tnear.per_ray)
    for (int k = 0; k < count; ++k) p.tnear[k] = r.tnear.array.at(first + k);
  if (r.tfar.per_ray)
    for (int k = 0; k < count; ++k) p.tfar[k] = r.tfar.array.at(first + k);
  return count;
}

// f(first, count, packet, valid) for each packet of 16 rays, in order.
template <class TO, class TD, class F>
void packets_of(const Rays& r, F&& f) {
  api::Ray16 p;
  int valid[kLanes];
  const bool packed = r.org.stride1 == sizeof(TO) && r.org.stride0 == 3 * sizeof(TO) &&
                      r.dir.stride1 == sizeof(TD) && r.dir.stride0 == 3 * sizeof(TD);
  for (py::ssize_t first = 0; first < r.n; first += kLanes) {
    // The rays two packets ahead, on their way while this packet is traced.
    if (first + 3 * kLanes <= r.n) {
      for (int c = 0; c < 3; ++c) {
        __builtin_prefetch(r.org.data + (first + 2 * kLanes) * r.org.stride0 + c * 64);
        __builtin_prefetch(r.dir.data + (first + 2 * kLanes) * r.dir.stride0 + c * 64);
      }
    }
    const int count =
        packed ? fill<TO, TD, true>(r, first, p, valid) : fill<TO, TD, false>(r, first, p, valid);
    f(first, count, p, valid);
  }
}

template <class F>
void each_packet(const Rays& r, F&& f) {
  if (r.org.f64)
    r.dir.f64 ? packets_of<double, double>(r, f) : packets_of<double, float>(r, f);
  else
    r.dir.f64 ? packets_of<float, double>(r, f) : packets_of<float, float>(r, f);
}

// The API names a packet's lane ("intersect: lane 3: dir must be unit length..."): the caller
// knows rays by their index in the arrays.
[[noreturn]] void rethrow_with_index(const InputError& e, py::ssize_t first) {
  const std::string m = e.what();
  const std::string key = ": lane ";
  const std::size_t at = m.find(key);
  if (at != std::string::npos) {
    std::size_t end = at + key.size();
    int k = 0;
    while (end < m.size() && m[end] >= '0' && m[end] <= '9') k = k * 10 + (m[end++] - '0');
    throw InputError(m.substr(0, at) + ": ray " + std::to_string(first + k) + m.substr(end));
  }
  throw e;
}

// An array to write n results into: a new one, or the caller's `out` when it is exactly what
// would be made (C-contiguous, writable, that dtype and shape), so that nothing is written
// outside it.
template <class T>
py::array_t<T> output(const py::object& out, std::vector<py::ssize_t> shape, const char* what) {
  if (out.is_none()) return py::array_t<T>(shape);
  const std::string want = std::string(what) + ": must be a writable C-contiguous " +
                           py::str(py::dtype::of<T>()).cast<std::string>() + " array of shape ";
  std::string dims = "(";
  for (std::size_t k = 0; k < shape.size(); ++k) dims += (k ? ", " : "") + std::to_string(shape[k]);
  dims += shape.size() == 1 ? ",)" : ")";
  if (!py::isinstance<py::array>(out)) throw InputError(want + dims);
  py::array a = out.cast<py::array>();
  const bool same_shape = a.ndim() == py::ssize_t(shape.size()) &&
                          std::equal(shape.begin(), shape.end(), a.shape(), a.shape() + a.ndim());
  if (!a.dtype().is(py::dtype::of<T>()) || !same_shape || !a.writeable() ||
      !(a.flags() & py::array::c_style))
    throw InputError(want + dims + ", not " + dtype_text(a) + " " + shape_text(a));
  return py::reinterpret_borrow<py::array_t<T>>(a);
}

}  // namespace

PyScene::PyScene(lancer::Scene description, std::string name, const CallOptions& defaults)
    : desc_(std::make_shared<const lancer::Scene>(std::move(description))), name_(std::move(name)) {
  defaults_ = options(defaults);  // from api::Options' own defaults
}

std::shared_ptr<PyScene> PyScene::load(const std::string& path, const CallOptions& defaults) {
  lancer::Scene s;
  {
    py::gil_scoped_release nogil;
    s = load_scene(path);
  }
  auto scene = std::make_shared<PyScene>(std::move(s), path, defaults);
  scene->prepared_nogil({});  // prepared now, as `lancer render` would: errors at load
  return scene;
}

std::shared_ptr<PyScene> PyScene::from_json(const std::string& text, const std::string& name,
                                            const CallOptions& defaults) {
  lancer::Scene s;
  {
    py::gil_scoped_release nogil;
    s = parse_scene(text, name);
  }
  auto scene = std::make_shared<PyScene>(std::move(s), name, defaults);
  scene->source_ = text;
  scene->prepared_nogil({});
  return scene;
}

api::Options PyScene::options(const CallOptions& call) const {
  api::Options o = defaults_;
  if (call.precision) o.precision = parse_precision(*call.precision, "precision");
  if (call.width) o.width = *call.width;
  if (call.threads) o.threads = *call.threads;
  return o;
}

std::shared_ptr<const api::Scene> PyScene::prepared(const api::Options& o) const {
  // Held while preparing: two threads asking for the same options prepare it once.
  std::lock_guard<std::mutex> lock(mutex_);
  const auto key = std::make_tuple(int(o.precision), o.width, o.threads);
  auto it = prepared_.find(key);
  if (it != prepared_.end()) return it->second;
  auto s = std::make_shared<const api::Scene>(api::Scene::from_description(*desc_, o));
  prepared_.emplace(key, s);
  return s;
}

std::shared_ptr<const api::Scene> PyScene::prepared_nogil(const CallOptions& call) const {
  const api::Options o = options(call);
  py::gil_scoped_release nogil;
  return prepared(o);
}

py::dict PyScene::info(const CallOptions& call) const {
  const api::Info& in = prepared_nogil(call)->info();
  py::dict d;
  d["precision"] = to_string(in.precision);
  d["precision_reason"] = in.precision_reason;
  d["width"] = in.width;
  d["isa"] = in.isa;
  d["one_ray"] = in.one_ray;
  d["threads"] = in.threads;
  d["nx"] = in.nx, d["ny"] = in.ny, d["supersample"] = in.supersample;
  d["objects"] = in.objects;
  return d;
}

py::array_t<float> PyScene::render(const CallOptions& call,
                                   std::optional<std::pair<int, int>> rows) const {
  auto s = prepared_nogil(call);
  const int nx = s->info().nx, ny = s->info().ny;
  const int r0 = rows ? rows->first : 0, r1 = rows ? rows->second : ny;
  if (r0 < 0 || r1 < r0 || r1 > ny) {
    float unused = 0;  // the API's own check and message; nothing is written
    s->render_rows(r0, r1, &unused, std::size_t(3) * nx);
  }
  py::array_t<float> out({py::ssize_t(r1 - r0), py::ssize_t(nx), py::ssize_t(3)});
  float* rgb = out.mutable_data();
  {
    py::gil_scoped_release nogil;
    s->render_rows(r0, r1, rgb, std::size_t(3) * nx);
  }
  return out;
}

py::tuple PyScene::intersect(py::array origins, py::array directions, py::object tnear,
                             py::object tfar, const CallOptions& call, py::object out) const {
  const Rays r = rays_of(origins, directions, tnear, tfar);
  const py::ssize_t n = r.n;
  py::object o0 = py::none(), o1 = py::none(), o2 = py::none();
  if (!out.is_none()) {
    if (!py::isinstance<py::tuple>(out) || py::len(out) != 3)
      throw InputError("out: must be None or a tuple (t, id, normal)");
    o0 = out[py::int_(0)], o1 = out[py::int_(1)], o2 = out[py::int_(2)];
  }
  py::array_t<float> t = output<float>(o0, {n}, "out[0] (t)");
  py::array_t<std::int32_t> id = output<std::int32_t>(o1, {n}, "out[1] (id)");
  py::array_t<float> normal = output<float>(o2, {n, 3}, "out[2] (normal)");
  auto s = prepared_nogil(call);
  float* tp = t.mutable_data();
  std::int32_t* ip = id.mutable_data();
  float* np_ = normal.mutable_data();
  {
    py::gil_scoped_release nogil;
    api::Hit16 h;
    each_packet(r, [&](py::ssize_t first, int count, const api::Ray16& p, const int* valid) {
      try {
        s->intersect<kLanes>(count == kLanes ? nullptr : valid, p, h);
      } catch (const InputError& e) {
        rethrow_with_index(e, first);
      }
      // A full packet's copies of constant size, inlined rather than calls to memcpy.
      if (count == kLanes) {
        std::memcpy(tp + first, h.t, kLanes * sizeof(float));
        std::memcpy(ip + first, h.id, kLanes * sizeof(std::int32_t));
      } else {
        std::memcpy(tp + first, h.t, count * sizeof(float));
        std::memcpy(ip + first, h.id, count * sizeof(std::int32_t));
      }
      float* normals = np_ + 3 * first;
      int k = 0;
      for (; k + 4 <= count; k += 4)
        lanes_to_rows4(h.ng_x + k, h.ng_y + k, h.ng_z + k, normals + 3 * k);
      for (; k < count; ++k)
        normals[3 * k] = h.ng_x[k], normals[3 * k + 1] = h.ng_y[k], normals[3 * k + 2] = h.ng_z[k];
    });
  }
  return py::make_tuple(t, id, normal);
}

py::array PyScene::occluded(py::array origins, py::array directions, py::object tnear,
                            py::object tfar, const CallOptions& call, py::object out) const {
  const Rays r = rays_of(origins, directions, tnear, tfar);
  const py::ssize_t n = r.n;
  py::array_t<bool> result = output<bool>(out, {n}, "out");
  auto s = prepared_nogil(call);
  bool* op = result.mutable_data();
  {
    py::gil_scoped_release nogil;
    int blocked[kLanes];
    each_packet(r, [&](py::ssize_t first, int count, const api::Ray16& p, const int* valid) {
      try {
        s->occluded<kLanes>(count == kLanes ? nullptr : valid, p, blocked);
      } catch (const InputError& e) {
        rethrow_with_index(e, first);
      }
      for (int k = 0; k < count; ++k) op[first + k] = blocked[k] != 0;
    });
  }
  return std::move(result);
}

py::tuple PyScene::camera_rays(int a, int b) const {
  auto s = prepared_nogil({});
  const int nx = s->info().nx, ny = s->info().ny;
  if (nx > 0 && ny > 0) {
    float o[3], d[3];
    s->camera_ray(0, 0, a, b, o, d);  // the API's check of the sub-sample, before any array
  }
  py::array_t<float> org({py::ssize_t(ny), py::ssize_t(nx), py::ssize_t(3)});
  py::array_t<float> dir({py::ssize_t(ny), py::ssize_t(nx), py::ssize_t(3)});
  float* op = org.mutable_data();
  float* dp = dir.mutable_data();
  {
    py::gil_scoped_release nogil;
    for (int j = 0; j < ny; ++j)
      for (int i = 0; i < nx; ++i) {
        const std::size_t k = (std::size_t(j) * nx + i) * 3;
        s->camera_ray(i, j, a, b, op + k, dp + k);
      }
  }
  return py::make_tuple(org, dir);
}

py::tuple PyScene::primary_hits(const CallOptions& call) const {
  auto s = prepared_nogil(call);
  api::PrimaryHits h;
  {
    py::gil_scoped_release nogil;
    h = s->primary_hits();
  }
  const py::ssize_t nx = h.nx, ny = h.ny;
  return py::make_tuple(to_array(std::move(h.t), {ny, nx}), to_array(std::move(h.id), {ny, nx}));
}

py::bytes PyScene::png(const CallOptions& call) const { return png_of(render(call, {})); }

py::bytes png_of(py::array image) {
  if (image.ndim() != 3 || image.shape(2) != 3)
    throw InputError("image: must have shape (ny, nx, 3), not " + shape_text(image));
  if (!is_float_array(image))
    throw InputError("image: must be float32 or float64, not " + dtype_text(image));
  Image img(int(image.shape(1)), int(image.shape(0)));
  auto f = py::array_t<float, py::array::c_style | py::array::forcecast>::ensure(image);
  std::memcpy(img.rgb.data(), f.data(), img.rgb.size() * sizeof(float));
  std::vector<unsigned char> bytes;
  {
    py::gil_scoped_release nogil;
    bytes = encode_png(img, "image");
  }
  return py::bytes(reinterpret_cast<const char*>(bytes.data()), bytes.size());
}

}  // namespace lancer::python
