# cmake -DCTEST=<ctest> -DBUILD_DIR=<build dir> -P check_listed_tests.cmake
# Fails naming every test of test_lists.cmake that the build dir does not register. With
# -DWHOLE_EXECUTABLES=ON (AEROVO_TEST_WHOLE_EXECUTABLES: the module unit tests run as one ctest
# test per executable, so their names are not registered) it only says which names it did not
# find; the builds registering every test (scripts/test.sh's Release stage) check them all.
cmake_minimum_required(VERSION 3.20)  # IN_LIST
include(${CMAKE_CURRENT_LIST_DIR}/test_lists.cmake)
execute_process(COMMAND ${CTEST} --test-dir ${BUILD_DIR} -N OUTPUT_VARIABLE _out
  RESULT_VARIABLE _rc)
if(NOT _rc EQUAL 0)
  message(FATAL_ERROR "ctest -N failed (${_rc}):\n${_out}")
endif()
string(REGEX MATCHALL "Test +#[0-9]+: [^\n]+" _lines "${_out}")
set(_names "")
foreach(_line ${_lines})
  string(REGEX REPLACE "^Test +#[0-9]+: " "" _name "${_line}")
  list(APPEND _names "${_name}")
endforeach()
set(_listed ${AEROVO_ACCURACY_TESTS} ${AEROVO_REPEATED_FLIGHT_TESTS})
list(LENGTH AEROVO_TEST_COSTS _n)
set(_i 0)
while(_i LESS _n)
  list(GET AEROVO_TEST_COSTS ${_i} _name)
  list(APPEND _listed ${_name})
  math(EXPR _i "${_i} + 2")
endwhile()
set(_missing "")
foreach(_name ${_listed})
  if(NOT _name IN_LIST _names)
    list(APPEND _missing ${_name})
  endif()
endforeach()
list(LENGTH _names _count)
if(_missing AND WHOLE_EXECUTABLES)
  list(JOIN _missing " " _missing)
  message(STATUS "not registered here (run inside whole test executables, or not at all): "
    "${_missing}")
elseif(_missing)
  list(JOIN _missing "\n  " _missing)
  message(FATAL_ERROR "cmake/ctest/test_lists.cmake names tests that ${BUILD_DIR} does not "
    "register (renamed or removed? update the list):\n  ${_missing}")
else()
  message(STATUS "every listed test is registered (${_count} tests)")
endif()
