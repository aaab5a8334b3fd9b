// The common formats by their own libraries (src/image_formats*.cpp): each reads back what it
// wrote, gives the pixels the image module (OpenImageIO) wrote and read before, reports damaged
// files as bad input, and a write that fails (a full disk, a file size limit) ends in an error
// with no file left.
#include <dlfcn.h>
#include <fcntl.h>
#include <gtest/gtest.h>
#include <png.h>
#include <signal.h>
#include <sys/mount.h>
#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <random>

#include "lancer/error.hpp"
#include "lancer/image.hpp"
#include "lancer/image_formats.hpp"
#include "lancer/image_module.hpp"
#include "lancer/output_file.hpp"
#include "support/test_util.hpp"

namespace lancer {
namespace {

const char* const kDirect[] = {".png", ".jpg", ".jpeg", ".ppm", ".tif", ".tiff", ".exr"};

bool is_float_format(const std::string& ext) {
  return ext == ".tif" || ext == ".tiff" || ext == ".exr";
}

// Every 8-bit level, values below 0 and above 1, NaN, and noise (for JPEG's blocks).
Image test_image(int nx, int ny, bool with_nan) {
  Image im(nx, ny);
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> u(-0.2f, 1.2f);
  for (std::size_t k = 0; k < im.rgb.size(); ++k)
    im.rgb[k] = k < 256 ? float(k) / 255.0f : k % 5 == 0 ? u(rng) * 40.0f : u(rng);
  if (with_nan) im.rgb[300] = std::nanf("");
  im.rgb[301] = 1e-40f;  // a subnormal: float formats keep it
  return im;
}

// lancer's image module, called directly: what write_image and read_image did before the
// direct encoders (the bytes clamped and rounded by lancer, as image_io.cpp's write_oiio does).
struct Module {
  ImageModuleWriteFn write = nullptr;
  ImageModuleReadFn read = nullptr;
  Module() {
    void* h = dlopen(LANCER_IMAGE_MODULE, RTLD_NOW | RTLD_LOCAL);
    if (!h) return;
    write = reinterpret_cast<ImageModuleWriteFn>(dlsym(h, "lancer_oiio_write"));
    read = reinterpret_cast<ImageModuleReadFn>(dlsym(h, "lancer_oiio_read"));
  }
  void write_file(const Image& im, const std::string& ext, const std::string& path) const {
    const bool is_float = is_float_format(ext);
    const std::vector<unsigned char> levels = to_bytes(im);
    const char* name = ext == ".png"                     ? "png"
                       : ext == ".ppm"                   ? "pnm"
                       : ext == ".exr"                   ? "openexr"
                       : ext == ".tif" || ext == ".tiff" ? "tiff"
                                                         : "jpeg";
    const int fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
    ASSERT_GE(fd, 0) << path;
    OutputFile out(fd);
    ImageModuleWrite w{
        name, is_float, im.nx, im.ny, is_float ? (const void*)im.rgb.data() : levels.data(), &out};
    std::string error;
    const int status = write(&w, &error);
    ::close(fd);
    ASSERT_EQ(status, kImageOk) << error;
    ASSERT_EQ(out.error(), 0) << path;
  }
  Image read_file(const std::string& path) const {
    Image im;
    std::string error;
    std::ifstream in(path, std::ios::binary);
    const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    EXPECT_EQ(
        read(path.c_str(), bytes.data(), bytes.size(), 65536, &im.nx, &im.ny, &im.rgb, &error),
        kImageOk)
        << error;
    return im;
  }
};

const Module& module() {
  static const Module m;
  return m;
}

// Bitwise, so that NaN equals NaN and -0 differs from 0.
bool same_bits(const std::vector<float>& a, const std::vector<float>& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(float)) == 0;
}

TEST(ImageFormats, EachFormatReadsBackWhatItWrote) {
  testing::TempDir dir;
  const Image im = test_image(37, 23, true);
  const Image original = test_image(37, 23, true);
  for (const char* ext : kDirect) {
    SCOPED_TRACE(ext);
    const std::string path = dir.file(std::string("a") + ext);
    write_image(im, path);
    // libtiff's predictor works in place: the encoder must hand it a copy.
    ASSERT_TRUE(same_bits(im.rgb, original.rgb)) << "the write changed the image it was given";
    Image back;
    ASSERT_TRUE(decode_image_file(path, &back)) << "decoded here, not by the module";
    ASSERT_EQ(back.nx, im.nx);
    ASSERT_EQ(back.ny, im.ny);
    if (is_float_format(ext)) {
      EXPECT_TRUE(same_bits(back.rgb, im.rgb)) << "floats kept exactly, NaN and subnormal included";
    } else if (std::string(ext) == ".png" || std::string(ext) == ".ppm") {
      const std::vector<unsigned char> levels = to_bytes(im);
      for (std::size_t k = 0; k < levels.size(); ++k)
        ASSERT_EQ(back.rgb[k], from_byte(levels[k])) << k;
    }
  }
}

// JPEG is lossy: a smooth image comes back near (and exactly as OpenImageIO decodes it, below).
TEST(ImageFormats, JpegReadsBackNear) {
  testing::TempDir dir;
  Image im(64, 48);
  for (int j = 0; j < im.ny; ++j)
    for (int i = 0; i < im.nx; ++i) {
      float* p = im.pixel(i, j);
      p[0] = i / 63.0f, p[1] = j / 47.0f, p[2] = 0.5f;
    }
  for (const char* ext : {".jpg", ".jpeg"}) {
    write_image(im, dir.file(std::string("s") + ext));
    Image back;
    ASSERT_TRUE(decode_image_file(dir.file(std::string("s") + ext), &back));
    ASSERT_EQ(back.rgb.size(), im.rgb.size());
    float worst = 0;
    for (std::size_t k = 0; k < im.rgb.size(); ++k)
      worst = std::max(worst, std::fabs(back.rgb[k] - im.rgb[k]));
    EXPECT_LT(worst, 6.0f / 255.0f) << ext;  // 4:2:0 chroma on a colour ramp
  }
}

// The same image through the module (the old path) and through write_image: the module reads
// identical pixels from both files, and the direct decoders read identical pixels to the module's.
TEST(ImageFormats, SamePixelsAsTheImageModule) {
  ASSERT_TRUE(module().write && module().read) << "cannot load " << LANCER_IMAGE_MODULE;
  testing::TempDir dir;
  const Image im = test_image(61, 29, true);
  for (const char* ext : kDirect) {
    SCOPED_TRACE(ext);
    const std::string old_file = dir.file(std::string("old") + ext);
    const std::string new_file = dir.file(std::string("new") + ext);
    module().write_file(im, ext, old_file);
    write_image(im, new_file);
    const Image old_pixels = module().read_file(old_file);
    const Image new_pixels = module().read_file(new_file);
    ASSERT_EQ(new_pixels.nx, old_pixels.nx);
    ASSERT_EQ(new_pixels.ny, old_pixels.ny);
    EXPECT_TRUE(same_bits(new_pixels.rgb, old_pixels.rgb)) << "pixels differ from the module's";
    for (const std::string& f : {old_file, new_file}) {
      Image direct;
      ASSERT_TRUE(decode_image_file(f, &direct)) << f;
      EXPECT_TRUE(same_bits(direct.rgb, module().read_file(f).rgb)) << f << ": decoded differently";
    }
  }
}

// A rendered scene, as users write it: the same PNG pixels as the module wrote.
TEST(ImageFormats, RenderedPngMatchesTheModule) {
  ASSERT_TRUE(module().write && module().read);
  testing::TempDir dir;
  const Scene scene = load_scene(testing::source_path("scenes/lorenzi-reflections.json"));
  const Image im = testing::render_with(scene, 1);
  module().write_file(im, ".png", dir.file("old.png"));
  write_image(im, dir.file("new.png"));
  EXPECT_TRUE(same_bits(read_image(dir.file("new.png")).rgb, read_image(dir.file("old.png")).rgb));
  EXPECT_TRUE(
      same_bits(read_image(dir.file("new.png")).rgb, module().read_file(dir.file("old.png")).rgb));
}

// PNG with alpha is premultiplied by OpenImageIO: left to it, not decoded differently here.
TEST(ImageFormats, LayoutsTheDecodersDoNotHandleGoToTheModule) {
  testing::TempDir dir;
  png_image image{};
  image.version = PNG_IMAGE_VERSION;
  image.width = 2;
  image.height = 1;
  image.format = PNG_FORMAT_RGBA;
  const unsigned char rgba[8] = {255, 0, 0, 128, 0, 255, 0, 255};
  ASSERT_TRUE(png_image_write_to_file(&image, dir.file("alpha.png").c_str(), 0, rgba, 0, nullptr));
  Image direct;
  EXPECT_FALSE(decode_image_file(dir.file("alpha.png"), &direct));
  const Image via_module = read_image(dir.file("alpha.png"));
  EXPECT_EQ(via_module.nx, 2);
}

TEST(ImageFormats, DamagedFilesAreBadInput) {
  testing::TempDir dir;
  const Image im = test_image(40, 30, false);
  for (const char* ext : {".png", ".jpg", ".ppm", ".tif", ".exr", ".pfm"}) {
    SCOPED_TRACE(ext);
    const std::string path = dir.file(std::string("d") + ext);
    write_image(im, path);
    std::ifstream in(path, std::ios::binary);
    std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    for (std::size_t keep : {bytes.size() / 2, std::size_t(12)}) {
      std::ofstream(path, std::ios::binary | std::ios::trunc) << bytes.substr(0, keep);
      Image out;
      EXPECT_THROW(decode_image_file(path, &out), InputError) << keep << " bytes";
    }
  }
  Image out;
  EXPECT_THROW(decode_image_file(dir.file("missing.png"), &out), InputError);
}

// Bytes changed anywhere: each decoder reads the file, leaves it to the module, or says it is
// damaged; nothing else (no crash, no other exception).
TEST(ImageFormats, CorruptedFilesAreDecodedOrBadInput) {
  testing::TempDir dir;
  const Image im = test_image(24, 16, false);
  std::mt19937 rng(11);
  for (const char* ext : {".png", ".jpg", ".ppm", ".tif", ".exr", ".pfm"}) {
    SCOPED_TRACE(ext);
    const std::string path = dir.file(std::string("c") + ext);
    write_image(im, path);
    std::ifstream in(path, std::ios::binary);
    const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    for (int trial = 0; trial < 80; ++trial) {
      std::string bad = bytes;
      for (int k = 0; k < 1 + trial % 4; ++k)
        bad[std::uniform_int_distribution<std::size_t>(0, bad.size() - 1)(rng)] = char(rng());
      std::ofstream(path, std::ios::binary | std::ios::trunc) << bad;
      Image out;
      try {
        decode_image_file(path, &out);
      } catch (const InputError&) {
      }
    }
  }
}

// The names in `dir`, sorted.
std::vector<std::string> names_in(const std::string& dir) {
  std::vector<std::string> names;
  for (const auto& e : std::filesystem::directory_iterator(dir))
    names.push_back(e.path().filename().string());
  std::sort(names.begin(), names.end());
  return names;
}

// A disk that fills up during the write: a 64 KiB tmpfs (needs root to mount; skipped without).
TEST(ImageFormats, AFullDiskEndsInAnErrorAndNoFile) {
  testing::TempDir dir;
  const std::string mnt = dir.file("small");
  std::filesystem::create_directory(mnt);
  if (mount("tmpfs", mnt.c_str(), "tmpfs", 0, "size=64k") != 0)
    GTEST_SKIP() << "cannot mount a tmpfs here: " << std::strerror(errno);
  struct Unmount {
    std::string path;
    ~Unmount() { umount(path.c_str()); }
  } unmount{mnt};
  const Image im = test_image(300, 200, false);  // every format's file exceeds 64 KiB
  for (const char* ext : kDirect) {
    SCOPED_TRACE(ext);
    EXPECT_THROW(write_image(im, mnt + "/full" + ext), OutputError);
    EXPECT_TRUE(names_in(mnt).empty()) << "a failed write leaves no file, temporary or not";
  }
}

// The same failure where mounting is not allowed: a file size limit (RLIMIT_FSIZE), under which
// write() fails with EFBIG once the file reaches it.
TEST(ImageFormats, AFileSizeLimitEndsInAnErrorAndNoFile) {
  testing::TempDir dir;
  const Image im = test_image(300, 200, false);
  signal(SIGXFSZ, SIG_IGN);
  struct rlimit old;
  getrlimit(RLIMIT_FSIZE, &old);
  struct rlimit low = old;
  low.rlim_cur = 16 * 1024;
  ASSERT_EQ(setrlimit(RLIMIT_FSIZE, &low), 0);
  for (const char* ext : kDirect) {
    SCOPED_TRACE(ext);
    EXPECT_THROW(write_image(im, dir.file(std::string("big") + ext)), OutputError);
    EXPECT_TRUE(names_in(dir.path()).empty());
  }
  setrlimit(RLIMIT_FSIZE, &old);
  write_image(im, dir.file("fits.png"));  // and the same write succeeds without the limit
  EXPECT_EQ(names_in(dir.path()), std::vector<std::string>{"fits.png"});
}

}  // namespace
}  // namespace lancer
