// Which launcher started this process, from its environment: built in every lancer, so that a
// build without MPI can tell it runs under mpirun.
#include <algorithm>
#include <cstdlib>

#include "lancer/mpi.hpp"

namespace lancer::mpi {

namespace {
// A whole number >= 0 in `name`, or -1.
int env_int(const char* name) {
  const char* v = std::getenv(name);
  if (!v || !*v) return -1;
  char* end = nullptr;
  const long n = std::strtol(v, &end, 10);
  return (*end == '\0' && n >= 0 && n < (1L << 30)) ? int(n) : -1;
}
}  // namespace

Launch launch_from_environment() {
  // Open MPI, then the PMI of MPICH, Intel MPI and Slurm's srun.
  const char* pairs[][2] = {{"OMPI_COMM_WORLD_SIZE", "OMPI_COMM_WORLD_RANK"},
                            {"PMI_SIZE", "PMI_RANK"},
                            {"PMIX_SIZE", "PMIX_RANK"}};
  for (const auto& p : pairs) {
    const int size = env_int(p[0]);
    if (size >= 1) return {size, std::max(0, env_int(p[1])), p[0]};
  }
  return {};
}

}  // namespace lancer::mpi
