// Traces every camera ray of a scene as packets of 16 world-space rays through lancer's library
// API, and checks the hits against lancer's own: the primary distances and object ids of the
// library's primary mode, bit for bit, occlusion against closest hit, and, given the PFM that
// `lancer render SCENE -o FILE.pfm` wrote, the rows rendered into this program's buffer.
//
//   trace_packets SCENE [RENDER.pfm]      exit 0 iff everything is identical
#include <cstdio>
#include <cstring>
#include <fstream>
#include <lancer/lancer.hpp>
#include <limits>
#include <string>
#include <vector>

namespace {

bool same_bits(float a, float b) { return std::memcmp(&a, &b, sizeof a) == 0; }

// A PFM as lancer writes it: "PF", nx ny, -1 (little-endian), rows bottom to top.
std::vector<float> read_pfm(const std::string& path, int nx, int ny) {
  std::ifstream in(path, std::ios::binary);
  std::string magic;
  int w = 0, h = 0;
  double scale = 0;
  in >> magic >> w >> h >> scale;
  in.get();
  if (!in || magic != "PF" || w != nx || h != ny || scale >= 0)
    throw lancer::InputError(path + ": not a little-endian " + std::to_string(nx) + "x" +
                             std::to_string(ny) + " colour PFM");
  std::vector<float> rgb(std::size_t(nx) * ny * 3);
  for (int j = ny - 1; j >= 0; --j)
    in.read(reinterpret_cast<char*>(rgb.data() + std::size_t(j) * nx * 3),
            std::streamsize(std::size_t(nx) * 3 * sizeof(float)));
  if (!in) throw lancer::InputError(path + ": truncated");
  return rgb;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2 || argc > 3) {
    std::fprintf(stderr, "usage: trace_packets SCENE [RENDER.pfm]\n");
    return 2;
  }
  try {
    lancer::api::Options options;
    options.precision = lancer::Precision::exact;  // the precision `lancer render` bits are for
    const lancer::api::Scene scene = lancer::api::Scene::load(argv[1], options);
    const lancer::api::Info& info = scene.info();
    std::printf("lancer %s: %s, %dx%d, %d objects, %s precision, widest kernel %d lanes (%s)\n",
                lancer::api::version(), argv[1], info.nx, info.ny, info.objects,
                lancer::to_string(info.precision), info.width, info.isa.c_str());

    // Every camera ray in world space, 16 per packet; per pixel the distances summed over its
    // sub-samples in lancer's order, and the object hit by sub-sample (0, 0).
    const int s = info.supersample;
    const std::size_t pixels = std::size_t(info.nx) * info.ny;
    std::vector<float> t(pixels, 0.0f);
    std::vector<int> id(pixels, -1);
    std::size_t rays = 0, occlusion_differs = 0;
    for (int j = 0; j < info.ny; ++j)
      for (int b = 0; b < s; ++b)
        for (int a = 0; a < s; ++a)
          for (int i0 = 0; i0 < info.nx; i0 += 16) {
            lancer::api::Ray16 r;
            lancer::api::Hit16 h;
            int valid[16], occluded[16];
            for (int k = 0; k < 16; ++k) {
              const int i = i0 + k < info.nx ? i0 + k : info.nx - 1;
              valid[k] = i0 + k < info.nx ? -1 : 0;
              float org[3], dir[3];
              scene.camera_ray(i, j, a, b, org, dir);
              r.org_x[k] = org[0], r.org_y[k] = org[1], r.org_z[k] = org[2];
              r.dir_x[k] = dir[0], r.dir_y[k] = dir[1], r.dir_z[k] = dir[2];
              r.tfar[k] = std::numeric_limits<float>::infinity();
              r.tnear[k] = 0, r.mask[k] = lancer::api::kAllObjects;
            }
            scene.intersect(valid, r, h);
            scene.occluded(valid, r, occluded);
            for (int k = 0; k < 16 && i0 + k < info.nx; ++k) {
              const std::size_t p = std::size_t(j) * info.nx + i0 + k;
              t[p] = t[p] + h.t[k];
              if (a == 0 && b == 0) id[p] = h.id[k];
              occlusion_differs += (occluded[k] != 0) != (h.id[k] >= 0);
              ++rays;
            }
          }

    const lancer::api::PrimaryHits lancer_hits = scene.primary_hits();
    std::size_t differ = 0, hits = 0;
    for (std::size_t p = 0; p < pixels; ++p) {
      differ += !same_bits(t[p], lancer_hits.t[p]) || id[p] != lancer_hits.id[p];
      hits += id[p] >= 0;
    }
    std::printf(
        "%zu camera rays in packets of 16: %zu pixels hit something; %zu of %zu pixels "
        "differ from lancer's primary hits; occlusion disagrees with closest hit on %zu\n",
        rays, hits, differ, pixels, occlusion_differs);
    bool ok = differ == 0 && occlusion_differs == 0;

    if (argc == 3) {
      // Rows rendered into this program's buffer, in bands of 32 rows, row stride with padding.
      const std::size_t stride = 3 * std::size_t(info.nx) + 4;
      std::vector<float> mine(stride * info.ny);
      for (int r0 = 0; r0 < info.ny; r0 += 32) {
        const int r1 = r0 + 32 < info.ny ? r0 + 32 : info.ny;
        scene.render_rows(r0, r1, mine.data() + std::size_t(r0) * stride, stride);
      }
      const std::vector<float> theirs = read_pfm(argv[2], info.nx, info.ny);
      std::size_t values_differ = 0;
      for (int j = 0; j < info.ny; ++j)
        for (int x = 0; x < 3 * info.nx; ++x)
          values_differ +=
              !same_bits(mine[j * stride + x], theirs[std::size_t(j) * info.nx * 3 + x]);
      std::printf("render_rows against %s: %zu values differ\n", argv[2], values_differ);
      ok = ok && values_differ == 0;
    }
    std::printf("%s\n", ok ? "identical" : "DIFFERENT");
    return ok ? 0 : 1;
  } catch (const lancer::InputError& e) {
    std::fprintf(stderr, "trace_packets: %s\n", e.what());
    return 2;
  }
}
