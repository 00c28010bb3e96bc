# libFuzzer targets for the ROS 2 bag readers (core/io/ros2/): the CDR
# decoders and the MCAP reader (in-memory entry point). Included from
# tests/fuzz/CMakeLists.txt after its SWEEPSCAN_BUILD_FUZZERS / clang checks.
# The readers' sources are recompiled here with the fuzzer's coverage and
# sanitizer instrumentation (sweepscan_ros2 itself stays uninstrumented);
# zstd and lz4 come from core/io/ros2/CMakeLists.txt's pkg-config targets.
# Seed corpora: tests/fuzz/corpus/{mcap,cdr}, from scripts/make-ros2-test-bags.sh.
add_library(sweepscan_ros2_fuzz STATIC
  ${PROJECT_SOURCE_DIR}/core/io/ros2/cdr.cc
  ${PROJECT_SOURCE_DIR}/core/io/ros2/mcap.cc
  ${PROJECT_SOURCE_DIR}/core/io/ros2/mcap_records.cc
  ${PROJECT_SOURCE_DIR}/core/io/ros/ros_messages.cc)
target_link_libraries(sweepscan_ros2_fuzz PUBLIC sweepscan_base PkgConfig::SWEEPSCAN_ROS2_ZSTD
                      PkgConfig::SWEEPSCAN_ROS2_LZ4 PkgConfig::SWEEPSCAN_ROS2_ZLIB)
target_compile_options(sweepscan_ros2_fuzz PRIVATE
  -fsanitize=fuzzer-no-link,address,undefined -fno-sanitize-recover=undefined
  -fno-omit-frame-pointer -g)

foreach(name mcap cdr)
  set(target ${name}_fuzz)
  add_executable(${target} ${CMAKE_CURRENT_LIST_DIR}/${name}_fuzz.cc)
  target_link_libraries(${target} PRIVATE sweepscan_ros2_fuzz)
  target_compile_options(${target} PRIVATE ${SWEEPSCAN_FUZZ_FLAGS})
  target_link_options(${target} PRIVATE ${SWEEPSCAN_FUZZ_FLAGS})
  # Smoke run on the seed corpus; new inputs go to the scratch corpus (first).
  set(scratch_corpus ${CMAKE_CURRENT_BINARY_DIR}/corpus_${name})
  file(MAKE_DIRECTORY ${scratch_corpus})
  add_test(NAME ${target}_smoke
    COMMAND ${target} -runs=20000 -seed=1 ${scratch_corpus}
            ${CMAKE_CURRENT_LIST_DIR}/corpus/${name})
endforeach()
