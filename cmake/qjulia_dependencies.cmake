# The packages the qjulia library links, found the same way by its build (CMakeLists.txt) and by
# find_package(qjulia) (qjuliaConfig.cmake: a static libqjulia needs them when a program links
# it). No system path is written here: each package is found by its own config file, by the
# find module Debian ships with it, or by pkg-config. None of them appears in a public header.
#
# QJULIA_OPENVDB_MODULE_PATH: the folder of FindOpenVDB.cmake (OpenVDB installs a find module,
# not a config file), searched in <prefix>/lib/<arch>/cmake/OpenVDB of the usual prefixes.
if(NOT QJULIA_OPENVDB_MODULE_PATH)
  find_path(QJULIA_OPENVDB_MODULE_PATH FindOpenVDB.cmake
    PATHS ${CMAKE_PREFIX_PATH} ${CMAKE_SYSTEM_PREFIX_PATH}
    PATH_SUFFIXES lib/${CMAKE_LIBRARY_ARCHITECTURE}/cmake/OpenVDB lib/cmake/OpenVDB
                  lib64/cmake/OpenVDB
    NO_DEFAULT_PATH)
endif()
if(NOT QJULIA_OPENVDB_MODULE_PATH)
  message(FATAL_ERROR "FindOpenVDB.cmake not found: install libopenvdb-dev or set "
                      "QJULIA_OPENVDB_MODULE_PATH to its folder")
endif()

# In the build: find_package(... REQUIRED). In qjuliaConfig.cmake (QJULIA_CONSUMER set):
# find_dependency, which reports a missing package as the reason qjulia was not found.
macro(qjulia_dependency)
  if(QJULIA_CONSUMER)
    find_dependency(${ARGN})
  else()
    find_package(${ARGN} REQUIRED)
  endif()
endmacro()

# TBB first, by its config file: OpenVDB's folder also holds a FindTBB.cmake.
qjulia_dependency(TBB CONFIG)
# Highway: the SIMD evaluator (dispatched at run time).
qjulia_dependency(hwy CONFIG)
list(APPEND CMAKE_MODULE_PATH ${QJULIA_OPENVDB_MODULE_PATH})
# FindOpenVDB sets BUILD_SHARED_LIBS ON (for Boost's sake): the caller's choice is kept.
if(DEFINED BUILD_SHARED_LIBS)
  set(_qjulia_shared_libs "${BUILD_SHARED_LIBS}")
endif()
qjulia_dependency(OpenVDB)
if(DEFINED _qjulia_shared_libs)
  set(BUILD_SHARED_LIBS "${_qjulia_shared_libs}")
  unset(_qjulia_shared_libs)
else()
  unset(BUILD_SHARED_LIBS)
endif()
qjulia_dependency(OpenMesh)
qjulia_dependency(CGAL)
qjulia_dependency(TinyGLTF)
qjulia_dependency(PNG)
qjulia_dependency(PkgConfig)
pkg_check_modules(LIB3MF REQUIRED IMPORTED_TARGET lib3MF)
# libzip: the 3MF reader checks archives with it before lib3mf parses them.
pkg_check_modules(LIBZIP REQUIRED IMPORTED_TARGET libzip)
