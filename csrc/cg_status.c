/* cg_status.c -- status messages and build facts of the core. */
#include "cg.h"

#ifdef _OPENMP
#include <omp.h>
#endif

const char *cg_strerror(cg_status status)
{
    switch (status) {
    case CG_OK: return "success";
    case CG_ERR_ARGUMENT: return "invalid argument";
    case CG_ERR_NOMEM: return "out of memory";
    case CG_ERR_DIVERGENT: return "a ray stays inside the evaluation region forever "
                                  "(its direction has no component along a resolved, non-periodic axis), "
                                  "so its line integral is infinite";
    case CG_ERR_UNSUPPORTED: return "gradients are only available for the Gaussian kernel and for "
                                    "full-dimensional Lucy or Heaviside kernels";
    case CG_ERR_INTERRUPTED: return "interrupted";
    case CG_ERR_TEXT_NUMBER: return "not a number";
    case CG_ERR_TEXT_INTEGER: return "not an integer (an integer column)";
    case CG_ERR_TEXT_OVERFLOW: return "integer out of the 64-bit range";
    case CG_ERR_TEXT_ROW_LENGTH: return "wrong number of values on the line";
    case CG_ERR_TEXT_ROWS: return "more rows than expected";
    case CG_ERR_FSTAT_LINES: return "the .fstat frame's lines contradict each other or the .data frame";
    default: return "unknown error";
    }
}

int cg_have_openmp(void)
{
#ifdef _OPENMP
    return 1;
#else
    return 0;
#endif
}

int cg_default_threads(void)
{
#ifdef _OPENMP
    return omp_get_max_threads();
#else
    return 1;
#endif
}
