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
  ${PROJECT_SOURCE_DIR}/core/io/ros2/mcap_summary.cc
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

# The ROS 1 bag checks (core/io/rosbag1/rosbag1_check.h: the bounds walked
# before rosbag_storage reads a bag) on a bag image and on message bodies.
# bz2 and roslz4 stay uninstrumented. Seeds: tests/fuzz/corpus/rosbag1
# (ROS's own Python writer: none, bz2 and lz4 chunks).
find_package(BZip2 REQUIRED)
add_library(sweepscan_rosbag1_check_fuzz STATIC
  ${PROJECT_SOURCE_DIR}/core/io/rosbag1/rosbag1_check.cc
  ${PROJECT_SOURCE_DIR}/core/io/ros/ros_messages.cc)
target_link_libraries(sweepscan_rosbag1_check_fuzz PUBLIC sweepscan_base BZip2::BZip2 ${ROSLZ4_LIBRARY})
target_compile_options(sweepscan_rosbag1_check_fuzz PRIVATE
  -fsanitize=fuzzer-no-link,address,undefined -fno-sanitize-recover=undefined
  -fno-omit-frame-pointer -g)
add_executable(rosbag1_fuzz ${CMAKE_CURRENT_LIST_DIR}/rosbag1_fuzz.cc)
target_link_libraries(rosbag1_fuzz PRIVATE sweepscan_rosbag1_check_fuzz)
target_compile_options(rosbag1_fuzz PRIVATE ${SWEEPSCAN_FUZZ_FLAGS})
target_link_options(rosbag1_fuzz PRIVATE ${SWEEPSCAN_FUZZ_FLAGS})
file(MAKE_DIRECTORY ${CMAKE_CURRENT_BINARY_DIR}/corpus_rosbag1)
add_test(NAME rosbag1_fuzz_smoke
  COMMAND rosbag1_fuzz -runs=20000 -seed=1 ${CMAKE_CURRENT_BINARY_DIR}/corpus_rosbag1
          ${CMAKE_CURRENT_LIST_DIR}/corpus/rosbag1)
