# `cmake --install`: the library, its public headers, the qjulia command and a CMake package,
# so that a C++ project does find_package(qjulia) and links qjulia::qjulia
# (examples/consumer; scripts/check_install.sh builds it against an installed tree).
include(CMakePackageConfigHelpers)

set(QJULIA_CMAKE_DIR ${CMAKE_INSTALL_LIBDIR}/cmake/qjulia)
install(TARGETS qjulia EXPORT qjuliaTargets
        ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR}
        LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR}
        INCLUDES DESTINATION ${CMAKE_INSTALL_INCLUDEDIR})
install(DIRECTORY ${PROJECT_SOURCE_DIR}/lib/include/qjulia
        DESTINATION ${CMAKE_INSTALL_INCLUDEDIR})
install(TARGETS qjulia_cli EXPORT qjuliaTargets RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})
# The modules, loaded on first use from <libdir>/qjulia: OpenVDB's (lib/src/base/vdb_module.h),
# lib3mf's (lib/src/io/threemf_module.h), OpenMesh's (lib/src/mesh/openmesh_module.h) and the
# web server's.
install(TARGETS qjulia_vdb LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR}/qjulia)
install(TARGETS qjulia_3mf LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR}/qjulia)
install(TARGETS qjulia_openmesh LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR}/qjulia)
install(TARGETS qjulia_http LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR}/qjulia)
if(TARGET qjulia_mpi)
  install(TARGETS qjulia_mpi RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})
endif()
install(EXPORT qjuliaTargets NAMESPACE qjulia:: DESTINATION ${QJULIA_CMAKE_DIR})

configure_package_config_file(${CMAKE_CURRENT_LIST_DIR}/qjuliaConfig.cmake.in
                              ${CMAKE_CURRENT_BINARY_DIR}/qjuliaConfig.cmake
                              INSTALL_DESTINATION ${QJULIA_CMAKE_DIR})
write_basic_package_version_file(${CMAKE_CURRENT_BINARY_DIR}/qjuliaConfigVersion.cmake
                                 COMPATIBILITY SameMinorVersion)
install(FILES ${CMAKE_CURRENT_BINARY_DIR}/qjuliaConfig.cmake
              ${CMAKE_CURRENT_BINARY_DIR}/qjuliaConfigVersion.cmake
              ${CMAKE_CURRENT_LIST_DIR}/qjulia_dependencies.cmake
        DESTINATION ${QJULIA_CMAKE_DIR})
