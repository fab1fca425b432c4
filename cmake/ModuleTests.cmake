# A module's own tests, beside it in <module>/tests/ (as OpenCV's
# modules/<name>/test and pbrt's *_test.cpp): one GoogleTest program,
# psrig_<module>_tests, each test file named after what it tests.
#
#   psrig_module_tests(formats
#     SOURCES scan_reader_test.cpp ...
#     LIBRARIES psrig_formats ...
#     [ENVIRONMENT "NAME=value"]
#     [NOT_UNDER_EMULATOR "why"])   (cmake/EmulatedTests.cmake)
function(psrig_module_tests module)
  cmake_parse_arguments(PARSE_ARGV 1 arg "" "NOT_UNDER_EMULATOR" "SOURCES;LIBRARIES;ENVIRONMENT")
  set(target psrig_${module}_tests)
  add_executable(${target} ${arg_SOURCES})
  target_link_libraries(${target} PRIVATE
    ${arg_LIBRARIES} psrig_test_support GTest::gtest_main GTest::gmock psrig_warnings)
  target_compile_definitions(${target} PRIVATE PSRIG_SOURCE_DIR="${PROJECT_SOURCE_DIR}"
    PSRIG_VERSION="${PROJECT_VERSION}")
  set(skip "")
  if(arg_NOT_UNDER_EMULATOR)
    set(skip NOT_UNDER_EMULATOR "${arg_NOT_UNDER_EMULATOR}")
  endif()
  if(arg_ENVIRONMENT)
    psrig_discover_tests(${target} ${skip} DISCOVERY_TIMEOUT 60 PROPERTIES ENVIRONMENT "${arg_ENVIRONMENT}")
  else()
    psrig_discover_tests(${target} ${skip} DISCOVERY_TIMEOUT 60)
  endif()
endfunction()
