# Installation (cmake --install) and the Debian packages (cpack, DEB), in two
# components:
#   robotd       -> sweepscan-robotd_VERSION_ARCH.deb: the robot agent, its
#                   systemd service, /etc/sweepscan/robotd.conf, udev rules
#   workstation  -> sweepscan_VERSION_ARCH.deb: the desktop app, the CLI, the
#                   simulator, the renderer, the scenarios
# With SWEEPSCAN_ROBOT_ONLY (the arm64 cross-build) only robotd exists.
# Operator's guide: docs/deployment.md. Files installed from packaging/.
#
#   cmake --install build --prefix /tmp/x      # a plain installation
#   (cd build && cpack)                        # the .deb files; scripts/package.sh
#
# System files: with the prefix /usr (the packages) the configuration goes
# to /etc/sweepscan, the unit to /lib/systemd/system and the udev rules to
# /lib/udev/rules.d, as Debian 12's own packages do; with any other prefix P
# to P/etc/sweepscan, P/lib/systemd/system, P/lib/udev/rules.d, and the paths
# inside the unit and the configuration follow P. This is decided when
# installing (the prefix may be given then), hence install(CODE).

include(GNUInstallDirs)

set(SWEEPSCAN_PACKAGING_DIR "${PROJECT_SOURCE_DIR}/packaging")
set(CMAKE_INSTALL_DEFAULT_DIRECTORY_PERMISSIONS
    OWNER_READ OWNER_WRITE OWNER_EXECUTE GROUP_READ GROUP_EXECUTE WORLD_READ WORLD_EXECUTE)
set(_sweepscan_robotd_docdir "${CMAKE_INSTALL_DATAROOTDIR}/doc/sweepscan-robotd")
set(_sweepscan_workstation_docdir "${CMAKE_INSTALL_DATAROOTDIR}/doc/sweepscan")

# sweepscan_install_system_file(FILE COMPONENT KIND): KIND is sysconf
# (etc/sweepscan), unit (lib/systemd/system) or udev (lib/udev/rules.d),
# under / for the prefix /usr, else under the prefix (see above).
function(sweepscan_install_system_file file component kind)
  if(kind STREQUAL "sysconf")
    set(subdir "etc/sweepscan")
  elseif(kind STREQUAL "unit")
    set(subdir "lib/systemd/system")
  elseif(kind STREQUAL "udev")
    set(subdir "lib/udev/rules.d")
  else()
    message(FATAL_ERROR "sweepscan_install_system_file: unknown kind ${kind}")
  endif()
  get_filename_component(name "${file}" NAME)
  set(staged "${CMAKE_BINARY_DIR}/packaging/install/${name}")
  install(CODE "
    # ${name}: /${subdir} for the prefix /usr, else PREFIX/${subdir}.
    string(REGEX REPLACE \"/+$\" \"\" _sweepscan_prefix \"\${CMAKE_INSTALL_PREFIX}\")
    if(_sweepscan_prefix STREQUAL \"/usr\")
      set(_sweepscan_root \"\")
      set(_sweepscan_source \"${file}\")
    else()
      set(_sweepscan_root \"\${_sweepscan_prefix}\")
      # Paths inside the unit and the configuration follow the prefix.
      file(READ \"${file}\" _sweepscan_text)
      string(REPLACE \"/usr/bin/sweepscan-robotd\" \"\${_sweepscan_prefix}/${CMAKE_INSTALL_BINDIR}/sweepscan-robotd\"
             _sweepscan_text \"\${_sweepscan_text}\")
      string(REPLACE \"/etc/sweepscan/\" \"\${_sweepscan_prefix}/etc/sweepscan/\" _sweepscan_text \"\${_sweepscan_text}\")
      file(WRITE \"${staged}\" \"\${_sweepscan_text}\")
      set(_sweepscan_source \"${staged}\")
    endif()
    file(INSTALL DESTINATION \"\${_sweepscan_root}/${subdir}\" TYPE FILE
         PERMISSIONS OWNER_READ OWNER_WRITE GROUP_READ WORLD_READ
         FILES \"\${_sweepscan_source}\")
  " COMPONENT ${component})
endfunction()

# Debian wants changelogs gzipped without a time stamp (gzip -9n).
function(sweepscan_gzip_at_configure input output)
  execute_process(COMMAND gzip -9nc "${input}" OUTPUT_FILE "${output}" RESULT_VARIABLE result)
  if(NOT result EQUAL 0)
    message(FATAL_ERROR "gzip -9nc ${input} failed")
  endif()
endfunction()
file(MAKE_DIRECTORY "${CMAKE_BINARY_DIR}/packaging")
configure_file("${SWEEPSCAN_PACKAGING_DIR}/debian/changelog.in" "${CMAKE_BINARY_DIR}/packaging/changelog" @ONLY)
sweepscan_gzip_at_configure("${CMAKE_BINARY_DIR}/packaging/changelog" "${CMAKE_BINARY_DIR}/packaging/changelog.gz")

# ---------------------------------------------------------------------------
# Man pages: help2man runs each built program's --help (through
# CMAKE_CROSSCOMPILING_EMULATOR when cross-compiling) into
# ${CMAKE_BINARY_DIR}/man/NAME.1.gz; the target `man` is part of ALL.
# ---------------------------------------------------------------------------
find_program(SWEEPSCAN_HELP2MAN help2man)
set(SWEEPSCAN_MAN_PAGES ON)
if(NOT SWEEPSCAN_HELP2MAN)
  message(STATUS "help2man not found: no man pages (apt install help2man)")
  set(SWEEPSCAN_MAN_PAGES OFF)
elseif(CMAKE_CROSSCOMPILING AND NOT CMAKE_CROSSCOMPILING_EMULATOR)
  message(STATUS "Cross-compiling without CMAKE_CROSSCOMPILING_EMULATOR: no man pages")
  set(SWEEPSCAN_MAN_PAGES OFF)
endif()

set(_sweepscan_man_outputs "")
# sweepscan_man_page(TARGET COMPONENT DESCRIPTION [INCLUDE])
function(sweepscan_man_page target component description)
  if(NOT SWEEPSCAN_MAN_PAGES OR NOT TARGET ${target})
    return()
  endif()
  set(include "${SWEEPSCAN_PACKAGING_DIR}/man/see-also.h2m")
  if(ARGC GREATER 3)
    set(include "${ARGV3}")
  endif()
  set(emulator "")
  if(CMAKE_CROSSCOMPILING)
    string(REPLACE ";" "|" emulator "${CMAKE_CROSSCOMPILING_EMULATOR}")
  endif()
  set(output "${CMAKE_BINARY_DIR}/man/${target}.1.gz")
  add_custom_command(
    OUTPUT "${output}"
    COMMAND ${CMAKE_COMMAND} "-DHELP2MAN=${SWEEPSCAN_HELP2MAN}" "-DNAME=${target}"
            "-DEXE=$<TARGET_FILE:${target}>" "-DEMULATOR=${emulator}" "-DVERSION=${PROJECT_VERSION}"
            "-DDESCRIPTION=${description}" "-DINCLUDE=${include}" "-DOUTPUT=${output}"
            -P "${SWEEPSCAN_PACKAGING_DIR}/cmake/manpage.cmake"
    DEPENDS ${target} "${SWEEPSCAN_PACKAGING_DIR}/cmake/manpage.cmake" "${include}"
    COMMENT "Man page ${target}.1 (help2man)"
    VERBATIM)
  install(FILES "${output}" DESTINATION "${CMAKE_INSTALL_MANDIR}/man1" COMPONENT ${component})
  set(_sweepscan_man_outputs ${_sweepscan_man_outputs} "${output}" PARENT_SCOPE)
endfunction()

if(SWEEPSCAN_MAN_PAGES)
  file(MAKE_DIRECTORY "${CMAKE_BINARY_DIR}/man")
endif()
sweepscan_man_page(sweepscan-robotd robotd "robot agent of the sweepscan lidar scanning robot"
                   "${SWEEPSCAN_PACKAGING_DIR}/man/sweepscan-robotd.h2m")
sweepscan_man_page(sweepscan workstation "desktop workstation for mobile 2D-lidar 3D scanning")
sweepscan_man_page(sweepscan-cli workstation "process, reconstruct and evaluate sweepscan sessions headless")
sweepscan_man_page(sweepscan-sim workstation "simulated sweepscan robot behind byte-exact device emulations")
sweepscan_man_page(sweepscan-render workstation "render a PLY or PCD point cloud to a PNG image")
if(_sweepscan_man_outputs)
  add_custom_target(man ALL DEPENDS ${_sweepscan_man_outputs})
endif()

# ---------------------------------------------------------------------------
# Component robotd: the robot's computer.
# ---------------------------------------------------------------------------
if(TARGET sweepscan-robotd)
  install(TARGETS sweepscan-robotd RUNTIME DESTINATION "${CMAKE_INSTALL_BINDIR}" COMPONENT robotd)
  sweepscan_install_system_file("${SWEEPSCAN_PACKAGING_DIR}/robotd.conf" robotd sysconf)
  sweepscan_install_system_file("${SWEEPSCAN_PACKAGING_DIR}/systemd/sweepscan-robotd.service" robotd unit)
  sweepscan_install_system_file("${SWEEPSCAN_PACKAGING_DIR}/udev/60-sweepscan.rules" robotd udev)
  install(FILES "${SWEEPSCAN_PACKAGING_DIR}/udev/60-sweepscan-local.rules.example"
                "${SWEEPSCAN_PACKAGING_DIR}/debian/copyright"
                "${CMAKE_BINARY_DIR}/packaging/changelog.gz"
                "${PROJECT_SOURCE_DIR}/docs/deployment.md"
                "${PROJECT_SOURCE_DIR}/docs/robot-agent.md"
          DESTINATION "${_sweepscan_robotd_docdir}" COMPONENT robotd)
endif()

# ---------------------------------------------------------------------------
# Component workstation: the operator's computer.
# ---------------------------------------------------------------------------
set(_sweepscan_workstation_programs "")
foreach(program sweepscan sweepscan-cli sweepscan-sim sweepscan-render)
  if(TARGET ${program})
    list(APPEND _sweepscan_workstation_programs ${program})
  endif()
endforeach()
if(_sweepscan_workstation_programs)
  install(TARGETS ${_sweepscan_workstation_programs} RUNTIME DESTINATION "${CMAKE_INSTALL_BINDIR}"
          COMPONENT workstation)
  # The app looks for them in BINDIR/../share/sweepscan/scenarios.
  install(DIRECTORY "${PROJECT_SOURCE_DIR}/resources/scenarios/"
          DESTINATION "${CMAKE_INSTALL_DATADIR}/sweepscan/scenarios" COMPONENT workstation
          FILES_MATCHING PATTERN "*.json")
  install(FILES "${SWEEPSCAN_PACKAGING_DIR}/debian/copyright" "${CMAKE_BINARY_DIR}/packaging/changelog.gz"
          DESTINATION "${_sweepscan_workstation_docdir}" COMPONENT workstation)
endif()
if(TARGET sweepscan)
  install(FILES "${SWEEPSCAN_PACKAGING_DIR}/sweepscan.desktop"
          DESTINATION "${CMAKE_INSTALL_DATADIR}/applications" COMPONENT workstation)
  install(FILES "${SWEEPSCAN_PACKAGING_DIR}/icons/sweepscan.svg"
          DESTINATION "${CMAKE_INSTALL_DATADIR}/icons/hicolor/scalable/apps" COMPONENT workstation)
endif()

# ---------------------------------------------------------------------------
# CPack: one .deb per component.
# ---------------------------------------------------------------------------
set(CPACK_GENERATOR "DEB")
set(CPACK_PACKAGE_NAME "sweepscan")
set(CPACK_PACKAGE_VERSION "${PROJECT_VERSION}")
set(CPACK_PACKAGE_VENDOR "sweepscan developers")
set(CPACK_PACKAGE_CONTACT "sweepscan developers <sweepscan@localhost>")
set(CPACK_PACKAGING_INSTALL_PREFIX "/usr")
set(CPACK_STRIP_FILES ON)
set(CPACK_INSTALL_DEFAULT_DIRECTORY_PERMISSIONS ${CMAKE_INSTALL_DEFAULT_DIRECTORY_PERMISSIONS})
set(CPACK_DEB_COMPONENT_INSTALL ON)
if(SWEEPSCAN_ROBOT_ONLY)
  set(CPACK_COMPONENTS_ALL robotd)
else()
  set(CPACK_COMPONENTS_ALL robotd workstation)
endif()

set(CPACK_DEBIAN_FILE_NAME "DEB-DEFAULT")  # NAME_VERSION_ARCH.deb
set(CPACK_DEBIAN_PACKAGE_MAINTAINER "sweepscan developers <sweepscan@localhost>")
set(CPACK_DEBIAN_PACKAGE_PRIORITY "optional")
set(CPACK_DEBIAN_PACKAGE_SHLIBDEPS ON)
set(CPACK_DEBIAN_PACKAGE_CONTROL_STRICT_PERMISSION ON)
set(CPACK_DEBIAN_COMPRESSION_TYPE "xz")
# dpkg --print-architecture names the build machine's; a cross-build names
# the target's (dpkg-shlibdeps then finds the arm64 libraries installed by
# multiarch, e.g. libqt5core5a:arm64).
if(CMAKE_CROSSCOMPILING)
  if(CMAKE_SYSTEM_PROCESSOR MATCHES "^(aarch64|arm64|ARM64)$")
    set(CPACK_DEBIAN_PACKAGE_ARCHITECTURE "arm64")
  elseif(CMAKE_SYSTEM_PROCESSOR MATCHES "^(armv7.*|armhf|arm)$")
    set(CPACK_DEBIAN_PACKAGE_ARCHITECTURE "armhf")
  elseif(CMAKE_SYSTEM_PROCESSOR MATCHES "^(x86_64|AMD64|amd64)$")
    set(CPACK_DEBIAN_PACKAGE_ARCHITECTURE "amd64")
  else()
    message(WARNING "No Debian architecture known for ${CMAKE_SYSTEM_PROCESSOR}; "
                    "set CPACK_DEBIAN_PACKAGE_ARCHITECTURE")
  endif()
endif()

set(CPACK_DEBIAN_ROBOTD_PACKAGE_NAME "sweepscan-robotd")
set(CPACK_DEBIAN_ROBOTD_PACKAGE_SECTION "net")
# adduser: postinst makes the service's user.
set(CPACK_DEBIAN_ROBOTD_PACKAGE_DEPENDS "adduser")
set(CPACK_DEBIAN_ROBOTD_PACKAGE_CONTROL_EXTRA
    "${SWEEPSCAN_PACKAGING_DIR}/debian/robotd/postinst"
    "${SWEEPSCAN_PACKAGING_DIR}/debian/robotd/prerm"
    "${SWEEPSCAN_PACKAGING_DIR}/debian/robotd/postrm"
    "${SWEEPSCAN_PACKAGING_DIR}/debian/robotd/conffiles")
set(CPACK_DEBIAN_ROBOTD_DESCRIPTION
    "robot agent of the sweepscan lidar scanning robot
sweepscan-robotd runs on the computer of a sweepscan robot (a
differential-drive robot with a vertical YDLIDAR X4, a HI219 IMU and a
motor board). It streams the lidar, IMU and motor-board bytes to the
sweepscan workstation over an authenticated link (TCP with a pre-shared
key, or a serial line) and applies the workstation's drive commands within
speed and acceleration limits, with a watchdog that stops the motors when
the link goes quiet.

This package contains the agent, a hardened systemd service (not enabled
on installation), its configuration file /etc/sweepscan/robotd.conf and
udev rules that name the boards /dev/sweepscan/lidar, imu and motor. A
system user sweepscan and a random link key are made on installation.")

set(CPACK_DEBIAN_WORKSTATION_PACKAGE_NAME "sweepscan")
set(CPACK_DEBIAN_WORKSTATION_PACKAGE_SECTION "science")
set(CPACK_DEBIAN_WORKSTATION_DESCRIPTION
    "operator workstation for mobile 2D-lidar 3D scanning
sweepscan turns the scans of a 2D lidar standing vertically on a driving
robot into a 3D point cloud: every sample is placed at the robot's pose at
its own time (wheel odometry and IMU fused by an EKF), the lidar's
mounting error is calibrated, and the result is evaluated and kept as
sessions.

This package contains the desktop app (connect to the robot, drive, watch
the cloud grow, record, replay, export), the headless command-line tool
sweepscan-cli, the simulated robot sweepscan-sim with its scenarios, and
sweepscan-render (point cloud to PNG).")

include(CPack)
