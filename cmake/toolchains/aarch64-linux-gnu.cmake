# Cross-building sweepscan-robotd for the robot's arm64 computer (a Raspberry
# Pi 4/5 on Raspberry Pi OS or Debian 12) on a Debian 12 amd64 machine, with
# Debian's multiarch: the arm64 libraries (qtbase5-dev:arm64, ...) install
# beside the amd64 ones under /usr/lib/aarch64-linux-gnu, so the "sysroot" is
# / itself. scripts/build-arm64.sh installs what this needs and uses it.
set(CMAKE_SYSTEM_NAME Linux)
set(CMAKE_SYSTEM_PROCESSOR aarch64)
set(CMAKE_LIBRARY_ARCHITECTURE aarch64-linux-gnu)
set(CMAKE_C_COMPILER aarch64-linux-gnu-gcc)
set(CMAKE_CXX_COMPILER aarch64-linux-gnu-g++)

# Programs (moc, help2man, dpkg-shlibdeps) are the build machine's; libraries
# and their CMake packages are looked for in the arm64 multiarch folders
# first (find_* add lib/aarch64-linux-gnu from CMAKE_LIBRARY_ARCHITECTURE).
set(CMAKE_FIND_ROOT_PATH_MODE_PROGRAM NEVER)
set(CMAKE_PREFIX_PATH /usr/lib/aarch64-linux-gnu/cmake)
# pkg-config: the arm64 .pc files only (robotd looks nothing up with it since
# it stopped linking libsystemd, but a lookup must never find amd64 ones).
set(ENV{PKG_CONFIG_LIBDIR} /usr/lib/aarch64-linux-gnu/pkgconfig:/usr/share/pkgconfig)

# Running what was built (help2man's man pages, the end-to-end check): qemu's
# user-mode emulator. The arm64 loader and libraries are where multiarch put
# them (/lib/ld-linux-aarch64.so.1, /usr/lib/aarch64-linux-gnu), so qemu's
# library prefix (-L) is /.
find_program(SWEEPSCAN_QEMU_AARCH64 qemu-aarch64-static)
if(SWEEPSCAN_QEMU_AARCH64)
  set(CMAKE_CROSSCOMPILING_EMULATOR ${SWEEPSCAN_QEMU_AARCH64} -L /)
endif()
