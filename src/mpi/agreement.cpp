#include "agreement.hpp"

#include <cinttypes>
#include <cstdio>
#include <fstream>

#include "lancer/error.hpp"
#include "lancer/text.hpp"

namespace lancer::mpi {

namespace {
constexpr std::uint64_t kFnvOffset = 14695981039346656037ull, kFnvPrime = 1099511628211ull;

std::uint64_t fnv(std::uint64_t h, const unsigned char* p, std::size_t n) {
  for (std::size_t i = 0; i < n; ++i) h = (h ^ p[i]) * kFnvPrime;
  return h;
}

std::string shown(Fingerprint::Field field, const Fingerprint& f) {
  const std::int64_t v = f.v[field];
  char text[96];
  switch (field) {
    case Fingerprint::kCommand:
      return v == 1 ? "render" : v == 2 ? "bench" : "?";
    case Fingerprint::kSceneBytes:
    case Fingerprint::kSceneSize:
      std::snprintf(text, sizeof text, "%" PRId64 " bytes, FNV-1a %016" PRIx64,
                    f.v[Fingerprint::kSceneSize], std::uint64_t(f.v[Fingerprint::kSceneBytes]));
      return text;
    case Fingerprint::kNx:
    case Fingerprint::kNy:
      std::snprintf(text, sizeof text, "%" PRId64 " x %" PRId64, f.v[Fingerprint::kNx],
                    f.v[Fingerprint::kNy]);
      return text;
    case Fingerprint::kPrecision:
      return v >= 0 && v <= int(Precision::automatic) ? to_string(Precision(v)) : "?";
    case Fingerprint::kWidth:
      return v == 0 ? "auto" : std::to_string(v);
    case Fingerprint::kBenchRounds:
      std::snprintf(text, sizeof text, "%016" PRIx64, std::uint64_t(v));
      return text;
    default:
      return std::to_string(v);
  }
}

const char* name_of(Fingerprint::Field field) {
  switch (field) {
    case Fingerprint::kCommand:
      return "the command";
    case Fingerprint::kSceneBytes:
    case Fingerprint::kSceneSize:
      return "the scene file's bytes (a stale copy on one node?)";
    case Fingerprint::kNx:
    case Fingerprint::kNy:
      return "the image size (--resolution or the scene's)";
    case Fingerprint::kSupersample:
      return "the sub-samples per axis (--supersample or the scene's)";
    case Fingerprint::kPrecision:
      return "--precision";
    case Fingerprint::kWidth:
      return "--width";
    case Fingerprint::kBenchRounds:
      return "bench's --threads or --repeat (their hash)";
    default:
      return "?";
  }
}
}  // namespace

std::uint64_t hash_file(const std::string& path, std::int64_t& bytes) {
  std::ifstream in(path, std::ios::binary);
  if (!in)
    throw InputError(shown_path(path) +
                     ": cannot be read to check that every rank has the same file");
  std::uint64_t h = kFnvOffset;
  bytes = 0;
  std::vector<char> buf(1 << 20);
  while (in) {
    in.read(buf.data(), std::streamsize(buf.size()));
    const std::size_t n = std::size_t(in.gcount());
    h = fnv(h, reinterpret_cast<const unsigned char*>(buf.data()), n);
    bytes += std::int64_t(n);
  }
  if (in.bad())
    throw InputError(shown_path(path) + ": read failed while checking it against the other ranks");
  return h;
}

Fingerprint fingerprint(const Asked& asked, const Scene& scene) {
  Fingerprint f;
  f.v[Fingerprint::kCommand] = asked.command == "render" ? 1 : asked.command == "bench" ? 2 : 0;
  f.v[Fingerprint::kSceneBytes] =
      std::int64_t(hash_file(asked.scene_path, f.v[Fingerprint::kSceneSize]));
  f.v[Fingerprint::kNx] = scene.camera.nx;
  f.v[Fingerprint::kNy] = scene.camera.ny;
  f.v[Fingerprint::kSupersample] = scene.supersample;
  f.v[Fingerprint::kPrecision] = int(asked.precision);
  f.v[Fingerprint::kWidth] = asked.width;
  // Bench's rounds: ranks looping over different thread lists or repeats would wait in
  // collectives the others never reach.
  std::uint64_t h = kFnvOffset;
  for (const int t : asked.bench_threads) {
    const std::int64_t x = t;
    h = fnv(h, reinterpret_cast<const unsigned char*>(&x), sizeof x);
  }
  const std::int64_t repeat = asked.bench_repeat;
  h = fnv(h, reinterpret_cast<const unsigned char*>(&repeat), sizeof repeat);
  f.v[Fingerprint::kBenchRounds] = std::int64_t(h);
  return f;
}

std::string disagreement(const Fingerprint& mine, const Fingerprint& first) {
  for (int i = 0; i < Fingerprint::kCount; ++i) {
    const auto field = Fingerprint::Field(i);
    if (mine.v[i] == first.v[i]) continue;
    return std::string("the ranks disagree on ") + name_of(field) + ": " + shown(field, mine) +
           " here, " + shown(field, first) +
           " on rank 0 (every rank must run the same command on the same scene with the same "
           "options); no output written";
  }
  return "";
}

}  // namespace lancer::mpi
