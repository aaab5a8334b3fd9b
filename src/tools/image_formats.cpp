// The common formats without OpenImageIO (include/lancer/image_formats.hpp): dispatch, PPM and
// PFM, PNG through libpng, JPEG through libjpeg-turbo. TIFF and OpenEXR are in
// image_formats_float.cpp, a module loaded on first use.
//
// libpng and libjpeg report errors by calling a function that must not return: it longjmps back
// to a setjmp in the function that called the library. A longjmp skips C++ destructors, so the
// functions holding a setjmp own no C++ object; their callers own the buffers.
#include "lancer/image_formats.hpp"

#include <dlfcn.h>
#include <fcntl.h>
#include <jpeglib.h>
// After jpeglib.h, which it needs: the message codes (JWRN_JPEG_EOF).
#include <jerror.h>
#include <png.h>
#include <unistd.h>

#include <cctype>
#include <cerrno>
#include <cmath>
#include <csetjmp>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <memory>
#include <new>
#include <stdexcept>
#include <utility>

#include "lancer/error.hpp"

namespace lancer {

namespace {

// --- PPM (binary, 8-bit) and PFM -----------------------------------------------------------------

std::vector<unsigned char> encode_ppm(const Image& im) {
  const std::string header =
      "P6\n" + std::to_string(im.nx) + " " + std::to_string(im.ny) + "\n255\n";
  std::vector<unsigned char> out(header.begin(), header.end());
  const std::vector<unsigned char> levels = to_bytes(im);
  out.insert(out.end(), levels.begin(), levels.end());
  return out;
}

// A netpbm header: the magic, then `count` unsigned numbers separated by white space and
// comments, then one white-space byte. False if malformed. *pos ends at the pixels.
bool pnm_numbers(const std::vector<unsigned char>& b, std::size_t* pos, int count, long* v) {
  std::size_t p = 2;
  for (int k = 0; k < count; ++k) {
    for (;;) {
      while (p < b.size() && std::isspace(b[p])) ++p;
      if (p < b.size() && b[p] == '#') {
        while (p < b.size() && b[p] != '\n') ++p;
        continue;
      }
      break;
    }
    if (p >= b.size() || !std::isdigit(b[p])) return false;
    v[k] = 0;
    while (p < b.size() && std::isdigit(b[p])) {
      v[k] = v[k] * 10 + (b[p++] - '0');
      if (v[k] > (1L << 30)) return false;
    }
  }
  if (p >= b.size() || !std::isspace(b[p])) return false;
  *pos = p + 1;
  return true;
}

// Binary PPM of 8-bit levels; other depths are the module's.
bool decode_ppm(const std::vector<unsigned char>& b, const std::string& name, Image* out) {
  long v[3];
  std::size_t pos;
  if (!pnm_numbers(b, &pos, 3, v) || v[0] < 1 || v[1] < 1)
    throw InputError(name + ": damaged PPM header");
  if (v[2] != 255) return false;
  const std::size_t n = std::size_t(v[0]) * std::size_t(v[1]) * 3;
  if (b.size() - pos < n) throw InputError(name + ": PPM file is cut short");
  *out = Image(int(v[0]), int(v[1]));
  for (std::size_t k = 0; k < n; ++k) out->rgb[k] = from_byte(b[pos + k]);
  return true;
}

// Colour PFM of scale +-1 (the sign says the byte order), rows bottom to top.
bool decode_pfm(const std::vector<unsigned char>& b, const std::string& name, Image* out) {
  if (b[1] != 'F') return false;  // "Pf": grey
  long v[2];
  std::size_t pos;
  if (!pnm_numbers(b, &pos, 2, v) || v[0] < 1 || v[1] < 1)
    throw InputError(name + ": damaged PFM header");
  // The scale, a decimal number on its own line.
  std::size_t end = pos;
  while (end < b.size() && b[end] != '\n') ++end;
  if (end >= b.size()) throw InputError(name + ": damaged PFM header");
  const std::string scale_text(b.begin() + pos, b.begin() + end);
  char* stop = nullptr;
  const double scale = std::strtod(scale_text.c_str(), &stop);
  if (stop == scale_text.c_str() || std::fabs(scale) != 1.0) return false;
  pos = end + 1;
  const std::size_t nx = std::size_t(v[0]), ny = std::size_t(v[1]);
  if ((b.size() - pos) / 12 / nx < ny) throw InputError(name + ": PFM file is cut short");
  *out = Image(int(nx), int(ny));
  const bool swap = scale > 0;  // big-endian data on this little-endian machine
  for (std::size_t j = 0; j < ny; ++j) {
    const unsigned char* row = b.data() + pos + (ny - 1 - j) * nx * 12;
    for (std::size_t k = 0; k < nx * 3; ++k) {
      unsigned char q[4];
      std::memcpy(q, row + 4 * k, 4);
      if (swap) std::swap(q[0], q[3]), std::swap(q[1], q[2]);
      std::memcpy(&out->rgb[j * nx * 3 + k], q, 4);
    }
  }
  return true;
}

// --- PNG ----------------------------------------------------------------------------------------

// What the PNG read's callbacks share with it. Plain data: a longjmp may cross it.
struct PngSource {
  const unsigned char* data;
  std::size_t size, pos;
  char message[256];
};

void png_read_from(png_structp png, png_bytep to, png_size_t n) {
  PngSource* s = static_cast<PngSource*>(png_get_io_ptr(png));
  if (s->size - s->pos < n) png_error(png, "the file is cut short");
  std::memcpy(to, s->data + s->pos, n);
  s->pos += n;
}

void png_on_error(png_structp png, png_const_charp message) {
  PngSource* s = static_cast<PngSource*>(png_get_error_ptr(png));
  std::snprintf(s->message, sizeof s->message, "%s", message);
  png_longjmp(png, 1);  // back to the setjmp of read_png_header or read_png_rows
}
void png_on_warning(png_structp, png_const_charp) {}

// The header's layout: the channels' bit depth (8 or 16) when decoded here, 0 when the image
// module must read it (alpha, which it premultiplies; palettes and grey below 8 bits, interlacing).
// False with s->message on an error.
bool read_png_header(png_structp png, png_infop info, PngSource* s, png_uint_32* nx,
                     png_uint_32* ny, int* depth) {
  if (setjmp(png_jmpbuf(png))) return false;
  png_set_read_fn(png, s, png_read_from);
  png_read_info(png, info);
  int bit_depth, colour, interlace;
  png_get_IHDR(png, info, nx, ny, &bit_depth, &colour, &interlace, nullptr, nullptr);
  const bool plain = (colour == PNG_COLOR_TYPE_RGB || colour == PNG_COLOR_TYPE_GRAY) &&
                     (bit_depth == 8 || bit_depth == 16) && interlace == PNG_INTERLACE_NONE &&
                     !png_get_valid(png, info, PNG_INFO_tRNS);
  *depth = plain ? bit_depth : 0;
  return true;
}

// The rows into `pixels` (ny rows of row_bytes: RGB samples, 16-bit ones in this machine's order).
bool read_png_rows(png_structp png, png_infop info, unsigned char* pixels, std::size_t row_bytes,
                   png_uint_32 ny) {
  if (setjmp(png_jmpbuf(png))) return false;
  png_set_gray_to_rgb(png);
  png_set_swap(png);
  png_read_update_info(png, info);
  if (png_get_rowbytes(png, info) != row_bytes) png_error(png, "unexpected row size");
  for (png_uint_32 j = 0; j < ny; ++j) png_read_row(png, pixels + j * row_bytes, nullptr);
  return true;
}

// The read structures, destroyed however the decode ends.
struct PngReader {
  png_structp png = nullptr;
  png_infop info = nullptr;
  explicit PngReader(PngSource* s) {
    png = png_create_read_struct(PNG_LIBPNG_VER_STRING, s, png_on_error, png_on_warning);
    if (png) info = png_create_info_struct(png);
    if (!png || !info) {
      png_destroy_read_struct(&png, &info, nullptr);
      throw std::bad_alloc();
    }
  }
  ~PngReader() { png_destroy_read_struct(&png, &info, nullptr); }
  PngReader(const PngReader&) = delete;
  PngReader& operator=(const PngReader&) = delete;
};

// --- JPEG ---------------------------------------------------------------------------------------

// libjpeg's error manager with the place to jump back to and the message.
struct JpegError {
  jpeg_error_mgr mgr;
  std::jmp_buf back;
  char message[JMSG_LENGTH_MAX];
  bool cut_short;  // libjpeg's warning that the data ended early (it fills the rest with grey)
};

void jpeg_on_error(j_common_ptr c) {
  JpegError* e = reinterpret_cast<JpegError*>(c->err);
  (*c->err->format_message)(c, e->message);
  std::longjmp(e->back, 1);
}
void jpeg_no_output(j_common_ptr) {}
void jpeg_on_message(j_common_ptr c, int level) {
  JpegError* e = reinterpret_cast<JpegError*>(c->err);
  if (level < 0 && c->err->msg_code == JWRN_JPEG_EOF) {
    e->cut_short = true;
    (*c->err->format_message)(c, e->message);
  }
}

// libjpeg's error manager, set to jump back rather than exit and to print nothing.
void init_jpeg_error(JpegError* e) {
  jpeg_std_error(&e->mgr);
  e->mgr.error_exit = jpeg_on_error;
  e->mgr.output_message = jpeg_no_output;
  e->mgr.emit_message = jpeg_on_message;
  e->message[0] = '\0';
  e->cut_short = false;
}

// Quality 98 and libjpeg's defaults otherwise (4:2:0, the standard Huffman tables), which is what
// the image module wrote: the same encoder, the same settings, the same decoded pixels.
constexpr int kJpegQuality = 98;

// Encodes 8-bit RGB rows into *mem (malloc'ed by libjpeg, freed by the caller, also on failure).
bool encode_jpeg_rows(JpegError* err, jpeg_compress_struct* c, const unsigned char* rgb, int nx,
                      int ny, unsigned char** mem, unsigned long* size) {
  if (setjmp(err->back)) {
    jpeg_destroy_compress(c);
    return false;
  }
  jpeg_create_compress(c);
  jpeg_mem_dest(c, mem, size);
  c->image_width = JDIMENSION(nx);
  c->image_height = JDIMENSION(ny);
  c->input_components = 3;
  c->in_color_space = JCS_RGB;
  jpeg_set_defaults(c);
  jpeg_set_quality(c, kJpegQuality, TRUE);
  jpeg_start_compress(c, TRUE);
  while (c->next_scanline < c->image_height) {
    JSAMPROW row = const_cast<JSAMPROW>(rgb + std::size_t(c->next_scanline) * nx * 3);
    jpeg_write_scanlines(c, &row, 1);
  }
  jpeg_finish_compress(c);
  jpeg_destroy_compress(c);
  return true;
}

// The header: the size, and whether the layout is decoded here (grey, YCbCr or RGB; CMYK and
// the like are left to the module).
bool read_jpeg_header(JpegError* err, jpeg_decompress_struct* d, const unsigned char* data,
                      std::size_t size, int* nx, int* ny, bool* decoded) {
  if (setjmp(err->back)) {
    jpeg_destroy_decompress(d);
    return false;
  }
  jpeg_create_decompress(d);
  jpeg_mem_src(d, data, static_cast<unsigned long>(size));
  jpeg_read_header(d, TRUE);
  *nx = int(d->image_width), *ny = int(d->image_height);
  *decoded = d->jpeg_color_space == JCS_GRAYSCALE || d->jpeg_color_space == JCS_YCbCr ||
             d->jpeg_color_space == JCS_RGB;
  jpeg_destroy_decompress(d);
  return true;
}

// The whole decode into `pixels` (nx * ny 8-bit RGB), sized by the caller from the header.
bool decode_jpeg_rows(JpegError* err, jpeg_decompress_struct* d, const unsigned char* data,
                      std::size_t size, unsigned char* pixels, int nx, int ny) {
  if (setjmp(err->back)) {
    jpeg_destroy_decompress(d);
    return false;
  }
  jpeg_create_decompress(d);
  jpeg_mem_src(d, data, static_cast<unsigned long>(size));
  jpeg_read_header(d, TRUE);
  d->out_color_space = JCS_RGB;
  jpeg_start_decompress(d);
  if (int(d->output_width) != nx || int(d->output_height) != ny || d->output_components != 3) {
    std::snprintf(err->message, sizeof err->message, "unexpected decoded size");
    jpeg_destroy_decompress(d);
    return false;
  }
  while (d->output_scanline < d->output_height) {
    JSAMPROW row = pixels + std::size_t(d->output_scanline) * nx * 3;
    jpeg_read_scanlines(d, &row, 1);
  }
  jpeg_finish_decompress(d);
  jpeg_destroy_decompress(d);
  return true;
}

// --- The float formats' module ----------------------------------------------------------------

struct FloatModule {
  FloatEncodeFn encode = nullptr;
  FloatDecodeFn decode = nullptr;
};

// Loaded once: where `cmake --install` puts it relative to the executable
// (<bindir>/../<libdir>/lancer/), else where this build made it.
const FloatModule& float_module() {
#if defined(LANCER_WITHOUT_IMAGE_MODULES)
  throw InputError(
      "TIFF and OpenEXR: this lancer was built without its image modules "
      "(LANCER_WITH_IMAGE_MODULES=OFF); it writes .pfm, .ppm, .png and .jpg");
#endif
  static const FloatModule module = [] {
    std::vector<std::string> tried;
    std::error_code ec;
    const std::filesystem::path exe = std::filesystem::read_symlink("/proc/self/exe", ec);
    if (!ec)
      tried.push_back(
          (exe.parent_path() / LANCER_FLOAT_MODULE_INSTALLED).lexically_normal().string());
    tried.push_back(LANCER_FLOAT_MODULE_BUILT);
    std::string why;
    for (const std::string& path : tried) {
      if (!std::filesystem::exists(path, ec)) continue;
      void* handle = dlopen(path.c_str(), RTLD_NOW | RTLD_LOCAL);
      if (!handle) {
        why = dlerror();
        continue;
      }
      FloatModule m;
      m.encode = reinterpret_cast<FloatEncodeFn>(dlsym(handle, "lancer_float_encode"));
      m.decode = reinterpret_cast<FloatDecodeFn>(dlsym(handle, "lancer_float_decode"));
      if (m.encode && m.decode) return m;
      why = path + " lacks lancer_float_encode or lancer_float_decode";
    }
    std::string where;
    for (const std::string& path : tried) where += (where.empty() ? "" : ", ") + path;
    throw std::runtime_error("lancer's TIFF and OpenEXR module is not installed: looked for " +
                             where + (why.empty() ? "" : " (" + why + ")"));
  }();
  return module;
}

void check_float_status(int status, const std::string& error) {
  if (status == kFloatOutOfMemory) throw std::bad_alloc();
  if (status != kFloatOk) throw InputError(error);
}

std::vector<unsigned char> encode_float(const Image& im, const std::string& ext,
                                        const std::string& name) {
  std::vector<unsigned char> out;
  std::string error;
  check_float_status(float_module().encode(ext.c_str(), &im, name.c_str(), &out, &error), error);
  return out;
}

bool decode_float(const char* ext, const std::vector<unsigned char>& bytes, const std::string& name,
                  Image* out) {
  bool decoded = false;
  std::string error;
  check_float_status(float_module().decode(ext, &bytes, name.c_str(), out, &decoded, &error),
                     error);
  return decoded;
}

}  // namespace

std::vector<unsigned char> to_bytes(const Image& im) {
  std::vector<unsigned char> bytes(im.rgb.size());
  for (std::size_t k = 0; k < bytes.size(); ++k) {
    const float v = im.rgb[k];
    const float c = v > 0.0f ? (v < 1.0f ? v : 1.0f) : 0.0f;  // NaN -> 0
    bytes[k] = static_cast<unsigned char>(std::lround(c * 255.0f));
  }
  return bytes;
}

bool has_direct_encoder(const std::string& ext) {
  for (const char* e : {".png", ".jpg", ".jpeg", ".ppm", ".tif", ".tiff", ".exr"})
    if (ext == e) return true;
  return false;
}

void load_direct_encoder(const std::string& ext) {
  if (ext == ".tif" || ext == ".tiff" || ext == ".exr") float_module();
}

std::vector<unsigned char> encode_image(const Image& im, const std::string& ext,
                                        const std::string& name) {
  if (ext == ".png") return encode_png(im, name);
  if (ext == ".jpg" || ext == ".jpeg") return encode_jpeg(im, name);
  if (ext == ".ppm") return encode_ppm(im);
  if (ext == ".tif" || ext == ".tiff" || ext == ".exr") return encode_float(im, ext, name);
  throw std::logic_error("encode_image: no encoder for " + ext);
}

std::vector<unsigned char> encode_png(const Image& im, const std::string& name) {
  const std::vector<unsigned char> levels = to_bytes(im);
  png_image image;
  std::memset(&image, 0, sizeof image);
  image.version = PNG_IMAGE_VERSION;
  image.width = png_uint_32(im.nx);
  image.height = png_uint_32(im.ny);
  image.format = PNG_FORMAT_RGB;
  // lancer's levels are its radiance clamped, not sRGB-encoded: no colour-space chunk, as before.
  image.flags = PNG_IMAGE_FLAG_COLORSPACE_NOT_sRGB;
  // The simplified API reports errors in image.message and never longjmps into our frames.
  png_alloc_size_t size = PNG_IMAGE_PNG_SIZE_MAX(image);
  std::vector<unsigned char> out(size);
  if (!png_image_write_to_memory(&image, out.data(), &size, 0, levels.data(), 0, nullptr)) {
    const std::string why = image.message;
    png_image_free(&image);
    throw InputError(name + ": cannot encode the PNG: " + why);
  }
  out.resize(size);
  return out;
}

bool decode_png(const std::vector<unsigned char>& bytes, const std::string& name, Image* out) {
  PngSource s{bytes.data(), bytes.size(), 0, {0}};
  PngReader r(&s);
  png_set_user_limits(r.png, 1u << 20, 1u << 20);
  png_uint_32 nx = 0, ny = 0;
  int depth = 0;
  if (!read_png_header(r.png, r.info, &s, &nx, &ny, &depth))
    throw InputError(name + ": damaged PNG: " + s.message);
  if (depth == 0) return false;
  const std::size_t row_bytes = std::size_t(nx) * 3 * (depth / 8);
  std::vector<unsigned char> pixels(row_bytes * ny);
  if (!read_png_rows(r.png, r.info, pixels.data(), row_bytes, ny))
    throw InputError(name + ": damaged PNG: " + s.message);
  *out = Image(int(nx), int(ny));
  if (depth == 8) {
    for (std::size_t k = 0; k < out->rgb.size(); ++k) out->rgb[k] = from_byte(pixels[k]);
  } else {
    for (std::size_t k = 0; k < out->rgb.size(); ++k) {
      std::uint16_t v;
      std::memcpy(&v, pixels.data() + 2 * k, 2);
      out->rgb[k] = from_u16(v);
    }
  }
  return true;
}

std::vector<unsigned char> encode_jpeg(const Image& im, const std::string& name) {
  const std::vector<unsigned char> levels = to_bytes(im);
  jpeg_compress_struct c;
  JpegError err;
  init_jpeg_error(&err);
  c.err = &err.mgr;
  unsigned char* mem = nullptr;
  unsigned long size = 0;
  const bool ok = encode_jpeg_rows(&err, &c, levels.data(), im.nx, im.ny, &mem, &size);
  std::unique_ptr<unsigned char, void (*)(void*)> owned(mem, std::free);
  if (!ok) throw InputError(name + ": cannot encode the JPEG: " + err.message);
  return std::vector<unsigned char>(mem, mem + size);
}

bool decode_jpeg(const std::vector<unsigned char>& bytes, const std::string& name, Image* out) {
  jpeg_decompress_struct d;
  JpegError err;
  init_jpeg_error(&err);
  d.err = &err.mgr;
  int nx = 0, ny = 0;
  bool decoded = false;
  if (!read_jpeg_header(&err, &d, bytes.data(), bytes.size(), &nx, &ny, &decoded))
    throw InputError(name + ": damaged JPEG: " + err.message);
  if (!decoded) return false;
  std::vector<unsigned char> pixels(std::size_t(nx) * ny * 3);
  if (!decode_jpeg_rows(&err, &d, bytes.data(), bytes.size(), pixels.data(), nx, ny) ||
      err.cut_short)
    throw InputError(name + ": damaged JPEG: " + err.message);
  *out = Image(nx, ny);
  for (std::size_t k = 0; k < out->rgb.size(); ++k) out->rgb[k] = from_byte(pixels[k]);
  return true;
}

bool decode_image_file(const std::string& path, Image* out) {
  std::unique_ptr<std::FILE, int (*)(std::FILE*)> f(std::fopen(path.c_str(), "rb"), &std::fclose);
  if (!f) throw InputError(path + ": cannot read image: " + std::strerror(errno));
  std::vector<unsigned char> b;
  unsigned char chunk[1 << 16];
  std::size_t n;
  while ((n = std::fread(chunk, 1, sizeof chunk, f.get())) > 0) b.insert(b.end(), chunk, chunk + n);
  if (std::ferror(f.get())) throw InputError(path + ": cannot read image: " + std::strerror(errno));
  return decode_image_bytes(b, path, out);
}

bool decode_image_bytes(const std::vector<unsigned char>& b, const std::string& path, Image* out) {
  auto starts = [&](const char* magic, std::size_t len) {
    return b.size() >= len && std::memcmp(b.data(), magic, len) == 0;
  };
  if (starts("\x89PNG\r\n\x1a\n", 8)) return decode_png(b, path, out);
  if (starts("\xff\xd8\xff", 3)) return decode_jpeg(b, path, out);
  if (starts("II*\0", 4) || starts("MM\0*", 4)) return decode_float(".tif", b, path, out);
  if (starts("\x76\x2f\x31\x01", 4)) return decode_float(".exr", b, path, out);
  if (starts("P6", 2)) return decode_ppm(b, path, out);
  if (starts("PF", 2) || starts("Pf", 2)) return decode_pfm(b, path, out);
  return false;
}

}  // namespace lancer
