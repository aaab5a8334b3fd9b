// `mpirun -np N lancer render`: every rank loads and prepares, renders its interleaved tiles,
// rank 0 gathers and alone writes the file.
#include <algorithm>
#include <climits>

#include "comm.hpp"
#include "lancer/error.hpp"
#include "lancer/mpi.hpp"
#include "lancer/packet/api.hpp"
#include "rows.hpp"

namespace lancer::mpi {

bool built_with_mpi() { return true; }

Frame set_up(const std::function<Scene()>& load, const Asked& asked, int local_ranks,
             const std::function<void(const Scene&)>& check) {
  int rank = 0;
  MPI_Comm_rank(MPI_COMM_WORLD, &rank);
  Frame f;
  const double t0 = now();
  // Every rank loads: parsing is needed in every address space anyway, and a scene file is read
  // in milliseconds (docs/mpi.md has the figures).
  Fingerprint mine, first;
  agree(MPI_COMM_WORLD, [&] {
    f.scene = load();
    mine = fingerprint(asked, f.scene);
  });
  // Rank 0's against every rank's own: the lowest rank that differs says what.
  first = mine;
  MPI_Bcast(first.v, Fingerprint::kCount, MPI_INT64_T, 0, MPI_COMM_WORLD);
  agree(MPI_COMM_WORLD, [&] {
    const std::string differs = disagreement(mine, first);
    if (!differs.empty()) throw InputError(differs);
  });
  // auto precision: rank 0 chooses and says why; the others take its choice.
  int p = int(asked.precision);
  agree(MPI_COMM_WORLD, [&] {
    if (asked.threads < 0) throw InputError("--threads: must be >= 0 (0 = all cores)");
    if (rank != 0) return;
    if (check) check(f.scene);
    if (asked.precision == Precision::automatic) {
      const PrecisionChoice c = choose_precision(f.scene);
      p = int(c.precision);
      f.precision_reason = c.reason;
    }
  });
  MPI_Bcast(&p, 1, MPI_INT, 0, MPI_COMM_WORLD);
  f.precision = Precision(p);
  // auto width: the narrowest of the ranks' widest, so that ranks on different CPUs run the same
  // kernels (exact and double are the same bits at every width; fast is not). Asking the CPU
  // reads LANCER_MAX_WIDTH, which one rank may have wrong: inside the agreement.
  int widest = 0, w = asked.width;
  agree(MPI_COMM_WORLD, [&] {
    if (asked.width == 0) widest = resolve_width(0, f.precision);
  });
  if (asked.width == 0) MPI_Allreduce(&widest, &w, 1, MPI_INT, MPI_MIN, MPI_COMM_WORLD);
  agree(MPI_COMM_WORLD, [&] {
    f.width = resolve_width(w, f.precision);
    f.engine = std::make_unique<RowEngine>(f.scene, f.precision, f.width);
  });
  f.threads = asked.threads > 0 ? asked.threads
                                : std::max(1, hardware_threads() / std::max(1, local_ranks));
  f.load_seconds = now() - t0;
  return f;
}

void check_shapes(MPI_Comm comm, const Image& image, const RowShare& mine) {
  int rank = 0, size = 1;
  MPI_Comm_rank(comm, &rank);
  MPI_Comm_size(comm, &size);
  const int shape[3] = {image.nx, image.ny, mine.rows()};
  std::vector<int> all(std::size_t(size) * 3);
  MPI_Allgather(shape, 3, MPI_INT, all.data(), 3, MPI_INT, comm);
  for (int k = 0; k < size; ++k) {
    const int* s = &all[std::size_t(k) * 3];
    const int rows = RowShare{all[1], k, size}.rows();
    if (s[0] == all[0] && s[1] == all[1] && s[2] == rows) continue;
    // Every rank saw the same table: the lowest (rank 0) ends the job, the others wait for it.
    if (rank == 0)
      abort_job("rank " + std::to_string(k) + " holds a " + std::to_string(s[0]) + " x " +
                    std::to_string(s[1]) + " frame and " + std::to_string(s[2]) +
                    " rows, rank 0 expects " + std::to_string(all[0]) + " x " +
                    std::to_string(all[1]) + " and " + std::to_string(rows) + "; no output written",
                kStatusInternal);
    MPI_Barrier(comm);  // never returns: rank 0's MPI_Abort ends it
  }
}

double gather_image(MPI_Comm comm, const RowShare& mine, Image& image) {
  int rank = 0, size = 1;
  MPI_Comm_rank(comm, &rank);
  MPI_Comm_size(comm, &size);
  // Counted in rows, so that a frame of more than INT_MAX floats still gathers.
  MPI_Datatype row;
  MPI_Type_contiguous(image.nx * 3, MPI_FLOAT, &row);
  MPI_Type_commit(&row);
  std::vector<float> send;
  if (rank != 0) pack_rows(image, mine, send);
  std::vector<int> counts(size), displs(size);
  std::size_t total = 0;
  for (int k = 0; k < size; ++k) {
    counts[k] = k == 0 ? 0 : RowShare{image.ny, k, size}.rows();
    displs[k] = int(total);
    total += std::size_t(counts[k]);
  }
  std::vector<float> recv(rank == 0 ? total * std::size_t(image.nx) * 3 : 0);
  MPI_Gatherv(send.data(), rank == 0 ? 0 : mine.rows(), row, recv.data(), counts.data(),
              displs.data(), row, 0, comm);
  MPI_Type_free(&row);
  if (rank != 0) return 0;
  for (int k = 1; k < size; ++k)
    unpack_rows(recv.data() + std::size_t(displs[k]) * image.nx * 3, RowShare{image.ny, k, size},
                image);
  return double(recv.size()) * sizeof(float);
}

void render_command(
    const RenderJob& job,
    const std::function<void(const Scene&, const RenderResult&, const RankStats&)>& report) {
  Session mpi;
  Asked asked;
  asked.command = "render";
  asked.scene_path = job.scene_path;
  asked.precision = job.options.precision;
  asked.width = job.options.width;
  asked.threads = job.options.threads;
  const Frame f = set_up(job.load, asked, mpi.local_size,
                         [&](const Scene&) { check_output_path(job.output, job.scene_path); });
  const CameraSpec& cam = f.scene.camera;
  RenderResult res;
  res.structure = f.engine->structure();
  RankStats st;
  st.ranks = mpi.size;
  st.threads = f.threads;
  const RowShare share{cam.ny, mpi.rank, mpi.size};
  // Every rank holds a full frame and fills its rows: what the kernels' render_rows writes into.
  res.image = Image(cam.nx, cam.ny);
  double compute = 0, gather_start = 0, end = 0;
  try {
    MPI_Barrier(MPI_COMM_WORLD);
    const double start = now();
    res.rays = render_share(*f.engine, share, res.image, f.threads);
    compute = now() - start;
    quiet_barrier(MPI_COMM_WORLD);  // ranks done early sleep, not spin, beside ranks still busy
    check_shapes(MPI_COMM_WORLD, res.image, share);
    gather_start = now();
    st.gather_bytes = gather_image(MPI_COMM_WORLD, share, res.image);
    end = now();
    res.seconds = end - start;
  } catch (const std::bad_alloc&) {
    abort_job(mpi.rank ? "rank " + std::to_string(mpi.rank) + ": out of memory" : "out of memory",
              kStatusOutOfMemory);
  } catch (const std::exception& e) {
    abort_job("rank " + std::to_string(mpi.rank) + ": internal error: " + e.what(),
              kStatusInternal);
  }
  st.gather_seconds = end - gather_start;
  // The counts and times of every rank, summed or maxed onto rank 0.
  res.rays = sum_rays(MPI_COMM_WORLD, res.rays);
  double times[2] = {compute, f.load_seconds}, max_times[2];
  MPI_Reduce(times, max_times, 2, MPI_DOUBLE, MPI_MAX, 0, MPI_COMM_WORLD);
  MPI_Reduce(&compute, &st.compute_mean_seconds, 1, MPI_DOUBLE, MPI_SUM, 0, MPI_COMM_WORLD);
  st.compute_seconds = max_times[0];
  st.load_seconds = max_times[1];
  st.compute_mean_seconds /= mpi.size;
  res.width = f.width;
  res.threads = f.threads;
  res.isa = f.engine->isa();
  res.precision = f.precision;
  res.precision_reason = f.precision_reason;
  // Rank 0 writes while the others wait to learn whether it worked.
  agree(MPI_COMM_WORLD, [&] {
    if (mpi.rank == 0) write_image(res.image, job.output);
  });
  if (mpi.rank == 0 && report) report(f.scene, res, st);
}

}  // namespace lancer::mpi
