# Build-time script (cmake -P) that writes one ctest per GoogleTest test suite
# of EXECUTABLE into OUT: PREFIX<Suite> runs `EXECUTABLE --gtest_filter=Suite.*`
# with LABELS. One process per suite instead of one per test: the suites of a
# binary share its start-up (OpenImageIO and LibTorch load about 300 shared
# libraries) and the test list stays grouped as the source files group it.
# A suite whose every test skipped prints pf_test_main's skip line, which
# marks the ctest skipped.
cmake_minimum_required(VERSION 3.25)
foreach(var EXECUTABLE PREFIX LABELS OUT WORKING_DIRECTORY)
  if(NOT DEFINED ${var})
    message(FATAL_ERROR "gtest_suites.cmake: -D${var}=... is required")
  endif()
endforeach()

execute_process(
  COMMAND "${EXECUTABLE}" --gtest_list_tests
  OUTPUT_VARIABLE listing
  ERROR_VARIABLE errors
  RESULT_VARIABLE result
  TIMEOUT 120)
if(NOT result EQUAL 0)
  message(FATAL_ERROR "${EXECUTABLE} --gtest_list_tests failed (${result}):\n${listing}${errors}")
endif()

string(REPLACE ";" "\\;" listing "${listing}")
string(REPLACE "\n" ";" lines "${listing}")
set(script "")
foreach(line IN LISTS lines)
  # A suite line is its name and a dot, maybe followed by "  # TypeParam = ...";
  # test lines are indented.
  if(line MATCHES "^([A-Za-z0-9_/]+)\\.( +#.*)?$")
    set(suite "${CMAKE_MATCH_1}")
    set(name "${PREFIX}${suite}")
    string(APPEND script
      "add_test([==[${name}]==] [==[${EXECUTABLE}]==] [==[--gtest_filter=${suite}.*]==])\n"
      "set_tests_properties([==[${name}]==] PROPERTIES LABELS [==[${LABELS}]==]"
      " WORKING_DIRECTORY [==[${WORKING_DIRECTORY}]==]"
      " SKIP_REGULAR_EXPRESSION [==[\\[ PF SKIPPED \\]]==])\n")
  endif()
endforeach()
file(WRITE "${OUT}" "${script}")
