// Hot per-element loops are compiled twice, for x86-64-v3 (AVX2 + FMA) and for the baseline,
// with the version picked once at load time (GCC function multi-versioning, an ifunc): the
// library still runs on any x86-64 CPU. Results are deterministic on a given machine and do not
// depend on the thread count; the AVX2 version fuses multiply-adds, so its last bits may differ
// from the baseline version's. Elsewhere (other compilers or CPUs) the macro is empty.
#pragma once

#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__) && !defined(BLOBVK_NO_KERNEL_CLONES)
#define BLOBVK_FEM_KERNEL __attribute__((target_clones("arch=x86-64-v3", "default")))
// Kernels written with AVX2 intrinsics (a target attribute), called after __builtin_cpu_supports.
#define BLOBVK_FEM_AVX2 1
#else
#define BLOBVK_FEM_AVX2 0
#define BLOBVK_FEM_KERNEL
#endif
