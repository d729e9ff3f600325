# SPDX-License-Identifier: BSD-3-Clause
# vm_probe(NAME RESULT WHY [cmake args...]): configures and builds cmake/probe/NAME in
# ${CMAKE_BINARY_DIR}/probe/NAME with this build's C compiler. RESULT is ON when both steps
# succeed; otherwise OFF, and WHY holds the first error line, for the one status line that
# says why an optional part is off. A probe that fails never fails the configure.
function(vm_probe name result why)
  set(dir ${CMAKE_BINARY_DIR}/probe/${name})
  file(REMOVE_RECURSE ${dir})
  execute_process(
    COMMAND ${CMAKE_COMMAND} -S ${CMAKE_SOURCE_DIR}/cmake/probe/${name} -B ${dir}
            -DCMAKE_C_COMPILER=${CMAKE_C_COMPILER} -DCMAKE_BUILD_TYPE=Release ${ARGN}
    RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(rc EQUAL 0)
    execute_process(COMMAND ${CMAKE_COMMAND} --build ${dir}
                    RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
    set(step "does not build")
  else()
    set(step "not found or not usable")
  endif()
  if(rc EQUAL 0)
    set(${result} ON PARENT_SCOPE)
    set(${why} "" PARENT_SCOPE)
    return()
  endif()
  set(${result} OFF PARENT_SCOPE)
  # the first error of the log on one line: "CMake Error at/in PLACE:" prefixes dropped,
  # CMake's list of possible reasons cut off
  set(text "${err}")
  if(text STREQUAL "")
    set(text "${out}")
  endif()
  string(REGEX REPLACE "[ \t\r\n]+" " " text "${text}")
  string(FIND "${text}" "CMake Error" at)
  if(at GREATER -1)
    string(SUBSTRING "${text}" ${at} -1 text)
    string(FIND "${text}" ": " colon)
    math(EXPR colon "${colon} + 2")
    string(SUBSTRING "${text}" ${colon} -1 text)
  endif()
  string(FIND "${text}" " CMake Error" next)
  if(next GREATER -1)
    string(SUBSTRING "${text}" 0 ${next} text)
  endif()
  set(first "${text}")
  string(REGEX REPLACE " (Possible reasons|Call Stack).*$" "" first "${first}")
  string(STRIP "${first}" first)
  string(SUBSTRING "${first}" 0 160 first)
  set(${why} "${step}: ${first}" PARENT_SCOPE)
endfunction()
