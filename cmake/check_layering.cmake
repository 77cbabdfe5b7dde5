# Fails when a module includes a module above it (doc/architecture.md, "Layers"). Run by ctest as
# `layering`: cmake -DSOURCE_DIR=<package> -P check_layering.cmake
#
# Each module may include itself and the modules listed for it, nothing else. The layers, bottom up:
#   common, geometry <- map <- features <- {tracking, loop} <- mapping <- system
#   <- {io <- evaluation} <- sim <- ros <- {nodes, tools}
# mapping sits above loop because the mapper applies loop constraints with loop's Sim(3) pose graph
# and map correction; tracking and loop never include each other.
cmake_minimum_required(VERSION 3.10)
set(core_below_system common geometry map features tracking loop mapping)
set(allowed_common "")
set(allowed_geometry common)
set(allowed_map common geometry)
set(allowed_features common geometry map)
set(allowed_tracking common geometry map features)
set(allowed_loop common geometry map features)
set(allowed_mapping common geometry map features loop)
set(allowed_system ${core_below_system})
set(allowed_io ${core_below_system} system)
set(allowed_evaluation ${core_below_system} system io)
set(allowed_sim ${core_below_system} system io evaluation)
set(allowed_ros ${core_below_system} system io evaluation sim)
set(modules common geometry map features tracking loop mapping system io evaluation sim ros)

set(include_regex "#[ \t]*include[ \t]*[\"<](scale_drift_slam/|\\.\\./)([a-z_]+)/")
set(violations "")
set(checked 0)
foreach(module ${modules})
  file(GLOB_RECURSE files ${SOURCE_DIR}/include/scale_drift_slam/${module}/*.h
                          ${SOURCE_DIR}/src/${module}/*.h ${SOURCE_DIR}/src/${module}/*.cpp)
  foreach(file ${files})
    math(EXPR checked "${checked} + 1")
    file(STRINGS ${file} lines REGEX "${include_regex}")
    foreach(line ${lines})
      string(REGEX MATCH "${include_regex}" match "${line}")
      set(target ${CMAKE_MATCH_2})
      if(target STREQUAL module OR target IN_LIST allowed_${module})
        continue()
      endif()
      # Generated message headers (scale_drift_slam/Keyframe.h) are not modules.
      if(NOT target IN_LIST modules)
        continue()
      endif()
      file(RELATIVE_PATH relative ${SOURCE_DIR} ${file})
      list(APPEND violations "${relative}: ${module} must not include ${target} (${line})")
    endforeach()
  endforeach()
endforeach()

if(checked EQUAL 0)
  message(FATAL_ERROR "no source found under ${SOURCE_DIR}: wrong SOURCE_DIR?")
endif()
if(violations)
  list(JOIN violations "\n  " report)
  message(FATAL_ERROR "Includes against the layering (doc/architecture.md):\n  ${report}")
endif()
message(STATUS "layering holds in ${checked} files")
