// The common image formats, encoded and decoded by the libraries that do only that: PNG (libpng),
// JPEG (libjpeg-turbo), TIFF (libtiff), OpenEXR, and PPM and PFM by lancer's own code. A render
// written to one of them costs what the format needs, not OpenImageIO's 260 libraries; the image
// module (src/image_oiio.cpp) remains for the formats nothing lighter writes (BMP, Targa,
// Radiance HDR) and the layouts these decoders leave to it (alpha, palettes of other depths...).
// Internal to lancer_tools: write_image and read_image (image_io.cpp) call it.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "lancer/image.hpp"

namespace lancer {

// Whether write_image encodes `ext` (lower case, with the dot) here, without the image module.
bool has_direct_encoder(const std::string& ext);

// Loads what the encoder of `ext` needs (the float module for TIFF and OpenEXR), so that a
// missing module stops the command before its work. Throws std::runtime_error naming the paths.
void load_direct_encoder(const std::string& ext);

// The whole file for `ext`, in memory, so that nothing reaches the disk before the encoder has
// succeeded. Pixels as write_image documents: float formats (.exr, .tif, .tiff) keep radiance
// unclamped as 32-bit floats; integer ones (.png, .jpg, .jpeg, .ppm) clamp each channel to
// [0, 1] and round to the nearest of 256 levels. Throws InputError naming `name` when the library
// reports an error.
std::vector<unsigned char> encode_image(const Image& image, const std::string& ext,
                                        const std::string& name);

// Reads `path` and decodes it when its first bytes say PNG, JPEG, TIFF, OpenEXR, binary PPM or
// PFM in a layout decoded here (RGB or grey, no alpha; see image_formats.cpp), with the values
// the image module gives for the same file. False: the image module must read it. Throws
// InputError when the file cannot be read or is damaged.
bool decode_image_file(const std::string& path, Image* out);
// The same for a file's bytes already read (compare reads through the bounded reader).
bool decode_image_bytes(const std::vector<unsigned char>& bytes, const std::string& path,
                        Image* out);

// One decoder per format, on the file's bytes: false when the layout is left to the module.
bool decode_png(const std::vector<unsigned char>& bytes, const std::string& name, Image* out);
bool decode_jpeg(const std::vector<unsigned char>& bytes, const std::string& name, Image* out);
std::vector<unsigned char> encode_png(const Image& image, const std::string& name);
std::vector<unsigned char> encode_jpeg(const Image& image, const std::string& name);

// TIFF and OpenEXR: in a module of their own (src/image_formats_float.cpp, lancer-float.so),
// loaded with dlopen on first use, since libtiff and OpenEXR bring 12 libraries to every start.
// Its entry points (one build makes both sides; C++ types, unmangled names; `ext` is ".exr" or
// a TIFF extension; on kFloatError, *error is the whole message):
//   int lancer_float_encode(const char* ext, const Image*, const char* name,
//                           std::vector<unsigned char>* out, std::string* error) noexcept
//   int lancer_float_decode(const char* ext, const std::vector<unsigned char>* bytes,
//                           const char* name, Image* out, bool* decoded,
//                           std::string* error) noexcept
enum FloatModuleStatus : int { kFloatOk = 0, kFloatError = 1, kFloatOutOfMemory = 2 };
using FloatEncodeFn = int (*)(const char*, const Image*, const char*, std::vector<unsigned char>*,
                              std::string*) noexcept;
using FloatDecodeFn = int (*)(const char*, const std::vector<unsigned char>*, const char*, Image*,
                              bool*, std::string*) noexcept;

// Integer formats' levels: clamp to [0, 1] (NaN to 0) and round to the nearest of 256.
std::vector<unsigned char> to_bytes(const Image& image);
// And back, as the image module converts them (a multiplication by 1/255, not a division).
inline float from_byte(unsigned v) { return float(v) * (1.0f / 255.0f); }
inline float from_u16(unsigned v) { return float(v) * (1.0f / 65535.0f); }

}  // namespace lancer
