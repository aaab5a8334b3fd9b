// The interface between image_io.cpp and lancer's image module (src/tools/image_oiio.cpp, the only
// code that links OpenImageIO), which image_io.cpp loads with dlopen on first use. Internal: one
// build makes both sides.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

namespace lancer {

class OutputFile;

// An image to write: nx * ny RGB pixels, row-major from the top, floats or bytes.
struct ImageModuleWrite {
  const char* oiio_name;  // OpenImageIO's format name (ImageFormat::oiio_name)
  bool is_float;          // pixels are float, else unsigned char
  int nx, ny;
  const void* pixels;
  OutputFile* out;  // where the encoded file goes (every write checked there)
};

// What the entry points return; on kImageError, *error says why.
enum ImageModuleStatus : int { kImageOk = 0, kImageError = 1, kImageOutOfMemory = 2 };

// extern "C" int lancer_oiio_write(const ImageModuleWrite*, std::string* error) noexcept;
using ImageModuleWriteFn = int (*)(const ImageModuleWrite*, std::string*) noexcept;
// extern "C" int lancer_oiio_read(const char* name, const void* data, std::size_t size,
//                                 int max_side, int* nx, int* ny, std::vector<float>* rgb,
//                                 std::string* error) noexcept: decodes the file's bytes (name
// picks the format tried first); rgb gets nx * ny * 3 floats; a side over max_side is an error.
using ImageModuleReadFn = int (*)(const char*, const void*, std::size_t, int, int*, int*,
                                  std::vector<float>*, std::string*) noexcept;

}  // namespace lancer
