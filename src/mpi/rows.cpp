#include "rows.hpp"

#include <algorithm>
#include <cstring>

#include "lancer/error.hpp"
#include "lancer/packet/api.hpp"
#include "lancer/prepared.hpp"
#include "lancer/reference.hpp"
#include "lancer/tiles.hpp"

namespace lancer::mpi {

struct RowEngine::State {
  Precision precision = Precision::exact;
  PreparedScene<float> f;
  PreparedScene<double> d;
  const packet::KernelTable<float>* fk = nullptr;  // null: the reference (width 1)
  const packet::KernelTable<double>* dk = nullptr;
  std::string isa;
};

RowEngine::RowEngine(const Scene& scene, Precision precision, int width)
    : state_(std::make_unique<State>()) {
  LANCER_CHECK(precision != Precision::automatic);
  State& s = *state_;
  s.precision = precision;
  s.isa = packet::isa_name(width, precision);
  if (precision == Precision::dbl) {
    s.d = prepare<double>(scene);
    if (width != 1) s.dk = packet::double_kernels(width, s.d.features.shapes);
    LANCER_CHECK(width == 1 || s.dk);
  } else {
    s.f = prepare<float>(scene);
    if (width != 1) s.fk = packet::float_kernels(width, precision, s.f.features.shapes);
    LANCER_CHECK(width == 1 || s.fk);
  }
}

RowEngine::~RowEngine() = default;

const char* RowEngine::isa() const { return state_->isa.c_str(); }

StructureInfo RowEngine::structure() const {
  const State& s = *state_;
  return s.precision == Precision::dbl ? structure_of(s.d) : structure_of(s.f);
}

void RowEngine::render_rows(Image& image, int r0, int r1, RayCounts& counts) const {
  const State& s = *state_;
  if (s.precision == Precision::dbl) {
    if (s.dk)
      s.dk->render_rows(s.d, image, r0, r1, counts);
    else
      reference::render_rows(s.d, image, r0, r1, counts);
  } else {
    if (s.fk)
      s.fk->render_rows(s.f, image, r0, r1, counts);
    else
      reference::render_rows(s.f, image, r0, r1, counts);
  }
}

int RowShare::tiles() const {
  const int all = (ny + kTileRows - 1) / kTileRows;
  return all > rank ? (all - rank + ranks - 1) / ranks : 0;
}
int RowShare::tile_begin(int local) const { return (rank + local * ranks) * kTileRows; }
int RowShare::tile_end(int local) const { return std::min(ny, tile_begin(local) + kTileRows); }
int RowShare::rows() const {
  const int n = tiles();
  return n == 0 ? 0 : (n - 1) * kTileRows + (tile_end(n - 1) - tile_begin(n - 1));
}

RayCounts render_share(const RowEngine& engine, const RowShare& share, Image& image, int threads) {
  // run_tiles splits rows [0, tiles * kTileRows) into tiles of kTileRows: local tile r0 / kTileRows
  // is this rank's, mapped to its image rows.
  return run_tiles(share.tiles() * kTileRows, threads, [&](int r0, int, RayCounts& c) {
    const int local = r0 / kTileRows;
    engine.render_rows(image, share.tile_begin(local), share.tile_end(local), c);
  });
}

void pack_rows(const Image& image, const RowShare& share, std::vector<float>& out) {
  const std::size_t row = std::size_t(image.nx) * 3;
  out.resize(std::size_t(share.rows()) * row);
  float* dst = out.data();
  for (int t = 0; t < share.tiles(); ++t) {
    const std::size_t n = std::size_t(share.tile_end(t) - share.tile_begin(t)) * row;
    std::memcpy(dst, image.pixel(0, share.tile_begin(t)), n * sizeof(float));
    dst += n;
  }
}

void unpack_rows(const float* in, const RowShare& share, Image& image) {
  const std::size_t row = std::size_t(image.nx) * 3;
  for (int t = 0; t < share.tiles(); ++t) {
    const std::size_t n = std::size_t(share.tile_end(t) - share.tile_begin(t)) * row;
    std::memcpy(image.pixel(0, share.tile_begin(t)), in, n * sizeof(float));
    in += n;
  }
}

}  // namespace lancer::mpi
