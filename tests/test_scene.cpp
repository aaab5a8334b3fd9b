// Scene files: the format of SCENE-MODEL.md, its defaults, and one clear error per bad input.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "lancer/error.hpp"
#include "lancer/scene.hpp"
#include "support/test_util.hpp"

namespace lancer {
namespace {

using nlohmann::json;

json base_scene() {
  return json::parse(R"({
    "camera": {"type": "pinhole", "position": [0, 0, 5], "direction": [0, 0, -1],
               "distance": 5, "resolution": [30, 20], "bounds": [-3, 3, -2, 2]},
    "background": [0.5, 0.5, 1.0],
    "materials": {"chrome": {"color": 0.8, "ka": 0.1, "ks": 1, "reflect": 0.5}},
    "lights": [{"position": [60, 50, 100], "intensity": 1, "ambient": 0.5}],
    "objects": [
      {"type": "sphere", "center": [1, -1, -1], "radius": 1, "material": "chrome"},
      {"type": "plane", "point": [0, -2, 0], "normal": [0, 1, 0],
       "material": {"color": [0.9, 0.6, 0.6], "ka": 0.1, "kd": 0.5, "ks": 0.6}},
      {"type": "sphere", "center": [0, 0, -5], "radius": 2}
    ]})");
}

TEST(SceneLoad, ReadsEveryFieldAndDefault) {
  const Scene s = parse_scene(base_scene().dump(), "s.json");
  EXPECT_EQ(s.camera.type, CameraType::pinhole);
  EXPECT_EQ(s.camera.nx, 30);
  EXPECT_EQ(s.camera.ny, 20);
  EXPECT_DOUBLE_EQ(s.camera.xmin, -3);
  EXPECT_DOUBLE_EQ(s.camera.ymax, 2);
  EXPECT_DOUBLE_EQ(s.background.b, 1.0);
  EXPECT_DOUBLE_EQ(s.environment.r, 0.5) << "environment defaults to background";
  EXPECT_EQ(s.max_depth, 0);
  EXPECT_DOUBLE_EQ(s.epsilon, 1e-4);
  EXPECT_EQ(s.supersample, 1);
  ASSERT_EQ(s.spheres.size(), 2u);
  ASSERT_EQ(s.planes.size(), 1u);
  const Material& chrome = s.materials[s.spheres[0].material];
  EXPECT_DOUBLE_EQ(chrome.color.g, 0.8);
  EXPECT_DOUBLE_EQ(chrome.kd, 1) << "kd defaults to 1";
  EXPECT_DOUBLE_EQ(chrome.shininess, 100);
  EXPECT_DOUBLE_EQ(chrome.reflect, 0.5);
  const Material& plain = s.materials[s.spheres[1].material];
  EXPECT_DOUBLE_EQ(plain.color.r, 1);
  EXPECT_DOUBLE_EQ(plain.ka, 0);
  EXPECT_DOUBLE_EQ(plain.ks, 0);
  const Material& ground = s.materials[s.planes[0].material];
  EXPECT_DOUBLE_EQ(ground.color.g, 0.6);
  EXPECT_DOUBLE_EQ(ground.ks, 0.6);
  ASSERT_EQ(s.lights.size(), 1u);
  EXPECT_DOUBLE_EQ(s.lights[0].ambient.g, 0.5);
  EXPECT_DOUBLE_EQ(s.lights[0].intensity.b, 1);
  EXPECT_DOUBLE_EQ(chrome.transmit, 0) << "transmit defaults to 0";
  EXPECT_DOUBLE_EQ(chrome.ior, 1) << "ior defaults to 1";
}

TEST(SceneLoad, ColouredLightsAndGlass) {
  json j = base_scene();
  j["lights"][0]["intensity"] = {1, 0.9, 0.8};
  j["lights"][0]["ambient"] = {0.1, 0.2, 0.3};
  j["lights"].push_back({{"position", {0, 9, 0}}});
  j["materials"]["glass"] = {{"transmit", 0.85}, {"ior", 1.5}, {"reflect", 0.1}};
  j["objects"][2]["material"] = "glass";
  j["objects"][1]["material"]["transmit"] = 0.3;
  j["max_depth"] = 12;  // the most a material that reflects and transmits allows
  const Scene s = parse_scene(j.dump(), "s.json");
  EXPECT_DOUBLE_EQ(s.lights[0].intensity.g, 0.9);
  EXPECT_DOUBLE_EQ(s.lights[0].intensity.b, 0.8);
  EXPECT_DOUBLE_EQ(s.lights[0].ambient.r, 0.1);
  EXPECT_DOUBLE_EQ(s.lights[1].intensity.r, 1) << "intensity defaults to 1";
  EXPECT_DOUBLE_EQ(s.lights[1].ambient.b, 0) << "ambient defaults to 0";
  const Material& glass = s.materials[s.spheres[1].material];
  EXPECT_DOUBLE_EQ(glass.transmit, 0.85);
  EXPECT_DOUBLE_EQ(glass.ior, 1.5);
  EXPECT_DOUBLE_EQ(s.materials[s.planes[0].material].transmit, 0.3);
  EXPECT_DOUBLE_EQ(s.materials[s.planes[0].material].ior, 1);
}

TEST(SceneLoad, EveryShippedSceneLoads) {
  for (const std::string& path : testing::shipped_scenes()) {
    SCOPED_TRACE(path);
    EXPECT_NO_THROW(load_scene(path));
  }
}

struct BadCase {
  const char* name;
  void (*mutate)(json&);
  const char* message;  // the whole message after "s.json: "
};

const BadCase kBadCases[] = {
    {"unknown top key", [](json& j) { j["colour"] = 1; }, "colour: unknown key"},
    {"unknown object key", [](json& j) { j["objects"][0]["radiu"] = 1; },
     "objects[0].radiu: unknown key"},
    {"unknown camera key", [](json& j) { j["camera"]["fov"] = 1; }, "camera.fov: unknown key"},
    {"unknown material key", [](json& j) { j["materials"]["chrome"]["kr"] = 1; },
     "materials.chrome.kr: unknown key"},
    {"wrong type radius", [](json& j) { j["objects"][2]["radius"] = "2"; },
     "objects[2].radius: must be a number"},
    {"wrong type position",
     [](json& j) {
       j["camera"]["position"] = {1, 2};
     },
     "camera.position: must be an array of 3 numbers"},
    {"wrong type vector element", [](json& j) { j["objects"][0]["center"][1] = true; },
     "objects[0].center[1]: must be a number"},
    {"wrong type lights", [](json& j) { j["lights"] = json::object(); },
     "lights: must be an array"},
    {"missing camera", [](json& j) { j.erase("camera"); }, "camera: missing required field"},
    {"missing objects", [](json& j) { j.erase("objects"); }, "objects: missing required field"},
    {"missing radius", [](json& j) { j["objects"][2].erase("radius"); },
     "objects[2].radius: missing required field"},
    {"missing light position", [](json& j) { j["lights"][0].erase("position"); },
     "lights[0].position: missing required field"},
    {"missing distance", [](json& j) { j["camera"].erase("distance"); },
     "camera.distance: missing required field"},
    {"zero radius", [](json& j) { j["objects"][2]["radius"] = 0; },
     "objects[2].radius: must be > 0"},
    {"negative radius", [](json& j) { j["objects"][0]["radius"] = -1; },
     "objects[0].radius: must be > 0"},
    {"zero normal",
     [](json& j) {
       j["objects"][1]["normal"] = {0, 0, 0};
     },
     "objects[1].normal: must not be zero"},
    {"zero direction",
     [](json& j) {
       j["camera"]["direction"] = {0, 0, 0};
     },
     "camera.direction: must not be zero"},
    {"zero distance", [](json& j) { j["camera"]["distance"] = 0; }, "camera.distance: must be > 0"},
    {"empty bounds",
     [](json& j) {
       j["camera"]["bounds"] = {1, 1, -2, 2};
     },
     "camera.bounds: xmax must be > xmin"},
    {"inverted bounds",
     [](json& j) {
       j["camera"]["bounds"] = {-3, 3, 2, -2};
     },
     "camera.bounds: ymax must be > ymin"},
    {"zero resolution",
     [](json& j) {
       j["camera"]["resolution"] = {0, 20};
     },
     "camera.resolution[0]: must be a positive integer"},
    {"negative resolution",
     [](json& j) {
       j["camera"]["resolution"] = {30, -1};
     },
     "camera.resolution[1]: must be a positive integer"},
    {"fractional resolution",
     [](json& j) {
       j["camera"]["resolution"] = {30.5, 20};
     },
     "camera.resolution[0]: must be an integer"},
    {"negative max_depth", [](json& j) { j["max_depth"] = -1; }, "max_depth: must be >= 0"},
    {"supersample zero", [](json& j) { j["supersample"] = 0; }, "supersample: must be >= 1"},
    {"negative ka", [](json& j) { j["materials"]["chrome"]["ka"] = -0.1; },
     "materials.chrome.ka: must be >= 0"},
    {"negative inline kd", [](json& j) { j["objects"][1]["material"]["kd"] = -1; },
     "objects[1].material.kd: must be >= 0"},
    {"negative reflect", [](json& j) { j["materials"]["chrome"]["reflect"] = -1; },
     "materials.chrome.reflect: must be >= 0"},
    {"negative color",
     [](json& j) {
       j["materials"]["chrome"]["color"] = {1, -1, 1};
     },
     "materials.chrome.color: components must be >= 0"},
    {"negative intensity", [](json& j) { j["lights"][0]["intensity"] = -1; },
     "lights[0].intensity: must be >= 0"},
    {"undefined material", [](json& j) { j["objects"][0]["material"] = "gold"; },
     "objects[0].material: material \"gold\" is not defined"},
    {"unknown object type", [](json& j) { j["objects"][0]["type"] = "cube"; },
     "objects[0].type: must be \"sphere\", \"plane\", \"triangle\", \"mesh\" or \"cylinder\""},
    {"unknown camera type", [](json& j) { j["camera"]["type"] = "fisheye"; },
     "camera.type: must be \"pinhole\" or \"orthographic\""},
    {"max_depth over the cap", [](json& j) { j["max_depth"] = 1000; },
     "max_depth: must be at most 64"},
    // Issue 13: coloured lights, transmit and ior.
    {"ior zero", [](json& j) { j["materials"]["chrome"]["ior"] = 0; },
     "materials.chrome.ior: must be > 0"},
    {"negative inline ior", [](json& j) { j["objects"][1]["material"]["ior"] = -1.5; },
     "objects[1].material.ior: must be > 0"},
    {"ior not a number", [](json& j) { j["materials"]["chrome"]["ior"] = "glass"; },
     "materials.chrome.ior: must be a number"},
    {"ior too large", [](json& j) { j["materials"]["chrome"]["ior"] = 1e9; },
     "materials.chrome.ior: must be from 1e-06 to 1e+06"},
    {"negative transmit", [](json& j) { j["materials"]["chrome"]["transmit"] = -0.5; },
     "materials.chrome.transmit: must be >= 0"},
    {"transmit not a number", [](json& j) { j["objects"][1]["material"]["transmit"] = {1}; },
     "objects[1].material.transmit: must be a number"},
    {"negative intensity component",
     [](json& j) {
       j["lights"][0]["intensity"] = {1, -0.5, 1};
     },
     "lights[0].intensity: components must be >= 0"},
    {"negative ambient", [](json& j) { j["lights"][0]["ambient"] = -0.1; },
     "lights[0].ambient: must be >= 0"},
    {"short ambient",
     [](json& j) {
       j["lights"][0]["ambient"] = {1, 1};
     },
     "lights[0].ambient: must be a number or an array of 3 numbers"},
    {"long intensity",
     [](json& j) {
       j["lights"][0]["intensity"] = {1, 1, 1, 1};
     },
     "lights[0].intensity: must be a number or an array of 3 numbers"},
    {"intensity a string", [](json& j) { j["lights"][0]["intensity"] = "bright"; },
     "lights[0].intensity: must be a number or an array of 3 numbers"},
    {"intensity component a string",
     [](json& j) {
       j["lights"][0]["intensity"] = {1, "x", 1};
     },
     "lights[0].intensity[1]: must be a number"},
    {"ray tree too deep",
     [](json& j) {
       j["materials"]["chrome"]["transmit"] = 0.5;
       j["max_depth"] = 64;
     },
     "materials.chrome: reflects and transmits, so the ray tree doubles per bounce: max_depth "
     "must be at most 12 with it, not 64"},
    {"ray tree too deep inline",
     [](json& j) {
       j["objects"][1]["material"]["transmit"] = 0.5;
       j["objects"][1]["material"]["reflect"] = 0.5;
       j["max_depth"] = 13;
     },
     "objects[1].material: reflects and transmits, so the ray tree doubles per bounce: "
     "max_depth must be at most 12 with it, not 13"},
};

class BadScene : public ::testing::TestWithParam<BadCase> {};

TEST_P(BadScene, GivesOneLineNamingThePlace) {
  json j = base_scene();
  GetParam().mutate(j);
  const std::string msg = testing::load_error(j.dump());
  EXPECT_EQ(msg, std::string("s.json: ") + GetParam().message);
  EXPECT_EQ(msg.find('\n'), std::string::npos);
}

INSTANTIATE_TEST_SUITE_P(Contract, BadScene, ::testing::ValuesIn(kBadCases),
                         [](const auto& param_info) {
                           std::string n = param_info.param.name;
                           for (char& c : n)
                             if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
                           return n;
                         });

TEST(SceneLoad, NonFiniteNumbersAreRefused) {
  std::string text = base_scene().dump();
  const std::string from = "\"radius\":2";
  ASSERT_NE(text.find(from), std::string::npos);
  text.replace(text.find(from), from.size(), "\"radius\":1e999");
  EXPECT_EQ(testing::load_error(text),
            "s.json: number overflow parsing '1e999' (numbers must be finite)");
}

TEST(SceneLoad, SyntaxErrorsNameTheLine) {
  const std::string text = "{\n  \"camera\": {\n    \"type\": \"pinhole\",,\n  }\n}\n";
  const std::string msg = testing::load_error(text);
  EXPECT_EQ(msg.rfind("s.json:3: syntax error", 0), 0u) << msg;
  EXPECT_EQ(msg.find('\n'), std::string::npos);
}

TEST(SceneLoad, DeepNestingIsRefusedCleanly) {
  const std::string text = std::string(100000, '[') + std::string(100000, ']');
  EXPECT_NE(testing::load_error(text).find("nested deeper than"), std::string::npos);
}

TEST(SceneLoad, MissingFileNamesThePath) {
  try {
    load_scene("/nonexistent/scene.json");
    FAIL() << "expected an InputError";
  } catch (const InputError& e) {
    EXPECT_STREQ(e.what(), "/nonexistent/scene.json: cannot open scene file");
  }
}

// Through the CLI: exit status 2, one line on stderr, and no output file.
TEST(SceneCli, BadInputExitsTwoWithOneLineAndNoFile) {
  testing::TempDir dir;
  for (const BadCase& c : kBadCases) {
    SCOPED_TRACE(c.name);
    json j = base_scene();
    c.mutate(j);
    const std::string scene = dir.file("bad.json");
    std::ofstream(scene) << j.dump(2);
    const std::string out = dir.file("out.png");
    const auto r = testing::run_command(testing::cli() + " render " + scene + " -o " + out);
    EXPECT_EQ(r.status, 2) << r.out;
    EXPECT_EQ(r.out, "lancer: " + scene + ": " + c.message + "\n");
    EXPECT_FALSE(std::filesystem::exists(out));
  }
}

TEST(SceneCli, BadOptionsExitTwoNamingTheOption) {
  testing::TempDir dir;
  const std::string scene = testing::source_path("scenes/lorenzi-diffuse.json");
  const std::string out = dir.file("out.png");
  struct {
    const char* args;
    const char* names;
  } cases[] = {{"--width 3", "--width"},
               {"--width x", "--width"},
               {"--precision half", "--precision"},
               {"--resolution 10by10", "--resolution"},
               {"--resolution 0x10", "--resolution"},
               {"--supersample 0", "--supersample"},
               {"--threads -1", "--threads"},
               {"--precision double --width 16", "--width"}};
  for (const auto& c : cases) {
    SCOPED_TRACE(c.args);
    const auto r =
        testing::run_command(testing::cli() + " render " + scene + " -o " + out + " " + c.args);
    EXPECT_EQ(r.status, 2) << r.out;
    EXPECT_NE(r.out.find(c.names), std::string::npos) << r.out;
    EXPECT_EQ(std::count(r.out.begin(), r.out.end(), '\n'), 1) << r.out;
    EXPECT_FALSE(std::filesystem::exists(out));
  }
}

}  // namespace
}  // namespace lancer
