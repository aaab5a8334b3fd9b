// The Python module's scene: a description held once and prepared on demand, one prepared
// lancer::api::Scene per (precision, width, threads) asked for, so that render(precision=...)
// and intersect(...) with other options than the scene's defaults reuse what was prepared.
#pragma once

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <tuple>

#include "lancer/lancer.hpp"

namespace lancer::python {

namespace py = pybind11;

// What a call may override of the scene's defaults (None: the default).
struct CallOptions {
  std::optional<std::string> precision;
  std::optional<int> width, threads;
};

class PyScene {
 public:
  PyScene(lancer::Scene description, std::string name, const CallOptions& defaults);

  static std::shared_ptr<PyScene> load(const std::string& path, const CallOptions& defaults);
  // The dict serialised by Python's json module and read by the file loader, so that its
  // messages are the CLI's with the file named `name`.
  static std::shared_ptr<PyScene> from_json(const std::string& text, const std::string& name,
                                            const CallOptions& defaults);

  const std::string& name() const { return name_; }
  const lancer::Scene& description() const { return *desc_; }
  // The JSON a dict was read from; none for a file (name() is then its path).
  const std::optional<std::string>& source_text() const { return source_; }
  api::Options options(const CallOptions& call) const;
  // The scene prepared with `options` (prepared now if it was not yet). Called with the GIL
  // released: preparing may take seconds and renders sample rows for automatic precision.
  std::shared_ptr<const api::Scene> prepared(const api::Options& options) const;
  // The same with the GIL released around it.
  std::shared_ptr<const api::Scene> prepared_nogil(const CallOptions& call) const;

  py::dict info(const CallOptions& call) const;
  py::array_t<float> render(const CallOptions& call, std::optional<std::pair<int, int>> rows) const;
  // out: None (new arrays) or the arrays to write (C-contiguous, writable, exactly the shape
  // and dtype returned), returned themselves: a caller tracing batch after batch reuses them.
  py::tuple intersect(py::array origins, py::array directions, py::object tnear, py::object tfar,
                      const CallOptions& call, py::object out) const;
  py::array occluded(py::array origins, py::array directions, py::object tnear, py::object tfar,
                     const CallOptions& call, py::object out) const;
  py::tuple camera_rays(int a, int b) const;
  py::tuple primary_hits(const CallOptions& call) const;
  py::bytes png(const CallOptions& call) const;

 private:
  std::shared_ptr<const lancer::Scene> desc_;
  std::string name_;
  std::optional<std::string> source_;
  api::Options defaults_;
  mutable std::mutex mutex_;
  mutable std::map<std::tuple<int, int, int>, std::shared_ptr<const api::Scene>> prepared_;
};

// The array of a Python vector (std::vector moved into a capsule: no copy).
template <class T>
py::array_t<T> to_array(std::vector<T>&& v, std::vector<py::ssize_t> shape) {
  auto* held = new std::vector<T>(std::move(v));
  py::capsule owner(held, [](void* p) { delete static_cast<std::vector<T>*>(p); });
  return py::array_t<T>(shape, held->data(), owner);
}

// PNG bytes of a linear RGB image of shape (ny, nx, 3), as `lancer render -o x.png` writes them.
py::bytes png_of(py::array image);

void bind_scene(py::module_& m);
void bind_tools(py::module_& m);

}  // namespace lancer::python
