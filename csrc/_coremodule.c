/*
 * _coremodule.c -- the CPython binding of the cgbound core (cg.h).
 *
 * This is the only file that sees Python: it converts arguments to
 * contiguous float64 arrays, checks shapes and finiteness (naming the bad
 * argument), releases the GIL around the C work and maps cg_status codes to
 * Python exceptions once the GIL is held again.
 */
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#define NPY_NO_DEPRECATED_API NPY_1_7_API_VERSION
#include <numpy/arrayobject.h>

#include <limits.h>
#include <math.h>
#include <signal.h>
#include <string.h>

#include "cg.h"

/* ------------------------------------------------------------------ */
/* Ctrl-C while the GIL is released                                     */
/*
 * Python's own SIGINT handler only sets a flag that the interpreter checks
 * between bytecodes, so a long C call would ignore Ctrl-C until it finishes.
 * Around each GIL-released call made from the main thread we install a
 * handler that also sets `interrupt_flag` (polled by the core, which then
 * stops every thread within a few thousand kernel evaluations) and chains to
 * the previous handler, so Python still sees the signal (wakeup fd, custom
 * handlers). The previous handler is restored afterwards. The handler is only
 * installed when the previous disposition is a handler (not SIG_IGN/SIG_DFL),
 * i.e. when Ctrl-C would have raised or been handled in Python anyway.
 */
#if defined(SIGINT) && defined(SA_RESTART) && !defined(_WIN32)
#define CG_HAVE_SIGACTION 1
#else
#define CG_HAVE_SIGACTION 0
#endif

static volatile sig_atomic_t interrupt_flag = 0;
/* the core polls a `const volatile int *`: sig_atomic_t is int on every
   platform with sigaction that we build on */
_Static_assert(sizeof(sig_atomic_t) == sizeof(int), "sig_atomic_t must be an int");

static unsigned long main_thread_ident = 0;

typedef struct sigint_guard {
    int installed;
#if CG_HAVE_SIGACTION
    struct sigaction previous;
#endif
} sigint_guard;

#if CG_HAVE_SIGACTION
static struct sigaction chained; /* the handler active before ours */

static void on_sigint(int signum, siginfo_t *info, void *context)
{
    interrupt_flag = 1;
    if (chained.sa_flags & SA_SIGINFO) {
        if (chained.sa_sigaction) chained.sa_sigaction(signum, info, context);
    } else if (chained.sa_handler != SIG_DFL && chained.sa_handler != SIG_IGN && chained.sa_handler) {
        chained.sa_handler(signum);
    }
}
#endif

/* With the GIL held: install the temporary handler if we are on the main
   thread and Python handles SIGINT. Returns the flag the core should poll
   (NULL when no handler was installed). */
static const volatile int *sigint_begin(sigint_guard *g)
{
    g->installed = 0;
#if CG_HAVE_SIGACTION
    if (main_thread_ident == 0 || PyThread_get_thread_ident() != main_thread_ident) return NULL;
    struct sigaction current;
    if (sigaction(SIGINT, NULL, &current) != 0) return NULL;
    if (!(current.sa_flags & SA_SIGINFO) && (current.sa_handler == SIG_DFL || current.sa_handler == SIG_IGN))
        return NULL;
    chained = current;
    struct sigaction ours;
    memset(&ours, 0, sizeof ours);
    ours.sa_sigaction = on_sigint;
    ours.sa_flags = SA_SIGINFO | (current.sa_flags & SA_ONSTACK);
    sigemptyset(&ours.sa_mask);
    interrupt_flag = 0;
    if (sigaction(SIGINT, &ours, &g->previous) != 0) return NULL;
    g->installed = 1;
    return (const volatile int *)&interrupt_flag;
#else
    return NULL;
#endif
}

/* With the GIL held again: restore the previous handler and clear the flag. */
static void sigint_end(sigint_guard *g)
{
#if CG_HAVE_SIGACTION
    if (g->installed) sigaction(SIGINT, &g->previous, NULL);
#endif
    g->installed = 0;
    interrupt_flag = 0;
}

/* ------------------------------------------------------------------ */
/* argument conversion                                                  */
/*
 * Every wrapper parses its arguments with PyArg_ParseTupleAndKeywords and
 * one `O&` converter per argument (as scipy.ndimage's NI_ObjectToInputArray).
 * Converters that take a reference declare Py_CLEANUP_SUPPORTED: when a
 * later argument fails, Python calls them again with obj == NULL and they
 * release what they took. Their release functions also clear the pointers,
 * so each wrapper's one cleanup label can release every argument whatever
 * happened (nothing twice, nothing missed).
 *
 * Converters run in the order of the format string, so a converter may use
 * what an earlier one produced: the kernel needs the target's dimensions, and
 * an array's required shape may point at lengths found by earlier arguments
 * (positions fix the rows of values; the target fixes the columns).
 */

/* Whether all n values are finite: x * 0 is 0 for finite x and NaN for an
   infinity or NaN, so sums in 8 independent lanes (vectorised, no reordering
   of any one sum) tell, at a fraction of the cost of isfinite per value. */
static int all_finite(const double *data, npy_intp n)
{
    double lane[8] = {0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0};
    npy_intp i = 0;
    for (; i + 8 <= n; i += 8)
        for (int l = 0; l < 8; ++l) lane[l] += data[i + l] * 0.0;
    for (; i < n; ++i) lane[0] += data[i] * 0.0;
    double total = 0.0;
    for (int l = 0; l < 8; ++l) total += lane[l];
    return total == 0.0;
}

/* A C-contiguous, aligned float64 copy/view of obj with ndim dimensions;
   shape entries >= 0 are required, -1 is free. Checks finiteness. */
static PyArrayObject *as_array(PyObject *obj, const char *name, int ndim, const npy_intp *shape)
{
    PyArrayObject *arr = (PyArrayObject *)PyArray_FROM_OTF(obj, NPY_DOUBLE, NPY_ARRAY_IN_ARRAY);
    if (!arr) {
        PyErr_Format(PyExc_TypeError, "%s: expected an array of real numbers", name);
        return NULL;
    }
    if (PyArray_NDIM(arr) != ndim) {
        PyErr_Format(PyExc_ValueError, "%s: expected a %d-dimensional array, got %d dimensions",
                     name, ndim, PyArray_NDIM(arr));
        Py_DECREF(arr);
        return NULL;
    }
    for (int d = 0; d < ndim; ++d) {
        if (shape[d] >= 0 && PyArray_DIM(arr, d) != shape[d]) {
            PyErr_Format(PyExc_ValueError, "%s: expected length %zd along axis %d, got %zd",
                         name, (Py_ssize_t)shape[d], d, (Py_ssize_t)PyArray_DIM(arr, d));
            Py_DECREF(arr);
            return NULL;
        }
    }
    const double *data = (const double *)PyArray_DATA(arr);
    const npy_intp size = PyArray_SIZE(arr);
    for (npy_intp i = all_finite(data, size) ? size : 0; i < size; ++i) {
        if (!isfinite(data[i])) {
            char *text = PyOS_double_to_string(data[i], 'r', 0, 0, NULL);
            PyErr_Format(PyExc_ValueError, "%s: expected finite values, found %s at flat index %zd",
                         name, text ? text : "?", (Py_ssize_t)i);
            PyMem_Free(text);
            Py_DECREF(arr);
            return NULL;
        }
    }
    return arr;
}

/* An input array argument. The wrapper fills in name, ndim and the required
   length along each axis (NULL: free; else the address of a length that an
   earlier argument's converter sets); array_converter fills in the rest. */
typedef struct input_array {
    const char *name;
    int ndim;
    const npy_intp *length[2];
    PyArrayObject *array; /* owned; NULL until converted */
    npy_intp rows;        /* length along axis 0, once converted */
} input_array;

static void release_array(input_array *in)
{
    Py_CLEAR(in->array);
}

static int array_converter(PyObject *obj, void *address)
{
    input_array *in = (input_array *)address;
    if (!obj) { /* cleanup after a later argument failed */
        release_array(in);
        return 1;
    }
    npy_intp shape[2] = {-1, -1};
    for (int d = 0; d < in->ndim; ++d)
        if (in->length[d]) shape[d] = *in->length[d];
    in->array = as_array(obj, in->name, in->ndim, shape);
    if (!in->array) return 0;
    in->rows = PyArray_DIM(in->array, 0);
    return Py_CLEANUP_SUPPORTED;
}

static double *array_data(const input_array *in)
{
    return in->array ? (double *)PyArray_DATA(in->array) : NULL;
}

/* periodic[a], period[a] for n axes from two sequences (of the target or of
   minimum_image; `owner` and `entry` name them in the messages) */
static int convert_periodicity(PyObject *periodic_obj, PyObject *period_obj, Py_ssize_t n, const char *owner,
                               const char *entry, int *periodic, double *period)
{
    if (!PySequence_Check(periodic_obj) || !PySequence_Check(period_obj) ||
        PySequence_Size(periodic_obj) != n || PySequence_Size(period_obj) != n) {
        PyErr_Format(PyExc_ValueError, "%s: periodic and period need one entry per %s", owner, entry);
        return 0;
    }
    for (Py_ssize_t a = 0; a < n; ++a) {
        PyObject *p = PySequence_GetItem(periodic_obj, a), *L = PySequence_GetItem(period_obj, a);
        if (!p || !L) { Py_XDECREF(p); Py_XDECREF(L); return 0; }
        periodic[a] = PyObject_IsTrue(p);
        period[a] = PyFloat_AsDouble(L);
        Py_DECREF(p);
        Py_DECREF(L);
        if (PyErr_Occurred()) return 0;
        if (periodic[a] && !(period[a] > 0.0 && isfinite(period[a]))) {
            PyErr_Format(PyExc_ValueError, "%s: a periodic axis needs a positive finite period", owner);
            return 0;
        }
    }
    return 1;
}

typedef struct converted_target {
    cg_target target;
    PyArrayObject *coords[3]; /* owned, grids */
    PyArrayObject *points;    /* owned, point sets */
    npy_intp dim;             /* D, for the shapes of later arguments */
    npy_intp size;            /* P, the number of nodes */
} converted_target;

static void release_target(converted_target *ct)
{
    for (int a = 0; a < 3; ++a) Py_CLEAR(ct->coords[a]);
    Py_CLEAR(ct->points);
}

/* target = (dim, axes, coords or None, points or None, periodic, period) */
static int convert_target(PyObject *obj, converted_target *ct)
{
    int dim;
    PyObject *axes, *coords, *points, *periodic, *period;
    if (!PyTuple_Check(obj) ||
        !PyArg_ParseTuple(obj, "iOOOOO", &dim, &axes, &coords, &points, &periodic, &period)) {
        PyErr_SetString(PyExc_TypeError, "target: expected (dim, axes, coords, points, periodic, period)");
        return 0;
    }
    if (dim < 2 || dim > 3) {
        PyErr_Format(PyExc_ValueError, "target: dim must be 2 or 3, got %d", dim);
        return 0;
    }
    cg_target *t = &ct->target;
    t->dim = dim;
    PyObject *seq = PySequence_Fast(axes, "target: axes must be a sequence");
    if (!seq) return 0;
    const Py_ssize_t nr = PySequence_Fast_GET_SIZE(seq);
    if (nr > dim) {
        Py_DECREF(seq);
        PyErr_SetString(PyExc_ValueError, "target: more resolved axes than dimensions");
        return 0;
    }
    t->n_resolved = (int)nr;
    for (Py_ssize_t a = 0; a < nr; ++a) {
        const long v = PyLong_AsLong(PySequence_Fast_GET_ITEM(seq, a));
        if (v < 0 || v >= dim || (a > 0 && v <= t->axes[a - 1])) {
            Py_DECREF(seq);
            if (!PyErr_Occurred())
                PyErr_SetString(PyExc_ValueError, "target: axes must be increasing data axes");
            return 0;
        }
        t->axes[a] = (int)v;
    }
    Py_DECREF(seq);
    if (!convert_periodicity(periodic, period, nr, "target", "resolved axis", t->periodic, t->period)) return 0;
    if (coords != Py_None) {
        t->is_grid = 1;
        if (!PySequence_Check(coords) || PySequence_Size(coords) != nr) {
            PyErr_SetString(PyExc_ValueError, "target: coords needs one array per resolved axis");
            return 0;
        }
        for (Py_ssize_t a = 0; a < nr; ++a) {
            PyObject *c = PySequence_GetItem(coords, a);
            if (!c) return 0; /* the caller releases earlier axes */
            const npy_intp any = -1;
            ct->coords[a] = as_array(c, "grid coordinates", 1, &any);
            Py_DECREF(c);
            if (!ct->coords[a]) return 0;
            t->shape[a] = PyArray_DIM(ct->coords[a], 0);
            if (t->shape[a] < 1) {
                PyErr_SetString(PyExc_ValueError, "grid coordinates: every resolved axis needs at least one node");
                return 0;
            }
            t->coords[a] = (const double *)PyArray_DATA(ct->coords[a]);
        }
    } else {
        if (points == Py_None) {
            PyErr_SetString(PyExc_ValueError, "target: give coords (grid) or points");
            return 0;
        }
        const npy_intp shape[2] = {-1, nr};
        ct->points = as_array(points, "points", 2, shape);
        if (!ct->points) return 0;
        t->n_points = PyArray_DIM(ct->points, 0);
        t->points = (const double *)PyArray_DATA(ct->points);
    }
    ct->dim = dim;
    ct->size = cg_target_size(t);
    return 1;
}

static int target_converter(PyObject *obj, void *address)
{
    converted_target *ct = (converted_target *)address;
    if (!obj) { /* cleanup after a later argument failed */
        release_target(ct);
        return 1;
    }
    memset(ct, 0, sizeof *ct);
    if (!convert_target(obj, ct)) {
        release_target(ct);
        return 0;
    }
    return Py_CLEANUP_SUPPORTED;
}

/* The kernel argument: needs the target's dimensions, so the wrapper points
   `target` at the target argument, converted before it. */
typedef struct kernel_arg {
    const converted_target *target;
    cg_kernel kernel;
} kernel_arg;

/* kernel = (type, width, radius, truncated, avg_extent[, line_points[, per_node[, lower_dimensional
              [, mercurycg_line]]]]) */
static int kernel_converter(PyObject *obj, void *address)
{
    kernel_arg *ka = (kernel_arg *)address;
    cg_kernel *k = &ka->kernel;
    memset(k, 0, sizeof *k);
    if (!PyTuple_Check(obj) ||
        !PyArg_ParseTuple(obj, "iddid|iiii", &k->type, &k->width, &k->radius, &k->truncated_norm, &k->avg_extent,
                          &k->line_points, &k->per_node, &k->lower_dimensional, &k->mercurycg_line)) {
        PyErr_SetString(PyExc_TypeError, "kernel: expected (type, width, radius, truncated, avg_extent[, line_points"
                                         "[, per_node[, lower_dimensional[, mercurycg_line]]]])");
        return 0;
    }
    if (k->line_points < 0 || k->line_points > CG_MAX_LINE_POINTS) {
        PyErr_Format(PyExc_ValueError, "kernel: line_points must be 0 (exact) or 1..%d, got %d",
                     CG_MAX_LINE_POINTS, k->line_points);
        return 0;
    }
    k->dim = ka->target->target.dim;
    k->n_resolved = ka->target->target.n_resolved;
    if (cg_kernel_init(k) != CG_OK) {
        PyErr_SetString(PyExc_ValueError,
                        "kernel: type must be 0, 1 or 2, width, radius, avg_extent positive and finite, "
                        "lower_dimensional 0 or 1, mercurycg_line 0 or 1 (a Gaussian, one resolved axis)");
        return 0;
    }
    return 1;
}

/* n_threads: an int (as the "i" format), 0 or positive */
static int threads_converter(PyObject *obj, void *address)
{
    const long n = PyLong_AsLong(obj);
    if (n == -1 && PyErr_Occurred()) return 0;
    if (n > INT_MAX || n < INT_MIN) {
        PyErr_SetString(PyExc_OverflowError,
                        n > INT_MAX ? "signed integer is greater than maximum" : "signed integer is less than minimum");
        return 0;
    }
    if (n < 0) {
        PyErr_Format(PyExc_ValueError, "n_threads: expected 0 (the OpenMP default) or a positive count, got %ld", n);
        return 0;
    }
    *(int *)address = (int)n;
    return 1;
}

static PyObject *default_threads(PyObject *self, PyObject *args)
{
    (void)self;
    (void)args;
    return PyLong_FromLong(cg_default_threads());
}

/* Sets the Python exception for a failed core call (GIL held). */
static void raise_status(cg_status st)
{
    switch (st) {
    case CG_ERR_NOMEM: PyErr_NoMemory(); return;
    case CG_ERR_INTERRUPTED:
        /* run the Python-level handler the chained signal tripped (the
           default one raises KeyboardInterrupt); if it did not raise, the
           work is still incomplete, so raise KeyboardInterrupt ourselves */
        if (PyErr_CheckSignals() < 0) return;
        PyErr_SetNone(PyExc_KeyboardInterrupt);
        return;
    case CG_ERR_UNSUPPORTED: PyErr_SetString(PyExc_NotImplementedError, cg_strerror(st)); return;
    default: PyErr_SetString(PyExc_ValueError, cg_strerror(st)); return;
    }
}

/* output array of shape (P, extra...), not yet filled: zeroed by cg_fill_zero with the GIL released (not
   PyArray_ZEROS: calloc's fresh pages were then first touched in the kernels, a fault per 4 kB page at ~3 us on
   a virtual machine, and more of them per frame) */
static PyArrayObject *output_array(npy_intp P, int n_extra, const npy_intp *extra)
{
    npy_intp shape[4] = {P, 1, 1, 1};
    for (int i = 0; i < n_extra; ++i) shape[1 + i] = extra[i];
    return (PyArrayObject *)PyArray_EMPTY(1 + n_extra, shape, NPY_DOUBLE, 0);
}

/* ------------------------------------------------------------------ */
/* wrappers: parse (converters), check what spans arguments, allocate the
   result, run the core with the GIL released, one cleanup label           */

static PyObject *py_scatter(PyObject *args, PyObject *kwds, int segments)
{
    static char *kw_points[] = {"target", "kernel", "positions", "values", "gradient", "n_threads", NULL};
    static char *kw_segments[] = {"target", "kernel", "starts", "vectors", "values", "ray", "gradient", "n_threads",
                                  NULL};
    static char *kw_moments[] = {"target", "kernel", "starts", "vectors", "values", "gradient", "n_threads", NULL};
    static char *kw_outer[] = {"target", "kernel", "starts", "vectors", "factors", "ray", "gradient", "n_threads",
                               "negate", NULL};
    converted_target ct = {0};
    kernel_arg ka = {.target = &ct};
    input_array pos = {.name = segments ? "starts" : "positions", .ndim = 2, .length = {NULL, &ct.dim}};
    input_array vec = {.name = "vectors", .ndim = 2, .length = {&pos.rows, &ct.dim}};
    input_array val = {.name = segments == 3 ? "factors" : "values", .ndim = 2, .length = {&pos.rows, NULL}};
    int ray = 0, gradient = 0, n_threads = 0, negate = 0;
    PyArrayObject *out = NULL;
    int parsed;
    if (segments == 2)   /* first moments along segments */
        parsed = PyArg_ParseTupleAndKeywords(args, kwds, "O&O&O&O&O&|pO&", kw_moments, target_converter, &ct,
                                             kernel_converter, &ka, array_converter, &pos, array_converter, &vec,
                                             array_converter, &val, &gradient, threads_converter, &n_threads);
    else if (segments == 3) /* (negate: the vectors are -vectors) */
        parsed = PyArg_ParseTupleAndKeywords(args, kwds, "O&O&O&O&O&|ppO&p", kw_outer, target_converter, &ct,
                                             kernel_converter, &ka, array_converter, &pos, array_converter, &vec,
                                             array_converter, &val, &ray, &gradient, threads_converter, &n_threads,
                                             &negate);
    else if (segments)
        parsed = PyArg_ParseTupleAndKeywords(args, kwds, "O&O&O&O&O&|ppO&", kw_segments,
                                             target_converter, &ct,
                                             kernel_converter, &ka, array_converter, &pos, array_converter, &vec,
                                             array_converter, &val, &ray, &gradient, threads_converter, &n_threads);
    else
        parsed = PyArg_ParseTupleAndKeywords(args, kwds, "O&O&O&O&|pO&", kw_points, target_converter, &ct,
                                             kernel_converter, &ka, array_converter, &pos, array_converter, &val,
                                             &gradient, threads_converter, &n_threads);
    if (!parsed) goto done;
    const npy_intp n_columns = PyArray_DIM(val.array, 1);
    if (n_columns < 1) {
        PyErr_Format(PyExc_ValueError, "%s: expected at least one column", val.name);
        goto done;
    }
    if (segments == 3 && n_columns * ct.dim > CG_MAX_OUTER_VALUES) {
        PyErr_Format(PyExc_ValueError, "factors: expected at most %d columns (%d values per segment with %d-D "
                     "vectors), got %zd", (int)(CG_MAX_OUTER_VALUES / ct.dim), CG_MAX_OUTER_VALUES, (int)ct.dim,
                     (Py_ssize_t)n_columns);
        goto done;
    }
    /* the values per object: the factors' outer products with the vectors */
    const int n_values = (int)(segments == 3 ? n_columns * ct.dim : n_columns);
    ct.target.n_threads = n_threads;
    npy_intp extra[2] = {n_values, ct.target.n_resolved};
    out = output_array(ct.size, gradient ? 2 : 1, extra);
    if (!out) goto done;
    cg_status st;
    sigint_guard guard;
    ct.target.interrupt = sigint_begin(&guard);
    Py_BEGIN_ALLOW_THREADS
    cg_fill_zero(PyArray_DATA(out), (cg_index)PyArray_SIZE(out), n_threads);
    if (segments == 2)
        st = cg_scatter_segment_moments(&ct.target, &ka.kernel, pos.rows, array_data(&pos), array_data(&vec),
                                        n_values, array_data(&val), gradient, PyArray_DATA(out));
    else if (segments == 3)
        st = cg_scatter_segments_outer(&ct.target, &ka.kernel, pos.rows, array_data(&pos), array_data(&vec), negate,
                                       ray, (int)n_columns, array_data(&val), gradient, PyArray_DATA(out));
    else if (segments)
        st = cg_scatter_segments(&ct.target, &ka.kernel, pos.rows, array_data(&pos), array_data(&vec), ray,
                                 n_values, array_data(&val), gradient, PyArray_DATA(out));
    else
        st = cg_scatter_points(&ct.target, &ka.kernel, pos.rows, array_data(&pos), n_values, array_data(&val),
                               gradient, PyArray_DATA(out));
    Py_END_ALLOW_THREADS
    sigint_end(&guard);
    if (st == CG_ERR_UNSUPPORTED && segments == 2) {
        PyErr_SetString(PyExc_NotImplementedError,
                        "first moments along segments are available for the Gaussian (any averaged axes) and for "
                        "Lucy and Heaviside kernels (no gradient for Heaviside, nor over averaged axes)");
        Py_CLEAR(out);
    } else if (st != CG_OK) {
        raise_status(st);
        Py_CLEAR(out);
    }
done:
    release_target(&ct);
    release_array(&pos);
    release_array(&vec);
    release_array(&val);
    return (PyObject *)out;
}

static PyObject *py_scatter_points(PyObject *self, PyObject *args, PyObject *kwds)
{
    (void)self;
    return py_scatter(args, kwds, 0);
}

static PyObject *py_scatter_segments(PyObject *self, PyObject *args, PyObject *kwds)
{
    (void)self;
    return py_scatter(args, kwds, 1);
}

static PyObject *py_scatter_segments_outer(PyObject *self, PyObject *args, PyObject *kwds)
{
    (void)self;
    return py_scatter(args, kwds, 3);
}

static PyObject *py_scatter_segment_moments(PyObject *self, PyObject *args, PyObject *kwds)
{
    (void)self;
    return py_scatter(args, kwds, 2);
}

static PyObject *py_scatter_points_kinetic(PyObject *self, PyObject *args, PyObject *kwds)
{
    (void)self;
    static char *kw[] = {"target", "kernel", "positions", "masses", "velocities", "u_ref", "parts", "n_threads", NULL};
    converted_target ct = {0};
    kernel_arg ka = {.target = &ct};
    input_array pos = {.name = "positions", .ndim = 2, .length = {NULL, &ct.dim}};
    input_array mass = {.name = "masses", .ndim = 1, .length = {&pos.rows, NULL}};
    input_array vel = {.name = "velocities", .ndim = 2, .length = {&pos.rows, &ct.dim}};
    input_array uref = {.name = "u_ref", .ndim = 1, .length = {&ct.dim, NULL}};
    int parts = 0, n_threads = 0;
    PyArrayObject *out = NULL;
    if (!PyArg_ParseTupleAndKeywords(args, kwds, "O&O&O&O&O&O&i|O&", kw, target_converter, &ct, kernel_converter,
                                     &ka, array_converter, &pos, array_converter, &mass, array_converter, &vel,
                                     array_converter, &uref, &parts, threads_converter, &n_threads))
        goto done;
    const int D = (int)ct.dim;
    const npy_intp n_values = cg_kinetic_values_count(parts, D);
    if (n_values == 0) {
        PyErr_Format(PyExc_ValueError, "parts: expected a nonzero mask of CG_KINETIC_MASS (1), _MOMENTUM (2) and "
                     "_FLUX (4), got %d", parts);
        goto done;
    }
    {
        /* the values the core forms must be finite, as a values array's are (the products may overflow): by
           monotone rounding every m (v_r v_c) is at most m (v_max v_max) in magnitude */
        const double *m = array_data(&mass), *v = array_data(&vel), *u = array_data(&uref);
        for (npy_intp o = 0; o < pos.rows; ++o) {
            int finite = 1;
            double vmax = 0.0;
            for (int r = 0; r < D; ++r) {
                const double vr = v[o * D + r];
                if (parts & CG_KINETIC_MOMENTUM) finite &= isfinite(m[o] * (vr - u[r])) != 0;
                vmax = fabs(vr) > vmax ? fabs(vr) : vmax;
            }
            if (parts & CG_KINETIC_FLUX) finite &= isfinite(m[o] * (vmax * vmax)) != 0;
            if (!finite) {
                PyErr_Format(PyExc_ValueError, "velocities: expected the momentum m (v - u_ref) and the momentum "
                             "flux m v v of each particle in the floating-point range, got an overflow at particle "
                             "%zd", (Py_ssize_t)o);
                goto done;
            }
        }
    }
    ct.target.n_threads = n_threads;
    out = output_array(ct.size, 1, &n_values);
    if (!out) goto done;
    cg_status st;
    sigint_guard guard;
    ct.target.interrupt = sigint_begin(&guard);
    Py_BEGIN_ALLOW_THREADS
    cg_fill_zero(PyArray_DATA(out), (cg_index)PyArray_SIZE(out), n_threads);
    st = cg_scatter_points_kinetic(&ct.target, &ka.kernel, pos.rows, array_data(&pos), array_data(&mass),
                                   array_data(&vel), array_data(&uref), parts, PyArray_DATA(out));
    Py_END_ALLOW_THREADS
    sigint_end(&guard);
    if (st != CG_OK) {
        raise_status(st);
        Py_CLEAR(out);
    }
done:
    release_target(&ct);
    release_array(&pos);
    release_array(&mass);
    release_array(&vel);
    release_array(&uref);
    return (PyObject *)out;
}

static PyObject *py_scatter_fluctuation(PyObject *self, PyObject *args, PyObject *kwds)
{
    (void)self;
    static char *kw[] = {"target", "kernel", "positions", "masses", "velocities", "node_velocity", "n_threads", NULL};
    converted_target ct = {0};
    kernel_arg ka = {.target = &ct};
    input_array pos = {.name = "positions", .ndim = 2, .length = {NULL, &ct.dim}};
    input_array mass = {.name = "masses", .ndim = 1, .length = {&pos.rows, NULL}};
    input_array vel = {.name = "velocities", .ndim = 2, .length = {&pos.rows, &ct.dim}};
    input_array nodev = {.name = "node_velocity", .ndim = 2, .length = {&ct.size, &ct.dim}};
    int n_threads = 0;
    PyArrayObject *out = NULL;
    if (!PyArg_ParseTupleAndKeywords(args, kwds, "O&O&O&O&O&O&|O&", kw, target_converter, &ct, kernel_converter,
                                     &ka, array_converter, &pos, array_converter, &mass, array_converter, &vel,
                                     array_converter, &nodev, threads_converter, &n_threads))
        goto done;
    ct.target.n_threads = n_threads;
    const npy_intp extra[2] = {ct.dim, ct.dim};
    out = output_array(ct.size, 2, extra);
    if (!out) goto done;
    cg_status st;
    sigint_guard guard;
    ct.target.interrupt = sigint_begin(&guard);
    Py_BEGIN_ALLOW_THREADS
    cg_fill_zero(PyArray_DATA(out), (cg_index)PyArray_SIZE(out), n_threads);
    st = cg_scatter_fluctuation(&ct.target, &ka.kernel, pos.rows, array_data(&pos), array_data(&mass),
                                array_data(&vel), array_data(&nodev), PyArray_DATA(out));
    Py_END_ALLOW_THREADS
    sigint_end(&guard);
    if (st != CG_OK) {
        raise_status(st);
        Py_CLEAR(out);
    }
done:
    release_target(&ct);
    release_array(&pos);
    release_array(&mass);
    release_array(&vel);
    release_array(&nodev);
    return (PyObject *)out;
}

static PyObject *py_minimum_image(PyObject *self, PyObject *args, PyObject *kwds)
{
    (void)self;
    static char *kw[] = {"vectors", "periodic", "period", NULL};
    input_array vec = {.name = "vectors", .ndim = 2, .length = {NULL, NULL}};
    PyObject *periodic_obj, *period_obj;
    PyArrayObject *out = NULL;
    if (!PyArg_ParseTupleAndKeywords(args, kwds, "O&OO", kw, array_converter, &vec, &periodic_obj, &period_obj))
        goto done;
    const int D = (int)PyArray_DIM(vec.array, 1);
    int periodic[3] = {0, 0, 0};
    double period[3] = {0.0, 0.0, 0.0};
    if (D < 1 || D > 3) {
        PyErr_SetString(PyExc_ValueError, "minimum_image: periodic and period need one entry per column");
        goto done;
    }
    if (!convert_periodicity(periodic_obj, period_obj, D, "minimum_image", "column", periodic, period)) goto done;
    out = (PyArrayObject *)PyArray_NewCopy(vec.array, NPY_CORDER);
    if (!out) goto done;
    Py_BEGIN_ALLOW_THREADS
    cg_minimum_image(PyArray_DIM(out, 0), D, PyArray_DATA(out), periodic, period);
    Py_END_ALLOW_THREADS
done:
    release_array(&vec);
    return (PyObject *)out;
}

/* the kernel of the ring entry points: the full 3-D kernel */
static converted_target ring_space = {.target = {.dim = 3, .n_resolved = 3}, .dim = 3};

/* a 1-D array of int64 (row indices, counts; checked by the core) */
typedef struct index_array {
    const char *name;
    const npy_intp *length;
    PyArrayObject *array; /* owned */
} index_array;

static int index_converter(PyObject *obj, void *address)
{
    index_array *in = (index_array *)address;
    if (!obj) {
        Py_CLEAR(in->array);
        return 1;
    }
    in->array = (PyArrayObject *)PyArray_FROM_OTF(obj, NPY_INT64, NPY_ARRAY_IN_ARRAY | NPY_ARRAY_FORCECAST);
    if (!in->array) {
        PyErr_Format(PyExc_TypeError, "%s: expected an array of integers", in->name);
        return 0;
    }
    if (PyArray_NDIM(in->array) != 1 || (in->length && PyArray_DIM(in->array, 0) != *in->length)) {
        PyErr_Format(PyExc_ValueError, "%s: expected a 1-dimensional array with one entry per %s", in->name,
                     in->length ? "pair" : "piece");
        Py_CLEAR(in->array);
        return 0;
    }
    return Py_CLEANUP_SUPPORTED;
}

/* The piece lists of the ring paths: segment (one entry per piece) and, for
   n_groups rings or columns, first (their first pieces and one more, ending
   at the number of pieces; NULL: none). 0 with a ValueError set. */
static int check_pieces(const index_array *first, const index_array *segment, npy_intp n_pieces, npy_intp n_groups,
                        const char *group)
{
    if (first && PyArray_DIM(first->array, 0) != n_groups + 1) {
        PyErr_Format(PyExc_ValueError, "first: expected one entry per %s and one more (the pieces' end)", group);
        return 0;
    }
    if (PyArray_DIM(segment->array, 0) != n_pieces) {
        PyErr_SetString(PyExc_ValueError, "segment: expected one entry per piece (the length of lo)");
        return 0;
    }
    if (first && ((const cg_index *)PyArray_DATA(first->array))[n_groups] != n_pieces) {
        PyErr_SetString(PyExc_ValueError, "first: expected its last entry to be the number of pieces");
        return 0;
    }
    return 1;
}

static PyObject *py_ring_moments(PyObject *self, PyObject *args, PyObject *kwds)
{
    (void)self;
    static char *kw[] = {"kernel", "r", "h", "rho", "gradient", "n_moments", "n_threads", NULL};
    kernel_arg ka = {.target = &ring_space};
    double r;
    int gradient = 0, n_moments = 3;
    input_array h = {.name = "h", .ndim = 1, .length = {NULL, NULL}};
    input_array rho = {.name = "rho", .ndim = 1, .length = {&h.rows, NULL}};
    int n_threads = 0;
    PyArrayObject *out = NULL;
    if (!PyArg_ParseTupleAndKeywords(args, kwds, "O&dO&O&|piO&", kw, kernel_converter, &ka, &r, array_converter, &h,
                                     array_converter, &rho, &gradient, &n_moments, threads_converter, &n_threads))
        goto done;
    if (!(r >= 0.0) || !isfinite(r)) {
        PyErr_Format(PyExc_ValueError, "r: expected a finite radius >= 0, got %R", PyTuple_GetItem(args, 1));
        goto done;
    }
    if (n_moments < 1 || n_moments > 4) {
        PyErr_Format(PyExc_ValueError, "n_moments: expected 1 to 4 (the moments m = 0..3), got %d", n_moments);
        goto done;
    }
    const npy_intp shape[2] = {n_moments, h.rows};
    out = (PyArrayObject *)PyArray_ZEROS(2, shape, NPY_DOUBLE, 0);
    if (!out) goto done;
    cg_status st;
    Py_BEGIN_ALLOW_THREADS
    st = cg_ring_moments(&ka.kernel, r, h.rows, array_data(&h), array_data(&rho), gradient, n_moments,
                         PyArray_DATA(out), n_threads);
    Py_END_ALLOW_THREADS
    if (st != CG_OK) {
        raise_status(st);
        Py_CLEAR(out);
    }
done:
    release_array(&h);
    release_array(&rho);
    return (PyObject *)out;
}

static PyObject *py_ring_segment_sum(PyObject *self, PyObject *args, PyObject *kwds)
{
    (void)self;
    static char *kw[] = {"kernel", "r", "z", "segment", "lo", "hi", "panels", "geometry", "tensors", "weight",
                         "gradient", "n_threads", NULL};
    static const npy_intp six = 6, nine = 9;
    kernel_arg ka = {.target = &ring_space};
    double r, z, weight;
    index_array segment = {.name = "segment", .length = NULL};
    input_array lo = {.name = "lo", .ndim = 1, .length = {NULL, NULL}};
    input_array hi = {.name = "hi", .ndim = 1, .length = {&lo.rows, NULL}};
    index_array panels = {.name = "panels", .length = &lo.rows};
    input_array geom = {.name = "geometry", .ndim = 2, .length = {NULL, &six}};
    input_array tens = {.name = "tensors", .ndim = 2, .length = {&geom.rows, &nine}};
    int gradient = 0, n_threads = 0;
    PyArrayObject *out = NULL;
    if (!PyArg_ParseTupleAndKeywords(args, kwds, "O&ddO&O&O&O&O&O&d|pO&", kw, kernel_converter, &ka, &r, &z,
                                     index_converter, &segment, array_converter, &lo, array_converter, &hi,
                                     index_converter, &panels, array_converter, &geom, array_converter, &tens,
                                     &weight, &gradient, threads_converter, &n_threads))
        goto done;
    if (!(r >= 0.0) || !isfinite(r) || !isfinite(z) || !isfinite(weight)) {
        PyErr_SetString(PyExc_ValueError, "r, z, weight: expected finite numbers (r >= 0)");
        goto done;
    }
    if (!check_pieces(NULL, &segment, lo.rows, 0, NULL)) goto done;
    const npy_intp shape[3] = {3, 3, 3};
    out = (PyArrayObject *)PyArray_ZEROS(gradient ? 3 : 2, shape, NPY_DOUBLE, 0);
    if (!out) goto done;
    cg_status st;
    Py_BEGIN_ALLOW_THREADS
    st = (gradient ? cg_ring_segment_gradient_sum : cg_ring_segment_sum)(
        &ka.kernel, r, z, lo.rows, (const cg_index *)PyArray_DATA(segment.array), array_data(&lo), array_data(&hi),
        (const cg_index *)PyArray_DATA(panels.array), geom.rows, array_data(&geom), array_data(&tens), weight,
        PyArray_DATA(out), n_threads);
    Py_END_ALLOW_THREADS
    if (st == CG_ERR_ARGUMENT) {
        PyErr_SetString(PyExc_ValueError, "segment, lo, hi, panels: expected rows of geometry, "
                                          "0 <= lo <= hi <= 1 and panels >= 1");
        Py_CLEAR(out);
    } else if (st != CG_OK) {
        raise_status(st);
        Py_CLEAR(out);
    }
done:
    Py_CLEAR(segment.array);
    release_array(&lo);
    release_array(&hi);
    Py_CLEAR(panels.array);
    release_array(&geom);
    release_array(&tens);
    return (PyObject *)out;
}

static PyObject *py_ring_segment_columns(PyObject *self, PyObject *args, PyObject *kwds)
{
    (void)self;
    static char *kw[] = {"kernel", "rings", "first", "segment", "lo", "hi", "panels", "geometry", "tensors",
                         "gradient", "n_threads", NULL};
    static const npy_intp three = 3, six = 6, nine = 9;
    kernel_arg ka = {.target = &ring_space};
    input_array rings = {.name = "rings", .ndim = 2, .length = {NULL, &three}};
    index_array first = {.name = "first", .length = NULL};
    index_array segment = {.name = "segment", .length = NULL};
    input_array lo = {.name = "lo", .ndim = 1, .length = {NULL, NULL}};
    input_array hi = {.name = "hi", .ndim = 1, .length = {&lo.rows, NULL}};
    index_array panels = {.name = "panels", .length = &lo.rows};
    input_array geom = {.name = "geometry", .ndim = 2, .length = {NULL, &six}};
    input_array tens = {.name = "tensors", .ndim = 2, .length = {&geom.rows, &nine}};
    int gradient = 0, n_threads = 0;
    PyArrayObject *out = NULL;
    if (!PyArg_ParseTupleAndKeywords(args, kwds, "O&O&O&O&O&O&O&O&O&|pO&", kw, kernel_converter, &ka,
                                     array_converter, &rings, index_converter, &first, index_converter, &segment,
                                     array_converter, &lo, array_converter, &hi, index_converter, &panels,
                                     array_converter, &geom, array_converter, &tens, &gradient, threads_converter,
                                     &n_threads))
        goto done;
    if (!check_pieces(&first, &segment, lo.rows, rings.rows, "ring")) goto done;
    const npy_intp shape[2] = {rings.rows, gradient ? 27 : 9};
    out = (PyArrayObject *)PyArray_ZEROS(2, shape, NPY_DOUBLE, 0);
    if (!out) goto done;
    cg_status st;
    Py_BEGIN_ALLOW_THREADS
    st = cg_ring_segment_columns(&ka.kernel, rings.rows, array_data(&rings),
                                 (const cg_index *)PyArray_DATA(first.array),
                                 (const cg_index *)PyArray_DATA(segment.array), array_data(&lo), array_data(&hi),
                                 (const cg_index *)PyArray_DATA(panels.array), geom.rows, array_data(&geom),
                                 array_data(&tens), gradient, PyArray_DATA(out), n_threads);
    Py_END_ALLOW_THREADS
    if (st == CG_ERR_ARGUMENT) {
        PyErr_SetString(PyExc_ValueError, "rings, first, segment, lo, hi, panels: expected finite rows (r, z, weight) "
                                          "with r >= 0, nondecreasing first from 0, rows of geometry, "
                                          "0 <= lo <= hi <= 1 and panels >= 1");
        Py_CLEAR(out);
    } else if (st != CG_OK) {
        raise_status(st);
        Py_CLEAR(out);
    }
done:
    release_array(&rings);
    Py_CLEAR(first.array);
    Py_CLEAR(segment.array);
    release_array(&lo);
    release_array(&hi);
    Py_CLEAR(panels.array);
    release_array(&geom);
    release_array(&tens);
    return (PyObject *)out;
}

static PyObject *py_ring_axial_point_sum(PyObject *self, PyObject *args, PyObject *kwds)
{
    (void)self;
    static char *kw[] = {"kernel", "r", "lo", "hi", "xy", "zeta", "tensors", "weights", "n_threads", NULL};
    static const npy_intp two = 2, nine = 9;
    kernel_arg ka = {.target = &ring_space};
    double r, lo, hi;
    input_array xy = {.name = "xy", .ndim = 2, .length = {NULL, &two}};
    input_array zeta = {.name = "zeta", .ndim = 1, .length = {&xy.rows, NULL}};
    input_array tens = {.name = "tensors", .ndim = 2, .length = {&xy.rows, &nine}};
    input_array weights = {.name = "weights", .ndim = 1, .length = {&xy.rows, NULL}};
    int n_threads = 0;
    PyArrayObject *out = NULL;
    if (!PyArg_ParseTupleAndKeywords(args, kwds, "O&dddO&O&O&O&|O&", kw, kernel_converter, &ka, &r, &lo, &hi,
                                     array_converter, &xy, array_converter, &zeta, array_converter, &tens,
                                     array_converter, &weights, threads_converter, &n_threads))
        goto done;
    if (!(r >= 0.0) || !isfinite(r)) {
        PyErr_Format(PyExc_ValueError, "r: expected a finite radius >= 0, got %R", PyTuple_GetItem(args, 1));
        goto done;
    }
    if (!isfinite(lo) || !isfinite(hi) || !(lo < hi)) {
        PyErr_Format(PyExc_ValueError, "lo, hi: expected finite numbers with lo < hi, got %g and %g", lo, hi);
        goto done;
    }
    const npy_intp shape[2] = {3, 3};
    out = (PyArrayObject *)PyArray_ZEROS(2, shape, NPY_DOUBLE, 0);
    if (!out) goto done;
    cg_status st;
    Py_BEGIN_ALLOW_THREADS
    st = cg_ring_axial_point_sum(&ka.kernel, r, lo, hi, xy.rows, array_data(&xy), array_data(&zeta),
                                 array_data(&tens), array_data(&weights), PyArray_DATA(out), n_threads);
    Py_END_ALLOW_THREADS
    if (st != CG_OK) {
        raise_status(st);
        Py_CLEAR(out);
    }
done:
    release_array(&xy);
    release_array(&zeta);
    release_array(&tens);
    release_array(&weights);
    return (PyObject *)out;
}

static PyObject *py_quartic_roots(PyObject *self, PyObject *args, PyObject *kwds)
{
    (void)self;
    static char *kw[] = {"coef", "n_threads", NULL};
    static const npy_intp five = 5;
    input_array coef = {.name = "coef", .ndim = 2, .length = {NULL, &five}};
    int n_threads = 0;
    PyArrayObject *out = NULL;
    if (!PyArg_ParseTupleAndKeywords(args, kwds, "O&|O&", kw, array_converter, &coef, threads_converter, &n_threads))
        goto done;
    const double *c = array_data(&coef);
    for (npy_intp i = 0; i < coef.rows; ++i)
        if (c[5 * i] == 0.0) {
            PyErr_Format(PyExc_ValueError,
                         "coef: expected a nonzero leading coefficient in every row, got 0 in row %zd", (Py_ssize_t)i);
            goto done;
        }
    const npy_intp shape[2] = {coef.rows, 4};
    out = (PyArrayObject *)PyArray_ZEROS(2, shape, NPY_CDOUBLE, 0);
    if (!out) goto done;
    cg_status st;
    Py_BEGIN_ALLOW_THREADS
    st = cg_quartic_roots(coef.rows, c, (double *)PyArray_DATA(out), n_threads);
    Py_END_ALLOW_THREADS
    if (st != CG_OK) {
        raise_status(st);
        Py_CLEAR(out);
    }
done:
    release_array(&coef);
    return (PyObject *)out;
}

static PyObject *py_axial_segment_sum(PyObject *self, PyObject *args, PyObject *kwds)
{
    (void)self;
    static char *kw[] = {"kernel", "bottoms", "column", "first", "segment", "lo", "hi", "panels", "starts",
                         "vectors", "values", "n_threads", NULL};
    static const npy_intp three = 3, nine = 9;
    kernel_arg ka = {.target = &ring_space};
    input_array bottoms = {.name = "bottoms", .ndim = 2, .length = {NULL, &three}};
    input_array column = {.name = "column", .ndim = 1, .length = {&three, NULL}};
    index_array first = {.name = "first", .length = NULL};
    index_array segment = {.name = "segment", .length = NULL};
    input_array lo = {.name = "lo", .ndim = 1, .length = {NULL, NULL}};
    input_array hi = {.name = "hi", .ndim = 1, .length = {&lo.rows, NULL}};
    index_array panels = {.name = "panels", .length = &lo.rows};
    input_array starts = {.name = "starts", .ndim = 2, .length = {NULL, &three}};
    input_array vectors = {.name = "vectors", .ndim = 2, .length = {&starts.rows, &three}};
    input_array values = {.name = "values", .ndim = 2, .length = {&starts.rows, &nine}};
    int n_threads = 0;
    PyArrayObject *out = NULL;
    if (!PyArg_ParseTupleAndKeywords(args, kwds, "O&O&O&O&O&O&O&O&O&O&O&|O&", kw, kernel_converter, &ka,
                                     array_converter, &bottoms, array_converter, &column, index_converter, &first,
                                     index_converter, &segment, array_converter, &lo, array_converter, &hi,
                                     index_converter, &panels, array_converter, &starts, array_converter, &vectors,
                                     array_converter, &values, threads_converter, &n_threads))
        goto done;
    if (!check_pieces(&first, &segment, lo.rows, bottoms.rows, "column")) goto done;
    const npy_intp shape[2] = {bottoms.rows, 9};
    out = (PyArrayObject *)PyArray_ZEROS(2, shape, NPY_DOUBLE, 0);
    if (!out) goto done;
    cg_status st;
    Py_BEGIN_ALLOW_THREADS
    st = cg_axial_segment_sum(&ka.kernel, bottoms.rows, array_data(&bottoms), array_data(&column),
                              (const cg_index *)PyArray_DATA(first.array),
                              (const cg_index *)PyArray_DATA(segment.array), array_data(&lo), array_data(&hi),
                              (const cg_index *)PyArray_DATA(panels.array), starts.rows, array_data(&starts),
                              array_data(&vectors), array_data(&values), PyArray_DATA(out), n_threads);
    Py_END_ALLOW_THREADS
    if (st == CG_ERR_ARGUMENT) {
        PyErr_SetString(PyExc_ValueError, "first, segment, lo, hi, panels, column: expected nondecreasing first "
                                          "from 0, rows of starts, 0 <= lo <= hi <= 1, panels >= 1, a finite column "
                                          "and the full 3-D kernel with exact line integrals");
        Py_CLEAR(out);
    } else if (st != CG_OK) {
        raise_status(st);
        Py_CLEAR(out);
    }
done:
    release_array(&bottoms);
    release_array(&column);
    Py_CLEAR(first.array);
    Py_CLEAR(segment.array);
    release_array(&lo);
    release_array(&hi);
    Py_CLEAR(panels.array);
    release_array(&starts);
    release_array(&vectors);
    release_array(&values);
    return (PyObject *)out;
}

static PyObject *py_wrap(PyObject *self, PyObject *args, PyObject *kwds)
{
    (void)self;
    static char *kw[] = {"positions", "periodic", "lower", "upper", NULL};
    input_array pos = {.name = "positions", .ndim = 2, .length = {NULL, NULL}};
    input_array lower = {.name = "lower", .ndim = 1, .length = {NULL, NULL}};
    input_array upper = {.name = "upper", .ndim = 1, .length = {NULL, NULL}};
    PyObject *periodic_obj;
    PyArrayObject *out = NULL;
    cg_status status = CG_OK;
    if (!PyArg_ParseTupleAndKeywords(args, kwds, "O&OO&O&", kw, array_converter, &pos, &periodic_obj,
                                     array_converter, &lower, array_converter, &upper))
        goto done;
    const npy_intp D = PyArray_DIM(pos.array, 1);
    int periodic[3] = {0, 0, 0};
    if (D < 1 || D > 3 || PySequence_Size(periodic_obj) != D || lower.rows != D || upper.rows != D) {
        PyErr_Clear();
        PyErr_SetString(PyExc_ValueError, "wrap: positions need 1 to 3 columns, and periodic, lower and upper "
                                          "one entry per column");
        goto done;
    }
    for (npy_intp d = 0; d < D; ++d) {
        PyObject *p = PySequence_GetItem(periodic_obj, d);
        periodic[d] = p ? PyObject_IsTrue(p) : -1;
        Py_XDECREF(p);
        if (periodic[d] < 0) goto done;
    }
    out = (PyArrayObject *)PyArray_NewCopy(pos.array, NPY_CORDER);
    if (!out) goto done;
    Py_BEGIN_ALLOW_THREADS
    status = cg_wrap(PyArray_DIM(out, 0), (int)D, PyArray_DATA(out), periodic, array_data(&lower),
                     array_data(&upper));
    Py_END_ALLOW_THREADS
    if (status != CG_OK) {
        PyErr_Format(PyExc_ValueError, "wrap: %s (a periodic axis needs upper > lower, and positions within "
                     "reach of the box: x - lower must not overflow)", cg_strerror(status));
        Py_CLEAR(out);
    }
done:
    release_array(&pos);
    release_array(&lower);
    release_array(&upper);
    return (PyObject *)out;
}

static PyObject *py_have_openmp(PyObject *self, PyObject *args)
{
    (void)self;
    (void)args;
    return PyBool_FromLong(cg_have_openmp());
}

static PyObject *py_set_wide_vectors(PyObject *self, PyObject *arg)
{
    (void)self;
    const int allow = PyObject_IsTrue(arg);
    if (allow < 0) return NULL;
    return PyBool_FromLong(cg_set_wide_vectors(allow));
}

static PyObject *py_wide_vectors(PyObject *self, PyObject *args)
{
    (void)self;
    (void)args;
    return PyBool_FromLong(cg_wide_vectors());
}

/* the tests' element-wise functions (x a 1-D array): out = fn(x), where every value is >= 0 (nonnegative) or
   <= 0; otherwise refused as "x: expected <expected> at index i" */
static PyObject *elementwise(PyObject *arg, int nonnegative, const char *expected,
                             void (*fn)(const double *, double *, cg_index))
{
    const npy_intp shape[1] = {-1};
    PyArrayObject *x = as_array(arg, "x", 1, shape);
    if (!x) return NULL;
    const npy_intp n = PyArray_DIM(x, 0);
    const double *xs = (const double *)PyArray_DATA(x);
    for (npy_intp i = 0; i < n; ++i)
        if (!(nonnegative ? xs[i] >= 0.0 : xs[i] <= 0.0)) {
            PyErr_Format(PyExc_ValueError, "x: expected %s at index %zd", expected, (Py_ssize_t)i);
            Py_DECREF(x);
            return NULL;
        }
    PyArrayObject *out = (PyArrayObject *)PyArray_SimpleNew(1, &n, NPY_DOUBLE);
    if (!out) {
        Py_DECREF(x);
        return NULL;
    }
    Py_BEGIN_ALLOW_THREADS
    fn(xs, (double *)PyArray_DATA(out), (cg_index)n);
    Py_END_ALLOW_THREADS
    Py_DECREF(x);
    return (PyObject *)out;
}

static PyObject *py_gaussian_erfcx(PyObject *self, PyObject *arg)
{
    (void)self;
    return elementwise(arg, 1, "values >= 0, got a negative value", cg_gaussian_erfcx);
}

static PyObject *py_gaussian_exp(PyObject *self, PyObject *arg)
{
    (void)self;
    return elementwise(arg, 0, "values <= 0 (a Gaussian's exponents), got a positive value or NaN", cg_gaussian_exp);
}

/* ================================================================== */
/* text parsing (cg_text.h): owned by the text-parser work; one block,  */
/* its entries in the method table come from CG_TEXT_METHODS below.     */
/* ================================================================== */
#include "cg_text.h"

/* a held read-only contiguous buffer (bytes, bytearray, memoryview, mmap) */
typedef struct text_buffer {
    Py_buffer view;
    int held;
} text_buffer;

static void release_text_buffer(text_buffer *b)
{
    if (b->held) PyBuffer_Release(&b->view);
    b->held = 0;
}

/* O& converter (with cleanup): data -> text_buffer */
static int convert_text_buffer(PyObject *obj, void *out)
{
    text_buffer *b = (text_buffer *)out;
    if (!obj) { /* cleanup call after a later argument failed */
        release_text_buffer(b);
        return 1;
    }
    if (PyObject_GetBuffer(obj, &b->view, PyBUF_SIMPLE) < 0) {
        PyErr_Format(PyExc_TypeError, "data: expected bytes, bytearray, mmap or a contiguous memoryview, got %.200s",
                     Py_TYPE(obj)->tp_name);
        return 0;
    }
    b->held = 1;
    return Py_CLEANUP_SUPPORTED;
}

/* check 0 <= start <= stop <= len(data) */
static int check_text_range(const text_buffer *b, Py_ssize_t start, Py_ssize_t stop)
{
    if (start < 0 || stop < start || stop > b->view.len) {
        PyErr_Format(PyExc_ValueError, "start, stop: expected 0 <= start <= stop <= len(data) = %zd, got %zd, %zd",
                     b->view.len, start, stop);
        return 0;
    }
    return 1;
}

/* a C-contiguous (shape[0], shape[1]) array over memory at data, inside the buffer of owner (its base) */
static PyArrayObject *view_of(PyObject *owner, const npy_intp *shape, int type, void *data)
{
    PyArrayObject *arr = (PyArrayObject *)PyArray_New(&PyArray_Type, 2, (npy_intp *)shape, type, NULL, data, 0,
                                                      NPY_ARRAY_CARRAY, NULL);
    if (!arr) return NULL;
    Py_INCREF(owner);
    if (PyArray_SetBaseObject(arr, owner) < 0) { /* (it took the reference even so) */
        Py_DECREF(arr);
        return NULL;
    }
    return arr;
}

/* The export of out()'s buffer, held for as long as tables view it: a capsule (not itself a buffer, so every view
   of the tables leads back to it) that releases the export when the last view is gone. While it lives, the
   exporter can neither move its memory (a bytearray's resize, an mmap's close) nor be released (a memoryview). */
#define TABLE_EXPORT "cgbound.text_table_export"

static void release_table_export(PyObject *capsule)
{
    Py_buffer *view = (Py_buffer *)PyCapsule_GetPointer(capsule, TABLE_EXPORT);
    if (view) {
        PyBuffer_Release(view);
        PyMem_Free(view);
    }
}

static PyObject *py_text_parse_table(PyObject *self, PyObject *args)
{
    (void)self;
    text_buffer data = {0}, mask = {0};
    Py_ssize_t start, stop, ncols, max_rows;
    int flags, n_threads = 1, parts = 0;
    PyObject *out = Py_None, *lease = NULL, *export = NULL;
    PyArrayObject *values = NULL, *ints = NULL;
    PyObject *ret = NULL;
    if (!PyArg_ParseTuple(args, "O&nnnO&ni|iiO", convert_text_buffer, &data, &start, &stop, &ncols,
                          convert_text_buffer, &mask, &max_rows, &flags, &n_threads, &parts, &out))
        return NULL;
    if (out != Py_None && !PyCallable_Check(out)) {
        PyErr_Format(PyExc_TypeError, "out: expected None or a callable, got %.200s", Py_TYPE(out)->tp_name);
        goto done;
    }
    if (!check_text_range(&data, start, stop)) goto done;
    if (n_threads < 1 || parts < 0 || parts > CG_TEXT_MAX_THREADS) {
        PyErr_Format(PyExc_ValueError,
                     "n_threads, parts: expected a positive count and 0 .. %d parts, got %d, %d",
                     CG_TEXT_MAX_THREADS, n_threads, parts);
        goto done;
    }
    if (ncols < 1 || mask.view.len != ncols) {
        PyErr_Format(PyExc_ValueError, "ncols: expected a positive count equal to len(int_mask) = %zd, got %zd",
                     mask.view.len, ncols);
        goto done;
    }
    const char *text = (const char *)data.view.buf + start;
    const size_t length = (size_t)(stop - start);
    const unsigned char *is_int = (const unsigned char *)mask.view.buf;
    npy_intp n_int = 0;
    for (Py_ssize_t c = 0; c < ncols; ++c) n_int += is_int[c] != 0;
    flags &= CG_TEXT_SKIP_BLANK | CG_TEXT_STOP_AT_MAX_ROWS;
    /* parts: 0 from n_threads and the range's size; > 0 exactly that many (tests of small parts) */
    cg_text_plan plan;
    int planned = 0;
    if (max_rows < 0) { /* unknown: at most one row per line; the count is kept to place each part's rows */
        Py_BEGIN_ALLOW_THREADS
        cg_text_plan_lines(text, length, parts ? parts : cg_text_plan_parts(length, n_threads), &plan);
        Py_END_ALLOW_THREADS
        max_rows = (Py_ssize_t)plan.line[plan.parts];
        planned = 1;
    }
    if (max_rows > 0 && ncols > PY_SSIZE_T_MAX / (Py_ssize_t)sizeof(double) / max_rows) {
        PyErr_Format(PyExc_MemoryError, "a table of %zd x %zd values does not fit in memory", max_rows, ncols);
        goto done;
    }
    const npy_intp vshape[2] = {max_rows, ncols}, ishape[2] = {max_rows, n_int};
    /* out(nbytes): memory for both tables (values, then ints from a 64-byte offset) whose pages were already
       touched by an earlier frame, or None for new arrays; asked for here, once the size is known (after the
       plan's line count). vbytes fits (checked above); ioffset and nbytes are checked here */
    Py_ssize_t nbytes = 0, ioffset = 0;
    if (out != Py_None && max_rows > 0) {
        const Py_ssize_t vbytes = max_rows * ncols * (Py_ssize_t)sizeof(double);
        if (vbytes > PY_SSIZE_T_MAX - 63 ||
            n_int > (PY_SSIZE_T_MAX - ((vbytes + 63) & ~(Py_ssize_t)63)) / (Py_ssize_t)sizeof(int64_t) / max_rows) {
            PyErr_Format(PyExc_MemoryError, "a table of %zd x %zd values does not fit in memory", max_rows, ncols);
            goto done;
        }
        ioffset = (vbytes + 63) & ~(Py_ssize_t)63;
        nbytes = ioffset + max_rows * (Py_ssize_t)n_int * (Py_ssize_t)sizeof(int64_t);
        lease = PyObject_CallFunction(out, "n", nbytes);
        if (!lease) goto done;
    }
    if (lease && lease != Py_None) {
        Py_buffer *view = (Py_buffer *)PyMem_Malloc(sizeof *view);
        if (!view) {
            PyErr_NoMemory();
            goto done;
        }
        if (PyObject_GetBuffer(lease, view, PyBUF_WRITABLE) < 0) {
            PyMem_Free(view);
            PyErr_Clear();
            PyErr_Format(PyExc_TypeError, "out: expected it to return None or a writable contiguous buffer, got %.200s",
                         Py_TYPE(lease)->tp_name);
            goto done;
        }
        export = PyCapsule_New(view, TABLE_EXPORT, release_table_export);
        if (!export) {
            PyBuffer_Release(view);
            PyMem_Free(view);
            goto done;
        }
        char *mem = (char *)view->buf;
        if (view->len < nbytes || ((uintptr_t)mem & 7) != 0) {
            PyErr_Format(PyExc_ValueError, "out: expected a buffer of at least %zd bytes aligned to 8 bytes, got %zd "
                         "bytes at an address %d mod 8", nbytes, view->len, (int)((uintptr_t)mem & 7));
            goto done;
        }
        values = view_of(export, vshape, NPY_DOUBLE, mem);
        ints = values ? view_of(export, ishape, NPY_INT64, mem + ioffset) : NULL;
    } else {
        values = (PyArrayObject *)PyArray_SimpleNew(2, vshape, NPY_DOUBLE);
        ints = (PyArrayObject *)PyArray_SimpleNew(2, ishape, NPY_INT64);
    }
    if (!values || !ints) goto done;
    cg_text_result res;
    cg_status st;
    const unsigned char *int_columns = n_int ? is_int : NULL;
    double *vp = (double *)PyArray_DATA(values);
    int64_t *ip = (int64_t *)PyArray_DATA(ints);
    Py_BEGIN_ALLOW_THREADS
    if (planned)
        st = cg_text_parse_table_plan(text, length, &plan, ncols, int_columns, flags, max_rows, vp, ip, &res);
    else if (parts)
        st = cg_text_parse_table_parts(text, length, ncols, int_columns, flags, max_rows, vp, ip, &res, parts);
    else
        st = cg_text_parse_table_threads(text, length, ncols, int_columns, flags, max_rows, vp, ip, &res, n_threads);
    Py_END_ALLOW_THREADS
    if (st == CG_ERR_ARGUMENT) {
        PyErr_SetString(PyExc_ValueError, cg_strerror(st));
        goto done;
    }
    ret = Py_BuildValue("OOnn(isLLLL)(LLLLL)", values, ints, (Py_ssize_t)res.nrows, (Py_ssize_t)(start + res.end),
                        (int)st, cg_strerror(st),
                        (long long)res.error.line, (long long)res.error.column, (long long)res.error.offset,
                        (long long)res.error.length, (long long)res.nonfinite, (long long)res.first_nonfinite.line,
                        (long long)res.first_nonfinite.column, (long long)res.first_nonfinite.offset,
                        (long long)res.first_nonfinite.length);
done:
    Py_XDECREF(values);
    Py_XDECREF(ints);
    Py_XDECREF(export);
    Py_XDECREF(lease);
    release_text_buffer(&mask);
    release_text_buffer(&data);
    return ret;
}

static PyObject *py_text_plan_lines(PyObject *self, PyObject *args)
{
    (void)self;
    text_buffer data = {0};
    Py_ssize_t start, stop;
    int parts;
    PyObject *ret = NULL;
    if (!PyArg_ParseTuple(args, "O&nni", convert_text_buffer, &data, &start, &stop, &parts)) return NULL;
    if (!check_text_range(&data, start, stop)) goto done;
    if (parts < 1 || parts > CG_TEXT_MAX_THREADS) {
        PyErr_Format(PyExc_ValueError, "parts: expected 1 .. %d, got %d", CG_TEXT_MAX_THREADS, parts);
        goto done;
    }
    cg_text_plan plan;
    Py_BEGIN_ALLOW_THREADS
    cg_text_plan_lines((const char *)data.view.buf + start, (size_t)(stop - start), parts, &plan);
    Py_END_ALLOW_THREADS
    const npy_intp n = plan.parts + 1;
    PyArrayObject *starts = (PyArrayObject *)PyArray_SimpleNew(1, &n, NPY_INT64);
    PyArrayObject *lines = (PyArrayObject *)PyArray_SimpleNew(1, &n, NPY_INT64);
    if (starts && lines) {
        for (npy_intp k = 0; k < n; ++k) {
            ((int64_t *)PyArray_DATA(starts))[k] = start + plan.start[k];
            ((int64_t *)PyArray_DATA(lines))[k] = plan.line[k];
        }
        ret = Py_BuildValue("OO", starts, lines);
    }
    Py_XDECREF(starts);
    Py_XDECREF(lines);
done:
    release_text_buffer(&data);
    return ret;
}

static PyObject *py_text_find_lines(PyObject *self, PyObject *args)
{
    (void)self;
    text_buffer data = {0}, prefix = {0};
    Py_ssize_t start, stop;
    int n_threads = 1;
    PyArrayObject *offsets = NULL;
    PyObject *ret = NULL;
    if (!PyArg_ParseTuple(args, "O&nnO&|i", convert_text_buffer, &data, &start, &stop, convert_text_buffer, &prefix,
                          &n_threads))
        return NULL;
    if (!check_text_range(&data, start, stop)) goto done;
    if (n_threads < 1) {
        PyErr_Format(PyExc_ValueError, "n_threads: expected a positive count, got %d", n_threads);
        goto done;
    }
    const char *text = (const char *)data.view.buf + start;
    const size_t length = (size_t)(stop - start);
    int64_t count = 0;
    for (npy_intp capacity = 1024;;) { /* usually one scan; a second one with the exact size if more lines match */
        Py_XDECREF(offsets);
        offsets = (PyArrayObject *)PyArray_SimpleNew(1, &capacity, NPY_INT64);
        if (!offsets) goto done;
        int64_t *out = (int64_t *)PyArray_DATA(offsets);
        Py_BEGIN_ALLOW_THREADS
        cg_text_find_lines_threads(text, length, (const char *)prefix.view.buf, (size_t)prefix.view.len, out,
                                   capacity, &count, n_threads);
        for (int64_t i = 0; i < count && i < capacity; ++i) out[i] += start;
        Py_END_ALLOW_THREADS
        if (count <= capacity) break;
        capacity = (npy_intp)count;
    }
    ret = PySequence_GetSlice((PyObject *)offsets, 0, (Py_ssize_t)count);
done:
    Py_XDECREF(offsets);
    release_text_buffer(&prefix);
    release_text_buffer(&data);
    return ret;
}

static PyObject *py_text_count_lines(PyObject *self, PyObject *args)
{
    (void)self;
    text_buffer data = {0};
    Py_ssize_t start, stop;
    int n_threads = 1;
    PyObject *ret = NULL;
    if (!PyArg_ParseTuple(args, "O&nn|i", convert_text_buffer, &data, &start, &stop, &n_threads)) return NULL;
    if (check_text_range(&data, start, stop)) {
        int64_t count;
        Py_BEGIN_ALLOW_THREADS
        count = cg_text_count_lines_threads((const char *)data.view.buf + start, (size_t)(stop - start), n_threads);
        Py_END_ALLOW_THREADS
        ret = PyLong_FromLongLong((long long)count);
    }
    release_text_buffer(&data);
    return ret;
}

/* ---- MercuryDPM .fstat contacts (cg_fstat.h) ---- */
#include "cg_fstat.h"

/* a C-contiguous aligned array of obj with dtype type and ndim dimensions (a view when it already is one) */
static PyArrayObject *fstat_array(PyObject *obj, int type, int ndim, const char *name)
{
    PyArrayObject *arr = (PyArrayObject *)PyArray_FROM_OTF(obj, type, NPY_ARRAY_IN_ARRAY);
    if (!arr) return NULL;
    if (PyArray_NDIM(arr) != ndim) {
        PyErr_Format(PyExc_ValueError, "fstat_contacts: %s: expected %d dimensions, got %d", name, ndim,
                     PyArray_NDIM(arr));
        Py_DECREF(arr);
        return NULL;
    }
    return arr;
}

/* shrink a fresh C-contiguous output to its first rows (realloc, no copy of the kept part) */
static int fstat_shrink(PyArrayObject *arr, npy_intp rows)
{
    npy_intp dims[2] = {rows, PyArray_NDIM(arr) == 2 ? PyArray_DIM(arr, 1) : 0};
    PyArray_Dims shape = {dims, PyArray_NDIM(arr)};
    PyObject *res = PyArray_Resize(arr, &shape, 0, NPY_CORDER);
    if (!res) return 0;
    Py_DECREF(res);
    return 1;
}

static PyObject *py_fstat_contacts(PyObject *self, PyObject *args)
{
    (void)self;
    PyObject *rows_obj, *partners_obj, *positions_obj, *radii_obj, *fixed_obj, *periodic_obj, *period_obj;
    double time, time_tolerance, rtol;
    if (!PyArg_ParseTuple(args, "OOddOOOOOd", &rows_obj, &partners_obj, &time, &time_tolerance, &positions_obj,
                          &radii_obj, &fixed_obj, &periodic_obj, &period_obj, &rtol))
        return NULL;
    PyArrayObject *rows = NULL, *partners = NULL, *positions = NULL, *radii = NULL, *fixed = NULL;
    PyArrayObject *out_i = NULL, *out_j = NULL, *out_wall = NULL, *out_force = NULL, *out_point = NULL,
                  *out_overlap = NULL;
    PyObject *ret = NULL;
    rows = fstat_array(rows_obj, NPY_DOUBLE, 2, "rows");
    partners = rows ? fstat_array(partners_obj, NPY_INT64, 2, "partners") : NULL;
    positions = partners ? fstat_array(positions_obj, NPY_DOUBLE, 2, "positions") : NULL;
    radii = positions ? fstat_array(radii_obj, NPY_DOUBLE, 1, "radii") : NULL;
    fixed = radii ? fstat_array(fixed_obj, NPY_BOOL, 1, "fixed") : NULL;
    if (!fixed) goto done;
    const npy_intp m = PyArray_DIM(rows, 0), n = PyArray_DIM(positions, 0);
    const int d = (int)PyArray_DIM(positions, 1);
    if (PyArray_DIM(rows, 1) < CG_FSTAT_COLUMNS || PyArray_DIM(partners, 0) != m || PyArray_DIM(partners, 1) != 2 ||
        PyArray_DIM(radii, 0) != n || PyArray_DIM(fixed, 0) != n || (d != 2 && d != 3) || !(rtol >= 0)) {
        PyErr_SetString(PyExc_ValueError, "fstat_contacts: expected rows (M, >= 16), partners (M, 2), positions "
                                          "(N, 2 or 3), radii (N,), fixed (N,) and rtol >= 0");
        goto done;
    }
    int periodic[3] = {0, 0, 0};
    double period[3] = {1.0, 1.0, 1.0};
    if (!convert_periodicity(periodic_obj, period_obj, d, "fstat_contacts", "axis", periodic, period)) goto done;
    const npy_intp one[1] = {m}, two[2] = {m, d};
    out_i = (PyArrayObject *)PyArray_SimpleNew(1, one, NPY_INT64);
    out_j = (PyArrayObject *)PyArray_SimpleNew(1, one, NPY_INT64);
    out_wall = (PyArrayObject *)PyArray_SimpleNew(1, one, NPY_INT64);
    out_force = (PyArrayObject *)PyArray_SimpleNew(2, two, NPY_DOUBLE);
    out_point = (PyArrayObject *)PyArray_SimpleNew(2, two, NPY_DOUBLE);
    out_overlap = (PyArrayObject *)PyArray_SimpleNew(1, one, NPY_DOUBLE);
    if (!out_i || !out_j || !out_wall || !out_force || !out_point || !out_overlap) goto done;
    const cg_fstat_frame frame = {
        (const double *)PyArray_DATA(rows), (int64_t)m, (int64_t)PyArray_DIM(rows, 1),
        (const int64_t *)PyArray_DATA(partners), time, time_tolerance, (const double *)PyArray_DATA(positions),
        (int64_t)n, d, (const double *)PyArray_DATA(radii), (const unsigned char *)PyArray_DATA(fixed), periodic,
        period, rtol};
    cg_fstat_result res = {(int64_t *)PyArray_DATA(out_i), (int64_t *)PyArray_DATA(out_j),
                           (int64_t *)PyArray_DATA(out_wall), (double *)PyArray_DATA(out_force),
                           (double *)PyArray_DATA(out_point), (double *)PyArray_DATA(out_overlap)};
    cg_status st;
    Py_BEGIN_ALLOW_THREADS
    st = cg_fstat_contacts(&frame, &res);
    Py_END_ALLOW_THREADS
    if (st == CG_ERR_FSTAT_LINES) {
        ret = Py_BuildValue("i(LLLLLdd(ddd)(ddd))O", (int)res.problem, (long long)res.row, (long long)res.other_row,
                            (long long)res.pair_lo, (long long)res.pair_hi, (long long)res.count, res.df, res.dc,
                            res.force_row[0], res.force_row[1], res.force_row[2], res.force_other[0],
                            res.force_other[1], res.force_other[2], Py_None);
        goto done;
    }
    if (st == CG_ERR_NOMEM) {
        PyErr_NoMemory();
        goto done;
    }
    if (st != CG_OK) {
        PyErr_Format(PyExc_ValueError, "fstat_contacts: %s", cg_strerror(st));
        goto done;
    }
    const npy_intp kept = (npy_intp)res.n_kept;
    if (!fstat_shrink(out_i, kept) || !fstat_shrink(out_j, kept) || !fstat_shrink(out_wall, kept) ||
        !fstat_shrink(out_force, kept) || !fstat_shrink(out_point, kept) || !fstat_shrink(out_overlap, kept))
        goto done;
    ret = Py_BuildValue("i()(OOOOOO)", 0, out_i, out_j, out_wall, out_force, out_point, out_overlap);
done:
    Py_XDECREF(rows);
    Py_XDECREF(partners);
    Py_XDECREF(positions);
    Py_XDECREF(radii);
    Py_XDECREF(fixed);
    Py_XDECREF(out_i);
    Py_XDECREF(out_j);
    Py_XDECREF(out_wall);
    Py_XDECREF(out_force);
    Py_XDECREF(out_point);
    Py_XDECREF(out_overlap);
    return ret;
}

#define CG_TEXT_METHODS                                                                                             \
    {"text_parse_table", py_text_parse_table, METH_VARARGS,                                                         \
     "text_parse_table(data, start, stop, ncols, int_mask, max_rows, flags, n_threads=1, parts=0, out=None) -> "   \
     "(values, ints, nrows, end, (status, message, line, column, offset, length), (nonfinite, line, column, "      \
     "offset, length))\n\n"                                                                                        \
     "out: None (new arrays) or a callable out(nbytes) returning a writable buffer (8-byte aligned) of at least "   \
     "nbytes bytes, or None for new arrays: the tables are then views of it (values first, ints from the next "    \
     "64-byte offset), their base a capsule holding the buffer's export while any view lives. "                                                         \
     "flags: 1 skip blank lines, 2 stop after max_rows rows (end: offset in data where parsing stopped). "          \
     "Parse data[start:stop] as rows of ncols numbers (cg_text_parse_table); max_rows < 0: one per line at most. "  \
     "parts > 0: cut into exactly that many parts, one thread each (for tests). "                                  \
     "Errors are returned, not raised: cgbound.readers._text turns them into messages."},                           \
        {"text_plan_lines", py_text_plan_lines, METH_VARARGS,                                                       \
         "text_plan_lines(data, start, stop, parts) -> (starts, lines): data[start:stop] cut at line starts into "  \
         "parts (cg_text_plan_lines): int64 offsets in data of the parts and their end, and the lines before each " \
         "(the last: all of them)."},                                                                                \
        {"text_find_lines", py_text_find_lines, METH_VARARGS,                                                       \
         "text_find_lines(data, start, stop, prefix, n_threads=1) -> int64 offsets (from the start of data) of "   \
         "the lines of data[start:stop] that start with prefix (cg_text_find_lines_threads)."},                      \
        {"text_count_lines", py_text_count_lines, METH_VARARGS,                                                     \
         "text_count_lines(data, start, stop, n_threads=1) -> the lines of data[start:stop] "                      \
         "(cg_text_count_lines_threads): its '\\n' bytes, plus one if it is not empty and does not end with one."},

/* ================================================================== */
/* end of the text-parsing block                                        */
/* ================================================================== */

static PyMethodDef methods[] = {
    {"scatter_points", (PyCFunction)(void (*)(void))py_scatter_points, METH_VARARGS | METH_KEYWORDS,
     "scatter_points(target, kernel, positions, values, gradient=False, n_threads=0) -> (P, K) or (P, K, D_res)\n\n"
     "Sum of values[o] * M(node - positions[o]) over objects o (or of its gradient)."},
    {"scatter_segments", (PyCFunction)(void (*)(void))py_scatter_segments, METH_VARARGS | METH_KEYWORDS,
     "scatter_segments(target, kernel, starts, vectors, values, ray=False, gradient=False, n_threads=0)\n\n"
     "Sum of values[o] * int_0^S M(node - starts[o] - s vectors[o]) ds, S = 1 or infinity (ray)."},
    {"scatter_segments_outer", (PyCFunction)(void (*)(void))py_scatter_segments_outer, METH_VARARGS | METH_KEYWORDS,
     "scatter_segments_outer(target, kernel, starts, vectors, factors, ray=False, gradient=False, n_threads=0, "
     "negate=False)\n\n"
     "scatter_segments with values[o] = factors[o] (x) vectors[o] (flat, 0.0 + each product), formed in the core "
     "per segment (cg_scatter_segments_outer); negate: the vectors are -vectors (exactly)."},
    {"scatter_segment_moments", (PyCFunction)(void (*)(void))py_scatter_segment_moments, METH_VARARGS | METH_KEYWORDS,
     "scatter_segment_moments(target, kernel, starts, vectors, values, gradient=False, n_threads=0)\n\n"
     "Sum of values[o] * int_0^1 s M(node - starts[o] - s vectors[o]) ds (the kernel's first moment)."},
    {"scatter_points_kinetic", (PyCFunction)(void (*)(void))py_scatter_points_kinetic, METH_VARARGS | METH_KEYWORDS,
     "scatter_points_kinetic(target, kernel, positions, masses, velocities, u_ref, parts, n_threads=0) -> (P, K)\n\n"
     "scatter_points with values[o] the parts (mask: 1 m, 2 m (v - u_ref), 4 m v_r v_c for r <= c: the symmetric flux's "
     "upper triangle, row by row) formed in the core per particle (cg_scatter_points_kinetic)."},
    {"scatter_fluctuation", (PyCFunction)(void (*)(void))py_scatter_fluctuation, METH_VARARGS | METH_KEYWORDS,
     "scatter_fluctuation(target, kernel, positions, masses, velocities, node_velocity, n_threads=0) -> (P, D, D)\n\n"
     "Kinetic stress -sum m (v - V(node)) (v - V(node)) M(node - x) in fluctuation form."},
    {"minimum_image", (PyCFunction)(void (*)(void))py_minimum_image, METH_VARARGS | METH_KEYWORDS,
     "minimum_image(vectors, periodic, period) -> copy of vectors wrapped to the minimum image."},
    {"wrap", (PyCFunction)(void (*)(void))py_wrap, METH_VARARGS | METH_KEYWORDS,
     "wrap(positions, periodic, lower, upper) -> copy of positions wrapped into [lower, upper) on periodic axes."},
    {"ring_moments", (PyCFunction)(void (*)(void))py_ring_moments, METH_VARARGS | METH_KEYWORDS,
     "ring_moments(kernel, r, h, rho, gradient=False, n_moments=3, n_threads=0): the angular moments (n_moments, n) "
     "of the 3-D kernel over rings."},
    {"ring_segment_sum", (PyCFunction)(void (*)(void))py_ring_segment_sum, METH_VARARGS | METH_KEYWORDS,
     "ring_segment_sum(kernel, r, z, segment, lo, hi, panels, geometry, tensors, weight, gradient=False, "
     "n_threads=0): (3, 3), with gradient (3, 3, 3)."},
    {"ring_segment_columns", (PyCFunction)(void (*)(void))py_ring_segment_columns, METH_VARARGS | METH_KEYWORDS,
     "ring_segment_columns(kernel, rings, first, segment, lo, hi, panels, geometry, tensors, gradient=False, "
     "n_threads=0) -> (C, 9) or (C, 27): ring_segment_sum for each ring (r, z, weight) of rings (C, 3) over its "
     "pieces first[c]:first[c + 1], the same bits; columns independent."},
    {"ring_axial_point_sum", (PyCFunction)(void (*)(void))py_ring_axial_point_sum, METH_VARARGS | METH_KEYWORDS,
     "ring_axial_point_sum(kernel, r, lo, hi, xy, zeta, tensors, weights, n_threads=0) -> (3, 3): the weighted "
     "theta-averages of tensors (J, 9) at point sources (xy (J, 2), zeta (J,), ring frame) over the ring r, "
     "averaged exactly over z in [lo, hi]."},
    {"quartic_roots", (PyCFunction)(void (*)(void))py_quartic_roots, METH_VARARGS | METH_KEYWORDS,
     "quartic_roots(coef, n_threads=0) -> (n, 4) complex: the roots of the quartics coef (n, 5), highest power "
     "first (Aberth-Ehrlich iteration)."},
    {"axial_segment_sum", (PyCFunction)(void (*)(void))py_axial_segment_sum, METH_VARARGS | METH_KEYWORDS,
     "axial_segment_sum(kernel, bottoms, column, first, segment, lo, hi, panels, starts, vectors, values, "
     "n_threads=0): (n_columns, 9)."},
    {"have_openmp", py_have_openmp, METH_NOARGS, "Whether the core was built with OpenMP."},
    {"set_wide_vectors", py_set_wide_vectors, METH_O,
     "Internal: False makes the Gaussian on grids use its AVX2/baseline build instead of AVX-512 (identical "
     "results; for tests and benchmarks), True restores the default. Returns the previous setting."},
    {"wide_vectors", py_wide_vectors, METH_NOARGS, "Internal: whether the Gaussian on grids runs its AVX-512 build."},
    {"gaussian_erfcx", py_gaussian_erfcx, METH_O, "Internal: erfcx(x) for x >= 0 as the exact Gaussian line integrals evaluate it."},
    {"gaussian_exp", py_gaussian_exp, METH_O, "Internal: exp(x) for x <= 0 as the Gaussian paths evaluate it."},
    {"default_threads", default_threads, METH_NOARGS,
     "Threads a call with n_threads=0 may use (omp_get_max_threads(); 1 without OpenMP)."},
    CG_TEXT_METHODS
    {"fstat_contacts", py_fstat_contacts, METH_VARARGS,
     "fstat_contacts(rows, partners, time, time_tolerance, positions, radii, fixed, periodic, period, rtol) -> "
     "(0, (), (i, j, wall, force, point, overlap)) or (problem, (row, other_row, pair_lo, pair_hi, count, df, dc, "
     "force_row, force_other), None): the contacts of a MercuryDPM .fstat frame (cg_fstat_contacts)."},
    {NULL, NULL, 0, NULL}};

static struct PyModuleDef moduledef = {PyModuleDef_HEAD_INIT, "_core",
                                       "cgbound's C core: kernel scatters onto grids and points.", -1,
                                       methods, NULL, NULL, NULL, NULL};

/* identity of the interpreter's main thread (where signal handlers run) */
static int find_main_thread(void)
{
    PyObject *threading = PyImport_ImportModule("threading");
    if (!threading) return -1;
    PyObject *main = PyObject_CallMethod(threading, "main_thread", NULL);
    Py_DECREF(threading);
    if (!main) return -1;
    PyObject *ident = PyObject_GetAttrString(main, "ident");
    Py_DECREF(main);
    if (!ident) return -1;
    main_thread_ident = PyLong_AsUnsignedLong(ident);
    Py_DECREF(ident);
    if (PyErr_Occurred()) return -1;
    return 0;
}

PyMODINIT_FUNC PyInit__core(void)
{
    import_array();
    if (find_main_thread() < 0) return NULL;
    return PyModule_Create(&moduledef);
}
