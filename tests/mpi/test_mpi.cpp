#include <gtest/gtest.h>

#include <cstdlib>
#include <random>

#include "lancer/mpi.hpp"
#include "lancer/render.hpp"
#include "lancer/tiles.hpp"
#ifndef LANCER_NO_MPI
#include <fstream>

#include "agreement.hpp"
#include "rows.hpp"
#include "support/test_util.hpp"
#endif

namespace lancer::mpi {
namespace {

TEST(Launch, ReadsOpenMpiThenPmiAndRejectsGarbage) {
  for (const char* v : {"OMPI_COMM_WORLD_SIZE", "OMPI_COMM_WORLD_RANK", "PMI_SIZE", "PMI_RANK",
                        "PMIX_SIZE", "PMIX_RANK"})
    unsetenv(v);
  EXPECT_EQ(launch_from_environment().size, 1);
  setenv("PMI_SIZE", "8", 1);
  setenv("PMI_RANK", "3", 1);
  EXPECT_EQ(launch_from_environment().size, 8);
  EXPECT_EQ(launch_from_environment().rank, 3);
  setenv("OMPI_COMM_WORLD_SIZE", "4", 1);  // Open MPI first
  setenv("OMPI_COMM_WORLD_RANK", "1", 1);
  EXPECT_EQ(launch_from_environment().size, 4);
  EXPECT_EQ(launch_from_environment().rank, 1);
  setenv("OMPI_COMM_WORLD_SIZE", "4x", 1);  // not a number: the next launcher's variables
  EXPECT_EQ(launch_from_environment().size, 8);
  for (const char* v : {"OMPI_COMM_WORLD_SIZE", "OMPI_COMM_WORLD_RANK", "PMI_SIZE", "PMI_RANK"})
    unsetenv(v);
}

#ifndef LANCER_NO_MPI
// Seeded: every row of every image height belongs to exactly one rank's share, in tiles.
TEST(RowShare, SharesPartitionTheRows) {
  std::mt19937 rng(16);
  for (int trial = 0; trial < 300; ++trial) {
    const int ny = 1 + int(rng() % 200), ranks = 1 + int(rng() % 70);
    std::vector<int> owner(ny, -1);
    int rows = 0;
    for (int r = 0; r < ranks; ++r) {
      const RowShare s{ny, r, ranks};
      for (int t = 0; t < s.tiles(); ++t) {
        ASSERT_LT(s.tile_begin(t), s.tile_end(t));
        ASSERT_LE(s.tile_end(t) - s.tile_begin(t), kTileRows);
        for (int j = s.tile_begin(t); j < s.tile_end(t); ++j) {
          ASSERT_EQ(owner[j], -1) << "row " << j << " twice, ny " << ny << " ranks " << ranks;
          owner[j] = r;
        }
      }
      rows += s.rows();
    }
    EXPECT_EQ(rows, ny);
    for (int j = 0; j < ny; ++j) ASSERT_NE(owner[j], -1) << "row " << j << " nobody's";
  }
}

TEST(RowShare, PackUnpackRoundTrip) {
  Image a(7, 23), b(7, 23);
  for (std::size_t i = 0; i < a.rgb.size(); ++i) a.rgb[i] = float(i);
  std::vector<float> buf;
  for (int r = 0; r < 3; ++r) {
    const RowShare s{23, r, 3};
    pack_rows(a, s, buf);
    EXPECT_EQ(buf.size(), std::size_t(s.rows()) * 7 * 3);
    unpack_rows(buf.data(), s, b);
  }
  EXPECT_EQ(a.rgb, b.rgb);
}

// The shares of any rank count, rendered apart on the engine the ranks use and put together,
// are render()'s image bit for bit (exact and double, the reference and the widest packets).
TEST(RowEngine, SharesPutTogetherAreTheSingleProcessImage) {
  Scene scene = load_scene(std::string(LANCER_SOURCE_DIR) + "/scenes/lorenzi-reflections.json");
  scene.camera.nx = 37, scene.camera.ny = 29, scene.supersample = 2;
  for (Precision p : {Precision::exact, Precision::dbl})
    for (int width : {1, resolve_width(0, p)}) {
      RenderOptions opt;
      opt.precision = p, opt.width = width, opt.threads = 1;
      const RenderResult want = render(scene, opt);
      const RowEngine engine(scene, p, width);
      for (int ranks : {1, 2, 3, 4, 9}) {
        Image got(scene.camera.nx, scene.camera.ny);
        RayCounts rays;
        for (int r = 0; r < ranks; ++r)
          rays += render_share(engine, RowShare{scene.camera.ny, r, ranks}, got, 2);
        EXPECT_EQ(got.rgb, want.image.rgb)
            << to_string(p) << " width " << width << " ranks " << ranks;
        EXPECT_EQ(rays, want.rays);
      }
    }
}

// What ranks must agree on before rendering: equal fingerprints agree; each field that differs is
// named, with this rank's value and rank 0's.
TEST(Agreement, NamesWhatDiffersFromRankZero) {
  Scene scene = load_scene(std::string(LANCER_SOURCE_DIR) + "/scenes/lorenzi-diffuse.json");
  Asked asked;
  asked.command = "render";
  asked.scene_path = std::string(LANCER_SOURCE_DIR) + "/scenes/lorenzi-diffuse.json";
  const Fingerprint first = fingerprint(asked, scene);
  EXPECT_EQ(disagreement(fingerprint(asked, scene), first), "");
  Scene small = scene;
  small.camera.nx = 1, small.camera.ny = 1;
  EXPECT_NE(disagreement(fingerprint(asked, small), first)
                .find("the image size (--resolution or the scene's): 1 x 1 here, 300 x 200 on "
                      "rank 0"),
            std::string::npos);
  Scene sampled = scene;
  sampled.supersample = 3;
  EXPECT_NE(disagreement(fingerprint(asked, sampled), first).find("sub-samples"),
            std::string::npos);
  Asked other = asked;
  other.precision = Precision::dbl;
  EXPECT_NE(disagreement(fingerprint(other, scene), first).find("--precision: double here, auto"),
            std::string::npos);
  other = asked, other.width = 8;
  EXPECT_NE(disagreement(fingerprint(other, scene), first).find("--width: 8 here, auto"),
            std::string::npos);
  other = asked, other.command = "bench";
  EXPECT_NE(disagreement(fingerprint(other, scene), first).find("the command: bench here, render"),
            std::string::npos);
  other = asked, other.bench_repeat = 3;
  EXPECT_NE(disagreement(fingerprint(other, scene), first).find("--repeat"), std::string::npos);
  // A stale copy: one byte changed, same length.
  testing::TempDir dir;
  std::ifstream in(asked.scene_path, std::ios::binary);
  std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  bytes[bytes.find("0.7")] = '9';
  std::ofstream(dir.file("stale.json"), std::ios::binary) << bytes;
  other = asked, other.scene_path = dir.file("stale.json");
  EXPECT_NE(disagreement(fingerprint(other, scene), first).find("the scene file's bytes"),
            std::string::npos);
  other.scene_path = dir.file("missing.json");
  EXPECT_THROW(fingerprint(other, scene), InputError);
}
#endif

}  // namespace
}  // namespace lancer::mpi
