# The fuzz build (preset `fuzz`, build-fuzz/): Debian 12's clang with
# libFuzzer, AddressSanitizer and UBSan. The GCC build does not use this.
#
# Why clang 16 and a define: psrig speaks std::expected, and libstdc++ 12's
# <expected> is only there when __cpp_concepts >= 202002L. Debian's clang 14,
# 15 and 16 all still say 201907L, so <expected> comes out empty. clang 16 is
# the first to implement what that check stands for (P0848, conditionally
# trivial special members: <expected>'s two destructors, one constrained),
# so with clang 16 saying 202002L is true for what libstdc++ uses. clang 14
# (Debian's default) fails even with the define: it takes expected<T, E>'s
# constrained `~expected() = default` as deleted. Hence clang-16 (Debian 12
# package clang-16, libFuzzer in libclang-rt-16-dev) and the define, given as
# -U then -D so that no macro-redefinition warning is raised.
#
# -DFMT_CONSTEVAL= turns off fmt's compile-time format-string checks here
# (the GCC build keeps them): clang 16 miscompiles a consteval call
# inside a switch case, running the destructors of that statement's
# temporaries again at the end of the switch (llvm/llvm-project#60249).
# psrig logs as `logger("daemon")->info("...", id)` in switch cases, so the
# spdlog shared_ptr temporary was destroyed on paths that never made it:
# ASan's stack-use-after-scope in ScanService::cancel on the first DELETE
# the HTTP target sent. Not a psrig bug; without consteval it is gone.
#
# -D_GLIBCXX_ASSERTIONS: libstdc++'s bounds checks, for the fuzzer to trip.
# Build type "Fuzz" (set by the preset) adds no flags of its own: assertions
# on (no NDEBUG), which is what a fuzzer wants. -O0 here: most of what the
# targets link (the daemon's whole stack) is only run behind the API and
# compiles in half the time unoptimised; tests/fuzz/CMakeLists.txt gives the
# instrumented code, where the fuzzer spends its time, -O1.
#
# The sanitizers and libFuzzer's coverage are not set here for every
# file: tests/fuzz/CMakeLists.txt adds them to the libraries that read the
# untrusted bytes and to the targets (instrumented code compiles three
# times slower, and the rest, which the targets only run, need not be).
find_program(CMAKE_CXX_COMPILER NAMES clang++-16 REQUIRED)
set(CMAKE_CXX_FLAGS_INIT
    "-U__cpp_concepts -D__cpp_concepts=202002L -DFMT_CONSTEVAL= -D_GLIBCXX_ASSERTIONS -fno-omit-frame-pointer -gline-tables-only -O0")
set(CMAKE_EXE_LINKER_FLAGS_INIT "-fsanitize=address,undefined")
