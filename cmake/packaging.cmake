# Debian packages through CPack: `piezod` (the board: daemon, /etc/piezod.toml
# as a conffile, the systemd unit, its user) and, where the host is built,
# `piezo` (the host tools). `cpack -G DEB` in a build directory writes them.
include(GNUInstallDirs)

install(TARGETS piezod RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR} COMPONENT piezod)
# The board's config starts as the simulated rig: the service runs at once,
# touching no hardware, until the researcher names the real backends.
install(FILES ${PROJECT_SOURCE_DIR}/configs/piezod-sim.toml DESTINATION /etc
        RENAME piezod.toml COMPONENT piezod)
install(FILES ${PROJECT_SOURCE_DIR}/firmware/daemon/systemd/piezod.service
        DESTINATION lib/systemd/system COMPONENT piezod)
install(FILES ${PROJECT_SOURCE_DIR}/docs/protocol.md ${PROJECT_SOURCE_DIR}/docs/board.md
        ${PROJECT_SOURCE_DIR}/docs/configuration.md ${PROJECT_SOURCE_DIR}/docs/safety.md
        ${PROJECT_SOURCE_DIR}/docs/hardware.md
        DESTINATION ${CMAKE_INSTALL_DATAROOTDIR}/doc/piezod COMPONENT piezod)
install(FILES ${PROJECT_SOURCE_DIR}/configs/rig-example.toml
        DESTINATION ${CMAKE_INSTALL_DATAROOTDIR}/doc/piezod/examples COMPONENT piezod)
if(PIEZO_HOST)
  install(TARGETS piezo RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR} COMPONENT piezo)
  # Loaded by piezo when first needed (host/src/io/module_loader.hpp).
  install(TARGETS piezo_h5 piezo_rig_commands LIBRARY DESTINATION ${PIEZO_MODULE_DIR}
          COMPONENT piezo)
  if(TARGET piezo_mpi)
    install(TARGETS piezo_mpi LIBRARY DESTINATION ${PIEZO_MODULE_DIR} COMPONENT piezo)
  endif()
  file(GLOB guides ${PROJECT_SOURCE_DIR}/docs/*.md)
  install(FILES ${guides} DESTINATION ${CMAKE_INSTALL_DATAROOTDIR}/doc/piezo/docs COMPONENT piezo)
  install(DIRECTORY ${PROJECT_SOURCE_DIR}/docs/images
          DESTINATION ${CMAKE_INSTALL_DATAROOTDIR}/doc/piezo/docs COMPONENT piezo)
  install(FILES ${PROJECT_SOURCE_DIR}/README.md ${PROJECT_SOURCE_DIR}/CHANGELOG.md ${PROJECT_SOURCE_DIR}/configs/sim.toml
          ${PROJECT_SOURCE_DIR}/configs/modbus-hil.toml ${PROJECT_SOURCE_DIR}/configs/paper.toml
          DESTINATION ${CMAKE_INSTALL_DATAROOTDIR}/doc/piezo COMPONENT piezo)
endif()

set(CPACK_GENERATOR DEB)
set(CPACK_PACKAGE_NAME piezo-rig)
set(CPACK_PACKAGE_VERSION ${PROJECT_VERSION})
set(CPACK_PACKAGE_CONTACT "piezo-rig maintainers <piezo-rig@localhost>")
set(CPACK_PACKAGING_INSTALL_PREFIX /usr)
set(CPACK_DEB_COMPONENT_INSTALL ON)
set(CPACK_STRIP_FILES ON)
set(CPACK_DEBIAN_FILE_NAME DEB-DEFAULT)
set(CPACK_DEBIAN_PACKAGE_SHLIBDEPS ON)
set(CPACK_DEBIAN_PACKAGE_SECTION science)
if(CMAKE_SYSTEM_PROCESSOR STREQUAL "aarch64")
  set(CPACK_DEBIAN_PACKAGE_ARCHITECTURE arm64)
endif()
set(CPACK_COMPONENTS_ALL piezod)
if(PIEZO_HOST)
  list(APPEND CPACK_COMPONENTS_ALL piezo)
endif()
if(PIEZO_PYTHON)
  list(APPEND CPACK_COMPONENTS_ALL python)
endif()
set(CPACK_DEBIAN_PIEZOD_PACKAGE_NAME piezod)
set(CPACK_DEBIAN_PIEZOD_DESCRIPTION
    "piezo-rig board daemon: the drive-and-acquire firmware of a stick-slip piezo motor rig")
set(CPACK_DEBIAN_PIEZOD_PACKAGE_DEPENDS "passwd")
set(CPACK_DEBIAN_PIEZOD_PACKAGE_CONTROL_EXTRA
    ${PROJECT_SOURCE_DIR}/firmware/daemon/debian/conffiles
    ${PROJECT_SOURCE_DIR}/firmware/daemon/debian/postinst
    ${PROJECT_SOURCE_DIR}/firmware/daemon/debian/prerm
    ${PROJECT_SOURCE_DIR}/firmware/daemon/debian/postrm)
set(CPACK_DEBIAN_PIEZOD_PACKAGE_CONTROL_STRICT_PERMISSION ON)
set(CPACK_DEBIAN_PIEZO_PACKAGE_NAME piezo)
set(CPACK_DEBIAN_PIEZO_DESCRIPTION
    "piezo-rig host tools: runs, logs, observer, identification and sensitivity of the rig")
set(CPACK_DEBIAN_PIEZO_PACKAGE_DEPENDS "gnuplot-nox")
# piezo_rig for Debian's python3 (its module is built for that version).
set(CPACK_DEBIAN_PYTHON_PACKAGE_NAME python3-piezo-rig)
set(CPACK_DEBIAN_PYTHON_PACKAGE_SECTION python)
set(CPACK_DEBIAN_PYTHON_DESCRIPTION
    "piezo-rig from Python: the motor model, a piezod client and the run logs (piezo_rig)")
# piezo-tango, the Tango bridge, needs PyTango; the rest of the package not.
set(CPACK_DEBIAN_PYTHON_PACKAGE_RECOMMENDS "python3-tango")
set(CPACK_DEBIAN_PYTHON_PACKAGE_CONTROL_EXTRA ${PROJECT_SOURCE_DIR}/host/python/debian/prerm)
set(CPACK_DEBIAN_PYTHON_PACKAGE_CONTROL_STRICT_PERMISSION ON)
set(CPACK_DEBIAN_PYTHON_PACKAGE_DEPENDS
    "python3 (>= ${Python3_VERSION_MAJOR}.${Python3_VERSION_MINOR}), python3 (<< ${Python3_VERSION_MAJOR}.${Python3_VERSION_MINOR}.99), python3-numpy, python3-zmq, python3-msgpack, python3-h5py, python3-pandas")
include(CPack)
