# SPDX-License-Identifier: Apache-2.0
# The install rules of what has no CMakeLists.txt of its own (man pages, examples, documents,
# the licence, the default configuration). The Debian packages (debian/, built with
# `dpkg-buildpackage -us -uc -b`) split what `cmake --install` puts under DESTDIR between them.
#
# Included at the end of the top-level CMakeLists.txt, so that every target is known here.
# The binaries carry the profile directory and the units carry the paths of drivebusd and
# /etc/drivebus, all under CMAKE_INSTALL_PREFIX: the packages need the default, /usr. See
# docs/deployment.md.

if(NOT CMAKE_INSTALL_PREFIX STREQUAL "/usr")
  message(STATUS "install: CMAKE_INSTALL_PREFIX is ${CMAKE_INSTALL_PREFIX}; the Debian packages want /usr")
endif()

# drivebusctl and libdrivebus (client/): the library installs itself, with its headers, CMake
# package files and drivebus.pc.
if(TARGET drivebusctl)
  install(TARGETS drivebusctl RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})
endif()

# Man pages, by the section in their file name.
foreach(page drivebusd.8 drivebusd.toml.5 drivebusctl.1 drivebus-sim.1 drivebus-gateway.8 drivebus-mqtt.1)
  string(REGEX MATCH "[0-9]$" section "${page}")
  install(FILES ${PROJECT_SOURCE_DIR}/man/${page} DESTINATION ${CMAKE_INSTALL_MANDIR}/man${section})
endforeach()

# Documents and examples (docs/deployment.md is installed with the units, systemd/).
file(GLOB docs ${PROJECT_SOURCE_DIR}/docs/*.md)
list(REMOVE_ITEM docs ${PROJECT_SOURCE_DIR}/docs/deployment.md)
install(FILES ${PROJECT_SOURCE_DIR}/README.md ${docs} DESTINATION ${CMAKE_INSTALL_DOCDIR})
# The licence in Debian's machine-readable form (DEP-5): the one file debian/copyright, which
# every package also carries as /usr/share/doc/PACKAGE/copyright.
install(FILES ${PROJECT_SOURCE_DIR}/debian/copyright DESTINATION ${CMAKE_INSTALL_DOCDIR})
install(FILES ${PROJECT_SOURCE_DIR}/examples/atv21-atv58.toml ${PROJECT_SOURCE_DIR}/examples/gpio.toml
              ${PROJECT_SOURCE_DIR}/examples/sim.toml ${PROJECT_SOURCE_DIR}/examples/mqtt.toml
        DESTINATION ${CMAKE_INSTALL_DOCDIR}/examples)

# The default /etc/drivebus/drivebusd.toml: the real-board example (sim.toml names a pty of the
# simulator), with a first line that says where it came from. A conffile of the package
# drivebusd, so an edited copy survives upgrades.
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
