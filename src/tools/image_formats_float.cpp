// The float formats without OpenImageIO (include/lancer/image_formats.hpp): TIFF through libtiff
// and OpenEXR through its own library, both encoded into memory and decoded from it. Built as a
// module of its own (lancer-float.so), loaded with dlopen by image_formats.cpp on the first TIFF or
// OpenEXR: libtiff, OpenEXR and their 10 libraries (zstd, lzma, Lerc, jbig, webp, deflate, Iex,
// IlmThread, Imath...) cost every process that loaded them 2 ms of CPU at start. Both store
// 32-bit float RGB with zip compression (TIFF with the floating-point predictor), as the image
// module wrote them.
#include <OpenEXR/ImfChannelList.h>
#include <OpenEXR/ImfFrameBuffer.h>
#include <OpenEXR/ImfHeader.h>
#include <OpenEXR/ImfIO.h>
#include <OpenEXR/ImfInputFile.h>
#include <OpenEXR/ImfOutputFile.h>
#include <OpenEXR/ImfPartType.h>
#include <tiffio.h>

#include <algorithm>
#include <cstdarg>
#include <cstdio>
#include <cstring>
#include <exception>
#include <memory>
#include <new>

#include "lancer/error.hpp"
#include "lancer/image_formats.hpp"

namespace lancer {

namespace {

// Sides beyond this (a header's claim, not memory we have) are left to the module, whose checks
// they meet; Image's int sides must not wrap.
constexpr uint32_t kMaxSide = 1u << 24;

// --- TIFF ---------------------------------------------------------------------------------------

// A TIFF in memory, for libtiff's client I/O: written into `out`, or read from data/size. The
// callbacks return errors as libtiff expects (-1), never exceptions through its C frames.
struct TiffMemory {
  std::vector<unsigned char>* out = nullptr;
  const unsigned char* data = nullptr;
  std::size_t size = 0;
  std::size_t pos = 0;
  std::string error;  // the first error libtiff reported
};

tmsize_t tiff_read(thandle_t h, void* to, tmsize_t n) {
  TiffMemory* m = static_cast<TiffMemory*>(h);
  const std::size_t size = m->out ? m->out->size() : m->size;
  const unsigned char* data = m->out ? m->out->data() : m->data;
  if (n < 0 || m->pos > size) return -1;
  const std::size_t k = std::min(std::size_t(n), size - m->pos);
  std::memcpy(to, data + m->pos, k);
  m->pos += k;
  return tmsize_t(k);
}

tmsize_t tiff_write(thandle_t h, void* from, tmsize_t n) {
  TiffMemory* m = static_cast<TiffMemory*>(h);
  if (!m->out || n < 0) return -1;
  try {
    if (m->out->size() < m->pos + std::size_t(n)) m->out->resize(m->pos + std::size_t(n));
  } catch (const std::bad_alloc&) {
    return -1;
  }
  std::memcpy(m->out->data() + m->pos, from, std::size_t(n));
  m->pos += std::size_t(n);
  return n;
}

toff_t tiff_seek(thandle_t h, toff_t off, int whence) {
  TiffMemory* m = static_cast<TiffMemory*>(h);
  const std::size_t size = m->out ? m->out->size() : m->size;
  const std::size_t base = whence == SEEK_CUR ? m->pos : whence == SEEK_END ? size : 0;
  m->pos = base + std::size_t(off);
  return toff_t(m->pos);
}

int tiff_close(thandle_t) { return 0; }
toff_t tiff_size(thandle_t h) {
  TiffMemory* m = static_cast<TiffMemory*>(h);
  return toff_t(m->out ? m->out->size() : m->size);
}
int tiff_map(thandle_t, void**, toff_t*) { return 0; }
void tiff_unmap(thandle_t, void*, toff_t) {}

int tiff_on_error(TIFF*, void* user, const char* module, const char* fmt, va_list ap) {
  TiffMemory* m = static_cast<TiffMemory*>(user);
  if (m->error.empty()) {
    char text[512];
    std::vsnprintf(text, sizeof text, fmt, ap);
    m->error = std::string(module ? module : "libtiff") + ": " + text;
  }
  return 1;  // handled: not printed on stderr
}
int tiff_on_warning(TIFF*, void*, const char*, const char*, va_list) { return 1; }

// A TIFF handle on `m` with its errors collected there; closed when it goes.
struct TiffHandle {
  TIFF* t = nullptr;
  TiffHandle(TiffMemory* m, const char* mode) {
    std::unique_ptr<TIFFOpenOptions, void (*)(TIFFOpenOptions*)> opts(TIFFOpenOptionsAlloc(),
                                                                      TIFFOpenOptionsFree);
    if (!opts) throw std::bad_alloc();
    TIFFOpenOptionsSetErrorHandlerExtR(opts.get(), tiff_on_error, m);
    TIFFOpenOptionsSetWarningHandlerExtR(opts.get(), tiff_on_warning, m);
    t = TIFFClientOpenExt("memory", mode, m, tiff_read, tiff_write, tiff_seek, tiff_close,
                          tiff_size, tiff_map, tiff_unmap, opts.get());
  }
  ~TiffHandle() {
    if (t) TIFFClose(t);
  }
  TiffHandle(const TiffHandle&) = delete;
  TiffHandle& operator=(const TiffHandle&) = delete;
};

// --- OpenEXR ------------------------------------------------------------------------------------

class ExrMemoryOut : public Imf::OStream {
 public:
  explicit ExrMemoryOut(std::vector<unsigned char>* out) : Imf::OStream("memory"), out_(out) {}
  void write(const char c[], int n) override {
    if (out_->size() < pos_ + std::size_t(n)) out_->resize(pos_ + std::size_t(n));
    std::memcpy(out_->data() + pos_, c, std::size_t(n));
    pos_ += std::size_t(n);
  }
  uint64_t tellp() override { return pos_; }
  void seekp(uint64_t pos) override { pos_ = pos; }

 private:
  std::vector<unsigned char>* out_;
  std::size_t pos_ = 0;
};

class ExrMemoryIn : public Imf::IStream {
 public:
  ExrMemoryIn(const unsigned char* data, std::size_t size)
      : Imf::IStream("memory"), data_(data), size_(size) {}
  bool read(char c[], int n) override {
    if (pos_ > size_ || size_ - pos_ < std::size_t(n)) throw Iex::InputExc("the file is cut short");
    std::memcpy(c, data_ + pos_, std::size_t(n));
    pos_ += std::size_t(n);
    return pos_ < size_;
  }
  uint64_t tellg() override { return pos_; }
  void seekg(uint64_t pos) override { pos_ = pos; }

 private:
  const unsigned char* data_;
  std::size_t size_, pos_ = 0;
};

std::vector<unsigned char> encode_tiff(const Image& im, const std::string& name) {
  std::vector<unsigned char> out;
  TiffMemory m;
  m.out = &out;
  {
    TiffHandle h(&m, "w");
    if (!h.t) throw InputError(name + ": cannot encode the TIFF: " + m.error);
    TIFF* t = h.t;
    bool ok = TIFFSetField(t, TIFFTAG_IMAGEWIDTH, uint32_t(im.nx)) &&
              TIFFSetField(t, TIFFTAG_IMAGELENGTH, uint32_t(im.ny)) &&
              TIFFSetField(t, TIFFTAG_SAMPLESPERPIXEL, 3) &&
              TIFFSetField(t, TIFFTAG_BITSPERSAMPLE, 32) &&
              TIFFSetField(t, TIFFTAG_SAMPLEFORMAT, SAMPLEFORMAT_IEEEFP) &&
              TIFFSetField(t, TIFFTAG_PLANARCONFIG, PLANARCONFIG_CONTIG) &&
              TIFFSetField(t, TIFFTAG_PHOTOMETRIC, PHOTOMETRIC_RGB) &&
              TIFFSetField(t, TIFFTAG_ORIENTATION, ORIENTATION_TOPLEFT) &&
              TIFFSetField(t, TIFFTAG_COMPRESSION, COMPRESSION_ADOBE_DEFLATE) &&
              TIFFSetField(t, TIFFTAG_PREDICTOR, PREDICTOR_FLOATINGPOINT) &&
              TIFFSetField(t, TIFFTAG_ROWSPERSTRIP, 32);
    // libtiff applies the predictor in place, in the buffer it is given: a copy of each row.
    std::vector<float> row(std::size_t(im.nx) * 3);
    for (int j = 0; ok && j < im.ny; ++j) {
      std::copy(im.pixel(0, j), im.pixel(0, j) + row.size(), row.begin());
      ok = TIFFWriteScanline(t, row.data(), uint32_t(j), 0) == 1;
    }
    // The directory and the last strip are written here; TIFFClose would not say if that failed.
    ok = ok && TIFFFlush(t) == 1;
    if (!ok || !m.error.empty())
      throw InputError(name + ": cannot encode the TIFF: " +
                       (m.error.empty() ? std::string("libtiff failed") : m.error));
  }
  return out;
}

// One directory of RGB or grey samples, contiguous, in strips, top row first, of 8- or 16-bit
// integers or 32-bit floats; anything else (alpha, tiles, YCbCr, palettes...) is the module's.
bool decode_tiff(const std::vector<unsigned char>& bytes, const std::string& name, Image* out) {
  TiffMemory m;
  m.data = bytes.data();
  m.size = bytes.size();
  TiffHandle h(&m, "rm");
  if (!h.t) throw InputError(name + ": damaged TIFF: " + m.error);
  TIFF* t = h.t;
  uint32_t nx = 0, ny = 0;
  uint16_t spp = 1, bits = 1, format = SAMPLEFORMAT_UINT, planar = PLANARCONFIG_CONTIG,
           photometric = 0, orientation = ORIENTATION_TOPLEFT, extra = 0;
  uint16_t* extra_types = nullptr;
  TIFFGetField(t, TIFFTAG_IMAGEWIDTH, &nx);
  TIFFGetField(t, TIFFTAG_IMAGELENGTH, &ny);
  TIFFGetFieldDefaulted(t, TIFFTAG_SAMPLESPERPIXEL, &spp);
  TIFFGetFieldDefaulted(t, TIFFTAG_BITSPERSAMPLE, &bits);
  TIFFGetFieldDefaulted(t, TIFFTAG_SAMPLEFORMAT, &format);
  TIFFGetFieldDefaulted(t, TIFFTAG_PLANARCONFIG, &planar);
  TIFFGetFieldDefaulted(t, TIFFTAG_ORIENTATION, &orientation);
  TIFFGetFieldDefaulted(t, TIFFTAG_EXTRASAMPLES, &extra, &extra_types);
  if (!TIFFGetField(t, TIFFTAG_PHOTOMETRIC, &photometric)) return false;
  const bool layout = ((spp == 3 && photometric == PHOTOMETRIC_RGB) ||
                       (spp == 1 && photometric == PHOTOMETRIC_MINISBLACK)) &&
                      extra == 0 && planar == PLANARCONFIG_CONTIG && !TIFFIsTiled(t) &&
                      orientation == ORIENTATION_TOPLEFT && nx > 0 && ny > 0 && nx <= kMaxSide &&
                      ny <= kMaxSide;
  const bool type = (format == SAMPLEFORMAT_UINT && (bits == 8 || bits == 16)) ||
                    (format == SAMPLEFORMAT_IEEEFP && bits == 32);
  if (!layout || !type) return false;
  const std::size_t row_bytes = std::size_t(nx) * spp * (bits / 8);
  if (TIFFScanlineSize64(t) != row_bytes) return false;
  std::vector<unsigned char> row(row_bytes);
  *out = Image(int(nx), int(ny));
  for (uint32_t j = 0; j < ny; ++j) {
    if (TIFFReadScanline(t, row.data(), j, 0) != 1 || !m.error.empty())
      throw InputError(name + ": damaged TIFF: " + (m.error.empty() ? "unreadable row" : m.error));
    float* dst = out->pixel(0, int(j));
    for (std::size_t i = 0; i < nx; ++i)
      for (int c = 0; c < 3; ++c) {
        const std::size_t k = i * spp + (spp == 3 ? c : 0);
        if (bits == 8) {
          dst[i * 3 + c] = from_byte(row[k]);
        } else if (bits == 16) {
          uint16_t v;
          std::memcpy(&v, row.data() + 2 * k, 2);
          dst[i * 3 + c] = from_u16(v);
        } else {
          std::memcpy(&dst[i * 3 + c], row.data() + 4 * k, 4);
        }
      }
  }
  return true;
}

std::vector<unsigned char> encode_exr(const Image& im, const std::string& name) {
  std::vector<unsigned char> out;
  // Room for the largest file, so that the line offsets OutputFile writes when it is destroyed
  // (where it cannot report a failure) never need memory.
  out.reserve(std::size_t(im.nx) * im.ny * 12 + std::size_t(im.ny) * 8 + (1 << 16));
  try {
    ExrMemoryOut stream(&out);
    Imf::Header header(im.nx, im.ny);
    header.compression() = Imf::ZIP_COMPRESSION;
    for (const char* c : {"R", "G", "B"}) header.channels().insert(c, Imf::Channel(Imf::FLOAT));
    Imf::FrameBuffer frame;
    const std::size_t xs = 3 * sizeof(float), ys = xs * std::size_t(im.nx);
    const char* base = reinterpret_cast<const char*>(im.rgb.data());
    for (int c = 0; c < 3; ++c)
      frame.insert(std::string(1, "RGB"[c]),
                   Imf::Slice(Imf::FLOAT, const_cast<char*>(base) + 4 * c, xs, ys));
    Imf::OutputFile file(stream, header);
    file.setFrameBuffer(frame);
    file.writePixels(im.ny);
  } catch (const std::bad_alloc&) {
    throw;
  } catch (const std::exception& e) {
    throw InputError(name + ": cannot encode the OpenEXR: " + e.what());
  }
  return out;
}

// A flat image with R, G and B (half or float), or with Y alone; the data window's pixels, as the
// module reads them. Other channel sets, subsampled channels and deep images are the module's.
bool decode_exr(const std::vector<unsigned char>& bytes, const std::string& name, Image* out) {
  try {
    ExrMemoryIn stream(bytes.data(), bytes.size());
    Imf::InputFile file(stream);
    const Imf::Header& h = file.header();
    if (h.hasType() && h.type() != Imf::SCANLINEIMAGE && h.type() != Imf::TILEDIMAGE) return false;
    const Imf::ChannelList& channels = h.channels();
    auto usable = [&](const char* c) {
      const Imf::Channel* ch = channels.findChannel(c);
      return ch && ch->type != Imf::UINT && ch->xSampling == 1 && ch->ySampling == 1;
    };
    int count = 0;
    for (auto it = channels.begin(); it != channels.end(); ++it) ++count;
    const bool rgb = usable("R") && usable("G") && usable("B");
    const bool grey = count == 1 && usable("Y");
    if (!rgb && !grey) return false;
    const Imath::Box2i dw = h.dataWindow();
    const int64_t wide = int64_t(dw.max.x) - dw.min.x + 1, high = int64_t(dw.max.y) - dw.min.y + 1;
    if (wide < 1 || high < 1 || wide > kMaxSide || high > kMaxSide) return false;
    const int nx = int(wide), ny = int(high);
    *out = Image(nx, ny);
    Imf::FrameBuffer frame;
    const std::size_t xs = 3 * sizeof(float), ys = xs * std::size_t(nx);
    char* base = reinterpret_cast<char*>(out->rgb.data());
    for (int c = 0; c < (grey ? 1 : 3); ++c)
      frame.insert(grey ? std::string("Y") : std::string(1, "RGB"[c]),
                   Imf::Slice::Make(Imf::FLOAT, base + 4 * c, dw, xs, ys));
    file.setFrameBuffer(frame);
    file.readPixels(dw.min.y, dw.max.y);
    if (grey)
      for (std::size_t p = 0; p < std::size_t(nx) * ny; ++p)
        out->rgb[3 * p + 1] = out->rgb[3 * p + 2] = out->rgb[3 * p];
    return true;
  } catch (const std::bad_alloc&) {
    throw;
  } catch (const std::exception& e) {
    throw InputError(name + ": damaged OpenEXR: " + e.what());
  }
}

}  // namespace
}  // namespace lancer

// The module's entry points: errors come back as status and text, never as exceptions across
// the boundary.
extern "C" {

int lancer_float_encode(const char* ext, const lancer::Image* image, const char* name,
                        std::vector<unsigned char>* out, std::string* error) noexcept {
  try {
    const std::string e = ext;
    *out = e == ".exr" ? lancer::encode_exr(*image, name) : lancer::encode_tiff(*image, name);
    return lancer::kFloatOk;
  } catch (const std::bad_alloc&) {
    return lancer::kFloatOutOfMemory;
  } catch (const std::exception& e) {
    *error = e.what();
    return lancer::kFloatError;
  }
}

int lancer_float_decode(const char* ext, const std::vector<unsigned char>* bytes, const char* name,
                        lancer::Image* out, bool* decoded, std::string* error) noexcept {
  try {
    const std::string e = ext;
    *decoded = e == ".exr" ? lancer::decode_exr(*bytes, name, out)
                           : lancer::decode_tiff(*bytes, name, out);
    return lancer::kFloatOk;
  } catch (const std::bad_alloc&) {
    return lancer::kFloatOutOfMemory;
  } catch (const std::exception& e) {
    *error = e.what();
    return lancer::kFloatError;
  }
}

}  // extern "C"
