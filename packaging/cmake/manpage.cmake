# Makes one man page with help2man from a built program's --help, gzipped
# (gzip -9n, as Debian wants). Run by the `man` target of
# cmake/Packaging.cmake:
#   cmake -DHELP2MAN=... -DNAME=sweepscan-cli -DEXE=/path/to/sweepscan-cli
#         [-DEMULATOR=qemu-aarch64-static|-L|/] -DVERSION=0.1.0
#         -DDESCRIPTION="..." [-DINCLUDE=file.h2m] -DOUTPUT=man/sweepscan-cli.1.gz
#         -P manpage.cmake
# EMULATOR is CMAKE_CROSSCOMPILING_EMULATOR with '|' for ';' (a cross-built
# program runs through it, as CMake runs a target in a custom command).
# The version comes from VERSION, so a program needs no --version.
cmake_minimum_required(VERSION 3.19)

foreach(var HELP2MAN NAME EXE VERSION DESCRIPTION OUTPUT)
  if(NOT DEFINED ${var} OR "${${var}}" STREQUAL "")
    message(FATAL_ERROR "manpage.cmake: ${var} is not set")
  endif()
endforeach()

set(work "${OUTPUT}.work")
file(REMOVE_RECURSE "${work}")
file(MAKE_DIRECTORY "${work}")

# help2man names the page after the program it runs: a wrapper of that name
# runs the real one (through the emulator when cross-compiling).
string(REPLACE "|" ";" emulator "${EMULATOR}")
set(command "")
foreach(arg IN LISTS emulator ITEMS "${EXE}")
  string(REPLACE "'" "'\\''" arg "${arg}")
  string(APPEND command " '${arg}'")
endforeach()
set(wrapper "${work}/${NAME}")
file(WRITE "${wrapper}" "#!/bin/sh\n# help2man's view of ${NAME}\nexec${command} \"$@\"\n")
file(CHMOD "${wrapper}" PERMISSIONS OWNER_READ OWNER_WRITE OWNER_EXECUTE GROUP_READ GROUP_EXECUTE)

set(include_args "")
if(DEFINED INCLUDE AND NOT INCLUDE STREQUAL "")
  set(include_args "--include=${INCLUDE}")
endif()

# No display for the desktop app's --help; a fixed locale for the text.
execute_process(
  COMMAND ${CMAKE_COMMAND} -E env --unset=DISPLAY --unset=WAYLAND_DISPLAY LC_ALL=C.UTF-8
          QT_QPA_PLATFORM=offscreen
          "${HELP2MAN}" --no-info --no-discard-stderr --section=1
          "--version-string=${VERSION}" "--name=${DESCRIPTION}" ${include_args}
          "--output=${work}/${NAME}.1" "${wrapper}"
  RESULT_VARIABLE result
  OUTPUT_VARIABLE output
  ERROR_VARIABLE output)
if(NOT result EQUAL 0 OR NOT EXISTS "${work}/${NAME}.1")
  message(FATAL_ERROR "help2man failed for ${NAME} (${result}):\n${output}")
endif()

# The program prints its own path in "Usage: PATH [options]": the name only.
file(READ "${work}/${NAME}.1" page)
string(REPLACE "${EXE}" "${NAME}" page "${page}")
string(REPLACE "${wrapper}" "${NAME}" page "${page}")
file(WRITE "${work}/${NAME}.1" "${page}")

execute_process(COMMAND gzip -9nf "${work}/${NAME}.1" RESULT_VARIABLE result)
if(NOT result EQUAL 0)
  message(FATAL_ERROR "gzip failed for ${work}/${NAME}.1")
endif()
file(RENAME "${work}/${NAME}.1.gz" "${OUTPUT}")
file(REMOVE_RECURSE "${work}")
