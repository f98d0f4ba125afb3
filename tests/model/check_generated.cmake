# Regenerates the model header from the URDF and fails on any difference.
execute_process(COMMAND "${GENERATOR}" "${URDF}" "${OUT}" RESULT_VARIABLE rc)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "urdf2model failed (${rc})")
endif()
execute_process(COMMAND ${CMAKE_COMMAND} -E compare_files "${OUT}" "${CHECKED_IN}" RESULT_VARIABLE diff)
if(NOT diff EQUAL 0)
  message(FATAL_ERROR "${CHECKED_IN} is out of date with ${URDF}.\n"
                      "Regenerate: urdf2model ${URDF} ${CHECKED_IN}")
endif()
