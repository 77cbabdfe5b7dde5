# Test targets. Build them with the target `tests`, run them with ctest (README.md).
find_package(GTest REQUIRED)
if(NOT TARGET tests)
  add_custom_target(tests)
endif()

set(SDS_TEST_DATA_DIR ${PROJECT_SOURCE_DIR}/test/data)
set(SDS_TEST_OUTPUT_DIR ${CMAKE_BINARY_DIR}/test_output)
file(MAKE_DIRECTORY ${SDS_TEST_OUTPUT_DIR})

# One gtest program per core module (test/<module>/*.cpp), linked against the core only.
foreach(module ${SDS_CORE_MODULES})
  file(GLOB test_sources CONFIGURE_DEPENDS ${PROJECT_SOURCE_DIR}/test/${module}/*.cpp)
  if(NOT test_sources)
    continue()
  endif()
  set(target test_core_${module})
  add_executable(${target} EXCLUDE_FROM_ALL ${test_sources})
  target_link_libraries(${target} scale_drift_slam_core GTest::gtest GTest::gtest_main)
  target_compile_definitions(${target} PRIVATE
    SDS_TEST_DATA_DIR="${SDS_TEST_DATA_DIR}" SDS_TEST_OUTPUT_DIR="${SDS_TEST_OUTPUT_DIR}")
  add_dependencies(tests ${target})
  add_test(NAME ${target} COMMAND ${target}
           --gtest_output=xml:${SDS_TEST_OUTPUT_DIR}/${target}.xml)
  set_tests_properties(${target} PROPERTIES LABELS "core")
endforeach()

# The core must stay ROS-free: no ROS include in its sources, no ROS library in its link line.
file(GENERATE OUTPUT ${CMAKE_BINARY_DIR}/core_link_libraries.txt
     CONTENT "$<TARGET_PROPERTY:scale_drift_slam_core,LINK_LIBRARIES>\n")
string(REPLACE ";" "," sds_core_modules_csv "${SDS_CORE_MODULES}")
add_test(NAME core_is_ros_free
         COMMAND ${CMAKE_COMMAND}
                 -DSOURCE_DIR=${PROJECT_SOURCE_DIR}
                 -DMODULES=${sds_core_modules_csv}
                 -DLINK_FILE=${CMAKE_BINARY_DIR}/core_link_libraries.txt
                 -DCORE_LIBRARY=$<TARGET_FILE:scale_drift_slam_core>
                 -P ${PROJECT_SOURCE_DIR}/cmake/check_core_ros_free.cmake)
set_tests_properties(core_is_ros_free PROPERTIES LABELS "core")

# One-way layering of the modules (doc/architecture.md): no include goes up.
add_test(NAME layering
         COMMAND ${CMAKE_COMMAND} -DSOURCE_DIR=${PROJECT_SOURCE_DIR}
                 -P ${PROJECT_SOURCE_DIR}/cmake/check_layering.cmake)
set_tests_properties(layering PROPERTIES LABELS "core")

# ROS-layer tests (gtest without a master) and integration tests (rostest).
file(GLOB ros_test_sources CONFIGURE_DEPENDS ${PROJECT_SOURCE_DIR}/test/ros/*.cpp)
if(ros_test_sources)
  catkin_add_gtest(test_ros_layer ${ros_test_sources})
  target_link_libraries(test_ros_layer scale_drift_slam_ros ${GTEST_MAIN_LIBRARIES})
  target_compile_definitions(test_ros_layer PRIVATE SDS_TEST_DATA_DIR="${SDS_TEST_DATA_DIR}")
endif()

find_package(rostest REQUIRED)
file(GLOB rostest_files CONFIGURE_DEPENDS ${PROJECT_SOURCE_DIR}/test/rostest/*.test)
foreach(rostest_file ${rostest_files})
  add_rostest(${rostest_file})
endforeach()

# Tests of the command-line tools and scripts (test/tools/*.sh), run with the devel environment.
file(GLOB tool_tests CONFIGURE_DEPENDS ${PROJECT_SOURCE_DIR}/test/tools/test_*.sh)
foreach(tool_test ${tool_tests})
  get_filename_component(name ${tool_test} NAME_WE)
  add_test(NAME tool_${name}
           COMMAND ${CATKIN_DEVEL_PREFIX}/env.sh bash ${tool_test}
           WORKING_DIRECTORY ${SDS_TEST_OUTPUT_DIR})
  set_tests_properties(tool_${name} PROPERTIES LABELS "tools"
    ENVIRONMENT "SDS_BIN_DIR=${CATKIN_DEVEL_PREFIX}/lib/${PROJECT_NAME};SDS_TEST_DATA_DIR=${SDS_TEST_DATA_DIR};SDS_TEST_OUTPUT_DIR=${SDS_TEST_OUTPUT_DIR}")
endforeach()

# Benchmarks (test/bench/bench_<name>.cpp): built by the target `benchmarks`, run by scripts/bench,
# never by ctest. They measure; they assert nothing about time.
add_custom_target(benchmarks)
file(GLOB bench_sources CONFIGURE_DEPENDS ${PROJECT_SOURCE_DIR}/test/bench/bench_*.cpp)
foreach(bench_source ${bench_sources})
  get_filename_component(name ${bench_source} NAME_WE)
  add_executable(${name} EXCLUDE_FROM_ALL ${bench_source})
  target_link_libraries(${name} scale_drift_slam_core)
  target_include_directories(${name} PRIVATE ${PROJECT_SOURCE_DIR}/test/bench)
  target_compile_definitions(${name} PRIVATE SDS_TEST_DATA_DIR="${SDS_TEST_DATA_DIR}")
  add_dependencies(benchmarks ${name})
endforeach()
# bench_tracking runs the run_sequence tool.
if(TARGET bench_tracking)
  add_dependencies(bench_tracking run_sequence)
endif()

# Two machines (issue 20, test/twohosts/two_hosts.sh): the robot's and the base station's nodes in
# two network namespaces over a shaped veth link; once as is, once with a 5 s outage mid-run.
# Needs root (network namespaces): exits 77, reported as skipped, where it cannot make them.
foreach(variant shaped outage)
  set(arguments "")
  if(variant STREQUAL "outage")
    set(arguments --outage 5)
  endif()
  add_test(NAME twohosts_${variant}
           COMMAND ${CATKIN_DEVEL_PREFIX}/env.sh bash ${PROJECT_SOURCE_DIR}/test/twohosts/two_hosts.sh
                   ${arguments}
           WORKING_DIRECTORY ${SDS_TEST_OUTPUT_DIR})
  # RUN_SERIAL: each runs a whole SLAM stack in real time (30 Hz bag) plus the link emulator; two
  # of them at once on the 2-core CI machine starve the tracking node of CPU (the tracker then fell
  # behind and was lost for ~85 frames in 2 of 8 runs), which is not what these tests are about.
  set_tests_properties(twohosts_${variant} PROPERTIES LABELS "rostest" SKIP_RETURN_CODE 77
    RUN_SERIAL TRUE ENVIRONMENT "SDS_TEST_OUTPUT_DIR=${SDS_TEST_OUTPUT_DIR}")
endforeach()
