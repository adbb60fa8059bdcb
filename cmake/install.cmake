# What `cmake --install BUILD --prefix P` puts under P (docs/install.md):
#   bin/                      lane, lane-server, lane-client (those built)
#   lib/                      liblanedet_core.a, liblanedet_decode.a
#   include/lane/             the detector's and the decoder's public headers
#   lib/cmake/lanedet/        lanedetConfig.cmake: find_package(lanedet) gives
#                             lanedet::core and lanedet::decode
#   lib/pkgconfig/lanedet.pc  the same for pkg-config
#   share/lanedet/configs/    the example configs
# The libraries are static: a consumer links them and their dependencies
# (OpenCV, Eigen, abseil, libjpeg, libpng: Debian packages), which the
# package config and the .pc file name.
include(CMakePackageConfigHelpers)

install(TARGETS lane_core lane_decode EXPORT lanedetTargets
        ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR})
install(EXPORT lanedetTargets NAMESPACE lanedet::
        DESTINATION ${CMAKE_INSTALL_LIBDIR}/cmake/lanedet)
configure_package_config_file(${CMAKE_CURRENT_LIST_DIR}/lanedetConfig.cmake.in
                              ${CMAKE_CURRENT_BINARY_DIR}/lanedetConfig.cmake
                              INSTALL_DESTINATION ${CMAKE_INSTALL_LIBDIR}/cmake/lanedet)
# 0.x: a minor version may change the API.
write_basic_package_version_file(${CMAKE_CURRENT_BINARY_DIR}/lanedetConfigVersion.cmake
                                 COMPATIBILITY SameMinorVersion)
install(FILES ${CMAKE_CURRENT_BINARY_DIR}/lanedetConfig.cmake
              ${CMAKE_CURRENT_BINARY_DIR}/lanedetConfigVersion.cmake
        DESTINATION ${CMAKE_INSTALL_LIBDIR}/cmake/lanedet)
# The .pc file finds the prefix from its own place (relocatable): the way up
# from LIBDIR/pkgconfig (lib/pkgconfig, or lib/x86_64-linux-gnu/pkgconfig
# under /usr).
file(RELATIVE_PATH LANE_PC_TO_PREFIX "/${CMAKE_INSTALL_LIBDIR}/pkgconfig" "/")
configure_file(${CMAKE_CURRENT_LIST_DIR}/lanedet.pc.in ${CMAKE_CURRENT_BINARY_DIR}/lanedet.pc @ONLY)
install(FILES ${CMAKE_CURRENT_BINARY_DIR}/lanedet.pc
        DESTINATION ${CMAKE_INSTALL_LIBDIR}/pkgconfig)

foreach(program lane lane-server lane-client)
  if(TARGET ${program})
    install(TARGETS ${program} RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})
  endif()
endforeach()
install(DIRECTORY ${PROJECT_SOURCE_DIR}/configs/ DESTINATION ${CMAKE_INSTALL_DATADIR}/lanedet/configs)
