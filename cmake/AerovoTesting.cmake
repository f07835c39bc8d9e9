# Test registration shared by the module test executables (aerovo_module in CMakeLists.txt) and
# the end-to-end tests (tests/CMakeLists.txt).
#
# gtest_discover_tests registers one ctest test per GoogleTest test, each run as its own process.
# A suite whose tests share one expensive fixture (SetUpTestSuite simulates or runs a flight)
# would then set the fixture up again for every test. The suites listed here are registered as
# one ctest test per suite instead (name: the suite's name; --gtest_filter=Suite.*, and for
# value-parameterised suites */Suite.*): the same tests run, the fixture once. A failure names
# the GoogleTest test in the output. Configuring fails when a listed suite is in no test source.
set(AEROVO_WHOLE_SUITE_TESTS
  CliOutputs            # tests/e2e/outputs_test.cc: a simulated 121-frame video flight
  GeoProducts           # tests/e2e/geo_products_test.cc: simulate, run and report a flight
  HtmlReport            # tests/e2e/html_report_test.cc: simulate, run and report flights
  CliSignal             # tests/e2e/cli_signal_test.cc: a simulated 301-frame flight
  ReferenceOutputs      # tests/e2e/reference_outputs_test.cc: a simulated flight
  ExperimentOnSimulatedFlight  # src/aerovo/pipeline/experiment_test.cc: a simulated flight
  OfflineOptimisation   # tests/e2e/offline_optimisation_test.cc: a simulated lawnmower, 4 runs
  OfflineOptimisationThreads  # the same file: the lawnmower with 1 and 2 threads, 6 runs
  MapFix                # tests/e2e/map_fix_test.cc: a simulated lawnmower over the Callas map
  MapBuild              # tests/e2e/map_test.cc: a simulated flight and the map built from it
  GpsDenied             # tests/e2e/gps_denied_test.cc: a simulated flight over built-in terrain
)

# aerovo_discover_tests(TARGET [gtest_discover_tests arguments...]): gtest_discover_tests for
# TARGET's tests except the listed suites found in its sources, which get one ctest test each.
# The arguments' PROPERTIES (ENVIRONMENT ...) apply to both.
# aerovo_whole_suites_of(TARGET OUT): the suites of AEROVO_WHOLE_SUITE_TESTS defined in TARGET's
# sources (TEST/TEST_F/TEST_P(Suite, ...)), each also recorded as found (aerovo_check_whole_suite_tests).
function(aerovo_whole_suites_of target out)
  get_target_property(_srcs ${target} SOURCES)
  get_target_property(_dir ${target} SOURCE_DIR)
  set(_suites "")
  foreach(_suite ${AEROVO_WHOLE_SUITE_TESTS})
    foreach(_src ${_srcs})
      if(NOT IS_ABSOLUTE "${_src}")
        set(_src "${_dir}/${_src}")
      endif()
      file(STRINGS "${_src}" _m REGEX "^TEST(_[FP])?\\(${_suite},")
      if(_m)
        list(APPEND _suites ${_suite})
        set_property(GLOBAL APPEND PROPERTY AEROVO_WHOLE_SUITES_FOUND ${_suite})
        break()
      endif()
    endforeach()
  endforeach()
  set(${out} ${_suites} PARENT_SCOPE)
endfunction()

# A test of a listed suite that cmake/ctest/test_lists.cmake labels ("accuracy",
# "repeated_flight") keeps its own ctest test, Suite.Test, so that ctest -LE leaves it out; the
# suite's test runs the others (--gtest_filter=Suite.*-Suite.Test:...).
function(aerovo_discover_tests target)
  cmake_parse_arguments(D "" "" "PROPERTIES" ${ARGN})
  include(${PROJECT_SOURCE_DIR}/cmake/ctest/test_lists.cmake)
  set(_filter "")
  aerovo_whole_suites_of(${target} _suites)
  foreach(_suite ${_suites})
    set(_suite_filter "${_suite}.*:*/${_suite}.*")
    set(_labelled "")
    foreach(_name ${AEROVO_ACCURACY_TESTS} ${AEROVO_REPEATED_FLIGHT_TESTS})
      if(_name MATCHES "^${_suite}\\.")
        list(APPEND _labelled ${_name})
      endif()
    endforeach()
    set(_run ${_suite_filter})
    if(_labelled)
      list(JOIN _labelled ":" _minus)
      set(_run "${_suite_filter}-${_minus}")
    endif()
    add_test(NAME ${_suite} COMMAND ${target} --gtest_filter=${_run})
    foreach(_name ${_labelled})
      add_test(NAME ${_name} COMMAND ${target} --gtest_filter=${_name})
    endforeach()
    if(D_PROPERTIES)
      set_tests_properties(${_suite} ${_labelled} PROPERTIES ${D_PROPERTIES})
    endif()
    list(APPEND _filter ${_suite_filter})
  endforeach()
  set(_args ${D_UNPARSED_ARGUMENTS})
  if(D_PROPERTIES)
    list(APPEND _args PROPERTIES ${D_PROPERTIES})
  endif()
  if(_filter)
    list(JOIN _filter ":" _filter)
    gtest_discover_tests(${target} TEST_FILTER "-${_filter}" ${_args})
  else()
    gtest_discover_tests(${target} ${_args})
  endif()
endfunction()

# aerovo_add_whole_executable_test(TARGET [PROPERTIES ...]): one ctest test, named TARGET, that
# runs every GoogleTest test of TARGET in one process, leaving out the tests labelled "accuracy"
# and "repeated_flight" (cmake/ctest/test_lists.cmake), which the builds using this mode do not
# run. For AEROVO_TEST_WHOLE_EXECUTABLES (the sanitizer stage of scripts/test.sh): under
# AddressSanitizer each test process costs about half a second of start-up, more than most unit
# tests take (BENCHMARKS.md, CI time). A failure names the GoogleTest test in the output; a
# sanitizer report ends the process, so the tests after it in that executable do not run.
function(aerovo_add_whole_executable_test target)
  cmake_parse_arguments(W "" "" "PROPERTIES" ${ARGN})
  include(${PROJECT_SOURCE_DIR}/cmake/ctest/test_lists.cmake)
  set(_out "")
  foreach(_name ${AEROVO_ACCURACY_TESTS} ${AEROVO_REPEATED_FLIGHT_TESTS})
    if(_name MATCHES "\\.")
      list(APPEND _out "${_name}")
    else()  # a whole suite registered as one test
      list(APPEND _out "${_name}.*" "*/${_name}.*")
    endif()
  endforeach()
  list(JOIN _out ":" _out)
  add_test(NAME ${target} COMMAND ${target} --gtest_filter=-${_out})
  # Start these before the short end-to-end tests (test_lists.cmake, COST).
  set_tests_properties(${target} PROPERTIES COST 20 ${W_PROPERTIES})
  # The suites of AEROVO_WHOLE_SUITE_TESTS in TARGET's sources run in this one process too.
  aerovo_whole_suites_of(${target} _suites)
endfunction()

# At the end of configuring: every listed suite was found (a renamed or moved suite must not
# silently fall back to one process per test, nor vanish).
function(aerovo_check_whole_suite_tests)
  get_property(_found GLOBAL PROPERTY AEROVO_WHOLE_SUITES_FOUND)
  foreach(_suite ${AEROVO_WHOLE_SUITE_TESTS})
    if(NOT _suite IN_LIST _found)
      message(FATAL_ERROR "cmake/AerovoTesting.cmake lists the test suite ${_suite}, which no "
        "test source defines (TEST/TEST_F/TEST_P(${_suite}, ...)): update the list")
    endif()
  endforeach()
endfunction()

# aerovo_test_optimisation(TARGET): the test executable's own sources at -O1 in the Release
# build (appended after the build type's -O3, so the last -O wins); the library code under test
# keeps the build's flags. A test TU is mostly GoogleTest macros, expectations and scene
# generators, and compiles 25-45 % faster at -O1 than at -O3 (BENCHMARKS.md, CI time); it
# computes the same: without -ffast-math GCC and Clang keep IEEE semantics at every -O level
# (no reassociation; no FMA on the x86-64-v2 baseline, -ffp-contract=off elsewhere).
# Not in cross builds: their tests run under an emulator (scripts/test-aarch64.sh), where test
# code runs at its -O2. In the sanitizer build (library at -O1) the test sources are at -O0: an
# instrumented test TU compiles in about a third of its -O1 CPU time, and the tests stay as
# checked (ASan and UBSan instrument -O0 code alike). The cost: where a test TU and the library
# both instantiate an inline function (Eigen's, mostly), the linker may keep the test's -O0 copy,
# so some library code runs slower in the test executables (BENCHMARKS.md, CI time: less in all
# than the compile time saved).
function(aerovo_test_optimisation target)
  if(NOT CMAKE_CROSSCOMPILING)
    target_compile_options(${target} PRIVATE $<$<CONFIG:Release>:-O1>)
  endif()
  if(AEROVO_SANITIZE OR AEROVO_BUILD_FUZZERS)
    target_compile_options(${target} PRIVATE -O0)
  endif()
endfunction()
