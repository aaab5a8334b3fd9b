// The library API's input: descriptions built in code held to the file loader's rules with its
// messages, scenes the CLI renders loading through the API too, and options out of range.
#include <gtest/gtest.h>

#include <functional>
#include <nlohmann/json.hpp>
#include <vector>

#include "api/api_util.hpp"
#include "lancer/lancer.hpp"
#include "lancer/render.hpp"
#include "support/test_util.hpp"

namespace lancer {
namespace {

using json = nlohmann::json;
using testing::error_of;
using testing::with;

// A scene with an inline material per object, so that the description's materials[k] is the
// file's objects[k].material.
json base_file() {
  return json::parse(R"({
    "camera": {"type": "pinhole", "position": [0, 0, 5], "direction": [0, 0, -1],
               "distance": 5, "resolution": [32, 24], "bounds": [-3, 3, -2, 2]},
    "background": [0.5, 0.5, 1.0], "max_depth": 2,
    "lights": [{"position": [60, 50, 100], "intensity": 1, "ambient": 1}],
    "objects": [
      {"type": "sphere", "center": [2, -1, -5], "radius": 1, "material": {"kd": 1}},
      {"type": "sphere", "center": [-1, -1, -3], "radius": 1, "material": {"ks": 1}},
      {"type": "plane", "point": [0, -2, 0], "normal": [0, 1, 0], "material": {"ka": 0.1}}
    ]})");
}

// The message without the scene's name in front.
std::string place_and_what(const std::string& message, const std::string& name) {
  return message.rfind(name + ": ", 0) == 0 ? message.substr(name.size() + 2) : message;
}
// Only what is wrong, after the place.
std::string what_of(const std::string& message) { return message.substr(message.rfind(": ") + 2); }

struct Case {
  const char* label;
  std::function<void(json&)> in_file;
  std::function<void(Scene&)> in_code;
  bool same_place = true;  // materials are named by index in code, by object in a file
};

// The same mistake made in a scene file and in a description built in code gets the same
// message: the rules are the loader's, not a copy.
TEST(ApiInput, DescriptionInCodeGetsTheFileLoadersMessages) {
  const std::vector<Case> cases = {
      {"radius", [](json& j) { j["objects"][1]["radius"] = -1; },
       [](Scene& d) { d.spheres[1].radius = -1; }},
      {"tiny radius", [](json& j) { j["objects"][0]["radius"] = 1e-30; },
       [](Scene& d) { d.spheres[0].radius = 1e-30; }},
      {"centre", [](json& j) { j["objects"][0]["center"][2] = 2e18; },
       [](Scene& d) { d.spheres[0].center.z = 2e18; }},
      {"normal",
       [](json& j) {
         j["objects"][2]["normal"] = {0, 0, 0};
       },
       [](Scene& d) {
         d.planes[0].normal = {0, 0, 0};
       }},
      {"camera vertical",
       [](json& j) {
         j["camera"]["direction"] = {1e-300, -1, 0};
       },
       [](Scene& d) {
         d.camera.direction = {1e-300, -1, 0};
       }},
      {"resolution", [](json& j) { j["camera"]["resolution"][1] = 0; },
       [](Scene& d) { d.camera.ny = 0; }},
      {"bounds",
       [](json& j) {
         j["camera"]["bounds"] = {1, -1, -1, 1};
       },
       [](Scene& d) { d.camera.xmin = 1, d.camera.xmax = -1; }},
      {"distance", [](json& j) { j["camera"]["distance"] = 0; },
       [](Scene& d) { d.camera.distance = 0; }},
      {"background",
       [](json& j) {
         j["background"] = {0, -1, 0};
       },
       [](Scene& d) { d.background.g = -1; }},
      {"light", [](json& j) { j["lights"][0]["position"][0] = -5e18; },
       [](Scene& d) { d.lights[0].position.x = -5e18; }},
      {"light intensity",
       [](json& j) {
         j["lights"][0]["intensity"] = {1, 2, 1e35};
       },
       [](Scene& d) {
         d.lights[0].intensity = {1, 2, 1e35};
       }},
      {"max_depth", [](json& j) { j["max_depth"] = 65; }, [](Scene& d) { d.max_depth = 65; }},
      {"epsilon", [](json& j) { j["epsilon"] = -1; }, [](Scene& d) { d.epsilon = -1; }},
      {"supersample", [](json& j) { j["supersample"] = 0; }, [](Scene& d) { d.supersample = 0; }},
      {"samples",
       [](json& j) {
         j["supersample"] = 64, j["camera"]["resolution"] = {513, 512};
       },
       [](Scene& d) { d.supersample = 64, d.camera.nx = 513, d.camera.ny = 512; }},
      {"kd", [](json& j) { j["objects"][1]["material"]["kd"] = -0.5; },
       [](Scene& d) { d.materials[1].kd = -0.5; }, false},
      {"shininess", [](json& j) { j["objects"][0]["material"]["shininess"] = 2e6; },
       [](Scene& d) { d.materials[0].shininess = 2e6; }, false},
      {"ior", [](json& j) { j["objects"][0]["material"]["ior"] = 1e-7; },
       [](Scene& d) { d.materials[0].ior = 1e-7; }, false},
      {"ray tree",
       [](json& j) {
         j["max_depth"] = 13;
         j["objects"][1]["material"]["reflect"] = 0.5,
         j["objects"][1]["material"]["transmit"] = 0.5;
       },
       [](Scene& d) { d.max_depth = 13, d.materials[1].reflect = d.materials[1].transmit = 0.5; },
       false},
      {"radiance", [](json& j) { j["lights"][0]["intensity"] = 1e34; },
       [](Scene& d) {
         d.lights[0].intensity = {1e34, 1e34, 1e34};
       },
       false},
  };
  const Scene base = parse_scene(base_file().dump(), "f.json");
  ASSERT_EQ(base.materials.size(), 3u);
  for (const Case& c : cases) {
    SCOPED_TRACE(c.label);
    json j = base_file();
    c.in_file(j);
    const std::string from_file =
        place_and_what(error_of([&] { parse_scene(j.dump(), "f.json"); }), "f.json");
    Scene d = base;
    d.name = "code";
    c.in_code(d);
    const std::string from_code =
        place_and_what(error_of([&] { api::Scene::from_description(d); }), "code");
    ASSERT_NE(from_file, "(no error)");
    if (c.same_place)
      EXPECT_EQ(from_code, from_file);
    else
      EXPECT_EQ(what_of(from_code), what_of(from_file)) << from_code << " / " << from_file;
  }
}

// What only code can hold: values no JSON number gives, enumerators out of range, material
// indices.
TEST(ApiInput, DescriptionValuesNoFileCanHoldAreRefusedByPlace) {
  const Scene base = parse_scene(base_file().dump(), "code");
  Scene d = base;
  d.camera.distance = std::nan("");
  EXPECT_EQ(error_of([&] { api::Scene::from_description(d); }),
            "code: camera.distance: must be finite");
  d = base;
  d.spheres[0].center.y = -INFINITY;
  EXPECT_EQ(error_of([&] { api::Scene::from_description(d); }),
            "code: objects[0].center[1]: must be finite");
  d = base;
  d.camera.type = CameraType(7);
  EXPECT_EQ(error_of([&] { api::Scene::from_description(d); }),
            "code: camera.type: must be \"pinhole\" or \"orthographic\"");
  d = base;
  d.spheres[1].material = 3;
  EXPECT_EQ(error_of([&] { api::Scene::from_description(d); }),
            "code: objects[1].material: no material 3 (3 described)");
  d = base;
  d.name.clear();
  d.epsilon = std::nan("");
  EXPECT_EQ(error_of([&] { api::Scene::from_description(d); }), "scene: epsilon: must be finite");
}

// More materials than a file may name (65536), as a file holds them inline, one per sphere, and
// the CLI renders: the description names none, so no such limit applies. The API once wrote
// descriptions out as files with every material named, and refused these.
TEST(ApiInput, DescriptionWithMoreMaterialsThanAFileMayNameLoads) {
  Scene d = parse_scene(base_file().dump(), "code");
  d.spheres.clear();
  d.materials.resize(1);
  const int n = int(kMaxNamedMaterials) + 100;
  for (int i = 0; i < n; ++i) {
    Material m;
    m.kd = 0.5 + 0.5 * (i % 7) / 7.0;
    d.materials.push_back(m);
    d.spheres.push_back({{(i % 300) * 0.02 - 3, (i / 300) * 0.02 - 2, -10}, 0.01, i + 1});
  }
  d.planes[0].material = 0;
  const api::Scene scene = api::Scene::from_description(d, with(Precision::exact));
  EXPECT_EQ(scene.info().objects, n + 1);
  EXPECT_EQ(scene.description().materials.size(), std::size_t(n) + 1);
}

// Options out of range are refused before anything is read, as the CLI refuses them: a thread
// count above 4096 once reached TBB and crashed render_rows.
TEST(ApiInput, OptionsOutOfRangeAreRefused) {
  const std::string good = testing::source_path("scenes/lorenzi-shadows.json");
  api::Options o;
  o.threads = 1 << 30;
  EXPECT_EQ(error_of([&] { api::Scene::load(good, o); }),
            "threads: must be from 0 (all cores) to 4096, not 1073741824 (docs/limits.md)");
  o.threads = 5000;
  EXPECT_EQ(error_of([&] { api::Scene::load("/nonexistent.json", o); }),
            "threads: must be from 0 (all cores) to 4096, not 5000 (docs/limits.md)");
  o.threads = 0;
  o.precision = Precision(77);
  EXPECT_EQ(error_of([&] { api::Scene::load(good, o); }),
            "precision: must be exact, dbl, fast or automatic, not Precision(77)");
  EXPECT_EQ(error_of([&] { api::Scene::from_description(load_scene(good), o); }),
            "precision: must be exact, dbl, fast or automatic, not Precision(77)");
}

// Info::threads is what render_rows runs on: more than the cores runs on the cores.
TEST(ApiInput, ThreadsReportWhatRuns) {
  const std::string good = testing::source_path("scenes/lorenzi-shadows.json");
  api::Options o;
  o.threads = kMaxThreads;
  const api::Scene scene = api::Scene::load(good, o);
  EXPECT_EQ(scene.info().threads, std::min(kMaxThreads, hardware_threads()));
  std::vector<float> rows(3 * std::size_t(scene.info().nx) * 2);
  EXPECT_GT(scene.render_rows(0, 2, rows.data(), 3 * std::size_t(scene.info().nx)).camera, 0u);
  o.threads = 0;
  EXPECT_EQ(api::Scene::load(good, o).info().threads, hardware_threads());
}

}  // namespace
}  // namespace lancer
