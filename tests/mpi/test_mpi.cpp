#include <gtest/gtest.h>

#include <cstdlib>
#include <random>

#include "lancer/mpi.hpp"
#include "lancer/render.hpp"
#include "lancer/tiles.hpp"
#ifndef LANCER_NO_MPI
#include "rows.hpp"
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
#endif

}  // namespace
}  // namespace lancer::mpi
