# Regenerates a shipped robot's model from its robot file and the third-party URDF, and fails on
# any difference with the checked-in robot_model.hpp. The URDF is looked for beside the robot
# file, then in SHARED/robot and SHARED/robot/<name>; without it the check skips, saying so.
#   cmake -DGENERATOR=urdf2model -DROBOT_DIR=... -DSHARED=... -DOUT=... -P check_generated.cmake
file(STRINGS "${ROBOT_DIR}/robot.yaml" _urdf_line REGEX "^urdf:")
string(REGEX REPLACE "^urdf:[ ]*([^ #]+).*$" "\\1" _urdf "${_urdf_line}")
get_filename_component(_name "${ROBOT_DIR}" NAME)
set(_found "")
foreach(_candidate "${ROBOT_DIR}/${_urdf}" "${SHARED}/robot/${_urdf}" "${SHARED}/robot/${_name}/${_urdf}")
  if(EXISTS "${_candidate}")
    set(_found "${_candidate}")
    break()
  endif()
endforeach()
if(NOT _found)
  message("skipped: no ${_urdf} beside ${ROBOT_DIR}/robot.yaml nor in ${SHARED}/robot (third-party URDFs stay there)")
  return()
endif()
execute_process(COMMAND "${GENERATOR}" "${ROBOT_DIR}/robot.yaml" "${OUT}" --urdf "${_found}" RESULT_VARIABLE rc)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "urdf2model failed (${rc})")
endif()
execute_process(COMMAND ${CMAKE_COMMAND} -E compare_files "${OUT}" "${ROBOT_DIR}/robot_model.hpp" RESULT_VARIABLE diff)
if(NOT diff EQUAL 0)
  message(FATAL_ERROR "${ROBOT_DIR}/robot_model.hpp is out of date with its robot file and ${_found}.\n"
                      "Regenerate: urdf2model ${ROBOT_DIR}/robot.yaml ${ROBOT_DIR}/robot_model.hpp --urdf ${_found}")
endif()
message("${_name}: robot_model.hpp is what urdf2model makes of robot.yaml and ${_found}")
