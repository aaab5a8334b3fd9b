// lancer's image module: the only code that links OpenImageIO, loaded by image_io.cpp with
// dlopen when an image other than PFM is written or any image is read. OpenImageIO brings 260
// shared libraries, whose symbol lookups took 0.13 s of every lancer process's start
// (docs/tools.md, "Start-up"); commands that write no such image no longer load them.
// Both sides are built by one build (same compiler and standard library): the entry points
// take C++ types, unmangled for dlsym. Errors come back as text, never as exceptions.
#include <OpenImageIO/filesystem.h>
#include <OpenImageIO/imageio.h>
#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <new>
#include <string>
#include <vector>

#include "lancer/image_module.hpp"
#include "lancer/output_file.hpp"

namespace {

// OpenImageIO writes every format lancer offers through an IOProxy (all of them support it in
// 2.4): this one hands the bytes to lancer's OutputFile, which checks every write. Writing by file
// name instead, the PNG, BMP and Targa writers reported success with a truncated file on a full
// disk, and the JPEG writer's libjpeg called exit(1). The proxy tells the library every write
// succeeded, so that no library's own error path runs; the caller asks the OutputFile.
class OutputProxy final : public OIIO::Filesystem::IOProxy {
 public:
  explicit OutputProxy(lancer::OutputFile& out) : IOProxy("", Write), out_(out) {}
  const char* proxytype() const override { return "lancer"; }
  bool seek(int64_t offset) override {
    m_pos = offset;
    return offset >= 0;
  }
  size_t write(const void* buf, size_t size) override {
    out_.pwrite(buf, size, std::uint64_t(m_pos));
    m_pos += int64_t(size);
    return size;
  }
  size_t pwrite(const void* buf, size_t size, int64_t offset) override {
    out_.pwrite(buf, size, std::uint64_t(offset));
    return size;
  }
  size_t read(void* buf, size_t size) override {
    const size_t n = out_.pread(buf, size, std::uint64_t(m_pos));
    m_pos += int64_t(n);
    return n;
  }
  size_t pread(void* buf, size_t size, int64_t offset) override {
    return out_.pread(buf, size, std::uint64_t(offset));
  }
  size_t size() const override { return size_t(out_.end()); }

 private:
  lancer::OutputFile& out_;
};

// libpng's default error handler, which OpenImageIO 2.4's PNG reader leaves in place, prints
// "libpng error: ..." on stderr before OpenImageIO reports the same error as text: lancer's
// message is to be the one line. stderr is pointed at /dev/null while a file is decoded (compare
// decodes on one thread; nothing else of lancer's prints meanwhile).
class QuietStderr {
 public:
  QuietStderr() : saved_(dup(STDERR_FILENO)) {
    const int null = open("/dev/null", O_WRONLY | O_CLOEXEC);
    if (saved_ >= 0 && null >= 0) dup2(null, STDERR_FILENO);
    if (null >= 0) close(null);
  }
  ~QuietStderr() {
    if (saved_ < 0) return;
    dup2(saved_, STDERR_FILENO);
    close(saved_);
  }
  QuietStderr(const QuietStderr&) = delete;
  QuietStderr& operator=(const QuietStderr&) = delete;

 private:
  int saved_;
};

}  // namespace

extern "C" {

int lancer_oiio_write(const lancer::ImageModuleWrite* w, std::string* error) noexcept {
  try {
    auto out = OIIO::ImageOutput::create(w->oiio_name);
    if (!out) {
      *error = "this OpenImageIO cannot write the format";
      return lancer::kImageError;
    }
    const OIIO::TypeDesc type = w->is_float ? OIIO::TypeDesc::FLOAT : OIIO::TypeDesc::UINT8;
    const OIIO::ImageSpec spec(w->nx, w->ny, 3, type);
    OutputProxy proxy(*w->out);
    if (!out->set_ioproxy(&proxy) || !out->open("lancer-output", spec) ||
        !out->write_image(type, w->pixels) || !out->close()) {
      *error = out->geterror();
      if (error->empty()) *error = "cannot encode the image";
      return lancer::kImageError;
    }
    return lancer::kImageOk;
  } catch (const std::bad_alloc&) {
    return lancer::kImageOutOfMemory;
  } catch (const std::exception& e) {
    *error = e.what();
    return lancer::kImageError;
  }
}

int lancer_oiio_read(const char* name, const void* data, std::size_t size, int max_side, int* nx,
                     int* ny, std::vector<float>* rgb, std::string* error) noexcept {
  try {
    // From the bytes lancer's bounded reader read (src/input_file.cpp), never from the file name:
    // a FIFO or /dev/zero never reaches the library. The name picks the format to try first.
    const QuietStderr quiet;
    OIIO::Filesystem::IOMemReader mem(const_cast<void*>(data), size);
    OIIO::ImageSpec config;
    void* proxy = &mem;
    config.attribute("oiio:ioproxy", OIIO::TypeDesc::PTR, &proxy);
    auto in = OIIO::ImageInput::open(name, &config);
    if (!in) {
      *error = "cannot read image: " + OIIO::geterror();
      return lancer::kImageError;
    }
    const OIIO::ImageSpec& spec = in->spec();
    // The header's size before any allocation: a negative or huge one is bad input.
    if (spec.width < 1 || spec.height < 1 || spec.width > max_side || spec.height > max_side ||
        spec.depth > 1 || spec.nchannels < 1 || spec.nchannels > 64) {
      *error = "image size " + std::to_string(spec.width) + " x " + std::to_string(spec.height) +
               " x " + std::to_string(spec.nchannels) + " channels: must be 1 to " +
               std::to_string(max_side) + " pixels a side";
      return lancer::kImageError;
    }
    std::vector<float> all(std::size_t(spec.width) * spec.height * spec.nchannels);
    if (!in->read_image(0, 0, 0, -1, OIIO::TypeDesc::FLOAT, all.data())) {
      *error = in->geterror();
      return lancer::kImageError;
    }
    *nx = spec.width, *ny = spec.height;
    rgb->assign(std::size_t(spec.width) * spec.height * 3, 0.0f);
    for (std::size_t p = 0; p < std::size_t(spec.width) * spec.height; ++p)
      for (int c = 0; c < 3; ++c)
        (*rgb)[p * 3 + c] = all[p * spec.nchannels + std::min(c, spec.nchannels - 1)];
    return lancer::kImageOk;
  } catch (const std::bad_alloc&) {
    return lancer::kImageOutOfMemory;
  } catch (const std::exception& e) {
    *error = e.what();
    return lancer::kImageError;
  }
}

}  // extern "C"
