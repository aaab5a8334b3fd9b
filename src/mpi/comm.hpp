// The few MPI services the renderer and the bench share: the session, agreeing on failures so
// that every rank ends with one message, and waiting without spinning.
#pragma once

#include <mpi.h>

#include <functional>
#include <string>

#include "lancer/stats.hpp"

namespace lancer::mpi {

// MPI_Init_thread at construction (FUNNELED: only the main thread calls MPI, TBB's workers never
// do), MPI_Finalize at destruction.
class Session {
 public:
  Session();
  ~Session();
  Session(const Session&) = delete;
  Session& operator=(const Session&) = delete;
  int rank = 0, size = 1;
  int local_size = 1;  // ranks on this node (MPI_COMM_TYPE_SHARED)
};

// The CLI's exit statuses (docs/limits.md) for what agree() and abort_job() end a job with.
inline constexpr int kStatusBadInput = 2, kStatusOutOfMemory = 3, kStatusInternal = 5;

// A failure whose status and message are already decided (an error the CLI met on this rank
// before the session started): what agree() reports for it.
struct JobFailure {
  int status;
  std::string message;
};

// Runs fn on this rank, then every rank of `comm` learns whether it failed on any. If so, the
// lowest failing rank prints its one line (as the single-process CLI would: InputError exits 2,
// out of memory 3, anything else 5), and every rank finalizes and exits with the highest status.
// Collective: every rank of comm must call it at the same point, and fn must not call MPI (a rank
// whose fn throws would skip what the others wait in).
void agree(MPI_Comm comm, const std::function<void()>& fn);

// For failures past the point where ranks can agree (inside a collective): print and end the
// whole job through MPI_Abort with `status`.
[[noreturn]] void abort_job(const std::string& message, int status);

// A barrier that sleeps between polls instead of spinning: a rank that finished its rows (or sits
// out a bench configuration) must not take a core from a rank still rendering beside it.
void quiet_barrier(MPI_Comm comm);

double now();  // MPI_Wtime

// The rays of every rank by kind, summed onto rank 0 (other ranks get their own back).
RayCounts sum_rays(MPI_Comm comm, const RayCounts& mine);

}  // namespace lancer::mpi
