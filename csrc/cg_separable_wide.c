/*
 * cg_separable_wide.c -- cg_separable.c compiled again for CPUs with AVX-512:
 * its vectors are 8 doubles wide (CG_SEPARABLE_WIDE). The build of that file
 * chooses this one at run time where the CPU has AVX-512 (cg_internal.h).
 */
#include "cg_internal.h"

#ifdef CG_HAVE_WIDE_SEPARABLE
#pragma GCC target("avx512f")
#define CG_SEPARABLE_WIDE 1
#include "cg_separable.c"
#else
typedef int cg_separable_wide_unused; /* ISO C: no empty translation unit */
#endif
