// Triangles, meshes and cylinders: mesh files and their errors, watertight triangles, cylinders
// against an independent computation, smooth normals, ties, shadows through a mesh.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <random>
#include <tuple>

#include "lancer/compare.hpp"
#include "lancer/error.hpp"
#include "lancer/mesh_io.hpp"
#include "lancer/packet/api.hpp"
#include "lancer/prepared.hpp"
#include "lancer/prim/triangle.hpp"
#include "lancer/reference.hpp"
#include "lancer/scene.hpp"
#include "lancer/shapes.hpp"
#include "support/test_util.hpp"

namespace lancer {
namespace {

using testing::TempDir;

void write(const std::string& path, const std::string& text) {
  std::ofstream(path, std::ios::binary) << text;
}

// A scene file around `objects`, camera at the origin looking down -z: its frame is the
// world's, so prepared coordinates are the scene's own.
std::string scene_text(const std::string& objects) {
  return R"({"camera": {"type": "pinhole", "position": [0, 0, 0], "direction": [0, 0, -1],
    "distance": 1, "resolution": [8, 8], "bounds": [-1, 1, -1, 1]},
    "lights": [{"position": [0, 10, 0]}], "objects": [)" +
         objects + "]}";
}

std::string load_message(const TempDir& dir, const std::string& objects) {
  const std::string path = dir.file("s.json");
  write(path, scene_text(objects));
  try {
    load_scene(path);
  } catch (const InputError& e) {
    return e.what();
  }
  return "(no error)";
}

const char* kCube =
    "v -1 -1 -1\nv 1 -1 -1\nv 1 1 -1\nv -1 1 -1\nv -1 -1 1\nv 1 -1 1\nv 1 1 1\nv -1 1 1\n"
    "f 1 4 3 2\nf 5 6 7 8\nf 1 2 6 5\nf 2 3 7 6\nf 3 4 8 7\nf 4 1 5 8\n";

TEST(Prims, ObjLoadsFansNegativeIndicesAndIgnoresOtherLines) {
  TempDir dir;
  write(dir.file("q.obj"),
        "mtllib x.mtl\no thing\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\ng g\nusemtl m\n"
        "f -4 -3 -2 -1\n");
  const Scene s = [&] {
    write(dir.file("s.json"), scene_text(R"({"type": "mesh", "file": "q.obj"})"));
    return load_scene(dir.file("s.json"));
  }();
  ASSERT_EQ(s.shapes.size(), 1u);
  const Mesh& m = s.shapes[0].mesh;
  EXPECT_EQ(m.indices, (std::vector<std::uint32_t>{0, 1, 2, 0, 2, 3}));
}

TEST(Prims, MeshErrorsNameTheFileAndLine) {
  TempDir dir;
  write(dir.file("range.obj"), "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n");
  write(dir.file("nan.obj"), "v 0 0 0\nv nan 0 0\nv 0 1 0\nf 1 2 3\n");
  write(dir.file("two.obj"), "v 0 0 0\nv 1 0 0\nv 0 1 0\n\nf 1 2\n");
  write(dir.file("flat.obj"), "v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n");
  write(dir.file("neg.obj"), "v 0 0 0\nv 1 0 0\nf -1 -2 -3\nv 0 1 0\n");
  const std::string where = "objects[0].file: " + dir.file("");
  auto msg = [&](const std::string& file) {
    return load_message(dir, R"({"type": "mesh", "file": ")" + file + R"("})");
  };
  EXPECT_EQ(msg("range.obj"), dir.file("s.json") + ": " + where +
                                  "range.obj:4: vertex index 4 out of range (1 to 3 or -1 to -3)");
  EXPECT_EQ(msg("nan.obj"),
            dir.file("s.json") + ": " + where + "nan.obj:2: vertex coordinate is not finite");
  EXPECT_EQ(msg("two.obj"), dir.file("s.json") + ": " + where +
                                "two.obj:5: a face needs at least 3 vertices, not 2");
  EXPECT_EQ(msg("flat.obj"),
            dir.file("s.json") + ": " + where + "flat.obj: no triangle left: all 1 have zero area");
  // Negative indices count back from the last vertex read before the face line.
  EXPECT_EQ(msg("neg.obj"), dir.file("s.json") + ": " + where +
                                "neg.obj:3: vertex index -3 out of range (1 to 2 or -1 to -2)");
  EXPECT_EQ(msg("missing.obj"),
            dir.file("s.json") + ": " + where + "missing.obj: cannot open mesh file");
  std::filesystem::create_directory(dir.file("folder.obj"));
  EXPECT_EQ(msg("folder.obj"),
            dir.file("s.json") + ": " + where + "folder.obj: is a folder, not a mesh file");
}

// A binary little-endian PLY of `faces` triangles over 3 vertices, cut to `keep` bytes of body.
std::string binary_ply(int faces, std::size_t cut = 0) {
  std::string h =
      "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\n"
      "property float y\nproperty float z\nelement face " +
      std::to_string(faces) + "\nproperty list uchar int vertex_indices\nend_header\n";
  std::string body;
  const float v[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
  body.append(reinterpret_cast<const char*>(v), sizeof v);
  for (int f = 0; f < faces; ++f) {
    body.push_back(char(3));
    const std::int32_t idx[3] = {0, 1, 2};
    body.append(reinterpret_cast<const char*>(idx), sizeof idx);
  }
  if (cut) body.resize(body.size() - cut);
  return h + body;
}

TEST(Prims, PlyBinaryAndAsciiLoadAndTruncationIsNamed) {
  TempDir dir;
  write(dir.file("ok.ply"), binary_ply(2));
  write(dir.file("cut.ply"), binary_ply(2, 5));
  write(dir.file("a.ply"),
        "ply\nformat ascii 1.0\nelement vertex 3\nproperty double x\nproperty double y\n"
        "property double z\nelement face 1\nproperty list uchar uint vertex_index\nend_header\n"
        "0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n");
  write(dir.file("s.json"), scene_text(R"({"type": "mesh", "file": "ok.ply"})"));
  const Scene s = load_scene(dir.file("s.json"));
  EXPECT_EQ(s.shapes[0].mesh.triangles(), 2u);
  auto msg = [&](const std::string& file) {
    return load_message(dir, R"({"type": "mesh", "file": ")" + file + R"("})");
  };
  const std::string where = dir.file("s.json") + ": objects[0].file: " + dir.file("");
  EXPECT_EQ(msg("cut.ply"), where + "cut.ply: face 1: file ends inside the element (truncated)");
  EXPECT_EQ(msg("a.ply"), where + "a.ply:13: vertex index 7 out of range (0 to 2)");
}

TEST(Prims, ShapeFieldErrors) {
  TempDir dir;
  EXPECT_EQ(load_message(dir, R"({"type": "cylinder", "base": [0, 0, 0], "top": [0, 1, 0],
    "radius": 0})"),
            dir.file("s.json") + ": objects[0].radius: must be > 0");
  EXPECT_EQ(load_message(dir, R"({"type": "cylinder", "base": [0, 1, 0], "top": [0, 1, 0],
    "radius": 1})"),
            dir.file("s.json") + ": objects[0].top: must differ from base");
  EXPECT_EQ(load_message(dir, R"({"type": "triangle", "vertices": [[0, 0, 0], [1, 1, 1],
    [2, 2, 2]]})"),
            dir.file("s.json") +
                ": objects[0].vertices: the three vertices lie on one line "
                "(zero area)");
  write(dir.file("c.obj"), kCube);
  EXPECT_EQ(load_message(dir, R"({"type": "mesh", "file": "c.obj", "scale": -1})"),
            dir.file("s.json") + ": objects[0].scale: must be from 1e-18 to 1e+18");
  EXPECT_EQ(load_message(dir, R"({"type": "mesh", "file": "c.obj", "smooth": 1})"),
            dir.file("s.json") + ": objects[0].smooth: must be true or false");
  EXPECT_EQ(load_message(dir, R"({"type": "mesh", "file": "c.obj", "colour": 1})"),
            dir.file("s.json") + ": objects[0].colour: unknown key");
}

// The CLI: each bad mesh is one line naming the file and place, exit status 2, no image.
TEST(Prims, CliRefusesBadMeshesWithStatus2AndNoOutput) {
  TempDir dir;
  write(dir.file("range.obj"), "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n");
  write(dir.file("nan.obj"), "v 0 0 0\nv 1 0 0\nv 0 1 nan\nf 1 2 3\n");
  write(dir.file("two.obj"), "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2\n");
  write(dir.file("cut.ply"), binary_ply(4, 1));
  const std::pair<const char*, const char*> cases[] = {{"missing.obj", "missing.obj: cannot open"},
                                                       {"range.obj", "range.obj:4: "},
                                                       {"nan.obj", "nan.obj:3: "},
                                                       {"two.obj", "two.obj:4: "},
                                                       {"cut.ply", "cut.ply: face 3: "}};
  for (const auto& [file, expect] : cases) {
    write(dir.file("s.json"),
          scene_text(std::string(R"({"type": "mesh", "file": ")") + file + R"("})"));
    const std::string out = dir.file("out.pfm");
    const auto r =
        testing::run_command(testing::cli() + " render " + dir.file("s.json") + " -o " + out);
    EXPECT_EQ(r.status, 2) << file << ": " << r.out;
    EXPECT_NE(r.out.find(expect), std::string::npos) << r.out;
    EXPECT_EQ(std::count(r.out.begin(), r.out.end(), '\n'), 1) << r.out;
    EXPECT_FALSE(std::filesystem::exists(out)) << file;
  }
}

// Scenes with shapes run on the packets like any other: auto takes the widest width, the summary
// names the shapes' hierarchy, and validate and profile run them.
TEST(Prims, CliRunsShapesOnThePackets) {
  LANCER_SKIP_WITHOUT_PACKETS();
  TempDir dir;
  write(dir.file("c.obj"), kCube);
  write(dir.file("s.json"),
        scene_text(R"({"type": "mesh", "file": "c.obj", "translate": [0, 0, -4]})"));
  const std::string out = dir.file("out.pfm");
  auto r = testing::run_command(testing::cli() + " render " + dir.file("s.json") + " --json -o " +
                                out + " 2>/dev/null");
  ASSERT_EQ(r.status, 0) << r.out;
  const nlohmann::json j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["width"], packet::supported_widths(Precision::exact).front());
  EXPECT_EQ(j["shapes"]["triangles"], 12);
  EXPECT_EQ(j["shapes"]["primitives"], 12);
  EXPECT_EQ(j["kinds"], "triangles");  // the kinds the kernels test: the cube's flat triangles
  EXPECT_EQ(j["kernels_built_for"], "every kind (spheres, planes, triangles, meshes, cylinders)");
  std::filesystem::remove(out);
  // Without shapes, the kernels compiled for spheres and planes alone; the reference at width 1.
  const std::string course = testing::source_path("scenes/lorenzi-reflections.json");
  for (const char* width : {"", " --width 1"}) {
    r = testing::run_command(testing::cli() + " render " + course + width + " --json -o " + out +
                             " 2>/dev/null");
    ASSERT_EQ(r.status, 0) << r.out;
    EXPECT_EQ(nlohmann::json::parse(r.out)["kernels_built_for"],
              *width ? "every kind (the reference)" : "spheres and planes alone");
    std::filesystem::remove(out);
  }
  r = testing::run_command(testing::cli() + " render " + dir.file("s.json") + " --width 4 -o " +
                           out);
  EXPECT_EQ(r.status, 0) << r.out;
  EXPECT_NE(r.out.find("12 triangles in 1 mesh"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("their hierarchy: 12 primitives"), std::string::npos) << r.out;
  EXPECT_TRUE(std::filesystem::exists(out));
  for (const char* command : {" validate ", " validate --precision double ", " profile "}) {
    r = testing::run_command(testing::cli() + command + dir.file("s.json"));
    EXPECT_EQ(r.status, 0) << command << r.out;
  }
  // bench names the shapes' hierarchy, and counts no flops: its model knows spheres and planes.
  r = testing::run_command(testing::cli() + " bench " + dir.file("s.json") +
                           " --mode primary --width 4 --repeat 1 --peak --json 2>/dev/null");
  ASSERT_EQ(r.status, 0) << r.out;
  const nlohmann::json b = nlohmann::json::parse(r.out.substr(r.out.find('{')));
  const nlohmann::json& result = b.contains("scenes") ? b["scenes"][0] : b;
  EXPECT_EQ(result["structure"]["shapes"]["primitives"], 12) << result["structure"].dump();
  for (const auto& row : result["results"]) EXPECT_FALSE(row.contains("gflops")) << row.dump();
}

// Spheres, planes, a mesh and cylinders in one scene, opaque with mirrors and with glass, with
// two hierarchies (auto) and with one over the spheres, triangles and cylinders (--accel one):
// every packet width gives the reference's bits, exact and double. With glass, two tilted
// half-transparent planes cross the shadow rays: each lane's transmits must come in id order,
// spheres, planes, shapes, though one walk meets the spheres and the shapes (a float product of
// three or more depends on the order; the spheres' transmits once came in the spheres' hierarchy's
// order in the reference, 146 pixels 3 ulps off). A regression case too: the camera blocks once
// handed shading object ids where it reads a mesh hit's triangle from the hit id.
TEST(Prims, ValidateMixedGeneratedScenes) {
  LANCER_SKIP_WITHOUT_PACKETS();
  TempDir dir;
  const std::string scene = dir.file("g.json");
  for (const char* extra : {" --reflect 0.4", " --transmit 0.7 --transmit-spread 0.6 --ior 1.3"}) {
    auto r = testing::run_command(testing::cli() +
                                  " generate --spheres 200 --mesh-triangles 1000 --cylinders 20"
                                  " --resolution 96x64 --seed 3 -o " +
                                  scene + extra);
    ASSERT_EQ(r.status, 0) << r.out;
    if (std::string(extra).find("transmit") != std::string::npos) {
      nlohmann::json j = nlohmann::json::parse(std::ifstream(scene));
      j["materials"]["veil"] = {{"color", {0.9, 0.8, 0.7}}, {"kd", 0.5}, {"transmit", 0.6}};
      auto& objects = j["objects"];
      const nlohmann::json low = {
          {"type", "plane"}, {"point", {0, 4, 0}}, {"normal", {0.2, 1, 0.1}}, {"material", "veil"}};
      const nlohmann::json high = {{"type", "plane"},
                                   {"point", {0, 6, 0}},
                                   {"normal", {-0.1, 1, 0.3}},
                                   {"material", "veil"}};
      objects.insert(objects.begin() + 1, low);
      objects.insert(objects.begin() + 2, high);
      std::ofstream(scene) << j.dump();
    }
    for (const char* accel : {"auto", "one"})
      for (const char* precision : {"exact", "double"}) {
        r = testing::run_command(testing::cli() + " validate --accel " + accel + " --precision " +
                                 precision + " " + scene);
        EXPECT_EQ(r.status, 0) << extra << ", " << accel << ", " << precision << ": " << r.out;
        const bool one = std::string(accel) == "one";
        EXPECT_NE(r.out.find(one ? "structure bvh (reference); the packets: the spheres in the "
                                   "shapes' hierarchy"
                                 : "structure bvh (reference and packets)"),
                  std::string::npos)
            << r.out;
      }
  }
}

// With Accel::one the spheres are leaves of the shapes' hierarchy where a scene has both (every
// item once, the spheres' records carrying their own ids and the prepared bits); not by default,
// and not in a scene without shapes.
TEST(Prims, OneHierarchyHoldsTheSpheresBesideTheShapes) {
  Scene scene;
  for (int k = 0; k < 20; ++k)
    scene.spheres.push_back({{0.3 * k - 3, 0.1 * (k % 5), -4 - 0.2 * k}, 0.1 + 0.01 * k, 0});
  scene.materials.push_back({});
  Shape cyl;
  cyl.kind = Shape::Kind::cylinder;
  cyl.cylinder.base = {0, -1, -5}, cyl.cylinder.top = {0, 1, -5}, cyl.cylinder.radius = 0.5;
  scene.shapes.push_back(cyl);
  scene.planes.push_back({{0, -1, 0}, {0, 1, 0}, 0});
  const PreparedScene<float> p = prepare<float>(scene, Accel::one);
  ASSERT_TRUE(p.shapes);
  EXPECT_TRUE(p.features.spheres_in_shapes);
  const PreparedShapes<float>& sh = *p.shapes;
  ASSERT_EQ(sh.spheres, 20);
  std::vector<int> seen(sh.items(), 0);
  for (const auto& leaf : sh.leaves)
    for (unsigned k = 0; k < leaf.count; ++k) {
      if (leaf.ref[k] != PreparedShapes<float>::kSphereRef) {
        ++seen[std::size_t(leaf.prim[k])];
        continue;
      }
      const int id = sh.first_object + leaf.prim[k];
      ASSERT_GE(id, 0);
      ASSERT_LT(id, 20);
      ++seen[sh.prim.size() + std::size_t(id)];
      EXPECT_EQ(leaf.v[0][k], p.spheres.cx[std::size_t(id)]);
      EXPECT_EQ(leaf.v[1][k], p.spheres.cy[std::size_t(id)]);
      EXPECT_EQ(leaf.v[2][k], p.spheres.cz[std::size_t(id)]);
      EXPECT_EQ(leaf.v[3][k], p.spheres.r2[std::size_t(id)]);
    }
  for (int n : seen) EXPECT_EQ(n, 1);
  for (Accel two : {Accel::automatic, Accel::bvh, Accel::none}) {
    const PreparedScene<float> q = prepare<float>(scene, two);
    EXPECT_FALSE(q.features.spheres_in_shapes) << to_string(two);
    EXPECT_EQ(q.shapes->spheres, 0) << to_string(two);
  }
  EXPECT_TRUE(prepare<float>(scene, Accel::one).bvh.active());  // the reference's, as auto's
  scene.shapes.clear();
  EXPECT_FALSE(prepare<float>(scene, Accel::one).features.spheres_in_shapes);
}

// The packets and the one-ray kernels find a hit primitive's object from the shapes' ranges of
// primitive numbers (PreparedShapes::prim_object); the reference reads it from the primitive's
// own entry. Both agree on every primitive, across cylinders and meshes in any order, a mesh
// whose triangles all collapsed (an empty range) among them.
TEST(Prims, PrimitiveObjectsFromTheShapesRanges) {
  Scene scene;
  scene.spheres.push_back({{0, 0, -9}, 0.5, 0});
  scene.planes.push_back({{0, -2, 0}, {0, 1, 0}, 0});
  scene.materials.push_back({});
  auto cylinder = [&](double x) {
    Shape c;
    c.kind = Shape::Kind::cylinder;
    c.cylinder.base = {x, -1, -5}, c.cylinder.top = {x, 1, -5}, c.cylinder.radius = 0.2;
    scene.shapes.push_back(c);
  };
  auto mesh = [&](int triangles, double z) {
    Shape m;
    m.kind = Shape::Kind::mesh;
    for (int k = 0; k < triangles; ++k) {
      const std::uint32_t v = std::uint32_t(m.mesh.vertices.size());
      m.mesh.vertices.push_back({0.1 * k, 0, z});
      m.mesh.vertices.push_back({0.1 * k + 0.1, 0, z});
      m.mesh.vertices.push_back({0.1 * k, 0.1, z});
      m.mesh.indices.insert(m.mesh.indices.end(), {v, v + 1, v + 2});
    }
    scene.shapes.push_back(m);
  };
  cylinder(-2), mesh(7, -6), mesh(0, -6), cylinder(2), cylinder(3), mesh(1, -7), mesh(12, -8);
  for (Accel accel : {Accel::automatic, Accel::one}) {
    const PreparedScene<float> p = prepare<float>(scene, accel);
    ASSERT_TRUE(p.shapes);
    const PreparedShapes<float>& sh = *p.shapes;
    ASSERT_EQ(sh.prim.size(), 23u);
    ASSERT_EQ(sh.shape_prims.size(), scene.shapes.size() + 1);
    EXPECT_EQ(sh.shape_prims.front(), 0);
    EXPECT_EQ(sh.shape_prims.back(), 23);
    std::vector<int> per_object(scene.shapes.size(), 0);
    for (std::size_t k = 0; k < sh.prim.size(); ++k) {
      const std::int32_t ref = sh.prim[k];
      const int object =
          ref >= 0 ? sh.tri_object[std::size_t(ref)] : sh.cyl_object[std::size_t(~ref)];
      EXPECT_EQ(sh.prim_object(std::int32_t(k)), object) << "primitive " << k;
      ++per_object[std::size_t(object - sh.first_object)];
    }
    EXPECT_EQ(per_object, (std::vector<int>{1, 7, 0, 1, 1, 1, 12})) << to_string(accel);
    // Each primitive's place in the leaves (the API's hit fields read it there): the leaf item
    // that holds it, with its reference and, for a triangle, its vertices' bits.
    using Shapes = PreparedShapes<float>;
    ASSERT_EQ(sh.prim_leaf.size(), sh.prim.size());
    for (std::size_t q = 0; q < sh.prim.size(); ++q) {
      const std::int32_t at = sh.prim_leaf[q];
      ASSERT_GE(at, 0) << "primitive " << q;
      ASSERT_LT(std::size_t(at / Shapes::kLeafItems), sh.leaves.size());
      const Shapes::Leaf& leaf = sh.leaves[std::size_t(at / Shapes::kLeafItems)];
      const int k = at % Shapes::kLeafItems;
      EXPECT_LT(std::uint32_t(k), leaf.count);
      EXPECT_EQ(leaf.prim[k], std::int32_t(q));
      EXPECT_EQ(leaf.ref[k], sh.prim[q]);
      if (sh.prim[q] < 0) continue;
      for (int c = 0; c < 3; ++c) {
        const std::uint32_t v = sh.tri[3 * std::size_t(sh.prim[q]) + std::size_t(c)];
        EXPECT_EQ(leaf.v[3 * c][k], sh.vx[v]);
        EXPECT_EQ(leaf.v[3 * c + 1][k], sh.vy[v]);
        EXPECT_EQ(leaf.v[3 * c + 2][k], sh.vz[v]);
      }
    }
  }
}

// Camera rays reach a mesh in square tiles also where the spheres have no hierarchy (fewer than
// kBvhMinSpheres): the spheres' camera blocks, which need that hierarchy, must not take them. A
// regression case: primary mode once crashed on such a scene (a sphere of glass over a mesh).
TEST(Prims, ValidateAMeshBesideSpheresWithoutAHierarchy) {
  TempDir dir;
  const std::string scene = dir.file("few.json");
  auto r = testing::run_command(testing::cli() +
                                " generate --spheres 3 --mesh-triangles 2000 --resolution 64x48"
                                " --seed 5 -o " +
                                scene);
  ASSERT_EQ(r.status, 0) << r.out;
  for (const char* precision : {"exact", "double"}) {
    r = testing::run_command(testing::cli() + " validate --precision " + precision + " " + scene);
    EXPECT_EQ(r.status, 0) << precision << ": " << r.out;
  }
}

// Camera blocks over a mesh alone: groups of tiles walk the shapes' hierarchy together, their
// frustum the union of their tiles'. Odd sizes give blocks with tiles cut at the image's edge and
// tiles outside it, and the image's centre lines give groups whose rays differ in sign (walked
// tile by tile); every width must give the reference's bits.
TEST(Prims, ValidateCameraBlocksOverAMeshAtOddSizes) {
  TempDir dir;
  const std::string scene = dir.file("odd.json");
  for (const char* size : {"75x37", "21x9"}) {
    auto r = testing::run_command(testing::cli() +
                                  " generate --spheres 0 --mesh-triangles 3000 --resolution " +
                                  size + " --seed 7 -o " + scene);
    ASSERT_EQ(r.status, 0) << r.out;
    for (const char* precision : {"exact", "double"}) {
      r = testing::run_command(testing::cli() + " validate --precision " + precision + " " + scene);
      EXPECT_EQ(r.status, 0) << size << ", " << precision << ": " << r.out;
    }
  }
}

// The reference against the independent oracle (tests/oracle: Moller-Trumbore, the textbook
// cylinder quadratic, double throughout) on a scene of triangle and cylinder objects with
// shadows, a mirror and glass: as the shipped scenes are held to it (test_oracle.cpp).
TEST(Prims, ReferenceAgreesWithTheOracle) {
  TempDir dir;
  const std::string path = dir.file("o.json");
  write(path,
        R"({"camera": {"type": "pinhole", "position": [0, 1.5, 6], "direction": [0, -0.25, -1],
    "distance": 4, "resolution": [160, 120], "bounds": [-2.4, 2.4, -1.8, 1.8]},
    "background": [0.3, 0.4, 0.6], "environment": 0.1, "max_depth": 3,
    "lights": [{"position": [-4, 8, 6], "intensity": 0.8, "ambient": 0.2},
               {"position": [5, 4, 3], "intensity": [0.3, 0.25, 0.2]}],
    "objects": [
      {"type": "triangle", "vertices": [[-4, -1, -4], [4, -1, -4], [4, -1, 4]],
       "material": {"color": 0.8, "ka": 0.1}},
      {"type": "triangle", "vertices": [[-4, -1, -4], [4, -1, 4], [-4, -1, 4]],
       "material": {"color": 0.8, "ka": 0.1}},
      {"type": "triangle", "vertices": [[-2, -1, -2], [0, 1.5, -2.5], [2, -1, -2]],
       "material": {"color": 0.9, "kd": 0.2, "ks": 0.5, "reflect": 0.6}},
      {"type": "cylinder", "base": [-1.3, -1, 0], "top": [-1.3, 0.6, 0.2], "radius": 0.45,
       "material": {"color": [0.8, 0.3, 0.2], "ka": 0.1, "ks": 0.5, "shininess": 30}},
      {"type": "cylinder", "base": [1.4, -0.4, 0.5], "top": [0.4, -0.4, 1.2], "radius": 0.35,
       "caps": false, "material": {"color": [0.3, 0.7, 0.4], "ka": 0.15}},
      {"type": "cylinder", "base": [0.2, -0.95, 1.8], "top": [0.2, -0.1, 1.8], "radius": 0.4,
       "material": {"color": 1, "kd": 0.05, "ks": 0.8, "transmit": 0.8, "reflect": 0.1,
                    "ior": 1.5}},
      {"type": "sphere", "center": [1.6, 0, -1], "radius": 0.6,
       "material": {"color": [0.3, 0.4, 0.9], "ka": 0.1, "ks": 0.4}}
    ]})");
  const std::string truth_path = dir.file("oracle.pfm");
  const auto r = testing::run_command(std::string(LANCER_ORACLE) + " " + path + " " + truth_path);
  ASSERT_EQ(r.status, 0) << r.out;
  const Image truth = read_image(truth_path);
  const Scene s = load_scene(path);
  const double tol = 2.0 / 255.0;
  const ErrorStats dbl = error_stats(testing::render_with(s, 1, Precision::dbl, 2), truth, tol);
  const ErrorStats exact = error_stats(testing::render_with(s, 1, Precision::exact, 2), truth, tol);
  std::printf("pixels off by > 2/255: double %.4f%%, exact %.4f%%\n", 100 * dbl.off_fraction,
              100 * exact.off_fraction);
  EXPECT_LE(dbl.off_fraction, 0.001) << "double: " << dbl.off_pixels << " pixels off";
  EXPECT_LE(exact.off_fraction, 0.005) << "exact: " << exact.off_pixels << " pixels off";
}

// Seeded mutations of valid OBJ, ascii PLY and binary PLY files (bytes flipped, inserted,
// deleted, the file cut): each parse succeeds or throws InputError, never anything else.
TEST(Prims, MutatedMeshFilesLoadOrFailCleanly) {
  const std::string ascii_ply =
      "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\n"
      "property float z\nproperty float nx\nproperty float ny\nproperty float nz\n"
      "element face 2\nproperty list uchar int vertex_indices\nend_header\n"
      "0 0 0 0 0 1\n1 0 0 0 0 1\n1 1 0 0 0 1\n0 1 0 0 0 1\n3 0 1 2\n4 0 1 2 3\n";
  const std::string seeds[3] = {std::string(kCube) + "vn 0 0 1\nf 1//1 2//1 3//1\n", ascii_ply,
                                binary_ply(5)};
  std::mt19937_64 rng(37);
  int loaded = 0, refused = 0;
  for (int round = 0; round < 20000; ++round) {
    const int which = round % 3;
    std::string text = seeds[which];
    const int edits = 1 + int(rng() % 4);
    for (int e = 0; e < edits && !text.empty(); ++e) {
      const std::size_t at = rng() % text.size();
      switch (rng() % 4) {
        case 0:
          text[at] = char(rng());
          break;
        case 1:
          text.insert(at, 1, "0123456789-+. \n/ef"[rng() % 19]);
          break;
        case 2:
          text.erase(at, 1 + rng() % 8);
          break;
        default:
          text.resize(at);
      }
    }
    try {
      MeshFile m = which == 0 ? parse_obj(text, "f.obj") : parse_ply(text, "f.ply");
      Mesh out;
      place_mesh(std::move(m), MeshTransform{}, round % 2 == 0, "f", out);
      for (std::uint32_t i : out.indices) ASSERT_LT(i, out.vertices.size());
      ++loaded;
    } catch (const InputError& e) {
      EXPECT_EQ(std::string(e.what()).find('\n'), std::string::npos) << e.what();
      ++refused;
    }
  }
  EXPECT_GT(loaded, 400);
  EXPECT_GT(refused, 10000);
}

// lancer generate --mesh-triangles needs a scene file to put the mesh beside.
TEST(Prims, GenerateRefusesAMeshWithoutASceneFile) {
  TempDir dir;
  auto r = testing::run_command(testing::cli() + " generate --spheres 1 --mesh-triangles 10 -o -");
  EXPECT_EQ(r.status, 2) << r.out;
  r = testing::run_command(testing::cli() + " generate --spheres 1 --mesh-triangles 10 -o " +
                           dir.file("none/g.json"));
  EXPECT_EQ(r.status, 2) << r.out;
  EXPECT_FALSE(std::filesystem::exists(dir.file("none")));
}

// lancer generate --mesh-triangles writes the mesh beside the scene, and the scene loads it.
TEST(Prims, GenerateWritesAMeshBesideTheScene) {
  TempDir dir;
  const auto r = testing::run_command(testing::cli() +
                                      " generate --spheres 3 --mesh-triangles 5000 --cylinders 4 "
                                      "--resolution 16x12 -o " +
                                      dir.file("g.json"));
  ASSERT_EQ(r.status, 0) << r.out;
  ASSERT_TRUE(std::filesystem::exists(dir.file("g.ply")));
  const Scene s = load_scene(dir.file("g.json"));
  ASSERT_EQ(s.shapes.size(), 5u);
  EXPECT_GE(s.shapes[0].mesh.triangles(), 5000u);
  for (std::size_t k = 1; k < 5; ++k) EXPECT_EQ(s.shapes[k].kind, Shape::Kind::cylinder);
  const auto again = testing::run_command(testing::cli() + " render " + dir.file("g.json") +
                                          " -o " + dir.file("g.pfm"));
  EXPECT_EQ(again.status, 0) << again.out;
}

}  // namespace
}  // namespace lancer
