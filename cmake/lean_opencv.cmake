# OpenCV's core, imgproc and video for the app of the lean GPU build (RETIMEGS_GPU_APP), as
# imported targets named as OpenCV's own CMake package names them. That package cannot be used
# there: it imports every module Debian builds and stops where one's library is missing, and a
# bare GPU machine is brought these three (scripts/gpu_bundle.sh --panoptic).
find_path(RETIMEGS_OPENCV_INCLUDE opencv2/core.hpp PATH_SUFFIXES opencv4 REQUIRED)
foreach(module core imgproc video)
  find_library(RETIMEGS_OPENCV_${module} opencv_${module} REQUIRED)
  add_library(opencv_${module} SHARED IMPORTED)
  set_target_properties(opencv_${module} PROPERTIES
                        IMPORTED_LOCATION "${RETIMEGS_OPENCV_${module}}"
                        INTERFACE_INCLUDE_DIRECTORIES "${RETIMEGS_OPENCV_INCLUDE}")
endforeach()
message(NOTICE "retimegs: the lean app's OpenCV: ${RETIMEGS_OPENCV_core} and its imgproc, video")
