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
find_program(CMAKE_CXX_COMPILER NAMES clang++-16 REQUIRED)
set(CMAKE_CXX_FLAGS_INIT
    "-U__cpp_concepts -D__cpp_concepts=202002L -D_GLIBCXX_ASSERTIONS -fsanitize=fuzzer-no-link,address,undefined -fno-sanitize-recover=undefined -fno-omit-frame-pointer -gline-tables-only -O1")
# Build type "Fuzz" (set by the preset) adds no flags of its own: -O1 and
# assertions on (no NDEBUG), which is what a fuzzer wants.
set(CMAKE_EXE_LINKER_FLAGS_INIT "-fsanitize=address,undefined")
