# FindCHOLMOD: SuiteSparse CHOLMOD (tested with Debian's SuiteSparse 5.12).
#
# Provides the imported target CHOLMOD::CHOLMOD (cholmod + suitesparseconfig) and the variables
# CHOLMOD_FOUND, CHOLMOD_INCLUDE_DIR, CHOLMOD_LIBRARY, SUITESPARSECONFIG_LIBRARY, CHOLMOD_VERSION.
#
# CHOLMOD's supernodal factorization spends its time in BLAS/LAPACK. Debian's libcholmod links the
# generic libblas.so.3 / liblapack.so.3, which update-alternatives points at OpenBLAS when
# libopenblas-dev is installed (the reference BLAS is ~3x slower, REFERENCE.md). This module warns
# when the selected libblas.so.3 is not OpenBLAS; scripts/setup.sh should select it with
#   update-alternatives --set libblas.so.3-x86_64-linux-gnu \
#       /usr/lib/x86_64-linux-gnu/openblas-pthread/libblas.so.3
# (and the same for liblapack.so.3-x86_64-linux-gnu).

find_path(CHOLMOD_INCLUDE_DIR NAMES cholmod.h
  PATH_SUFFIXES suitesparse include/suitesparse)
find_library(CHOLMOD_LIBRARY NAMES cholmod)
find_library(SUITESPARSECONFIG_LIBRARY NAMES suitesparseconfig)

# the version macros live in cholmod_core.h (CHOLMOD 3.x in SuiteSparse 5.x) or cholmod.h (4.x+)
set(_cholmod_version_header "${CHOLMOD_INCLUDE_DIR}/cholmod_core.h")
if(NOT EXISTS "${_cholmod_version_header}")
  set(_cholmod_version_header "${CHOLMOD_INCLUDE_DIR}/cholmod.h")
endif()
if(CHOLMOD_INCLUDE_DIR AND EXISTS "${_cholmod_version_header}")
  file(STRINGS "${_cholmod_version_header}" _cholmod_version_lines
    REGEX "#define CHOLMOD_(MAIN|SUB|SUBSUB)_VERSION[ \t]+[0-9]+")
  string(REGEX REPLACE ".*CHOLMOD_MAIN_VERSION[ \t]+([0-9]+).*" "\\1" _major "${_cholmod_version_lines}")
  string(REGEX REPLACE ".*CHOLMOD_SUB_VERSION[ \t]+([0-9]+).*" "\\1" _minor "${_cholmod_version_lines}")
  string(REGEX REPLACE ".*CHOLMOD_SUBSUB_VERSION[ \t]+([0-9]+).*" "\\1" _patch "${_cholmod_version_lines}")
  set(CHOLMOD_VERSION "${_major}.${_minor}.${_patch}")
endif()

include(FindPackageHandleStandardArgs)
find_package_handle_standard_args(CHOLMOD
  REQUIRED_VARS CHOLMOD_LIBRARY SUITESPARSECONFIG_LIBRARY CHOLMOD_INCLUDE_DIR
  VERSION_VAR CHOLMOD_VERSION)

if(CHOLMOD_FOUND AND NOT TARGET CHOLMOD::CHOLMOD)
  add_library(CHOLMOD::CHOLMOD UNKNOWN IMPORTED GLOBAL)
  set_target_properties(CHOLMOD::CHOLMOD PROPERTIES
    IMPORTED_LOCATION "${CHOLMOD_LIBRARY}"
    INTERFACE_INCLUDE_DIRECTORIES "${CHOLMOD_INCLUDE_DIR}"
    INTERFACE_LINK_LIBRARIES "${SUITESPARSECONFIG_LIBRARY}")

  # which BLAS will CHOLMOD use at run time? (libblas.so.3 is an update-alternatives link)
  get_filename_component(_cholmod_libdir "${CHOLMOD_LIBRARY}" DIRECTORY)
  if(EXISTS "${_cholmod_libdir}/libblas.so.3")
    get_filename_component(_blas_real "${_cholmod_libdir}/libblas.so.3" REALPATH)
    if(NOT _blas_real MATCHES "openblas")
      message(WARNING "CHOLMOD will use ${_blas_real}, not OpenBLAS: factorizations are ~3x "
                      "slower. Select OpenBLAS with update-alternatives (see FindCHOLMOD.cmake).")
    else()
      message(STATUS "CHOLMOD BLAS: ${_blas_real}")
    endif()
  endif()
endif()

mark_as_advanced(CHOLMOD_INCLUDE_DIR CHOLMOD_LIBRARY SUITESPARSECONFIG_LIBRARY)
