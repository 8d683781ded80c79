# test_consumer and test_sobel_plugin: install the build tree to a scratch prefix, then
# configure, build and run an outside project against it (the one beside this script, or
# PROJECT_DIR), with weft's own compiler, generator, build type and sanitizer flags. Run as
#   cmake -DWEFT_BINARY_DIR=... -DWORK_DIR=... -DGENERATOR=... -DMAKE_PROGRAM=... -DCXX=... -DC=...
#         -DBUILD_TYPE=... [-DEXTRA_FLAGS=...] [-DPROJECT_DIR=...] [-DRUN=cmd|arg|...] -P run_consumer.cmake
# RUN is the check to run once built ('|'-separated; @BUILD@ is the project's build folder);
# by default the project's weft_consumer program. The scratch directory is made afresh each
# run and removed when the test passes.
foreach(var WEFT_BINARY_DIR WORK_DIR GENERATOR MAKE_PROGRAM CXX C)
  if(NOT DEFINED ${var} OR "${${var}}" STREQUAL "")
    message(FATAL_ERROR "run_consumer.cmake: -D${var}=... is required")
  endif()
endforeach()
set(prefix ${WORK_DIR}/prefix)
set(build ${WORK_DIR}/build)
if(NOT DEFINED PROJECT_DIR OR "${PROJECT_DIR}" STREQUAL "")
  set(PROJECT_DIR ${CMAKE_CURRENT_LIST_DIR})
endif()
if(NOT DEFINED RUN OR "${RUN}" STREQUAL "")
  set(RUN "@BUILD@/weft_consumer")
endif()
string(REPLACE "@BUILD@" "${build}" RUN "${RUN}")
string(REPLACE "|" ";" RUN "${RUN}")

function(run what)
  execute_process(COMMAND ${ARGN} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE out)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "consumer: ${what} failed (${rc}):\n${out}")
  endif()
  set(last_output "${out}" PARENT_SCOPE)
endfunction()

file(REMOVE_RECURSE ${WORK_DIR})
run("install to ${prefix}" ${CMAKE_COMMAND} --install ${WEFT_BINARY_DIR} --prefix ${prefix})
run("configure" ${CMAKE_COMMAND} -S ${PROJECT_DIR} -B ${build} -G ${GENERATOR}
    -DCMAKE_MAKE_PROGRAM=${MAKE_PROGRAM} -DCMAKE_CXX_COMPILER=${CXX} -DCMAKE_C_COMPILER=${C}
    -DCMAKE_BUILD_TYPE=${BUILD_TYPE} -DCMAKE_PREFIX_PATH=${prefix} -DCMAKE_FIND_USE_PACKAGE_REGISTRY=OFF
    "-DCMAKE_CXX_FLAGS=${EXTRA_FLAGS}" "-DCMAKE_EXE_LINKER_FLAGS=${EXTRA_FLAGS}")
# The package found must be the scratch install, not one elsewhere on the machine.
file(STRINGS ${build}/CMakeCache.txt found REGEX "^weft_DIR:")
string(REGEX REPLACE "^weft_DIR:[A-Z]*=" "" found "${found}")
file(REAL_PATH "${found}" found)
file(REAL_PATH "${prefix}" real_prefix)
string(FIND "${found}/" "${real_prefix}/" at)
if(NOT at EQUAL 0)
  message(FATAL_ERROR "consumer: found weft at '${found}', not in the scratch install ${prefix}")
endif()
run("build" ${CMAKE_COMMAND} --build ${build})
run("run" ${RUN})
message(STATUS "${last_output}")
file(REMOVE_RECURSE ${WORK_DIR})
