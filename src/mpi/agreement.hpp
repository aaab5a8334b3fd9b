// What every rank of a job must agree on before it renders: the same command on the same scene
// file's bytes, the same image (size and samples) and the same requested precision and width,
// and, for bench, the same rounds. Ranks given different ones (a stale copy of the scene on one
// node, an option passed to one rank only) would render different frames into one image, or
// wait in collectives of different shapes: the job ends with one line naming what differs.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "lancer/precision.hpp"
#include "lancer/scene.hpp"

namespace lancer::mpi {

// What this rank was asked before the ranks agree on it.
struct Asked {
  std::string command;  // "render" or "bench"
  std::string scene_path;
  Precision precision = Precision::automatic;
  int width = 0;  // 0 = auto
  int threads = 0;
  std::vector<int> bench_threads;  // bench only: the thread counts and repeats of its rounds
  int bench_repeat = 0;
};

// A fixed-size record of what must agree, as 64-bit integers (one MPI_Bcast).
struct Fingerprint {
  enum Field {
    kCommand,
    kSceneBytes,
    kSceneSize,
    kNx,
    kNy,
    kSupersample,
    kPrecision,
    kWidth,
    kBenchRounds,
    kCount
  };
  std::int64_t v[kCount] = {};
};

// FNV-1a (64 bits) of a file's bytes and their count; throws InputError naming the file if it
// cannot be read. A check that the ranks read the same bytes, not a defence against forgery.
std::uint64_t hash_file(const std::string& path, std::int64_t& bytes);

// This rank's fingerprint: what it was asked and the scene it loaded (after the overrides).
Fingerprint fingerprint(const Asked& asked, const Scene& scene);

// Empty if `mine` equals rank 0's `first`, else one line saying what differs on this rank.
std::string disagreement(const Fingerprint& mine, const Fingerprint& first);

}  // namespace lancer::mpi
