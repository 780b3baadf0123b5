# Installs the current dynamap build into a scratch prefix, then configures, builds and runs
# tests/consumer against it. Driven by the ctest test `test_consumer_project`:
#   cmake -DDYNAMAP_BUILD_DIR=... -DCONSUMER_SOURCE_DIR=... -DWORK_DIR=... -DCXX_COMPILER=...
#         -DCXX_FLAGS=... -DEXE_LINKER_FLAGS=... -DBUILD_TYPE=... -DGENERATOR=... -P run_consumer.cmake
foreach(var DYNAMAP_BUILD_DIR CONSUMER_SOURCE_DIR WORK_DIR CXX_COMPILER GENERATOR)
  if(NOT DEFINED ${var} OR "${${var}}" STREQUAL "")
    message(FATAL_ERROR "run_consumer.cmake: ${var} is required")
  endif()
endforeach()

set(prefix ${WORK_DIR}/prefix)
set(build ${WORK_DIR}/build)
file(REMOVE_RECURSE ${WORK_DIR})
file(MAKE_DIRECTORY ${WORK_DIR})

function(run_step what)
  execute_process(COMMAND ${ARGN} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "${what} failed (${rc}):\n${out}\n${err}")
  endif()
  message(STATUS "${what}: ok")
  set(last_output "${out}" PARENT_SCOPE)
endfunction()

run_step("install" ${CMAKE_COMMAND} --install ${DYNAMAP_BUILD_DIR} --prefix ${prefix})

# Same compiler, build type and (sanitizer) flags as the library, so the objects link together.
run_step("configure consumer" ${CMAKE_COMMAND} -S ${CONSUMER_SOURCE_DIR} -B ${build}
         -G ${GENERATOR}
         -DCMAKE_PREFIX_PATH=${prefix}
         -DCMAKE_CXX_COMPILER=${CXX_COMPILER}
         -DCMAKE_BUILD_TYPE=${BUILD_TYPE}
         "-DCMAKE_CXX_FLAGS=${CXX_FLAGS}"
         "-DCMAKE_EXE_LINKER_FLAGS=${EXE_LINKER_FLAGS}")
run_step("build consumer" ${CMAKE_COMMAND} --build ${build})

# The package must not point back into the build tree.
file(READ ${build}/CMakeCache.txt cache)
string(REGEX MATCH "dynamap_DIR:PATH=([^\n]*)" _ "${cache}")
set(found_dir "${CMAKE_MATCH_1}")
string(FIND "${found_dir}" "${prefix}/" at)
if(NOT at EQUAL 0)
  message(FATAL_ERROR "consumer found dynamap at '${found_dir}', not under ${prefix}")
endif()

run_step("run consumer" ${build}/app)
message(STATUS "${last_output}")
