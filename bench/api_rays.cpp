// Rays from a file through the C++ library API alone: the reference side of the Python module's
// tests (tests/python: its intersect and occluded against intersect<16> and occluded<16>) and of
// its overhead benchmark (scripts/python-overhead.py).
//
//   lancer_api_rays SCENE RAYS OUT [--repeat R] [--precision P] [--width W] [--serve]
//
// RAYS: n rays as float32, origins (n x 3) then directions (n x 3), then tfar (n): what numpy's
// tofile() writes for three C-ordered arrays. The rays are laid into Ray16 packets (untimed),
// then intersect<16> over every packet is timed R times (1 by default), and occluded<16> once.
// OUT: t (n float32), id (n int32), normal (n x 3 float32), occluded (n int32).
// Prints {"rays": n, "seconds": [...]} (seconds of each timed intersect pass) on stdout.
// --serve: after the R passes, one more timed pass per line read on stdin, its wall and thread
// CPU seconds printed on a line of their own, until end of input; so that a caller alternates
// single passes of this program and of its own, side by side, however busy the machine.
#include <time.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <string>
#include <vector>

#include "lancer/lancer.hpp"

namespace {

std::vector<float> read_floats(const std::string& path) {
  std::ifstream in(path, std::ios::binary | std::ios::ate);
  if (!in) throw lancer::InputError(path + ": cannot open");
  const std::streamsize bytes = in.tellg();
  if (bytes % (7 * sizeof(float)) != 0)
    throw lancer::InputError(path + ": not 7 floats a ray (origins, directions, tfar)");
  std::vector<float> v(std::size_t(bytes) / sizeof(float));
  in.seekg(0);
  in.read(reinterpret_cast<char*>(v.data()), bytes);
  return v;
}

struct Args {
  std::string scene, rays, out;
  int repeat = 1;
  bool serve = false;
  lancer::api::Options options;
};

Args parse(int argc, char** argv) {
  if (argc < 4)
    throw lancer::InputError(
        "usage: lancer_api_rays SCENE RAYS OUT [--repeat R] [--precision P] [--width W]");
  Args a;
  a.scene = argv[1], a.rays = argv[2], a.out = argv[3];
  a.options.threads = 1;
  for (int k = 4; k < argc; k += 2) {
    const std::string opt = argv[k];
    if (opt == "--serve") {
      a.serve = true;
      --k;
      continue;
    }
    if (k + 1 >= argc) throw lancer::InputError(opt + ": needs a value");
    const std::string val = argv[k + 1];
    if (opt == "--repeat")
      a.repeat = std::max(1, std::atoi(val.c_str()));
    else if (opt == "--precision")
      a.options.precision = lancer::parse_precision(val, "--precision");
    else if (opt == "--width")
      a.options.width = std::atoi(val.c_str());
    else
      throw lancer::InputError(opt + ": unknown option");
  }
  return a;
}

int run(const Args& a) {
  const lancer::api::Scene scene = lancer::api::Scene::load(a.scene, a.options);
  const std::vector<float> v = read_floats(a.rays);
  const std::size_t n = v.size() / 7;
  const float* org = v.data();
  const float* dir = org + 3 * n;
  const float* tfar = dir + 3 * n;
  const std::size_t packets = (n + 15) / 16;
  std::vector<lancer::api::Ray16> rays(packets);
  std::vector<std::vector<int>> valid(packets, std::vector<int>(16, 0));
  for (std::size_t i = 0; i < n; ++i) {
    lancer::api::Ray16& p = rays[i / 16];
    const std::size_t k = i % 16;
    p.org_x[k] = org[3 * i], p.org_y[k] = org[3 * i + 1], p.org_z[k] = org[3 * i + 2];
    p.dir_x[k] = dir[3 * i], p.dir_y[k] = dir[3 * i + 1], p.dir_z[k] = dir[3 * i + 2];
    p.tnear[k] = 0, p.tfar[k] = tfar[i], p.mask[k] = lancer::api::kAllObjects;
    valid[i / 16][k] = -1;
  }
  // The last packet's idle lanes: a harmless copy of its first ray, inactive.
  for (std::size_t k = n % 16; n % 16 != 0 && k < 16; ++k) {
    lancer::api::Ray16& p = rays.back();
    p.org_x[k] = p.org_x[0], p.org_y[k] = p.org_y[0], p.org_z[k] = p.org_z[0];
    p.dir_x[k] = p.dir_x[0], p.dir_y[k] = p.dir_y[0], p.dir_z[k] = p.dir_z[0];
    p.tnear[k] = 0, p.tfar[k] = p.tfar[0], p.mask[k] = lancer::api::kAllObjects;
  }
  std::vector<lancer::api::Hit16> hits(packets);
  // Wall and this thread's CPU seconds of one pass over every packet (the CPU time leaves out
  // what a busy machine's other processes take while this one waits to run).
  double cpu = 0;
  const auto pass = [&] {
    timespec c0, c1;
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &c0);
    const auto t0 = std::chrono::steady_clock::now();
    for (std::size_t p = 0; p < packets; ++p)
      scene.intersect(p + 1 == packets && n % 16 ? valid[p].data() : nullptr, rays[p], hits[p]);
    const double wall =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &c1);
    cpu = double(c1.tv_sec - c0.tv_sec) + 1e-9 * double(c1.tv_nsec - c0.tv_nsec);
    return wall;
  };
  std::vector<double> seconds;
  for (int r = 0; r < a.repeat; ++r) seconds.push_back(pass());
  if (a.serve) {
    std::printf("ready\n");
    std::fflush(stdout);
    for (int c; (c = std::getchar()) != EOF;)
      if (c == '\n') {
        const double wall = pass();
        std::printf("%.9g %.9g\n", wall, cpu);
        std::fflush(stdout);
      }
  }
  std::vector<int> blocked(packets * 16);
  for (std::size_t p = 0; p < packets; ++p)
    scene.occluded(p + 1 == packets && n % 16 ? valid[p].data() : nullptr, rays[p],
                   blocked.data() + 16 * p);
  std::vector<float> t(n), normal(3 * n);
  std::vector<int> id(n), occ(n);
  for (std::size_t i = 0; i < n; ++i) {
    const lancer::api::Hit16& h = hits[i / 16];
    const std::size_t k = i % 16;
    t[i] = h.t[k], id[i] = h.id[k], occ[i] = blocked[i];
    normal[3 * i] = h.ng_x[k], normal[3 * i + 1] = h.ng_y[k], normal[3 * i + 2] = h.ng_z[k];
  }
  std::ofstream out(a.out, std::ios::binary);
  out.write(reinterpret_cast<const char*>(t.data()), std::streamsize(n * sizeof(float)));
  out.write(reinterpret_cast<const char*>(id.data()), std::streamsize(n * sizeof(int)));
  out.write(reinterpret_cast<const char*>(normal.data()), std::streamsize(3 * n * sizeof(float)));
  out.write(reinterpret_cast<const char*>(occ.data()), std::streamsize(n * sizeof(int)));
  if (!out.flush()) throw lancer::InputError(a.out + ": cannot write");
  std::printf("{\"rays\": %zu, \"seconds\": [", n);
  for (std::size_t k = 0; k < seconds.size(); ++k) std::printf("%s%.9g", k ? ", " : "", seconds[k]);
  std::printf("]}\n");
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    return run(parse(argc, argv));
  } catch (const std::exception& e) {
    std::fprintf(stderr, "lancer_api_rays: %s\n", e.what());
    return 2;
  }
}
