/* lancer's library API in C: a scene loaded from a file and prepared once, rows rendered into
 * the caller's buffer, closest-hit and occlusion queries on arrays of rays, and the error of the
 * last call that failed. A thin layer over include/lancer/lancer.hpp (docs/api.md); compiles as
 * C99 and C++.
 *
 *   lancer_scene* s = lancer_scene_load("scene.json", NULL);
 *   if (!s) { fprintf(stderr, "%s\n", lancer_last_error()); return 2; }
 *   lancer_intersect(s, n, org, dir, NULL, NULL, t, id, NULL);
 *   lancer_scene_release(s);
 */
#ifndef LANCER_C_H
#define LANCER_C_H

#include <stddef.h>

#include "lancer/export.hpp"

#ifdef __cplusplus
extern "C" {
#endif

/* As lancer::Precision; zero is automatic, so that zeroed options are the defaults. */
enum lancer_precision {
  LANCER_PRECISION_AUTO = 0,
  LANCER_PRECISION_EXACT = 1,
  LANCER_PRECISION_DOUBLE = 2,
  LANCER_PRECISION_FAST = 3
};

/* As lancer::api::Options; all zero: automatic precision, the widest width, all cores. */
typedef struct lancer_options {
  int precision; /* enum lancer_precision */
  int width;     /* 0 widest, 1 the reference, 4, 8, 16 (float) or 2, 4, 8 (double) */
  int threads;   /* of lancer_render_rows: 0 all cores, at most 4096 */
} lancer_options;

/* What a scene chose, as lancer::api::Info. */
typedef struct lancer_info {
  int precision; /* enum lancer_precision, never AUTO */
  int width;
  int threads;
  int nx, ny, supersample;
  int objects; /* ids 0 .. objects - 1: spheres, then planes, then triangles, meshes, cylinders */
} lancer_info;

typedef struct lancer_scene lancer_scene;

/* Every call that can fail returns NULL or -1 and sets the calling thread's last error, one line
 * naming the place ("s.json: objects[2].radius: must be > 0"); the same calls clear it when they
 * succeed. The string stays valid until this thread's next call. */
LANCER_API const char* lancer_last_error(void);
LANCER_API const char* lancer_version(void);

/* options may be NULL (the defaults). */
LANCER_API lancer_scene* lancer_scene_load(const char* path, const lancer_options* options);
LANCER_API void lancer_scene_release(lancer_scene* scene); /* NULL is fine */
LANCER_API int lancer_scene_info(const lancer_scene* scene, lancer_info* info);

/* Rows [row_begin, row_end) into rgb, row j at rgb + (j - row_begin) * row_stride floats, 3 per
 * pixel: the bits `lancer render` computes. */
LANCER_API int lancer_render_rows(const lancer_scene* scene, int row_begin, int row_end, float* rgb,
                                  size_t row_stride);

/* count rays, xyz interleaved: org[3 i .. 3 i + 2], dir likewise (unit length). tnear and tfar
 * may be NULL (0 and infinity). Closest hits: t_out[i] (infinity for a miss), id_out[i] (-1 for a
 * miss), ng_out[3 i ..] the geometric normal (NULL: not wanted). Rays are traced 16 at a time,
 * each group checked whole first: on an error (naming the ray: "intersect: ray 19: dir must be
 * unit length, ...") the groups before the failing one have been written, no later one. */
LANCER_API int lancer_intersect(const lancer_scene* scene, size_t count, const float* org,
                                const float* dir, const float* tnear, const float* tfar,
                                float* t_out, int* id_out, float* ng_out);
/* occluded_out[i]: 1 where something lies at max(tnear, epsilon) < t < tfar, else 0. */
LANCER_API int lancer_occluded(const lancer_scene* scene, size_t count, const float* org,
                               const float* dir, const float* tnear, const float* tfar,
                               int* occluded_out);

#ifdef __cplusplus
}
#endif

#endif /* LANCER_C_H */
