// What the library exports. A shared liblancer (-DBUILD_SHARED_LIBS=ON) is built with hidden
// visibility, so that only what the installed headers declare with LANCER_API is in its dynamic
// symbol table: the library API, not the kernels, the BVH or anything else inside. A static
// library is unaffected.
#pragma once

#if defined(__GNUC__) || defined(__clang__)
#define LANCER_API __attribute__((visibility("default")))
#else
#define LANCER_API
#endif
