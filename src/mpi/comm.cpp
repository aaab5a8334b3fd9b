#include "comm.hpp"

#include <unistd.h>

#include <chrono>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <new>
#include <stdexcept>
#include <thread>

#include "lancer/error.hpp"
#include "lancer/mpi.hpp"
#include "lancer/text.hpp"

namespace lancer::mpi {

namespace {
void (*previous_term)(int) = nullptr;
// Set once this rank has said why the job ends: mpirun's SIGTERM, which can reach rank 0 while it
// still exits with that message, then adds no second line.
volatile std::sig_atomic_t said_why = 0;

// mpirun ends the surviving ranks with SIGTERM when one dies: rank 0 says so (mpirun -q says
// nothing itself), then the CLI's handler removes any temporary output and the signal ends it.
extern "C" void on_term(int sig) {
  static const char message[] =
      "lancer: the MPI job was ended (a rank died or the job was cancelled); no output written\n";
  if (!said_why) {
    ssize_t ignored = write(STDERR_FILENO, message, sizeof message - 1);
    (void)ignored;
  }
  if (previous_term && previous_term != SIG_IGN && previous_term != SIG_DFL) {
    previous_term(sig);
  } else {
    std::signal(sig, SIG_DFL);
    std::raise(sig);
  }
}
}  // namespace

Session::Session() {
  // Before MPI_Init, which takes seconds on a loaded machine: the rank from the environment.
  // A SIGTERM ignored at start stays ignored (main() left it so).
  if (launch_from_environment().rank == 0) {
    previous_term = std::signal(SIGTERM, on_term);
    if (previous_term == SIG_IGN) std::signal(SIGTERM, SIG_IGN);
  }
  int initialized = 0;
  MPI_Initialized(&initialized);
  if (!initialized) {
    int provided = 0;
    MPI_Init_thread(nullptr, nullptr, MPI_THREAD_FUNNELED, &provided);
  }
  // Errors in MPI calls end the job (the default), which is what a lost rank should do.
  MPI_Comm_rank(MPI_COMM_WORLD, &rank);
  MPI_Comm_size(MPI_COMM_WORLD, &size);
  MPI_Comm node;
  MPI_Comm_split_type(MPI_COMM_WORLD, MPI_COMM_TYPE_SHARED, rank, MPI_INFO_NULL, &node);
  MPI_Comm_size(node, &local_size);
  MPI_Comm_free(&node);
}

Session::~Session() {
  int finalized = 0;
  MPI_Finalized(&finalized);
  if (!finalized) MPI_Finalize();
}

void agree(MPI_Comm comm, const std::function<void()>& fn) {
  int status = 0;
  std::string message;
  try {
    fn();
  } catch (const JobFailure& e) {
    status = e.status, message = e.message;
  } catch (const InputError& e) {
    status = kStatusBadInput, message = e.what();
  } catch (const std::bad_alloc&) {
    status = kStatusOutOfMemory, message = "out of memory (limits: docs/limits.md)";
  } catch (const std::length_error& e) {
    status = kStatusOutOfMemory, message = std::string("out of memory: ") + e.what();
  } catch (const std::exception& e) {
    status = kStatusInternal, message = std::string("internal error: ") + e.what();
  }
  int rank = 0, size = 1;
  MPI_Comm_rank(comm, &rank);
  MPI_Comm_size(comm, &size);
  quiet_barrier(comm);  // ranks waiting for rank 0's write (or load) sleep, not spin, beside it
  int mine[2] = {status, status ? -rank : -size}, all[2];
  // Max of the status and of -rank: the highest status and the lowest failing rank.
  MPI_Allreduce(mine, all, 2, MPI_INT, MPI_MAX, comm);
  if (all[0] == 0) return;
  said_why = 1;  // the failing rank says it below; the others have nothing to add
  if (-all[1] == rank) {
    // Rank 0's message is the single-process one; another rank's says where it came from.
    if (rank == 0)
      std::fprintf(stderr, "lancer: %s\n", message.c_str());
    else
      std::fprintf(stderr, "lancer: rank %d: %s\n", rank, message.c_str());
  }
  std::fflush(stdout);
  std::fflush(stderr);
  MPI_Finalize();
  std::exit(all[0]);
}

bool end_job(int status, const std::string& message) {
  if (launch_from_environment().size <= 1) return false;
  int initialized = 0, finalized = 0;
  MPI_Initialized(&initialized);
  MPI_Finalized(&finalized);
  if (finalized) return false;  // past the job's end (rank 0's report): no peer is waiting
  if (initialized) {
    // Escaped the session's agreements: the peers may wait in any collective, so end them all.
    int rank = 0;
    MPI_Comm_rank(MPI_COMM_WORLD, &rank);
    abort_job(rank ? "rank " + std::to_string(rank) + ": " + message : message, status);
  }
  // Before render_command or bench_command began: the same first steps as theirs (the session,
  // then the load's agreement), so that every rank learns of it and ends with one line.
  Session session;
  agree(MPI_COMM_WORLD, [&] { throw JobFailure{status, message}; });
  return false;  // not reached: agree() exits
}

void abort_job(const std::string& message, int status) {
  said_why = 1;
  std::fprintf(stderr, "lancer: %s\n", escape_controls(message).c_str());
  std::fflush(stderr);
  MPI_Abort(MPI_COMM_WORLD, status);
  std::abort();  // not reached
}

void quiet_barrier(MPI_Comm comm) {
  MPI_Request request;
  MPI_Ibarrier(comm, &request);
  for (int done = 0;;) {
    MPI_Test(&request, &done, MPI_STATUS_IGNORE);
    if (done) return;
    std::this_thread::sleep_for(std::chrono::microseconds(50));
  }
}

double now() { return MPI_Wtime(); }

RayCounts sum_rays(MPI_Comm comm, const RayCounts& mine) {
  std::uint64_t rays[4] = {mine.camera, mine.shadow, mine.reflected, mine.refracted}, sum[4] = {};
  MPI_Reduce(rays, sum, 4, MPI_UINT64_T, MPI_SUM, 0, comm);
  int rank = 0;
  MPI_Comm_rank(comm, &rank);
  if (rank != 0) return mine;
  RayCounts all = mine;
  all.camera = sum[0], all.shadow = sum[1], all.reflected = sum[2], all.refracted = sum[3];
  return all;
}

}  // namespace lancer::mpi
