# Cross builds (preset arm64) run their tests through an emulator
# (CMAKE_CROSSCOMPILING_EMULATOR: qemu-aarch64). What cannot run there
# (a GPU, kernel devices, a preload library the emulator does not honour)
# is said where its tests are registered, with the reason:
#
#   psrig_discover_tests(<target> [NOT_UNDER_EMULATOR "reason"] [gtest_discover_tests args...])
#
# Natively it is gtest_discover_tests. Under the emulator such a program's
# tests are one test, <target>.NotUnderEmulator, that prints the reason and
# is reported skipped (exit 77), so ctest's summary names each one.
function(psrig_discover_tests target)
  cmake_parse_arguments(PARSE_ARGV 1 arg "" "NOT_UNDER_EMULATOR" "")
  if(arg_NOT_UNDER_EMULATOR AND CMAKE_CROSSCOMPILING_EMULATOR)
    add_test(NAME ${target}.NotUnderEmulator
      COMMAND sh -c "echo 'skipped under ${CMAKE_SYSTEM_PROCESSOR} emulation: $0'; exit 77"
              "${arg_NOT_UNDER_EMULATOR}")
    set_tests_properties(${target}.NotUnderEmulator PROPERTIES SKIP_RETURN_CODE 77)
    return()
  endif()
  gtest_discover_tests(${target} ${arg_UNPARSED_ARGUMENTS})
endfunction()
