// What one rank renders: the scene prepared once at the precision and width the ranks agreed on,
// and its share of the rows, tiles of kTileRows interleaved over the ranks (tile t to rank
// t % ranks) so that costly regions (a glass sphere, the horizon) fall on every rank alike.
// This is the seam to the library's scene handle: RowEngine is the only code here that knows how
// rows are rendered.
#pragma once

#include <memory>
#include <vector>

#include "lancer/image.hpp"
#include "lancer/precision.hpp"
#include "lancer/render.hpp"
#include "lancer/scene.hpp"
#include "lancer/stats.hpp"

namespace lancer::mpi {

class RowEngine {
 public:
  // precision resolved (not automatic), width resolved for it (1 = the reference).
  RowEngine(const Scene& scene, Precision precision, int width);
  ~RowEngine();
  RowEngine(const RowEngine&) = delete;
  RowEngine& operator=(const RowEngine&) = delete;
  // Renders rows [r0, r1) into `image` (the full frame), as render() renders them.
  void render_rows(Image& image, int r0, int r1, RayCounts& counts) const;
  const char* isa() const;
  StructureInfo structure() const;  // what prepare built over the spheres

 private:
  struct State;
  std::unique_ptr<State> state_;
};

// One rank's share of an image ny rows high.
struct RowShare {
  int ny = 0, rank = 0, ranks = 1;
  int tiles() const;                // tiles this rank renders
  int rows() const;                 // rows in them
  int tile_begin(int local) const;  // first image row of this rank's local-th tile
  int tile_end(int local) const;
};

// Renders a share's rows into `image` on `threads` threads (TBB tiles, as render()).
RayCounts render_share(const RowEngine& engine, const RowShare& share, Image& image, int threads);

// The share's rows, in order, to a contiguous buffer (nx * 3 floats a row) and back.
void pack_rows(const Image& image, const RowShare& share, std::vector<float>& out);
void unpack_rows(const float* in, const RowShare& share, Image& image);

}  // namespace lancer::mpi

#include <mpi.h>

#include <functional>
#include <string>

#include "agreement.hpp"

namespace lancer::mpi {

// Everything a rank needs before rendering, agreed over MPI_COMM_WORLD: the scene every rank
// loaded, the precision rank 0 resolved (auto), the width (requested, or the widest every rank
// runs), threads per rank (0: this node's cores over its ranks) and the prepared engine.
struct Frame {
  Scene scene;
  Precision precision = Precision::exact;
  std::string precision_reason;
  int width = 1, threads = 1;
  std::unique_ptr<RowEngine> engine;
  double load_seconds = 0;  // load + prepare on this rank
};
// Errors on any rank end the job through agree() (comm.hpp), and so do ranks that were asked
// different things (agreement.hpp). `check` runs on rank 0 after the load, before anything is
// rendered (the output path).
Frame set_up(const std::function<Scene()>& load, const Asked& asked, int local_ranks,
             const std::function<void(const Scene&)>& check);

// Every rank's frame and share as rank 0 expects them, checked before a byte of pixels moves
// (once per frame shape, outside timed loops): rank 0 sizes its receives from its own frame and
// never from a peer's word. After the fingerprint agreement a difference here is a bug, not an
// input error: rank 0 ends the job through MPI_Abort with one line. Collective over comm.
void check_shapes(MPI_Comm comm, const Image& image, const RowShare& mine);

// Gathers every rank's share of `image` onto rank 0 of `comm` (whose ranks hold the shares
// rank = 0..size-1 of the same frame, as check_shapes() checked). Returns the bytes rank 0
// received.
double gather_image(MPI_Comm comm, const RowShare& mine, Image& image);

}  // namespace lancer::mpi
