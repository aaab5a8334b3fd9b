// The interface between image_io.cpp and lancer's image module (src/tools/image_oiio.cpp, the only
// code that links OpenImageIO), which image_io.cpp loads with dlopen on first use. Internal: one
// build makes both sides.
#pragma once

#include <string>
#include <vector>

namespace lancer {

// An image to write: nx * ny RGB pixels, row-major from the top, floats or bytes.
struct ImageModuleWrite {
  const char* oiio_name;  // OpenImageIO's format name (ImageFormat::oiio_name)
  bool is_float;          // pixels are float, else unsigned char
  int nx, ny;
  const void* pixels;
  const char* path;
};

// What the entry points return; on kImageError, *error says why.
enum ImageModuleStatus : int { kImageOk = 0, kImageError = 1, kImageOutOfMemory = 2 };

// extern "C" int lancer_oiio_write(const ImageModuleWrite*, std::string* error) noexcept;
using ImageModuleWriteFn = int (*)(const ImageModuleWrite*, std::string*) noexcept;
// extern "C" int lancer_oiio_read(const char* path, int* nx, int* ny, std::vector<float>* rgb,
//                                 std::string* error) noexcept: rgb gets nx * ny * 3 floats.
using ImageModuleReadFn = int (*)(const char*, int*, int*, std::vector<float>*,
                                  std::string*) noexcept;

}  // namespace lancer
