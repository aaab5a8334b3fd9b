// The Python module `lancer` (its compiled part, lancer._lancer): docs/python.md.
#include <pybind11/stl.h>

#include "lancer/error.hpp"
#include "scene_py.hpp"

namespace lancer::python {

namespace {

// numpy scalars and arrays inside a description, as the plain numbers and lists json writes.
py::object plain(py::object o) {
  if (py::hasattr(o, "tolist")) return o.attr("tolist")();
  throw py::type_error("Scene: " + py::str(py::type::of(o)).cast<std::string>() +
                       " is not a JSON value (dicts, lists, numbers, strings, booleans)");
}

std::shared_ptr<PyScene> from_dict(const py::object& description, const std::string& name,
                                   const CallOptions& o) {
  if (!py::isinstance<py::dict>(description))
    throw py::type_error("Scene(description): a dict as the scene format describes (docs/" +
                         std::string("scene-format.md); Scene.load(path) reads a file"));
  py::object dumps = py::module_::import("json").attr("dumps");
  // allow_nan=False: NaN and infinities, which no JSON number holds, are refused with
  // json's ValueError rather than written as tokens the loader would call a syntax error.
  const std::string text =
      dumps(description, py::arg("allow_nan") = false, py::arg("default") = py::cpp_function(plain))
          .cast<std::string>();
  return PyScene::from_json(text, name, o);
}

CallOptions call(std::optional<std::string> precision, std::optional<int> width,
                 std::optional<int> threads) {
  return {std::move(precision), width, threads};
}

}  // namespace

void bind_scene(py::module_& m) {
  using Opt = std::optional<std::string>;
  using OptInt = std::optional<int>;
  py::class_<PyScene, std::shared_ptr<PyScene>>(m, "Scene", R"doc(
A scene prepared for tracing: Scene.load(path) or Scene(dict). precision ('auto', 'exact',
'double', 'fast'), width (0: widest, 1: the scalar reference, 4, 8, 16) and threads (0: all
cores) are the scene's defaults; render, intersect, occluded and primary_hits may override them.)doc")
      .def(py::init([](const py::object& d, const std::string& name, Opt p, OptInt w, OptInt t) {
             return from_dict(d, name, call(std::move(p), w, t));
           }),
           py::arg("description"), py::kw_only(), py::arg("name") = "dict",
           py::arg("precision") = py::none(), py::arg("width") = py::none(),
           py::arg("threads") = py::none())
      .def_static(
          "load",
          [](const py::object& path, Opt p, OptInt w, OptInt t) {
            // A str or any path-like object (pathlib.Path), as open() takes.
            const auto text = py::module_::import("os").attr("fspath")(path).cast<std::string>();
            return PyScene::load(text, call(std::move(p), w, t));
          },
          py::arg("path"), py::kw_only(), py::arg("precision") = py::none(),
          py::arg("width") = py::none(), py::arg("threads") = py::none(),
          "Reads a scene file as `lancer render` does")
      .def_property_readonly("name", &PyScene::name)
      .def_property_readonly("nx", [](const PyScene& s) { return s.description().camera.nx; })
      .def_property_readonly("ny", [](const PyScene& s) { return s.description().camera.ny; })
      .def(
          "info",
          [](const PyScene& s, Opt p, OptInt w, OptInt t) {
            return s.info(call(std::move(p), w, t));
          },
          py::kw_only(), py::arg("precision") = py::none(), py::arg("width") = py::none(),
          py::arg("threads") = py::none(), "What the scene resolved: precision, width, isa...")
      .def(
          "render",
          [](const PyScene& s, Opt p, OptInt w, OptInt t, std::optional<std::pair<int, int>> r) {
            return s.render(call(std::move(p), w, t), r);
          },
          py::kw_only(), py::arg("precision") = py::none(), py::arg("width") = py::none(),
          py::arg("threads") = py::none(), py::arg("rows") = py::none(),
          "Linear radiance, float32 (ny, nx, 3), row 0 at the top: `lancer render`'s bits; "
          "rows=(begin, end) renders those rows only")
      .def(
          "intersect",
          [](const PyScene& s, py::array o, py::array d, py::object tfar, py::object tnear, Opt p,
             OptInt w, py::object out) {
            return s.intersect(o, d, tnear, tfar, call(std::move(p), w, {}), out);
          },
          py::arg("origins"), py::arg("directions"), py::arg("tfar") = py::none(), py::kw_only(),
          py::arg("tnear") = py::none(), py::arg("precision") = py::none(),
          py::arg("width") = py::none(), py::arg("out") = py::none(),
          "Closest hits of (n, 3) rays (unit directions): (t, id, normal), id -1 on a miss")
      .def(
          "occluded",
          [](const PyScene& s, py::array o, py::array d, py::object tfar, py::object tnear, Opt p,
             OptInt w, py::object out) {
            return s.occluded(o, d, tnear, tfar, call(std::move(p), w, {}), out);
          },
          py::arg("origins"), py::arg("directions"), py::arg("tfar") = py::none(), py::kw_only(),
          py::arg("tnear") = py::none(), py::arg("precision") = py::none(),
          py::arg("width") = py::none(), py::arg("out") = py::none(),
          "Whether anything lies on each ray before tfar: bool (n,)")
      .def("camera_rays", &PyScene::camera_rays, py::arg("a") = 0, py::arg("b") = 0,
           "World-space camera rays of every pixel at sub-sample (a, b): origins, directions, "
           "each float32 (ny, nx, 3)")
      .def(
          "primary_hits",
          [](const PyScene& s, Opt p, OptInt w, OptInt t) {
            return s.primary_hits(call(std::move(p), w, t));
          },
          py::kw_only(), py::arg("precision") = py::none(), py::arg("width") = py::none(),
          py::arg("threads") = py::none(),
          "Per pixel: camera rays' distances summed over sub-samples (float32 (ny, nx)) and the "
          "first object hit (int32 (ny, nx), -1 for none)")
      .def("_repr_png_", [](const PyScene& s) { return s.png({}); })
      .def("__repr__", [](const PyScene& s) {
        return "<lancer.Scene '" + s.name() + "' " + std::to_string(s.description().camera.nx) +
               "x" + std::to_string(s.description().camera.ny) + ", " +
               std::to_string(s.description().num_objects()) + " objects>";
      });
  m.def("png", &png_of, py::arg("image"),
        "PNG bytes of a linear image (ny, nx, 3), as `lancer render -o x.png` writes it");
}

}  // namespace lancer::python

PYBIND11_MODULE(_lancer, m) {
  namespace py = pybind11;
  m.doc() = "lancer's library API over numpy arrays (docs/python.md)";
  // Bad input is a ValueError carrying the CLI's one-line message.
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const lancer::InputError& e) {
      PyErr_SetString(PyExc_ValueError, e.what());
    }
  });
  m.attr("version") = lancer::api::version();
  lancer::python::bind_scene(m);
  lancer::python::bind_tools(m);
}
