# Runs tests/evaluation/make_craniotomy.py into OUT and compares it with scenes/craniotomy.json.
execute_process(COMMAND ${PYTHON} ${SOURCE_DIR}/tests/evaluation/make_craniotomy.py ${OUT}
                RESULT_VARIABLE rc ERROR_VARIABLE err)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "make_craniotomy.py failed (${rc}): ${err}")
endif()
execute_process(COMMAND ${CMAKE_COMMAND} -E compare_files ${OUT} ${SOURCE_DIR}/scenes/craniotomy.json RESULT_VARIABLE same)
if(NOT same EQUAL 0)
  message(FATAL_ERROR "scenes/craniotomy.json is not what tests/evaluation/make_craniotomy.py writes: "
                      "run it (it writes the scene) or change the generator to match the scene")
endif()
message(STATUS "scenes/craniotomy.json is make_craniotomy.py's output")
