# Driven by CTest (see tests/CMakeLists.txt): install aerovo into a scratch prefix, check what is
# installed (no test helper, no internal target, no library path of a dependency; the version
# header, aerovo.pc, the bash completion, the man page when help2man is there), then build and
# run a tiny consumer with find_package(aerovo) and with pkg-config. Fails on the first step that
# fails. Arguments: BUILD_DIR PREFIX CONSUMER_SRC CONSUMER_BUILD CXX VERSION MAN_PAGE (ON/OFF).
function(run_step)
  execute_process(COMMAND ${ARGN} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "step failed (${rc}): ${ARGN}\n${out}\n${err}")
  endif()
  set(LAST_OUTPUT "${out}" PARENT_SCOPE)
endfunction()
function(check_output what)
  if(NOT LAST_OUTPUT MATCHES "aerovo ${VERSION}, keypoints: [1-9]")
    message(FATAL_ERROR "${what} consumer ran but did not print the version and keypoints:\n"
      "${LAST_OUTPUT}")
  endif()
  message(STATUS "${what}: ${LAST_OUTPUT}")
endfunction()

file(REMOVE_RECURSE ${PREFIX} ${CONSUMER_BUILD})
run_step(${CMAKE_COMMAND} --install ${BUILD_DIR} --prefix ${PREFIX})

# What is installed.
file(GLOB_RECURSE _headers RELATIVE ${PREFIX}/include ${PREFIX}/include/*.h)
foreach(h ${_headers})
  if(h MATCHES "test_util|testing\\.h$")
    message(FATAL_ERROR "test helper installed: include/${h}")
  endif()
endforeach()
if(NOT EXISTS ${PREFIX}/include/aerovo/version.h)
  message(FATAL_ERROR "include/aerovo/version.h not installed")
endif()
file(GLOB_RECURSE _cmake_files ${PREFIX}/*.cmake)
foreach(f ${_cmake_files})
  file(READ ${f} _text)
  if(_text MATCHES "aerovo_warnings")
    message(FATAL_ERROR "${f} exports the internal target aerovo_warnings")
  endif()
  if(_text MATCHES "/usr/lib[^ \"]*\\.(so|a)")
    message(FATAL_ERROR "${f} hard-codes a library path: ${CMAKE_MATCH_0}")
  endif()
endforeach()
file(GLOB_RECURSE _pc ${PREFIX}/*/aerovo.pc)
if(NOT _pc)
  message(FATAL_ERROR "aerovo.pc not installed")
endif()
get_filename_component(_pc_dir ${_pc} DIRECTORY)
if(NOT EXISTS ${PREFIX}/share/bash-completion/completions/aerovo)
  message(FATAL_ERROR "share/bash-completion/completions/aerovo not installed")
endif()
if(MAN_PAGE AND NOT EXISTS ${PREFIX}/share/man/man1/aerovo.1)
  message(FATAL_ERROR "share/man/man1/aerovo.1 not installed")
endif()

# find_package(aerovo).
run_step(${CMAKE_COMMAND} -S ${CONSUMER_SRC} -B ${CONSUMER_BUILD} -DCMAKE_PREFIX_PATH=${PREFIX}
         -DCMAKE_BUILD_TYPE=Release -DCMAKE_CXX_COMPILER=${CXX})
run_step(${CMAKE_COMMAND} --build ${CONSUMER_BUILD})
run_step(${CONSUMER_BUILD}/consumer)
check_output("find_package")

# pkg-config: c++ main.cc $(pkg-config --cflags --libs aerovo).
set(ENV{PKG_CONFIG_PATH} ${_pc_dir})
run_step(pkg-config --cflags --libs aerovo)
string(STRIP "${LAST_OUTPUT}" _flags)
separate_arguments(_flags UNIX_COMMAND "${_flags}")
run_step(${CXX} -std=c++17 -O1 ${CONSUMER_SRC}/main.cc ${_flags} -o ${CONSUMER_BUILD}/consumer_pc)
run_step(${CONSUMER_BUILD}/consumer_pc)
check_output("pkg-config")

# The installed program finds its image I/O plugin (<libdir>/aerovo; src/aerovo/imageio/image_io.h)
# beside itself at this prefix, which is not the one the build was configured for, and reads a
# PNG through it: the dynamic loader's log (LD_DEBUG=files) names the plugin it loaded.
file(GLOB_RECURSE _plugin ${PREFIX}/*/aerovo/libaerovo_imageio_opencv.so)
if(NOT _plugin)
  message(FATAL_ERROR "the image I/O plugin is not installed in <libdir>/aerovo")
endif()
get_filename_component(_png ${CONSUMER_SRC}/../../docs/map_fixes_tampa.png ABSOLUTE)
execute_process(COMMAND ${CMAKE_COMMAND} -E env LD_DEBUG=files
    ${PREFIX}/bin/aerovo features detect ${_png} --threads 1
  RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT rc EQUAL 0 OR NOT out MATCHES "[1-9][0-9]* keypoints")
  message(FATAL_ERROR "installed aerovo features detect ${_png} failed (${rc}):\n${out}\n${err}")
endif()
string(FIND "${err}" "file=${_plugin} " _at)
if(_at EQUAL -1)
  message(FATAL_ERROR "installed aerovo did not load the installed plugin ${_plugin}")
endif()
message(STATUS "installed aerovo: ${out}")
