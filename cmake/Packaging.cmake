# SPDX-License-Identifier: Apache-2.0
# Packaging: the install rules of what has no CMakeLists.txt of its own (man pages, examples,
# documents, the default configuration), and the .deb (CPack, generator DEB only).
#
#   cd build && cpack -G DEB            ->  drivebus_<version>_<arch>.deb
#   sudo apt install ./drivebus_0.1.0_amd64.deb
#
# Included at the end of the top-level CMakeLists.txt, so that every target is known here.
# The package installs under CMAKE_INSTALL_PREFIX, the prefix the binaries were built for (they
# carry the profile directory, the units carry the paths of drivebusd and /etc/drivebus): a
# Debian package needs the default, /usr. See docs/deployment.md.

if(NOT CMAKE_INSTALL_PREFIX STREQUAL "/usr")
  message(STATUS "package: CMAKE_INSTALL_PREFIX is ${CMAKE_INSTALL_PREFIX}; a .deb wants /usr")
endif()

# drivebusctl and libdrivebus (client/): the library installs itself, with its headers, CMake
# package files and drivebus.pc.
if(TARGET drivebusctl)
  install(TARGETS drivebusctl RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})
endif()

# Man pages, by the section in their file name.
foreach(page drivebusd.8 drivebusd.toml.5 drivebusctl.1 drivebus-sim.1)
  string(REGEX MATCH "[0-9]$" section "${page}")
  install(FILES ${PROJECT_SOURCE_DIR}/man/${page} DESTINATION ${CMAKE_INSTALL_MANDIR}/man${section})
endforeach()

# Documents and examples (docs/deployment.md is installed with the units, systemd/).
file(GLOB docs ${PROJECT_SOURCE_DIR}/docs/*.md)
list(REMOVE_ITEM docs ${PROJECT_SOURCE_DIR}/docs/deployment.md)
install(FILES ${PROJECT_SOURCE_DIR}/README.md ${docs} DESTINATION ${CMAKE_INSTALL_DOCDIR})
# The licence, where Debian looks for it (DEP-5, machine-readable).
install(FILES ${PROJECT_SOURCE_DIR}/cmake/copyright DESTINATION ${CMAKE_INSTALL_DOCDIR})
install(FILES ${PROJECT_SOURCE_DIR}/examples/atv21-atv58.toml ${PROJECT_SOURCE_DIR}/examples/gpio.toml
              ${PROJECT_SOURCE_DIR}/examples/sim.toml
        DESTINATION ${CMAKE_INSTALL_DOCDIR}/examples)

# The default /etc/drivebus/drivebusd.toml: the real-board example (sim.toml names a pty of the
# simulator), with a first line that says where it came from. A conffile in the package, so an
# edited copy survives upgrades.
file(READ ${PROJECT_SOURCE_DIR}/examples/atv21-atv58.toml example)
file(WRITE ${PROJECT_BINARY_DIR}/package/drivebusd.toml
     "# ${DRIVEBUS_CONFDIR}/drivebusd.toml: the example atv21-atv58.toml; edit it for this board\n"
     "# (drivebusd.toml(5)), then: drivebusd --config ${DRIVEBUS_CONFDIR}/drivebusd.toml --check-config\n"
     "#\n${example}")
set_property(DIRECTORY APPEND PROPERTY CMAKE_CONFIGURE_DEPENDS ${PROJECT_SOURCE_DIR}/examples/atv21-atv58.toml)
install(FILES ${PROJECT_BINARY_DIR}/package/drivebusd.toml DESTINATION ${DRIVEBUS_CONFDIR} COMPONENT deploy)
# The directory of its fragments (drivebusd.toml(5)), empty: one [[bus]] per file, added by the
# administrator or a configuration tool.
install(DIRECTORY DESTINATION ${DRIVEBUS_CONFDIR}/drivebusd.d COMPONENT deploy)

# --- The .deb -----------------------------------------------------------------------------
set(CPACK_GENERATOR DEB)
set(CPACK_PACKAGE_NAME drivebus)
set(CPACK_PACKAGE_VERSION ${PROJECT_VERSION})
set(CPACK_PACKAGE_CONTACT "drivebus developers <drivebus@localhost>")
set(CPACK_DEBIAN_PACKAGE_MAINTAINER "${CPACK_PACKAGE_CONTACT}")
set(CPACK_PACKAGE_DESCRIPTION_SUMMARY "Modbus RTU master for Altivar drives on RS485 lines")
set(CPACK_DEBIAN_PACKAGE_DESCRIPTION "drivebusd owns the RS485 lines of an industrial Linux board at real-time priority, frames
Modbus RTU by the exact 1.5 and 3.5 character silences, polls Schneider Altivar 21 and
Altivar 58 drives (or any Modbus RTU slave described by a profile) and shares their
registers with local applications through iceoryx shared memory.
.
The package holds drivebusd with its systemd units, udev rules and sysusers.d file,
drivebus-sim (simulated drives on a pty, for trying a master without hardware), the drive
profiles, and drivebusctl with libdrivebus when they are built.")
set(CPACK_DEBIAN_PACKAGE_SECTION misc)
set(CPACK_DEBIAN_PACKAGE_PRIORITY optional)
set(CPACK_DEBIAN_FILE_NAME DEB-DEFAULT)
set(CPACK_PACKAGING_INSTALL_PREFIX "${CMAKE_INSTALL_PREFIX}")
set(CPACK_STRIP_FILES ON)
# Library dependencies from the binaries themselves (dpkg-shlibdeps). libdrivebus, in this
# package, is looked up in its build directory.
set(CPACK_DEBIAN_PACKAGE_SHLIBDEPS ON)
if(TARGET drivebus)
  get_target_property(libdir drivebus BINARY_DIR)
  set(CPACK_DEBIAN_PACKAGE_SHLIBDEPS_PRIVATE_DIRS "${libdir}")
endif()
# systemd-sysusers (or, without systemd, adduser) creates the user in postinst.
set(CPACK_DEBIAN_PACKAGE_DEPENDS "systemd | adduser")
# The system RouDi of drivebus-roudi.service; drivebusd embeds its own without it.
set(CPACK_DEBIAN_PACKAGE_RECOMMENDS iceoryx)

# Maintainer scripts, and the conffiles: everything the package puts in /etc.
file(WRITE ${PROJECT_BINARY_DIR}/package/conffiles
     "${DRIVEBUS_CONFDIR}/drivebusd.toml\n${DRIVEBUS_CONFDIR}/roudi.toml\n")
set(CPACK_DEBIAN_PACKAGE_CONTROL_EXTRA
    ${PROJECT_SOURCE_DIR}/cmake/deb/postinst ${PROJECT_SOURCE_DIR}/cmake/deb/prerm
    ${PROJECT_SOURCE_DIR}/cmake/deb/postrm ${PROJECT_BINARY_DIR}/package/conffiles)
# libdrivebus in /usr/lib/<multiarch>: ldconfig through dpkg's trigger, as debhelper does (CPack
# adds its own ldconfig calls only to maintainer scripts it generates, not to ours).
if(TARGET drivebus)
  file(WRITE ${PROJECT_BINARY_DIR}/package/triggers "activate-noawait ldconfig\n")
  list(APPEND CPACK_DEBIAN_PACKAGE_CONTROL_EXTRA ${PROJECT_BINARY_DIR}/package/triggers)
endif()
set(CPACK_DEBIAN_PACKAGE_CONTROL_STRICT_PERMISSION ON)

include(CPack)
