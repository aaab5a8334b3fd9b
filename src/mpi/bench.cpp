// `mpirun -np N lancer bench`: full renders on 1..N ranks (x each thread count), configurations
// interleaved within each repeat as lancer bench does, medians; the time of a render runs from a
// barrier to the image gathered on rank 0, with compute, imbalance and gather apart.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <nlohmann/json.hpp>

#include "comm.hpp"
#include "lancer/mpi.hpp"
#include "rows.hpp"

namespace lancer::mpi {

namespace {

struct Config {
  int ranks = 1, threads = 1;
  MPI_Comm comm = MPI_COMM_NULL;  // the first `ranks` ranks; null on the others
  // Per render, one entry per repeat (rank 0 only).
  std::vector<double> seconds, compute_max, compute_mean, gather, cpu;
  double gather_bytes = 0;
};

struct Timed {
  double seconds = 0, compute_max = 0, compute_mean = 0, gather = 0, gather_bytes = 0;
  double cpu = 0;  // CPU seconds of rendering, summed over the ranks (every thread)
  RayCounts rays;
};

// The CPU time of this process, every thread: on a shared machine the wall time of a rank counts
// the other processes' turns too, its CPU time only its own work.
double process_cpu_seconds() {
  timespec ts{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
  return double(ts.tv_sec) + ts.tv_nsec * 1e-9;
}

// `reps` renders of the frame on c's ranks. Collective over c.comm.
Timed run(const Frame& f, Config& c, Image& image, int reps) {
  int rank = 0;
  MPI_Comm_rank(c.comm, &rank);
  const RowShare share{f.scene.camera.ny, rank, c.ranks};
  Timed t;
  double compute = 0, cpu = 0;
  check_shapes(c.comm, image, share);
  MPI_Barrier(c.comm);
  const double start = now();
  for (int i = 0; i < reps; ++i) {
    const double r0 = now(), c0 = process_cpu_seconds();
    t.rays = render_share(*f.engine, share, image, c.threads);
    compute += now() - r0;
    cpu += process_cpu_seconds() - c0;
    quiet_barrier(c.comm);
    const double g0 = now();
    t.gather_bytes = gather_image(c.comm, share, image);
    t.gather += now() - g0;
  }
  t.seconds = (now() - start) / reps;
  t.gather /= reps;
  compute /= reps;
  cpu /= reps;
  MPI_Reduce(&cpu, &t.cpu, 1, MPI_DOUBLE, MPI_SUM, 0, c.comm);
  MPI_Reduce(&compute, &t.compute_max, 1, MPI_DOUBLE, MPI_MAX, 0, c.comm);
  MPI_Reduce(&compute, &t.compute_mean, 1, MPI_DOUBLE, MPI_SUM, 0, c.comm);
  t.compute_mean /= c.ranks;
  t.rays = sum_rays(c.comm, t.rays);
  return t;
}

double median_of(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.empty() ? 0 : v[v.size() / 2] * 0.5 + v[(v.size() - 1) / 2] * 0.5;
}

}  // namespace

void bench_command(const BenchJob& job) {
  Session mpi;
  Asked asked;
  asked.command = "bench";
  asked.scene_path = job.scene_path;
  asked.precision = job.precision;
  asked.width = job.width;
  asked.threads = job.threads_list.front();
  asked.bench_threads = job.threads_list;
  asked.bench_repeat = job.repeat;
  const Frame f = set_up(job.load, asked, mpi.local_size, nullptr);
  std::vector<Config> configs;
  for (int threads : job.threads_list)
    for (int k = 1; k <= mpi.size; ++k) {
      Config c;
      c.ranks = k, c.threads = threads;
      configs.push_back(c);
    }
  // One communicator per rank count, shared by the thread counts.
  std::vector<MPI_Comm> comms(mpi.size + 1, MPI_COMM_NULL);
  for (int k = 1; k <= mpi.size; ++k)
    MPI_Comm_split(MPI_COMM_WORLD, mpi.rank < k ? 0 : MPI_UNDEFINED, mpi.rank, &comms[k]);
  for (Config& c : configs) c.comm = comms[c.ranks];
  Image image(f.scene.camera.nx, f.scene.camera.ny);

  // Warm-up of every configuration; the slowest (one rank) sets how many renders make a timed
  // run last about 50 ms, the same count for all.
  RayCounts rays;
  double one_rank = 0;
  for (Config& c : configs) {
    quiet_barrier(MPI_COMM_WORLD);
    if (c.comm == MPI_COMM_NULL) continue;
    const Timed t = run(f, c, image, 1);
    if (mpi.rank == 0) {
      rays = t.rays;
      one_rank = std::max(one_rank, t.seconds);
    }
  }
  int reps = one_rank > 0 ? int(std::ceil(0.05 / one_rank)) : 1;
  MPI_Bcast(&reps, 1, MPI_INT, 0, MPI_COMM_WORLD);
  for (int r = 0; r < job.repeat; ++r)
    for (Config& c : configs) {
      quiet_barrier(MPI_COMM_WORLD);  // ranks sitting this one out sleep
      if (c.comm == MPI_COMM_NULL) continue;
      const Timed t = run(f, c, image, reps);
      if (mpi.rank != 0) continue;
      c.seconds.push_back(t.seconds);
      c.compute_max.push_back(t.compute_max);
      c.compute_mean.push_back(t.compute_mean);
      c.gather.push_back(t.gather);
      c.cpu.push_back(t.cpu);
      c.gather_bytes = t.gather_bytes;
    }
  for (int k = 1; k <= mpi.size; ++k)
    if (comms[k] != MPI_COMM_NULL) MPI_Comm_free(&comms[k]);
  if (mpi.rank != 0) return;

  const double total = double(rays.total());
  auto mrays = [&](const Config& c) { return total / median_of(c.seconds) * 1e-6; };
  auto base = [&](const Config& c) {
    for (const Config& b : configs)
      if (b.ranks == 1 && b.threads == c.threads) return mrays(b);
    return 0.0;
  };
  auto cpu_base = [&](const Config& c) {
    for (const Config& b : configs)
      if (b.ranks == 1 && b.threads == c.threads) return median_of(b.cpu);
    return 0.0;
  };
  const char* isa = f.engine->isa();
  if (job.json) {
    nlohmann::json out;
    out["scene"] = job.scene_path;
    out["ranks_in_job"] = mpi.size;
    out["results"] = nlohmann::json::array();
    for (const Config& c : configs)
      out["results"].push_back({{"engine", "lancer"},
                                {"mode", "full"},
                                {"width", f.width},
                                {"isa", isa},
                                {"precision", to_string(f.precision)},
                                {"ranks", c.ranks},
                                {"threads", c.threads},
                                {"rays", rays.total()},
                                {"seconds", median_of(c.seconds)},
                                {"mrays_per_s", mrays(c)},
                                {"efficiency", mrays(c) / (c.ranks * base(c))},
                                {"compute_seconds", median_of(c.compute_max)},
                                {"compute_mean_seconds", median_of(c.compute_mean)},
                                {"compute_cpu_seconds", median_of(c.cpu)},
                                {"cpu_efficiency", cpu_base(c) / median_of(c.cpu)},
                                {"comm_seconds", median_of(c.gather)},
                                {"gather_bytes", c.gather_bytes}});
    std::printf("%s\n", out.dump(2).c_str());
    return;
  }
  std::printf(
      "lancer bench across MPI ranks: %s, full renders, %s precision, width %d (%s), median of %d "
      "runs of %d renders, configurations interleaved\n",
      job.scene_path.c_str(), to_string(f.precision), f.width, isa, job.repeat, reps);
  std::printf("  %5s %7s %12s %10s %10s %10s %10s %9s %10s %9s %10s %8s\n", "ranks", "threads",
              "rays", "seconds", "Mrays/s", "efficiency", "compute", "imbalance", "comm",
              "gather MB", "CPU s", "CPU eff");
  for (const Config& c : configs) {
    const double cm = median_of(c.compute_mean);
    std::printf(
        "  %5d %7d %12llu %10.5f %10.2f %9.1f%% %10.5f %8.2fx %10.5f %9.2f %10.5f %7.1f%%\n",
        c.ranks, c.threads, (unsigned long long)rays.total(), median_of(c.seconds), mrays(c),
        100 * mrays(c) / (c.ranks * base(c)), median_of(c.compute_max),
        cm > 0 ? median_of(c.compute_max) / cm : 1.0, median_of(c.gather), c.gather_bytes * 1e-6,
        median_of(c.cpu), 100 * cpu_base(c) / median_of(c.cpu));
  }
  std::printf(
      "  efficiency: Mrays/s / (ranks x the 1-rank Mrays/s at the same threads). compute: the "
      "slowest rank's rendering;\n  imbalance: slowest / mean rank. comm: the gather onto rank 0 "
      "after every rank finished (the time in communication).\n  CPU s: CPU "
      "seconds of rendering summed over the ranks; CPU eff: the 1-rank CPU s over this (work "
      "added by splitting,\n  free of the other processes' turns on a shared machine).\n");
}

}  // namespace lancer::mpi
