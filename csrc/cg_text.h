/*
 * cg_text.h -- the text-parsing layer of cgbound's core: whitespace-separated
 * numeric tables (LAMMPS/LIGGGHTS dumps, MercuryDPM .data/.fstat) read in one
 * pass from a byte range, and a fast scan for the lines that start frames.
 *
 * Plain C11, no Python. Functions return a cg_status (cg.h); the text errors
 * are CG_ERR_TEXT_* codes of that same enum, so cg_strerror() is the one
 * error-string function. The layer never allocates memory the caller must
 * free, never reads outside [text, text + length) (no NUL terminator is
 * needed or looked at) and keeps no state between calls (thread-safe; call
 * it with the GIL released).
 *
 * Text model
 *   line         bytes up to and including '\n' (the last line may lack it).
 *                Lines are numbered from 0 at the start of the range.
 *   separators   ' ', '\t', '\r', '\v', '\f' between tokens; a '\r' before
 *                '\n' (CRLF) is therefore just trailing space.
 *   token        a maximal run of other bytes. NUL bytes and non-ASCII bytes
 *                are token bytes, so they make a token malformed, never end it.
 *   row          one line with exactly ncols tokens.
 *   blank line   a line with no token: an error (CG_ERR_TEXT_ROW_LENGTH)
 *                unless CG_TEXT_SKIP_BLANK is given.
 *
 * Numbers (float columns), the grammar every engine we read writes:
 *   [+-]? (digits [. digits?] | . digits) ([eE] [+-]? digits)?
 *   [+-]? (nan | inf | infinity)           any letter case (glibc, C++ streams)
 *   [+-]? 1.#(INF | IND | QNAN | SNAN) 0*  any letter case (old MSVC runtimes)
 * Values are correctly rounded (round-half-even) to the nearest double:
 * bit-identical to Python's float() and to strtod in the C locale. Decimals
 * beyond the double range give +-inf (as strtod does) and count as non-finite;
 * underflow gives subnormals or +-0. Anything else (hex floats, '1_0', 'D'
 * exponents, '1.2.3') is CG_ERR_TEXT_NUMBER. nan/inf are parsed, not errors:
 * the first one and their number are reported in cg_text_result so the caller
 * can reject them by name.
 *
 * Integers (columns flagged in int_columns): [+-]? digits, exact in int64.
 * Outside int64 -> CG_ERR_TEXT_OVERFLOW; a valid float that is not of that
 * form ('1.0', '1e3', 'nan') -> CG_ERR_TEXT_INTEGER; anything else ->
 * CG_ERR_TEXT_NUMBER. Integer columns are also stored (converted, rounded to
 * nearest beyond 2^53) in the double table so column indices stay the same.
 */
#ifndef CGBOUND_CG_TEXT_H
#define CGBOUND_CG_TEXT_H

#include <stddef.h>
#include <stdint.h>

#include "cg.h"

#ifdef __cplusplus
extern "C" {
#endif

/* flags of cg_text_parse_table */
#define CG_TEXT_SKIP_BLANK 1 /* lines without tokens are skipped instead of being an error */
#define CG_TEXT_STOP_AT_MAX_ROWS 2 /* stop (CG_OK) after max_rows rows instead of failing on more: for
                                      frames delimited only by a declared count (MercuryDPM .data);
                                      result->end says where the next frame starts */

/* Where something is in the parsed range. */
typedef struct cg_text_where {
    int64_t line;   /* line index from the start of the range (0-based) */
    int64_t column; /* token index in that line (0-based); for a row-length
                       error: the number of tokens found if too few, ncols if
                       too many (the first extra token) */
    int64_t offset; /* byte offset from the start of the range of the token
                       (row-length errors: of the line) */
    int64_t length; /* its length in bytes (row-length errors: the line's,
                       without the line end) */
} cg_text_where;

typedef struct cg_text_result {
    int64_t nrows;            /* rows stored (all of them when the status is CG_OK) */
    int64_t end;              /* byte offset (from the start of the range) where parsing stopped: the
                                 length, or with CG_TEXT_STOP_AT_MAX_ROWS the start of the line after
                                 the last row */
    cg_text_where error;      /* the first error, when the status is not CG_OK */
    int64_t nonfinite;        /* number of nan/inf values stored */
    cg_text_where first_nonfinite; /* the first of them (valid if nonfinite > 0) */
} cg_text_result;

/*
 * Parse the rows of [text, text + length) into values (row-major, max_rows x
 * ncols doubles) and, for the columns with int_columns[c] != 0, into ints
 * (row-major, max_rows x n_int where n_int is the number of flagged columns,
 * in column order). int_columns may be NULL (no integer column); ints may be
 * NULL only then. Stops at the first error. More than max_rows rows is
 * CG_ERR_TEXT_ROWS (error.line = the first extra row); fewer is not an error
 * (compare result->nrows with what the file declared).
 * CG_ERR_ARGUMENT for ncols < 1, max_rows < 0 or NULL pointers.
 */
cg_status cg_text_parse_table(const char *text, size_t length, int64_t ncols, const unsigned char *int_columns,
                              int flags, int64_t max_rows, double *values, int64_t *ints, cg_text_result *result);

/*
 * cg_text_parse_table over up to n_threads threads (OpenMP; one without it):
 * the range (with CG_TEXT_STOP_AT_MAX_ROWS: its first max_rows lines) is
 * cut at line starts into parts of at least CG_TEXT_BYTES_PER_THREAD bytes
 * (cg_text_plan_parts); in one parallel region each part counts its lines,
 * then parses into its own rows (from the lines before it on).
 * Results, errors and result fields are the same as cg_text_parse_table's
 * (on any error the range is parsed again in one pass, which reports it).
 * With both CG_TEXT_SKIP_BLANK and CG_TEXT_STOP_AT_MAX_ROWS it parses in one pass.
 */
#define CG_TEXT_BYTES_PER_THREAD ((size_t)1 << 21)
#define CG_TEXT_MAX_THREADS 16
cg_status cg_text_parse_table_threads(const char *text, size_t length, int64_t ncols,
                                      const unsigned char *int_columns, int flags, int64_t max_rows, double *values,
                                      int64_t *ints, cg_text_result *result, int n_threads);
/* The same with exactly min(parts, CG_TEXT_MAX_THREADS) parts whatever the range's size (parts < 2: one pass),
 * one thread each: for tests of parts smaller than a line, empty parts, cuts next to errors. */
cg_status cg_text_parse_table_parts(const char *text, size_t length, int64_t ncols, const unsigned char *int_columns,
                                    int flags, int64_t max_rows, double *values, int64_t *ints,
                                    cg_text_result *result, int parts);

/*
 * A plan: a range cut at line starts into parts, with the lines before each.
 * Made once (the parts counted in parallel), it sizes a table whose row count
 * is not declared (line[parts] bounds the rows) and places each part's rows
 * in cg_text_parse_table_plan, so no line is counted twice.
 */
typedef struct cg_text_plan {
    int parts;                                  /* 1 .. CG_TEXT_MAX_THREADS */
    int64_t start[CG_TEXT_MAX_THREADS + 1];     /* part k: bytes [start[k], start[k + 1]) of the range; start[0] = 0,
                                                   start[parts] = length; a part starts after the first '\n' at
                                                   or after byte length / parts * k (or at length), so parts
                                                   may be empty or one long line */
    int64_t line[CG_TEXT_MAX_THREADS + 1];      /* lines before part k (cg_text_count_lines of [0, start[k]));
                                                   line[parts]: the range's lines */
} cg_text_plan;

/* How many parts for n_threads threads: min(n_threads, CG_TEXT_MAX_THREADS, length / CG_TEXT_BYTES_PER_THREAD),
 * at least 1. */
int cg_text_plan_parts(size_t length, int n_threads);

/* Cut [text, text + length) into parts (1 .. CG_TEXT_MAX_THREADS, else CG_ERR_ARGUMENT) and count each part's
 * lines, one thread per part. */
cg_status cg_text_plan_lines(const char *text, size_t length, int parts, cg_text_plan *plan);

/*
 * cg_text_parse_table with a plan of the same range (from cg_text_plan_lines; CG_ERR_ARGUMENT if it does not
 * cover [0, length) in order), one thread per part, no line counted again. The same results and errors as
 * cg_text_parse_table. With CG_TEXT_STOP_AT_MAX_ROWS the table is only the range's first lines: it is cut
 * again (cg_text_parse_table_parts with plan->parts).
 */
cg_status cg_text_parse_table_plan(const char *text, size_t length, const cg_text_plan *plan, int64_t ncols,
                                   const unsigned char *int_columns, int flags, int64_t max_rows, double *values,
                                   int64_t *ints, cg_text_result *result);

/* Number of lines in the range: '\n' count, plus one if the range is not
 * empty and does not end with '\n'. An upper bound for the rows it holds. */
int64_t cg_text_count_lines(const char *text, size_t length);
/* The same count over up to n_threads threads (ranges of at least 2 CG_TEXT_BYTES_PER_THREAD). */
int64_t cg_text_count_lines_threads(const char *text, size_t length, int n_threads);

/*
 * Byte offsets (from text) of the lines whose first prefix_length bytes equal
 * prefix, in order. The first min(count, capacity) are written to offsets
 * (may be NULL when capacity is 0); *count is set to the total, so a caller
 * can size a second call. prefix_length 0 matches every line.
 */
cg_status cg_text_find_lines(const char *text, size_t length, const char *prefix, size_t prefix_length,
                             int64_t *offsets, int64_t capacity, int64_t *count);
/* The same over up to n_threads threads for ranges of at least 2 CG_TEXT_BYTES_PER_THREAD (byte ranges, each
 * listed on its own thread into memory of its own, then joined; one pass if that memory cannot be had). */
cg_status cg_text_find_lines_threads(const char *text, size_t length, const char *prefix, size_t prefix_length,
                                     int64_t *offsets, int64_t capacity, int64_t *count, int n_threads);

/*
 * One token -> double, with the grammar above. Returns CG_OK or
 * CG_ERR_TEXT_NUMBER. (For tests and callers that read single fields.)
 */
cg_status cg_text_parse_double(const char *token, size_t length, double *value);

#ifdef __cplusplus
}
#endif

#endif /* CGBOUND_CG_TEXT_H */
