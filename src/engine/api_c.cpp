// The C API (include/lancer/lancer_c.h) over the C++ one: exceptions become -1 or NULL and the
// calling thread's last error.
#include <algorithm>
#include <limits>
#include <new>
#include <string>

#include "lancer/lancer.hpp"
#include "lancer/lancer_c.h"

struct lancer_scene {
  lancer::api::Scene scene;
};

namespace {

thread_local std::string last_error;

// Runs fn, returning `ok` or, on an exception, `failed` with the message kept.
template <class R, class Fn>
R guarded(R failed, Fn fn) {
  try {
    R r = fn();
    last_error.clear();
    return r;
  } catch (const lancer::InputError& e) {
    last_error = e.what();
  } catch (const std::bad_alloc&) {
    last_error = "out of memory";
  } catch (const std::exception& e) {
    last_error = std::string("internal error: ") + e.what();
  }
  return failed;
}

void need(const void* p, const char* what) {
  if (p == nullptr) throw lancer::InputError(std::string(what) + " is NULL");
}

lancer::Precision to_precision(int p) {
  switch (p) {
    case LANCER_PRECISION_AUTO:
      return lancer::Precision::automatic;
    case LANCER_PRECISION_EXACT:
      return lancer::Precision::exact;
    case LANCER_PRECISION_DOUBLE:
      return lancer::Precision::dbl;
    case LANCER_PRECISION_FAST:
      return lancer::Precision::fast;
  }
  throw lancer::InputError(
      "precision: must be LANCER_PRECISION_AUTO, _EXACT, _DOUBLE or _FAST, not " +
      std::to_string(p));
}

int from_precision(lancer::Precision p) {
  return p == lancer::Precision::exact ? LANCER_PRECISION_EXACT
         : p == lancer::Precision::dbl ? LANCER_PRECISION_DOUBLE
                                       : LANCER_PRECISION_FAST;
}

// "intersect: lane 3: ..." of the packet starting at ray `base` as "intersect: ray <base+3>: ...".
[[noreturn]] void rethrow_for_ray(const lancer::InputError& e, std::size_t base) {
  std::string m = e.what();
  const std::size_t at = m.find(": lane ");
  if (at != std::string::npos) {
    const std::size_t digits = at + 7, end = m.find(':', digits);
    if (end != std::string::npos) {
      const std::size_t lane = std::stoul(m.substr(digits, end - digits));
      m = m.substr(0, at) + ": ray " + std::to_string(base + lane) + m.substr(end);
    }
  }
  throw lancer::InputError(m);
}

// Rays [base, base + n) of the caller's arrays into a packet of 16 (n <= 16) and the valid mask.
void pack(std::size_t base, int n, const float* org, const float* dir, const float* tnear,
          const float* tfar, lancer::api::Ray16& r, int* valid) {
  for (int k = 0; k < 16; ++k) {
    const std::size_t i = base + std::size_t(std::min(k, n - 1));
    valid[k] = k < n ? -1 : 0;
    r.org_x[k] = org[3 * i], r.org_y[k] = org[3 * i + 1], r.org_z[k] = org[3 * i + 2];
    r.dir_x[k] = dir[3 * i], r.dir_y[k] = dir[3 * i + 1], r.dir_z[k] = dir[3 * i + 2];
    r.tnear[k] = tnear ? tnear[i] : 0.0f;
    r.tfar[k] = tfar ? tfar[i] : std::numeric_limits<float>::infinity();
    r.mask[k] = lancer::api::kAllObjects;
  }
}

}  // namespace

extern "C" {

const char* lancer_last_error(void) { return last_error.c_str(); }

const char* lancer_version(void) { return lancer::api::version(); }

lancer_scene* lancer_scene_load(const char* path, const lancer_options* options) {
  return guarded<lancer_scene*>(nullptr, [&] {
    need(path, "path");
    lancer::api::Options o;
    if (options) {
      o.precision = to_precision(options->precision);
      o.width = options->width;
      o.threads = options->threads;
    }
    return new lancer_scene{lancer::api::Scene::load(path, o)};
  });
}

void lancer_scene_release(lancer_scene* scene) { delete scene; }

int lancer_scene_info(const lancer_scene* scene, lancer_info* info) {
  return guarded(-1, [&] {
    need(scene, "scene"), need(info, "info");
    const lancer::api::Info& in = scene->scene.info();
    *info = {from_precision(in.precision),
             in.width,
             in.threads,
             in.nx,
             in.ny,
             in.supersample,
             in.objects};
    return 0;
  });
}

int lancer_render_rows(const lancer_scene* scene, int row_begin, int row_end, float* rgb,
                       size_t row_stride) {
  return guarded(-1, [&] {
    need(scene, "scene");
    scene->scene.render_rows(row_begin, row_end, rgb, row_stride);
    return 0;
  });
}

int lancer_intersect(const lancer_scene* scene, size_t count, const float* org, const float* dir,
                     const float* tnear, const float* tfar, float* t_out, int* id_out,
                     float* ng_out) {
  return guarded(-1, [&] {
    need(scene, "scene");
    if (count == 0) return 0;
    need(org, "org"), need(dir, "dir"), need(t_out, "t_out"), need(id_out, "id_out");
    for (std::size_t base = 0; base < count; base += 16) {
      const int n = int(std::min<std::size_t>(16, count - base));
      lancer::api::Ray16 r;
      lancer::api::Hit16 h;
      int valid[16];
      pack(base, n, org, dir, tnear, tfar, r, valid);
      try {
        scene->scene.intersect(valid, r, h);
      } catch (const lancer::InputError& e) {
        rethrow_for_ray(e, base);
      }
      for (int k = 0; k < n; ++k) {
        t_out[base + k] = h.t[k], id_out[base + k] = h.id[k];
        if (ng_out) {
          float* ng = ng_out + 3 * (base + k);
          ng[0] = h.ng_x[k], ng[1] = h.ng_y[k], ng[2] = h.ng_z[k];
        }
      }
    }
    return 0;
  });
}

int lancer_occluded(const lancer_scene* scene, size_t count, const float* org, const float* dir,
                    const float* tnear, const float* tfar, int* occluded_out) {
  return guarded(-1, [&] {
    need(scene, "scene");
    if (count == 0) return 0;
    need(org, "org"), need(dir, "dir"), need(occluded_out, "occluded_out");
    for (std::size_t base = 0; base < count; base += 16) {
      const int n = int(std::min<std::size_t>(16, count - base));
      lancer::api::Ray16 r;
      int valid[16], occ[16];
      pack(base, n, org, dir, tnear, tfar, r, valid);
      try {
        scene->scene.occluded(valid, r, occ);
      } catch (const lancer::InputError& e) {
        rethrow_for_ray(e, base);
      }
      std::copy(occ, occ + n, occluded_out + base);
    }
    return 0;
  });
}

}  // extern "C"
