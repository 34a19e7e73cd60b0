# Every dependency comes from a Debian 12 package.  A missing one stops
# configure with the package to install (scripts/install-deps.sh installs all).

macro(mr_require found debian_package what)
  if(NOT ${found})
    message(FATAL_ERROR
      "mr needs ${what}: install the Debian package '${debian_package}' "
      "(or run scripts/install-deps.sh)")
  endif()
endmacro()

find_package(Threads REQUIRED)

find_package(ZLIB QUIET)
mr_require(ZLIB_FOUND zlib1g-dev "zlib (mrcal's optimisation inputs are a deflated .npz)")

find_package(Eigen3 3.4 QUIET NO_MODULE)
mr_require(Eigen3_FOUND libeigen3-dev "Eigen 3.4")

find_package(TBB QUIET CONFIG)
mr_require(TBB_FOUND libtbb-dev "oneTBB")

find_package(nlohmann_json 3.10 QUIET CONFIG)
mr_require(nlohmann_json_FOUND nlohmann-json3-dev "nlohmann-json")

find_package(fmt QUIET CONFIG)
mr_require(fmt_FOUND libfmt-dev "fmt")

find_package(spdlog QUIET CONFIG)
mr_require(spdlog_FOUND libspdlog-dev "spdlog")

find_package(CLI11 QUIET CONFIG)
if(NOT CLI11_FOUND)
  find_path(CLI11_INCLUDE_DIR CLI/CLI.hpp)
  mr_require(CLI11_INCLUDE_DIR libcli11-dev "CLI11")
  add_library(CLI11::CLI11 INTERFACE IMPORTED)
  target_include_directories(CLI11::CLI11 INTERFACE ${CLI11_INCLUDE_DIR})
endif()

find_package(OpenImageIO QUIET CONFIG)
mr_require(OpenImageIO_FOUND libopenimageio-dev "OpenImageIO")
# Debian 12's OpenImageIO config lists /usr/include/opencv4 as an include
# directory even when OpenCV is not installed; drop paths that do not exist.
foreach(_oiio_target OpenImageIO::OpenImageIO OpenImageIO::OpenImageIO_Util)
  get_target_property(_dirs ${_oiio_target} INTERFACE_INCLUDE_DIRECTORIES)
  set(_kept "")
  foreach(_d IN LISTS _dirs)
    if(EXISTS "${_d}")
      list(APPEND _kept "${_d}")
    endif()
  endforeach()
  set_target_properties(${_oiio_target} PROPERTIES INTERFACE_INCLUDE_DIRECTORIES "${_kept}")
endforeach()

find_package(OpenEXR QUIET CONFIG)
mr_require(OpenEXR_FOUND libopenexr-dev "OpenEXR")

find_package(OpenMesh QUIET CONFIG)
if(NOT OpenMesh_FOUND AND NOT TARGET OpenMeshCore)
  mr_require(OpenMesh_FOUND libopenmesh-dev "OpenMesh")
endif()

# OpenCV stays in the .cpp files of the stages that use it (calib/charuco.cpp).
find_package(OpenCV 4 QUIET CONFIG COMPONENTS core imgproc imgcodecs videoio video calib3d aruco photo)
mr_require(OpenCV_FOUND "libopencv-dev libopencv-contrib-dev" "OpenCV 4 with the contrib aruco module")

find_package(Ceres QUIET CONFIG)
mr_require(Ceres_FOUND libceres-dev "Ceres Solver (the mirror sphere's robust cone fit)")

find_package(embree 3 QUIET CONFIG)
mr_require(embree_FOUND libembree-dev "Embree 3")

# glTF 2.0 assets (geometry/asset_gltf.cpp; docs/dependencies.md says why not assimp).
find_package(TinyGLTF QUIET CONFIG)
mr_require(TinyGLTF_FOUND libtinygltf-dev "tinygltf (glTF 2.0 assets)")

# Plates in camera log encodings and ACES (core/color_management.cpp).
# Debian 12's CMake config for it resolves its prefix to "/" (it lies in
# /usr/share/cmake): its pkg-config file is used instead.
find_package(PkgConfig QUIET)
if(PkgConfig_FOUND)
  pkg_check_modules(OCIO QUIET IMPORTED_TARGET OpenColorIO>=2.1)
endif()
mr_require(OCIO_FOUND libopencolorio-dev "OpenColorIO 2.1 (plates through colour-managed configs)")
add_library(OpenColorIO::OpenColorIO ALIAS PkgConfig::OCIO)

# mrcal ships neither a CMake config nor a pkg-config file in Debian 12.
find_path(MRCAL_INCLUDE_DIR mrcal/mrcal.h)
find_library(MRCAL_LIBRARY mrcal)
mr_require(MRCAL_INCLUDE_DIR libmrcal-dev "libmrcal (mrcal/mrcal.h)")
mr_require(MRCAL_LIBRARY libmrcal-dev "libmrcal (libmrcal.so)")
add_library(mr::mrcal UNKNOWN IMPORTED)
set_target_properties(mr::mrcal PROPERTIES IMPORTED_LOCATION ${MRCAL_LIBRARY}
                      INTERFACE_INCLUDE_DIRECTORIES ${MRCAL_INCLUDE_DIR})

# CHOLMOD's header, for the sparse Jacobian mrcal hands back (calib/calibrate.cpp).
find_path(CHOLMOD_INCLUDE_DIR suitesparse/cholmod.h)
mr_require(CHOLMOD_INCLUDE_DIR libsuitesparse-dev "CHOLMOD (suitesparse/cholmod.h)")

# mrgingham (chessboard corners) ships only a header and a shared library.
find_path(MRGINGHAM_INCLUDE_DIR mrgingham/mrgingham.hh)
find_library(MRGINGHAM_LIBRARY mrgingham)
mr_require(MRGINGHAM_INCLUDE_DIR libmrgingham-dev "mrgingham (mrgingham/mrgingham.hh)")
mr_require(MRGINGHAM_LIBRARY libmrgingham-dev "mrgingham (libmrgingham.so)")
add_library(mr::mrgingham UNKNOWN IMPORTED)
set_target_properties(mr::mrgingham PROPERTIES IMPORTED_LOCATION ${MRGINGHAM_LIBRARY}
                      INTERFACE_INCLUDE_DIRECTORIES ${MRGINGHAM_INCLUDE_DIR})

if(MR_BUILD_TESTS)
  find_package(GTest QUIET CONFIG)
  mr_require(GTest_FOUND "libgtest-dev libgmock-dev" "GoogleTest")
endif()
if(MR_BUILD_BENCHMARKS)
  find_package(benchmark QUIET CONFIG)
  mr_require(benchmark_FOUND libbenchmark-dev "Google Benchmark")
endif()
