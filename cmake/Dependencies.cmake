# All dependencies come from Debian 12 packages; see README.md for the apt-get line.
find_package(Threads REQUIRED)
find_package(nlohmann_json 3 REQUIRED)
find_package(CLI11 REQUIRED)
find_package(TBB REQUIRED)

# xsimd 8.1.0 (Debian) links an `xtl` target that the package does not ship.
if(NOT TARGET xtl)
  add_library(xtl INTERFACE IMPORTED)
endif()
find_package(xsimd 8 REQUIRED)

# Debian 12's libimath-dev exports Imath::PyImath_Python3_11, whose library only python3-imath
# ships: the check of its file printed a screen of "does not exist" on every configure, burying
# real warnings. Imath found first with its status messages held back; OpenImageIO's
# find_dependency(Imath) then finds the targets defined and reads nothing again.
set(_lancer_log_level "${CMAKE_MESSAGE_LOG_LEVEL}")
set(CMAKE_MESSAGE_LOG_LEVEL NOTICE)
find_package(Imath CONFIG QUIET)
if(_lancer_log_level)
  set(CMAKE_MESSAGE_LOG_LEVEL "${_lancer_log_level}")
else()
  unset(CMAKE_MESSAGE_LOG_LEVEL)
endif()
# The common image formats by their own libraries (src/image_formats.cpp), linked by lancer_tools:
# libpng-dev, libjpeg-dev (libjpeg-turbo), libtiff-dev, libopenexr-dev. OpenImageIO uses the same
# ones underneath, but brings 260 libraries with them.
find_package(PNG REQUIRED)
find_package(JPEG REQUIRED)
# The image modules (TIFF and OpenEXR; OpenImageIO) and the figures (cairo) can be left out where
# their libraries are not installed, as in the aarch64 cross build (docs/platforms.md).
option(LANCER_WITH_IMAGE_MODULES "Build the TIFF/OpenEXR and OpenImageIO image modules" ON)
option(LANCER_WITH_PLOTS "Draw figures with cairo (plot, and the figures of flux and trade)" ON)
if(LANCER_WITH_IMAGE_MODULES)
  find_package(TIFF 4.5 REQUIRED)  # 4.5: per-handle error handlers (TIFFOpenOptions)
  find_package(OpenEXR 3 CONFIG REQUIRED)

  # OpenImageIO 2.4 (Debian) lists /usr/include/opencv4, which does not exist without OpenCV.
  find_package(OpenImageIO REQUIRED)
  foreach(_prop INTERFACE_INCLUDE_DIRECTORIES INTERFACE_SYSTEM_INCLUDE_DIRECTORIES)
    get_target_property(_dirs OpenImageIO::OpenImageIO ${_prop})
    if(_dirs)
      list(FILTER _dirs EXCLUDE REGEX "opencv4")
      set_target_properties(OpenImageIO::OpenImageIO PROPERTIES ${_prop} "${_dirs}")
    endif()
  endforeach()
endif()

# The packet kernels' ISAs: SSE4.2, AVX2 and AVX-512F on x86-64; NEON on aarch64, where the
# kernels' x86 intrinsics come from SIMDe (Debian: libsimde-dev, headers only).
set(LANCER_AARCH64 OFF)
if(CMAKE_SYSTEM_PROCESSOR MATCHES "^(aarch64|arm64|ARM64)$")
  set(LANCER_AARCH64 ON)
  find_path(LANCER_SIMDE_INCLUDE simde/x86/avx512.h REQUIRED)
elseif(NOT CMAKE_SYSTEM_PROCESSOR MATCHES "^(x86_64|AMD64|amd64)$")
  message(FATAL_ERROR "lancer's packet kernels are built for x86-64 and aarch64, "
                      "not ${CMAKE_SYSTEM_PROCESSOR}")
endif()

# Embree 3 (Debian: libembree-dev), the peer of `lancer bench --peer embree`. Optional: without
# it the peer is compiled out and --peer embree says so (exit 2).
option(LANCER_WITH_EMBREE "Build the Embree peer (lancer bench --peer embree)" ON)
set(LANCER_HAVE_EMBREE OFF)
if(LANCER_WITH_EMBREE)
  find_package(embree 3 QUIET)
  if(embree_FOUND AND TARGET embree)
    set(LANCER_HAVE_EMBREE ON)
    message(STATUS "Embree ${EMBREE_VERSION}: the embree peer is built")
  else()
    message(STATUS "Embree 3 not found: the embree peer is compiled out "
                   "(apt-get install libembree-dev, or -DLANCER_WITH_EMBREE=OFF to silence)")
  endif()
endif()

# Open MPI (Debian: libopenmpi-dev openmpi-bin) for `mpirun -np N lancer render|bench`
# (docs/mpi.md). AUTO builds it when found; ON requires it; OFF leaves it out, and lancer then
# refuses to run under mpirun with a message saying how to get it.
set(LANCER_MPI AUTO CACHE STRING "Build the MPI renderer: AUTO, ON or OFF")
set_property(CACHE LANCER_MPI PROPERTY STRINGS AUTO ON OFF)
set(LANCER_HAVE_MPI OFF)
if(NOT LANCER_MPI STREQUAL "OFF")
  if(LANCER_MPI STREQUAL "ON")
    find_package(MPI REQUIRED COMPONENTS CXX)
  else()
    find_package(MPI QUIET COMPONENTS CXX)
  endif()
  if(MPI_CXX_FOUND)
    set(LANCER_HAVE_MPI ON)
    message(STATUS "MPI ${MPI_CXX_VERSION}: mpirun -np N lancer render is built")
  else()
    message(STATUS "MPI not found: lancer is built without MPI "
                   "(apt-get install libopenmpi-dev openmpi-bin, or -DLANCER_MPI=OFF to silence)")
  endif()
endif()
# Cached so that scripts (.ci/mpi.sh) can tell from CMakeCache.txt.
set(LANCER_HAVE_MPI ${LANCER_HAVE_MPI} CACHE INTERNAL "lancer built with MPI")

if(LANCER_BUILD_TESTS)
  find_package(GTest REQUIRED)
  include(GoogleTest)
endif()
if(LANCER_BUILD_BENCH)
  find_package(benchmark REQUIRED)
endif()
