# Writes a CTest file with one test per GoogleTest suite of a test binary (run after each link
# of it, CMakeLists.txt): `EXE --gtest_filter=Suite.*`, named after the suite. For the binaries
# that link OpenImageIO, whose start-up costs ~0.5 s, that cost is then paid once per suite
# rather than once per test (as with gtest_discover_tests).
#   cmake -DEXE=... -DOUT=... -DLABEL=... -DTIMEOUT=... -DCOST_PER_TEST=...
#         [-DENVIRONMENT=...] -P discover_suites.cmake
# COST (tests in the suite x COST_PER_TEST) makes CTest start the long suites first, so that
# the short unit tests fill the cores at the end rather than one long suite running alone.
execute_process(COMMAND "${EXE}" --gtest_list_tests OUTPUT_VARIABLE _list RESULT_VARIABLE _rc
                TIMEOUT 60)
if(NOT _rc EQUAL 0)
  message(FATAL_ERROR "${EXE} --gtest_list_tests failed (${_rc})")
endif()
string(REPLACE "\n" ";" _lines "${_list}")
set(_suites "")
foreach(_line IN LISTS _lines)
  # A suite line starts in column 0 and ends with '.', before an optional "# TypeParam" note;
  # its tests follow, indented.
  if(_line MATCHES "^([^ #][^ ]*)\\.( .*)?$")
    set(_suite "${CMAKE_MATCH_1}")
    list(APPEND _suites "${_suite}")
    set(_count_${_suite} 0)
  elseif(_line MATCHES "^  [^ ]" AND _suite)
    math(EXPR _count_${_suite} "${_count_${_suite}} + 1")
  endif()
endforeach()
set(_out "")
foreach(_suite IN LISTS _suites)
  math(EXPR _cost "${_count_${_suite}} * ${COST_PER_TEST}")
  string(APPEND _out "add_test([=[${_suite}]=] [=[${EXE}]=] [=[--gtest_filter=${_suite}.*]=])\n"
                     "set_tests_properties([=[${_suite}]=] PROPERTIES LABELS ${LABEL} "
                     "TIMEOUT ${TIMEOUT} COST ${_cost}")
  if(ENVIRONMENT)
    string(APPEND _out " ENVIRONMENT [=[${ENVIRONMENT}]=]")
  endif()
  string(APPEND _out ")\n")
endforeach()
file(WRITE "${OUT}" "${_out}")
