# The Debian package (cpack -G DEB in the build folder; tested by scripts/package-test.sh):
# one package, lanedet, with
#   /usr/bin/lane, lane-server, lane-client   the programs
#   /usr/lib, /usr/include, /usr/share/lanedet the library, headers, configs
#                                             (cmake/install.cmake)
#   /lib/systemd/system/lane-server.service   the hardened unit
#   /etc/default/lane-server                  its flags (a conffile, 0600)
#   /usr/share/doc/lanedet/                   README, copyright, changelog
# Depends: is computed by dpkg-shlibdeps from the programs' libraries.
#
# The unit and its flags are the `service` component, which
# `cmake --install` leaves out (they have absolute paths: a user's prefix
# must not write to /etc); the package takes every component.
install(FILES ${PROJECT_SOURCE_DIR}/deploy/systemd/lane-server.service
        DESTINATION /lib/systemd/system COMPONENT service EXCLUDE_FROM_ALL)
install(FILES ${PROJECT_SOURCE_DIR}/deploy/systemd/lane-server.default
        DESTINATION /etc/default RENAME lane-server PERMISSIONS OWNER_READ OWNER_WRITE
        COMPONENT service EXCLUDE_FROM_ALL)
install(FILES ${PROJECT_SOURCE_DIR}/README.md ${PROJECT_SOURCE_DIR}/deploy/debian/copyright
        DESTINATION ${CMAKE_INSTALL_DOCDIR} COMPONENT service EXCLUDE_FROM_ALL)
# Debian's changelog, compressed as policy asks (gzip -n: no timestamp), and
# lintian's overrides: the tags that remain, each with its reason.
# (A native package: its version has no Debian revision, hence changelog.gz.)
set(lane_changelog ${CMAKE_CURRENT_BINARY_DIR}/changelog)
string(TIMESTAMP lane_changelog_date "%a, %d %b %Y %H:%M:%S +0000" UTC)
file(WRITE ${lane_changelog}
     "lanedet (${PROJECT_VERSION}) unstable; urgency=medium\n\n"
     "  * Built from ${LANE_GIT_REVISION}; the project's history is its git log.\n\n"
     " -- lanedet developers <dev@lanedet.org>  ${lane_changelog_date}\n")
add_custom_command(OUTPUT ${lane_changelog}.gz
                   COMMAND gzip -9nf -k ${lane_changelog}
                   DEPENDS ${lane_changelog})
add_custom_target(lane_changelog ALL DEPENDS ${lane_changelog}.gz)
install(FILES ${lane_changelog}.gz DESTINATION ${CMAKE_INSTALL_DOCDIR}
        COMPONENT service EXCLUDE_FROM_ALL)
install(FILES ${PROJECT_SOURCE_DIR}/deploy/debian/lintian-overrides
        DESTINATION ${CMAKE_INSTALL_DATADIR}/lintian/overrides RENAME lanedet
        COMPONENT service EXCLUDE_FROM_ALL)

set(CPACK_GENERATOR DEB)
set(CPACK_PACKAGE_NAME lanedet)
set(CPACK_PACKAGE_VERSION ${PROJECT_VERSION})
set(CPACK_PACKAGE_VENDOR "lanedet developers")
set(CPACK_PACKAGE_CONTACT "lanedet developers <dev@lanedet.org>")
set(CPACK_PACKAGE_DESCRIPTION_SUMMARY "real-time lane-marker detection service (Aly 2008)")
# The synopsis is CPACK_PACKAGE_DESCRIPTION_SUMMARY; this is the long text
# (no semicolons: CMake would read them as list separators).
set(CPACK_DEBIAN_PACKAGE_DESCRIPTION
    "Detects lane markers in camera frames: inverse perspective mapping, a\n"
    "separable Gaussian filter, column-sum Hough, RANSAC lines and Bezier\n"
    "splines. lane-server serves per-camera sessions over gRPC with\n"
    "Prometheus metrics, lane-client streams frames and load-tests, lane\n"
    "detects, renders, calibrates and evaluates from files. Also the static\n"
    "library lanedet (find_package(lanedet), pkg-config lanedet).")
string(REPLACE ";" "" CPACK_DEBIAN_PACKAGE_DESCRIPTION "${CPACK_DEBIAN_PACKAGE_DESCRIPTION}")
set(CPACK_DEBIAN_PACKAGE_SECTION science)
set(CPACK_DEBIAN_PACKAGE_PRIORITY optional)
set(CPACK_DEBIAN_PACKAGE_HOMEPAGE "https://github.com/lanedet/lanedet")
set(CPACK_DEBIAN_FILE_NAME DEB-DEFAULT)
set(CPACK_DEBIAN_PACKAGE_SHLIBDEPS ON)
# The maintainer scripts' deb-systemd-invoke (added to the computed list).
set(CPACK_DEBIAN_PACKAGE_DEPENDS "init-system-helpers (>= 1.54~)")
set(CPACK_DEBIAN_PACKAGE_CONTROL_STRICT_PERMISSION ON)
set(CPACK_DEBIAN_PACKAGE_CONTROL_EXTRA
    ${PROJECT_SOURCE_DIR}/deploy/debian/postinst ${PROJECT_SOURCE_DIR}/deploy/debian/prerm
    ${PROJECT_SOURCE_DIR}/deploy/debian/postrm ${PROJECT_SOURCE_DIR}/deploy/debian/conffiles)
set(CPACK_PACKAGING_INSTALL_PREFIX /usr)
# Every component (the default ones and `service`) in the one package.
set(CPACK_DEB_COMPONENT_INSTALL ON)
set(CPACK_COMPONENTS_GROUPING ALL_COMPONENTS_IN_ONE)
set(CPACK_COMPONENTS_ALL Unspecified service)
set(CPACK_DEBIAN_ENABLE_COMPONENT_DEPENDS OFF)
# Release binaries: the package strips them (the build keeps its debug info).
set(CPACK_STRIP_FILES ON)
include(CPack)
