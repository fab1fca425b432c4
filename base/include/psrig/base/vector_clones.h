#pragma once
// Hot loops are plain loops left to GCC's vectoriser. On x86-64 each such
// function is also compiled for AVX2+FMA (x86-64-v3) and AVX-512
// (x86-64-v4), and the loader picks the best the CPU has; the baseline
// build stays runnable anywhere. Elsewhere (the rig's ARM board) the
// baseline ISA already has NEON.
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
#define PSRIG_VECTOR_CLONES \
  __attribute__((target_clones("arch=x86-64-v4", "arch=x86-64-v3", "default")))
#else
#define PSRIG_VECTOR_CLONES
#endif
