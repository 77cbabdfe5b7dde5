# Fails when the ROS-free core (include/scale_drift_slam/<module>, src/<module>) includes a ROS
# header or links a ROS library. Run by ctest as `core_is_ros_free`.
set(forbidden_include
    "#[ \t]*include[ \t]*[<\"](ros|rosbag|tf2|tf2_ros|tf2_eigen|tf2_geometry_msgs|cv_bridge|image_transport|std_msgs|sensor_msgs|geometry_msgs|nav_msgs|visualization_msgs|message_filters|scale_drift_slam/ros|scale_drift_slam/[A-Z])[/.]")
string(REPLACE "," ";" MODULES "${MODULES}")
set(violations "")
foreach(module ${MODULES})
  file(GLOB_RECURSE files ${SOURCE_DIR}/include/scale_drift_slam/${module}/*
                          ${SOURCE_DIR}/src/${module}/*)
  foreach(file ${files})
    file(STRINGS ${file} lines REGEX "${forbidden_include}")
    foreach(line ${lines})
      list(APPEND violations "${file}: ${line}")
    endforeach()
  endforeach()
endforeach()

file(READ ${LINK_FILE} link_libraries)
if(link_libraries MATCHES "(roscpp|rosbag|tf2|cv_bridge|image_transport|catkin)")
  list(APPEND violations "scale_drift_slam_core links a ROS library: ${link_libraries}")
endif()

# The built library itself must not reference ROS symbols (namespace ros::, rosbag::, tf2::).
find_program(NM nm)
if(NM AND EXISTS ${CORE_LIBRARY})
  execute_process(COMMAND ${NM} -C ${CORE_LIBRARY} OUTPUT_VARIABLE symbols ERROR_QUIET)
  string(REGEX MATCH "[ (](ros|rosbag|tf2|cv_bridge)::[A-Za-z_]+" ros_symbol "${symbols}")
  if(ros_symbol)
    list(APPEND violations "scale_drift_slam_core references the ROS symbol '${ros_symbol}'")
  endif()
endif()

if(violations)
  list(JOIN violations "\n  " report)
  message(FATAL_ERROR "The core is not ROS-free:\n  ${report}")
endif()
message(STATUS "core is ROS-free: ${MODULES}")
