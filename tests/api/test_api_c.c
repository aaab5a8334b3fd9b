/* The C API (include/lancer/lancer_c.h), compiled as C: loading, info, rows, closest hits and
 * occlusion on arrays (spheres and planes, then cylinders), and errors through lancer_last_error.
 * Exit status 0 iff every check holds; each failure prints one line. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "lancer/lancer_c.h"

static int failures = 0;

#define CHECK(cond)                                                      \
  do {                                                                   \
    if (!(cond)) {                                                       \
      fprintf(stderr, "test_api_c.c:%d: failed: %s\n", __LINE__, #cond); \
      ++failures;                                                        \
    }                                                                    \
  } while (0)

int main(void) {
  lancer_options opt;
  memset(&opt, 0, sizeof opt);
  opt.precision = LANCER_PRECISION_EXACT;
  opt.threads = 1;

  CHECK(lancer_scene_load("/nonexistent/s.json", NULL) == NULL);
  CHECK(strcmp(lancer_last_error(), "/nonexistent/s.json: cannot open scene file") == 0);
  opt.threads = 5000;
  CHECK(lancer_scene_load(LANCER_SOURCE_DIR "/scenes/lorenzi-shadows.json", &opt) == NULL);
  CHECK(strstr(lancer_last_error(), "threads: must be from 0 (all cores) to 4096") != NULL);
  opt.threads = 1;
  opt.precision = 9;
  CHECK(lancer_scene_load(LANCER_SOURCE_DIR "/scenes/lorenzi-shadows.json", &opt) == NULL);
  opt.precision = LANCER_PRECISION_EXACT;

  /* Spheres 0-2 (sphere 1 at (-1, -1, -3), radius 1), the plane y = -2 (id 3). */
  lancer_scene* s = lancer_scene_load(LANCER_SOURCE_DIR "/scenes/lorenzi-shadows.json", &opt);
  CHECK(s != NULL);
  if (!s) {
    fprintf(stderr, "%s\n", lancer_last_error());
    return 1;
  }
  CHECK(strcmp(lancer_last_error(), "") == 0);
  lancer_info info;
  CHECK(lancer_scene_info(s, &info) == 0);
  CHECK(info.nx == 300 && info.ny == 200 && info.objects == 4);
  CHECK(info.precision == LANCER_PRECISION_EXACT && info.threads == 1);
  CHECK(strlen(lancer_version()) > 0);

  /* Rows 100-101, with padding between rows that must stay untouched. */
  const size_t stride = 3 * 300 + 5;
  float* rgb = (float*)malloc(2 * stride * sizeof(float));
  for (size_t i = 0; i < 2 * stride; ++i) rgb[i] = -7.0f;
  CHECK(lancer_render_rows(s, 100, 102, rgb, stride) == 0);
  int lit = 0;
  for (int x = 0; x < 3 * 300; ++x) lit += rgb[x] > 0 && rgb[stride + x] > 0;
  CHECK(lit > 800);
  CHECK(rgb[3 * 300] == -7.0f && rgb[stride + 3 * 300] == -7.0f);
  CHECK(lancer_render_rows(s, 0, 201, rgb, stride) == -1);
  CHECK(strcmp(lancer_last_error(), "render_rows: rows [0, 201) outside [0, 200)") == 0);
  free(rgb);

  /* 20 rays from the camera: even ones at sphere 1's centre, odd ones straight up (a miss);
   * ray 18 starts inside sphere 1 by tnear, so its hit is the far side. */
  enum { n = 20 };
  float org[3 * n], dir[3 * n], tnear[n], tfar[n], t[n], ng[3 * n];
  int id[n], occ[n];
  const float len = sqrtf(66.0f);
  for (int i = 0; i < n; ++i) {
    org[3 * i] = 0, org[3 * i + 1] = 0, org[3 * i + 2] = 5;
    if (i % 2 == 0)
      dir[3 * i] = -1 / len, dir[3 * i + 1] = -1 / len, dir[3 * i + 2] = -8 / len;
    else
      dir[3 * i] = 0, dir[3 * i + 1] = 1, dir[3 * i + 2] = 0;
    tnear[i] = i == 18 ? len : 0;
    tfar[i] = INFINITY;
  }
  CHECK(lancer_intersect(s, n, org, dir, tnear, tfar, t, id, ng) == 0);
  for (int i = 0; i < n; ++i) {
    if (i % 2) {
      CHECK(id[i] == -1 && isinf(t[i]));
    } else {
      CHECK(id[i] == 1);
      CHECK(fabsf(t[i] - (i == 18 ? len + 1 : len - 1)) < 1e-4f);
    }
  }
  CHECK(fabsf(ng[0] * dir[0] + ng[1] * dir[1] + ng[2] * dir[2] + 1) < 1e-4f); /* facing the ray */
  CHECK(lancer_occluded(s, n, org, dir, NULL, NULL, occ) == 0);
  for (int i = 0; i < n; ++i) CHECK(occ[i] == (i % 2 == 0));
  tfar[0] = 1; /* sphere 1 begins at 7.12 */
  CHECK(lancer_occluded(s, 1, org, dir, NULL, tfar, occ) == 0 && occ[0] == 0);
  CHECK(lancer_intersect(s, n, org, dir, NULL, NULL, t, id, NULL) == 0);

  dir[3 * 19 + 1] = 2; /* not unit */
  CHECK(lancer_intersect(s, n, org, dir, NULL, NULL, t, id, NULL) == -1);
  CHECK(strcmp(lancer_last_error(),
               "intersect: ray 19: dir must be unit length, |dir|^2 = 4.000000") == 0);
  CHECK(lancer_occluded(s, n, org, dir, NULL, NULL, occ) == -1);
  CHECK(strncmp(lancer_last_error(), "occluded: ray 19: ", 18) == 0);
  CHECK(lancer_intersect(s, 1, NULL, dir, NULL, NULL, t, id, NULL) == -1);
  CHECK(strcmp(lancer_last_error(), "org is NULL") == 0);

  lancer_scene_release(s);
  lancer_scene_release(NULL);

  /* Cylinders 1-4 after the plane y = -1 (id 0); cylinder 1 stands on (-2, -1, 0), radius 0.6,
   * top at y = 1.2: its side from +z (normal +z), its top cap from above (normal +y). */
  s = lancer_scene_load(LANCER_SOURCE_DIR "/scenes/prims/cylinders.json", &opt);
  CHECK(s != NULL);
  if (!s) return 1;
  CHECK(lancer_scene_info(s, &info) == 0 && info.objects == 5);
  const float corg[6] = {-2, 0, 5, -2, 5, 0}, cdir[6] = {0, 0, -1, 0, -1, 0};
  CHECK(lancer_intersect(s, 2, corg, cdir, NULL, NULL, t, id, ng) == 0);
  CHECK(id[0] == 1 && fabsf(t[0] - 4.4f) < 1e-4f);
  CHECK(fabsf(ng[0]) < 1e-6f && fabsf(ng[1]) < 1e-6f && fabsf(ng[2] - 1) < 1e-6f);
  CHECK(id[1] == 1 && fabsf(t[1] - 3.8f) < 1e-4f);
  CHECK(fabsf(ng[3]) < 1e-6f && fabsf(ng[4] - 1) < 1e-6f && fabsf(ng[5]) < 1e-6f);
  lancer_scene_release(s);
  if (failures == 0) printf("test_api_c: every check holds\n");
  return failures == 0 ? 0 : 1;
}
