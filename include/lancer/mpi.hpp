// lancer across MPI ranks (docs/mpi.md): `mpirun -np N lancer render|bench`. The CLI calls these
// when an MPI launcher started it; a build without MPI has the same entry points, which refuse
// with a message saying how to get MPI instead of letting N processes each write the output.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "lancer/bench.hpp"
#include "lancer/render.hpp"
#include "lancer/scene.hpp"

namespace lancer::mpi {

// What the environment says about the launcher (Open MPI's OMPI_COMM_WORLD_*, PMI_* of MPICH
// and Slurm, PMIX_RANK): size 1 when not launched by one. Works in every build.
struct Launch {
  int size = 1;
  int rank = 0;
  const char* variable = nullptr;  // the variable that told us, for messages
};
Launch launch_from_environment();

// True if this lancer was built with MPI.
bool built_with_mpi();

// The CLI's way out for an error under a launcher of more than one rank (an option, or an
// environment variable, that only some ranks were given): every rank must learn of it, or the
// others wait for this one forever. Ends the job with `message` printed once (by the lowest
// failing rank) and exit `status` on every rank; never returns then. Returns false when this
// process is not one of several ranks (or the job is over): the caller reports as usual.
bool end_job(int status, const std::string& message);

// `lancer render` across the ranks of MPI_COMM_WORLD. `load` runs on every rank (each loads and
// prepares the scene: docs/mpi.md says why); rank 0 alone checks and writes `output`. Rows are
// interleaved over the ranks in tiles, each rank renders its own on options.threads threads
// (0: the cores of its node shared among the ranks on that node), rank 0 gathers the pixels.
// `report` runs on rank 0 after the file is written. Any error on any rank ends every rank with
// one message (from the lowest failing rank) and the CLI's exit status; never returns then.
struct RenderJob {
  std::function<Scene()> load;
  std::string scene_path, output;
  RenderOptions options;  // precision may be automatic; width 0 = the widest every rank runs
};
struct RankStats {
  int ranks = 1;
  int threads = 1;                  // per rank
  double load_seconds = 0;          // load + prepare, slowest rank
  double compute_seconds = 0;       // rendering its rows, slowest rank
  double compute_mean_seconds = 0;  // mean over ranks: slowest / mean is the imbalance
  double gather_seconds = 0;        // the pixels' gather onto rank 0, after every rank finished
  double gather_bytes = 0;          // pixel bytes rank 0 received from the others
};
void render_command(
    const RenderJob& job,
    const std::function<void(const Scene&, const RenderResult&, const RankStats&)>& report);

// `lancer bench` across ranks: for k = 1..N ranks (the first k of MPI_COMM_WORLD; the others wait
// without spinning), full renders timed as a whole (barrier to gathered image on rank 0), with
// the compute, imbalance wait and gather times apart. Rank 0 prints the table or JSON.
struct BenchJob {
  std::function<Scene()> load;
  std::string scene_path;
  Precision precision = Precision::exact;
  int width = 0;                     // 0: the widest every rank runs
  std::vector<int> threads_list{1};  // threads per rank; each with 1..N ranks
  int repeat = 5;
  bool json = false;
};
void bench_command(const BenchJob& job);

}  // namespace lancer::mpi
