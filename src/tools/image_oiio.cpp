// lancer's image module: the only code that links OpenImageIO, loaded by image_io.cpp with
// dlopen when an image other than PFM is written or any image is read. OpenImageIO brings 260
// shared libraries, whose symbol lookups took 0.13 s of every lancer process's start
// (docs/tools.md, "Start-up"); commands that write no such image no longer load them.
// Both sides are built by one build (same compiler and standard library): the entry points
// take C++ types, unmangled for dlsym. Errors come back as text, never as exceptions.
#include <OpenImageIO/imageio.h>

#include <algorithm>
#include <new>
#include <string>
#include <vector>

#include "lancer/image_module.hpp"

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
    if (!out->open(w->path, spec) || !out->write_image(type, w->pixels) || !out->close()) {
      *error = out->geterror();
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

int lancer_oiio_read(const char* path, int* nx, int* ny, std::vector<float>* rgb,
                     std::string* error) noexcept {
  try {
    auto in = OIIO::ImageInput::open(path);
    if (!in) {
      *error = "cannot read image: " + OIIO::geterror();
      return lancer::kImageError;
    }
    const OIIO::ImageSpec& spec = in->spec();
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
