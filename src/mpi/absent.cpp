// The MPI entry points of a lancer built without MPI: under mpirun, N copies would each render
// the whole image and race to write the same file; say how to get the MPI build instead.
#include <cstdio>
#include <cstdlib>
#include <string>

#include "lancer/mpi.hpp"

namespace lancer::mpi {

namespace {
[[noreturn]] void refuse(const char* command) {
  const Launch l = launch_from_environment();
  // One message for the job, not one per process.
  if (l.rank == 0)
    std::fprintf(stderr,
                 "lancer: %s runs under an MPI launcher (%s=%d), but this lancer was built "
                 "without MPI: install Open MPI (apt-get install libopenmpi-dev openmpi-bin) and "
                 "rebuild (cmake -DLANCER_MPI=ON), or run it without mpirun\n",
                 command, l.variable ? l.variable : "?", l.size);
  std::exit(2);
}
}  // namespace

bool built_with_mpi() { return false; }

// No MPI to tell the other ranks with; they meet the same refusal in render_command or
// bench_command, so rank 0 alone says this one.
bool end_job(int status, const std::string& message) {
  const Launch l = launch_from_environment();
  if (l.size <= 1) return false;
  if (l.rank == 0) std::fprintf(stderr, "lancer: %s\n", message.c_str());
  std::exit(status);
}

void render_command(
    const RenderJob&,
    const std::function<void(const Scene&, const RenderResult&, const RankStats&)>&) {
  refuse("lancer render");
}

void bench_command(const BenchJob&) { refuse("lancer bench"); }

}  // namespace lancer::mpi
