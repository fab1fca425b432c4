# Debian packages (scripts/package), by CPack's DEB generator from the
# install() rules' components: psrig (the command line, the patterns and
# the simulated rig's config), psrigd (the daemon, its units, sysusers,
# udev and modules-load files, the web catalogue, /etc/psrig/rig.toml as a
# conffile), psrig-preview (the kiosk and its unit). dpkg-shlibdeps finds
# the libraries each program needs; a cross build's are looked up in its
# sysroot (scripts/package indexes it for dpkg).
set(CPACK_GENERATOR DEB)
# Packaging builds only what it installs (scripts/package names the targets).
set(CMAKE_SKIP_INSTALL_ALL_DEPENDENCY ON)
set(CPACK_DEB_COMPONENT_INSTALL ON)
set(CPACK_COMPONENTS_ALL psrig psrigd psrig-preview)
set(CPACK_PACKAGE_NAME psrig)
# No project address exists yet: set the real one when there is.
set(PSRIG_PACKAGE_MAINTAINER "psrig authors <psrig@example.org>" CACHE STRING "The packages' Maintainer")
set(CPACK_PACKAGE_CONTACT "${PSRIG_PACKAGE_MAINTAINER}")
set(CPACK_PACKAGE_DESCRIPTION_SUMMARY "photometric-stereo capture rig for textile swatches")
set(CPACK_PACKAGING_INSTALL_PREFIX /usr)
set(CPACK_STRIP_FILES ON)
set(CPACK_DEBIAN_FILE_NAME DEB-DEFAULT)
set(CPACK_DEBIAN_PACKAGE_SECTION science)
set(CPACK_DEBIAN_PACKAGE_SHLIBDEPS ON)
set(CPACK_DEBIAN_PACKAGE_CONTROL_STRICT_PERMISSION ON)
if(CMAKE_CROSSCOMPILING)
  # dpkg names aarch64 arm64; CPack would ask this machine's dpkg.
  if(CMAKE_SYSTEM_PROCESSOR STREQUAL "aarch64")
    set(CPACK_DEBIAN_PACKAGE_ARCHITECTURE arm64)
  endif()
  set(CPACK_DEBIAN_PACKAGE_SHLIBDEPS_PRIVATE_DIRS
    ${CMAKE_SYSROOT}/usr/lib/${CMAKE_LIBRARY_ARCHITECTURE} ${CMAKE_SYSROOT}/lib/${CMAKE_LIBRARY_ARCHITECTURE}
    ${CMAKE_SYSROOT}/usr/lib/${CMAKE_LIBRARY_ARCHITECTURE}/blas
    ${CMAKE_SYSROOT}/usr/lib/${CMAKE_LIBRARY_ARCHITECTURE}/lapack)
endif()

set(CPACK_DEBIAN_PSRIG_PACKAGE_NAME psrig)
set(CPACK_COMPONENT_PSRIG_DESCRIPTION "photometric-stereo capture rig: command line
psrig scans textile swatches on a three-LED photometric-stereo rig (or its
simulator), processes frames into normal, albedo and height maps, measures
the fabric and exports materials. Includes the knit and weave patterns and
the simulated rig's configuration (/usr/share/psrig/sim.toml).")
set(CPACK_DEBIAN_PSRIGD_PACKAGE_NAME psrigd)
set(CPACK_DEBIAN_PSRIGD_PACKAGE_DEPENDS "psrig (= ${PROJECT_VERSION}), systemd")
set(CPACK_DEBIAN_PSRIGD_PACKAGE_CONTROL_EXTRA
  ${PROJECT_SOURCE_DIR}/config/debian/psrigd/conffiles
  ${PROJECT_SOURCE_DIR}/config/debian/psrigd/postinst
  ${PROJECT_SOURCE_DIR}/config/debian/psrigd/postrm)
set(CPACK_COMPONENT_PSRIGD_DESCRIPTION "photometric-stereo capture rig: service
psrigd runs the rig as a systemd service: queued scans into a catalogue, a
web catalogue and HTTP API on port 8470, a Modbus TCP server for a PLC.
Configuration in /etc/psrig/rig.toml; installing enables nothing.")
set(CPACK_DEBIAN_PSRIG-PREVIEW_PACKAGE_NAME psrig-preview)
set(CPACK_DEBIAN_PSRIG-PREVIEW_PACKAGE_DEPENDS "psrig (= ${PROJECT_VERSION})")
set(CPACK_COMPONENT_PSRIG-PREVIEW_DESCRIPTION "photometric-stereo capture rig: GLES preview and kiosk
psrig-preview renders scanned swatches with OpenGL ES (headless or full
screen on KMS), knits and drapes their cloth; psrig-preview-kiosk.service
shows the newest scan on the board's display (not enabled on install).")

# Each package's copyright and changelog, as Debian policy asks.
set(psrig_changelog ${PROJECT_BINARY_DIR}/changelog.gz)
add_custom_command(OUTPUT ${psrig_changelog}
  COMMAND gzip -9n -c ${PROJECT_SOURCE_DIR}/config/debian/changelog > ${psrig_changelog}
  DEPENDS ${PROJECT_SOURCE_DIR}/config/debian/changelog)
add_custom_target(psrig_changelog ALL DEPENDS ${psrig_changelog})
foreach(component IN LISTS CPACK_COMPONENTS_ALL)
  install(FILES ${PROJECT_SOURCE_DIR}/config/debian/copyright ${psrig_changelog}
    DESTINATION ${CMAKE_INSTALL_DATADIR}/doc/${component} COMPONENT ${component})
endforeach()
install(FILES ${PROJECT_SOURCE_DIR}/README.md DESTINATION ${CMAKE_INSTALL_DATADIR}/doc/psrig COMPONENT psrig)
include(CPack)
