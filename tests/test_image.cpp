// Image files: our PFM writer read back by OpenImageIO, clamping and rounding of integer formats,
// row order, and writes that appear whole or not at all.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>

#include "lancer/error.hpp"
#include "lancer/image.hpp"
#include "support/test_util.hpp"

namespace lancer {
namespace {

Image gradient(int nx, int ny) {
  Image im(nx, ny);
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i) {
      float* p = im.pixel(i, j);
      p[0] = 0.1f * i - 0.2f;  // some negative and some above 1: float formats keep them
      p[1] = 1.5f * j;
      p[2] = 1e-3f * (i + 7 * j);
    }
  return im;
}

TEST(ImageFiles, PfmRoundTripsThroughOpenImageIO) {
  testing::TempDir dir;
  const Image im = gradient(7, 5);
  write_image(im, dir.file("a.pfm"));
  const Image back = read_image(dir.file("a.pfm"));
  ASSERT_EQ(back.nx, 7);
  ASSERT_EQ(back.ny, 5);
  EXPECT_EQ(back.rgb, im.rgb) << "PFM must store floats exactly, top row first once read";
}

// OpenImageIO and the 260 libraries it needs load with the image module only, for the formats
// nothing lighter writes (docs/tools.md, "Start-up"): a process that writes or reads PNG, JPEG,
// TIFF, OpenEXR, PPM or PFM never maps it; one that writes BMP, Targa or HDR does. Fails if
// lancer's executable links OpenImageIO again, or a common format goes back to the module.
TEST(ImageFiles, OpenImageIOLoadsOnlyForItsFormats) {
  testing::TempDir dir;
  const std::string scene = std::string(LANCER_SOURCE_DIR) + "/scenes/lorenzi-diffuse.json";
  auto maps_oiio = [&](const std::string& args) {
    const auto r = testing::run_command("LD_DEBUG=files " + testing::cli() + " " + args);
    EXPECT_EQ(r.status, 0) << args << ": " << r.out;
    return r.out.find("libOpenImageIO") != std::string::npos;
  };
  EXPECT_FALSE(maps_oiio("--help"));
  for (const char* ext : {".pfm", ".png", ".jpg", ".tif", ".exr", ".ppm"}) {
    SCOPED_TRACE(ext);
    const std::string out = dir.file(std::string("a") + ext);
    EXPECT_FALSE(maps_oiio("render " + scene + " --resolution 16x8 -o " + out));
    EXPECT_FALSE(maps_oiio("compare " + out + " " + out));
  }
  for (const char* ext : {".bmp", ".tga", ".hdr"}) {
    SCOPED_TRACE(ext);
    const std::string out = dir.file(std::string("a") + ext);
    EXPECT_TRUE(maps_oiio("render " + scene + " --resolution 16x8 -o " + out));
    EXPECT_TRUE(maps_oiio("compare " + out + " " + out));
  }
}

// libtiff and OpenEXR (and the 10 libraries they need) load with the float module only, on the
// first TIFF or OpenEXR: other processes start without them.
TEST(ImageFiles, TiffAndOpenExrLoadOnlyForTheirFormats) {
  testing::TempDir dir;
  const std::string scene = std::string(LANCER_SOURCE_DIR) + "/scenes/lorenzi-diffuse.json";
  auto maps_float_libraries = [&](const std::string& args) {
    const auto r = testing::run_command("LD_DEBUG=files " + testing::cli() + " " + args);
    EXPECT_EQ(r.status, 0) << args << ": " << r.out;
    const bool tiff = r.out.find("libtiff") != std::string::npos;
    const bool exr = r.out.find("libOpenEXR") != std::string::npos;
    EXPECT_EQ(tiff, exr) << args << ": both come with the module";
    return tiff && exr;
  };
  EXPECT_FALSE(maps_float_libraries("--version"));
  for (const char* ext : {".pfm", ".png", ".jpg", ".ppm"}) {
    const std::string out = dir.file(std::string("a") + ext);
    EXPECT_FALSE(maps_float_libraries("render " + scene + " --resolution 16x8 -o " + out)) << ext;
  }
  for (const char* ext : {".tif", ".exr"}) {
    const std::string out = dir.file(std::string("a") + ext);
    EXPECT_TRUE(maps_float_libraries("render " + scene + " --resolution 16x8 -o " + out)) << ext;
    EXPECT_TRUE(maps_float_libraries("compare " + out + " " + out)) << ext;
  }
}

TEST(ImageFiles, PfmHeaderAndBottomUpRows) {
  testing::TempDir dir;
  Image im(2, 2);
  im.pixel(0, 0)[0] = 1.0f;  // top-left red
  write_image(im, dir.file("b.pfm"));
  std::ifstream in(dir.file("b.pfm"), std::ios::binary);
  std::string magic, scale;
  int nx, ny;
  in >> magic >> nx >> ny >> scale;
  in.get();
  EXPECT_EQ(magic, "PF");
  EXPECT_EQ(nx, 2);
  EXPECT_EQ(ny, 2);
  EXPECT_EQ(scale, "-1.0") << "negative scale: little-endian";
  std::vector<float> data(12);
  in.read(reinterpret_cast<char*>(data.data()), 48);
  EXPECT_EQ(data[6], 1.0f) << "the top row comes last in a PFM";
}

TEST(ImageFiles, FloatFormatsKeepRadianceUnclamped) {
  testing::TempDir dir;
  const Image im = gradient(6, 4);
  for (const char* name : {"c.exr", "c.tif"}) {
    SCOPED_TRACE(name);
    write_image(im, dir.file(name));
    const Image back = read_image(dir.file(name));
    EXPECT_EQ(back.rgb, im.rgb);
  }
}

TEST(ImageFiles, IntegerFormatsClampAndRoundToNearest) {
  testing::TempDir dir;
  Image im(4, 1);
  const float values[4] = {-0.5f, 0.5f / 255.0f + 1e-4f, 254.4f / 255.0f, 7.0f};
  const float expect[4] = {0.0f, 1.0f / 255.0f, 254.0f / 255.0f, 1.0f};
  for (int i = 0; i < 4; ++i) im.pixel(i, 0)[0] = im.pixel(i, 0)[1] = im.pixel(i, 0)[2] = values[i];
  for (const char* name : {"d.png", "d.ppm"}) {
    SCOPED_TRACE(name);
    write_image(im, dir.file(name));
    const Image back = read_image(dir.file(name));
    for (int i = 0; i < 4; ++i) EXPECT_NEAR(back.pixel(i, 0)[0], expect[i], 1e-6) << i;
  }
}

TEST(ImageFiles, RowZeroIsTheTopOfEveryFormat) {
  testing::TempDir dir;
  Image im(3, 2);
  im.pixel(1, 0)[1] = 1.0f;  // top row, green
  for (const char* name : {"e.png", "e.pfm", "e.exr"}) {
    SCOPED_TRACE(name);
    write_image(im, dir.file(name));
    const Image back = read_image(dir.file(name));
    EXPECT_EQ(back.pixel(1, 0)[1], 1.0f);
    EXPECT_EQ(back.pixel(1, 1)[1], 0.0f);
  }
}

TEST(ImageFiles, BadTargetsAreRefusedBeforeWriting) {
  testing::TempDir dir;
  const Image im(2, 2);
  EXPECT_THROW(write_image(im, dir.file("no/such/folder/x.png")), InputError);
  EXPECT_THROW(write_image(im, dir.file("x.unknownext")), InputError);
  EXPECT_THROW(write_image(im, dir.file("noextension")), InputError);
  EXPECT_THROW(write_image(im, dir.path()), InputError);
  // Nothing, not even a temporary file, is left behind.
  EXPECT_TRUE(std::filesystem::is_empty(dir.path()));
}

TEST(ImageFiles, AWriteLeavesOnlyTheTarget) {
  testing::TempDir dir;
  write_image(gradient(3, 3), dir.file("f.png"));
  write_image(gradient(3, 3), dir.file("f.png"));  // replacing an existing file
  std::vector<std::string> names;
  for (const auto& e : std::filesystem::directory_iterator(dir.path()))
    names.push_back(e.path().filename().string());
  EXPECT_EQ(names, std::vector<std::string>{"f.png"});
}

}  // namespace
}  // namespace lancer
