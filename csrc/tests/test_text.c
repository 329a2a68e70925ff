/* test_text.c -- cg_text.h without Python: text that ends exactly at a page followed by an
 * inaccessible page (any read past the range faults), every prefix of each text, and a few
 * exact values. Run by tests/test_text_parser.py (also under valgrind). */
#define _DEFAULT_SOURCE
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>
#include <unistd.h>

#include "../cg_text.h"

static int failures = 0;
#define CHECK(c)                                                              \
    do {                                                                      \
        if (!(c)) {                                                           \
            fprintf(stderr, "%s:%d: check failed: %s\n", __FILE__, __LINE__, #c); \
            ++failures;                                                       \
        }                                                                     \
    } while (0)

/* rows x cols tokens drawn from pick (xorshift from state; in an integer column of ints a token with '.' or 'e'
   becomes int_tokens[k % 2]), parsed as a table of its first `table` rows (with flags) into arrays of exactly that
   size: every value against strtod, every integer against strtoll; also_as_floats: the same text parsed first
   with no integer column */
static void short_token_rows(int rows, int table, int cols, const unsigned char *ints, int flags, int also_as_floats,
                             const char *const *pick, int npick, const char *const *int_tokens, uint64_t state)
{
    int n_int = 0, slot[256];
    for (int c = 0; c < cols; ++c) slot[c] = ints && ints[c] ? n_int++ : -1;
    char *text = malloc((size_t)rows * (size_t)cols * 8);
    const char **token = malloc((size_t)rows * (size_t)cols * sizeof *token);
    double *got = malloc((size_t)table * (size_t)cols * sizeof *got);
    int64_t *got_ints = n_int ? malloc((size_t)table * (size_t)n_int * sizeof *got_ints) : NULL;
    CHECK(text && token && got && (got_ints || !n_int));
    if (text && token && got && (got_ints || !n_int)) {
        size_t n = 0;
        for (int k = 0; k < rows * cols; ++k) {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            token[k] = pick[(state >> 20) % (uint64_t)npick];
            if (slot[k % cols] >= 0 && strpbrk(token[k], ".e")) token[k] = int_tokens[k % 2];
            n += (size_t)sprintf(text + n, "%s%c", token[k], k % cols == cols - 1 ? '\n' : ' ');
        }
        cg_text_result res;
        int wrong = 0;
        if (also_as_floats) {
            CHECK(cg_text_parse_table(text, n, cols, NULL, flags, table, got, NULL, &res) == CG_OK &&
                  res.nrows == table);
            for (int k = 0; k < table * cols && res.nrows == table; ++k) wrong += got[k] != strtod(token[k], NULL);
            CHECK(wrong == 0);
        }
        CHECK(cg_text_parse_table(text, n, cols, ints, flags, table, got, got_ints, &res) == CG_OK &&
              res.nrows == table);
        for (int k = 0; k < table * cols && res.nrows == table; ++k)
            wrong += got[k] != strtod(token[k], NULL) ||
                     (slot[k % cols] >= 0 &&
                      got_ints[k / cols * n_int + slot[k % cols]] != strtoll(token[k], NULL, 10));
        CHECK(wrong == 0);
    }
    free(text);
    free(token);
    free(got);
    free(got_ints);
}

int main(void)
{
    const long page = sysconf(_SC_PAGESIZE);
    char *map = mmap(NULL, 2 * (size_t)page, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
    if (map == MAP_FAILED) return 2;
    if (mprotect(map + page, (size_t)page, PROT_NONE) != 0) return 2;
    const char *texts[] = {"1 2\n3 4",   "1 2\r\n3 4\r", "1 2\n3",     "1 2\n3 4 5", "1 2\n3 nan",  "1 2\n3 -1.#INF00",
                           "1 2\n3 1e",  "1 2\n3 1e+", "1 2\n3 inf", "1 2\n\t ",  "1 2\n3 1.",  "1 2\n3 " ,
                           "1 2\n3 +",   "1 2\n3 x",   "1 2\n3 12345678901234567890123", "1 2\n3 1.#",
                           /* longer than the 8-byte word paths need: every prefix ends a word short of the page */
                           "7 0.5\n8 1.0273923374642910\n9 -0.0029136591653913836\n10 4.46e-05\n11 -0\n12 1e+05",
                           "123456789012 0.1234567890123456789012\n-1234567890123456 12345678901234567890.5e+05",
                           "1234567 12345678\n123456789 1234567.12345678e-12345678\n9 +.5",
                           /* longer than the row path's margin (2 columns x 48 bytes): rows of the usual shapes
                              and every way to leave it, cut at every byte before the page */
                           "0 0\n-1 0.95395734275277411\n12345678 1.5e-05\n0.0029136591653913836 -0.010000000000000009\n"
                           "7 0\r\n1\t2 \n3  4\n5 0.1234567890123456789012345\n6 1.e5\n123456789012345678 1\n"
                           "-0 -0.0\n8 1e308\n9 .5\n10 5.\n11 1e-0005\n12 nan\n0 0\n0 0\n0 0\n-1 -9.7e-300\n"
                           "1234567890123456 2.2250738585072011e-308\n17 18\n19 0.95395734275277411\n20 1.0e-100",
                           "0 0\n-1 0.95395734275277411\n12345678 1.5e-05\n0.0029136591653913836 -0.010000000000000009\n"
                           "13 0 0\n14 15\n16 17\n18 19\n20 21\n22 23\n24 25\n26 27\n28 29\n30 31\n32 33\n34 35\n"
                           "36 37\n38 39\n40 41\n42 43\n44 45\n46 47\n48 49\n50 51\n52 53\n54 55\n56 57\n58 59\n"};
    double values[128];
    int64_t ints[128], offsets[8], count;
    const unsigned char int_cols[2] = {1, 0};
    for (size_t t = 0; t < sizeof texts / sizeof *texts; ++t) {
        const size_t n = strlen(texts[t]);
        for (size_t len = 0; len <= n; ++len) {
            char *at = map + page - len; /* the range ends at the inaccessible page */
            memcpy(at, texts[t], len);
            cg_text_result res;
            for (int flags = 0; flags < 2; ++flags) {
                cg_status st = cg_text_parse_table(at, len, 2, NULL, flags, 64, values, NULL, &res);
                CHECK(st == CG_OK || (st >= CG_ERR_TEXT_NUMBER && st <= CG_ERR_TEXT_ROWS));
                CHECK(res.error.offset + res.error.length <= (int64_t)len);
                st = cg_text_parse_table(at, len, 2, int_cols, flags, 64, values, ints, &res);
                CHECK(st == CG_OK || (st >= CG_ERR_TEXT_NUMBER && st <= CG_ERR_TEXT_ROWS));
            }
            CHECK(cg_text_find_lines(at, len, "3 ", 2, offsets, 8, &count) == CG_OK);
            CHECK(cg_text_find_lines(at, len, "", 0, offsets, 8, &count) == CG_OK);
            CHECK(cg_text_count_lines(at, len) >= 0);
            /* cut into 1-4 parts: the plan's counts add up; the parse equals one pass (rows, end, error) */
            for (int parts = 1; parts <= 4; ++parts) {
                cg_text_plan plan;
                CHECK(cg_text_plan_lines(at, len, parts, &plan) == CG_OK && plan.parts == parts &&
                      plan.line[parts] == cg_text_count_lines(at, len) && plan.start[parts] == (int64_t)len);
                for (int flags = 0; flags < 4; ++flags)
                    for (int64_t rows = 1; rows <= 8; rows += 7) {
                        cg_text_result one, cut;
                        double v2[16];
                        int64_t i2[16];
                        const cg_status a = cg_text_parse_table(at, len, 2, int_cols, flags, rows, values, ints, &one);
                        const cg_status b =
                            cg_text_parse_table_parts(at, len, 2, int_cols, flags, rows, v2, i2, &cut, parts);
                        CHECK(a == b && one.nrows == cut.nrows && one.end == cut.end &&
                              one.error.line == cut.error.line && one.error.column == cut.error.column &&
                              one.error.offset == cut.error.offset && one.error.length == cut.error.length &&
                              one.nonfinite == cut.nonfinite);
                        CHECK(a != CG_OK || memcmp(values, v2, (size_t)one.nrows * 2 * sizeof *values) == 0);
                        if (!(flags & CG_TEXT_STOP_AT_MAX_ROWS) && plan.line[parts] <= rows) {
                            const cg_status c = cg_text_parse_table_plan(at, len, &plan, 2, int_cols, flags, rows, v2,
                                                                         i2, &cut);
                            CHECK(a == c && one.nrows == cut.nrows && one.error.line == cut.error.line &&
                                  one.error.offset == cut.error.offset);
                        }
                    }
            }
            double v;
            cg_text_parse_double(at, len, &v);
        }
    }
    /* the threaded line count: cut anywhere, with and without a final line end */
    {
        const size_t big = 5 * ((size_t)1 << 20) + 7;
        char *text = malloc(big);
        CHECK(text != NULL);
        if (text) {
            for (size_t k = 0; k < big; ++k) text[k] = (char)(k % 61 == 60 || k % 4099 == 17 ? '\n' : 'x');
            for (size_t len = big - 2; len <= big; ++len)
                for (int t = 1; t <= 3; ++t)
                    CHECK(cg_text_count_lines_threads(text, len, t) == cg_text_count_lines(text, len));
            /* the threaded line search: the same offsets (every line start; lines starting "xx\n": few) */
            const char *prefixes[2] = {"", "x\n"};
            for (int q = 0; q < 2; ++q) {
                int64_t n1 = 0, n3 = 0, small = 0;
                CHECK(cg_text_find_lines(text, big, prefixes[q], strlen(prefixes[q]), NULL, 0, &n1) == CG_OK);
                int64_t *a = malloc((size_t)(n1 + 1) * sizeof *a), *b = malloc((size_t)(n1 + 1) * sizeof *b);
                CHECK(a && b && n1 > 0);
                if (a && b) {
                    CHECK(cg_text_find_lines(text, big, prefixes[q], strlen(prefixes[q]), a, n1, &n1) == CG_OK);
                    for (int t = 2; t <= 3; ++t) {
                        CHECK(cg_text_find_lines_threads(text, big, prefixes[q], strlen(prefixes[q]), b, n1, &n3, t) ==
                                  CG_OK &&
                              n3 == n1 && memcmp(a, b, (size_t)n1 * sizeof *a) == 0);
                        CHECK(cg_text_find_lines_threads(text, big, prefixes[q], strlen(prefixes[q]), b, 1, &small, t) ==
                                  CG_OK &&
                              small == n1 && b[0] == a[0]);
                    }
                }
                free(a);
                free(b);
            }
            free(text);
        }
    }
    /* the row path's values (this build's: SSE2 or 8-byte word fractions) against strtod and the one-token
       parser, on rows of the usual shape far from the range's end: mantissas of 1 to 23 digits, 0. and dd.
       integer parts, leading zeros, exponents */
    {
        enum { ROWS = 4000 };
        char *text = malloc((size_t)ROWS * 64), token[ROWS][48];
        double *got = malloc((size_t)ROWS * 2 * sizeof *got);
        int64_t *ids = malloc((size_t)ROWS * sizeof *ids);
        CHECK(text && got && ids);
        if (text && got && ids) {
            size_t n = 0;
            uint64_t state = 88172645463325252ULL;
            for (int r = 0; r < ROWS; ++r) {
                state ^= state << 13;
                state ^= state >> 7;
                state ^= state << 17;
                const double x = (double)(state >> 11) / 9007199254740992.0; /* [0, 1) */
                const int digits = 1 + (int)(state % 23);
                int shape = (int)((state >> 5) % 5);
                const char *sign = (state >> 9) & 1 ? "-" : "";
                /* the first rows: rounding carried into the next binade (a power of two), exact binary values */
                static const char *fixed[] = {"1.9999999999999999", "-7.9999999999999999", "0.99999999999999999",
                                              "63.999999999999999", "3.9999999999999999e-05", "1.5", "-0.5",
                                              "0.0", "45.049999999999997", "0.25e1", "4.46e-05", "1.5e+01",
                                              "-9.8765432109876543e-99", "0.0e-05", "1.2345e5", "7.0000000000000001e+22",
                                              "1.2345678901234567e+13", "9.007199254740993e+15",
                                              "9.007199254740995e+15", "1.8014398509481986e+16", "1.5E15", "1.5e05",
                                              "1.5e-5", "1.5e-055", "0.00000000000000000012345e-05", "00.5",
                                              "0.123456789012345678901234", "-0.0", "05.25e-01"};
                if (r < (int)(sizeof fixed / sizeof *fixed)) {
                    snprintf(token[r], sizeof token[r], "%s", fixed[r]);
                    shape = -1;
                }
                switch (shape) {
                case 0: snprintf(token[r], sizeof token[r], "%s%.*f", sign, digits, x); break;        /* 0.ddd */
                case 1: snprintf(token[r], sizeof token[r], "%s%.*f", sign, digits, 1.0 + 8.0 * x); break; /* d.ddd */
                case 2: snprintf(token[r], sizeof token[r], "%s%.*f", sign, digits, 10.0 + 89.0 * x); break;
                case 3: snprintf(token[r], sizeof token[r], "%s%.*e", sign, digits - 1, x * 1e-300); break;
                case 4: snprintf(token[r], sizeof token[r], "%s%.*f", sign, digits, x * 1e-6); break; /* 0.000ddd */
                default: break;
                }
                n += (size_t)sprintf(text + n, "%d %s\n", r, token[r]);
            }
            const unsigned char first_int[2] = {1, 0};
            cg_text_result res;
            CHECK(cg_text_parse_table(text, n, 2, first_int, 0, ROWS, got, ids, &res) == CG_OK && res.nrows == ROWS);
            int wrong = 0;
            for (int r = 0; r < ROWS && res.nrows == ROWS; ++r) {
                double one = 0.0;
                const double c = strtod(token[r], NULL);
                const int same = cg_text_parse_double(token[r], strlen(token[r]), &one) == CG_OK &&
                                 memcmp(&got[2 * r + 1], &c, sizeof c) == 0 && memcmp(&one, &c, sizeof c) == 0 &&
                                 ids[r] == r;
                if (!same && wrong++ < 5) fprintf(stderr, "row %d: '%s' gave %.17g, strtod %.17g\n", r, token[r],
                                                  got[2 * r + 1], c);
            }
            CHECK(wrong == 0);
        }
        free(text);
        free(got);
        free(ids);
    }
    /* rows of 9 columns, most of them one-digit tokens (the row path takes up to 4 "d " at once), against strtod;
       columns 0 and 4 integers (each to its place in the row of ints) */
    {
        static const char *pick[] = {"0", "1", "9", "-1", "0.5", "12", "-3.25", "7", "0"};
        static const unsigned char int9[9] = {1, 0, 0, 0, 1, 0, 0, 0, 0};
        static const char *int_tokens[2] = {"56", "-1234"};
        short_token_rows(500, 500, 9, int9, 0, 1, pick, 9, int_tokens, 0x9E3779B97F4A7C15ULL);
    }
    /* 11 columns, integers at 0 and 6: four float columns on each side (the row path's blocks of four one-digit
       tokens beside integer columns); STOP_AT_MAX_ROWS with 40 lines after the table, into arrays of exactly the
       table's size, so that its last row is also taken by the row path (valgrind and ASan see any write past) */
    {
        static const char *pick[] = {"0", "1", "9", "-1", "0.5", "3", "-3.25", "7", "0", "2.5e-03"};
        static const unsigned char int11[11] = {1, 0, 0, 0, 0, 0, 1, 0, 0, 0, 0};
        static const char *int_tokens[2] = {"8", "-42"};
        short_token_rows(300, 260, 11, int11, CG_TEXT_STOP_AT_MAX_ROWS, 0, pick, 10, int_tokens, 0x2545F4914F6CDD1DULL);
    }
    /* values */
    const char *ok = "4.9406564584124654e-324 -0\n0.1 9007199254740993\n";
    cg_text_result res;
    CHECK(cg_text_parse_table(ok, strlen(ok), 2, NULL, 0, 2, values, NULL, &res) == CG_OK && res.nrows == 2);
    CHECK(values[0] == 4.9406564584124654e-324 && values[1] == 0.0 && values[2] == 0.1 &&
          values[3] == 9007199254740992.0);
    CHECK(cg_text_parse_table(ok, strlen(ok), 2, NULL, 0, 1, values, NULL, &res) == CG_ERR_TEXT_ROWS &&
          res.error.line == 1);
    CHECK(cg_text_parse_table(ok, strlen(ok), 0, NULL, 0, 1, values, NULL, &res) == CG_ERR_ARGUMENT);
    CHECK(strcmp(cg_strerror(CG_ERR_TEXT_NUMBER), "not a number") == 0);
    /* plans: arguments, and a plan that does not cover the range */
    cg_text_plan plan;
    CHECK(cg_text_plan_lines(ok, strlen(ok), 0, &plan) == CG_ERR_ARGUMENT);
    CHECK(cg_text_plan_lines(ok, strlen(ok), CG_TEXT_MAX_THREADS + 1, &plan) == CG_ERR_ARGUMENT);
    CHECK(cg_text_plan_lines(NULL, 0, 3, &plan) == CG_OK && plan.line[3] == 0 && plan.start[3] == 0);
    CHECK(cg_text_plan_lines(ok, strlen(ok), 2, &plan) == CG_OK && plan.start[1] == 27 && plan.line[1] == 1 &&
          plan.line[2] == 2);
    CHECK(cg_text_parse_table_plan(ok, strlen(ok) - 1, &plan, 2, NULL, 0, 2, values, NULL, &res) == CG_ERR_ARGUMENT);
    CHECK(cg_text_parse_table_plan(ok, strlen(ok), &plan, 2, NULL, 0, 2, values, NULL, &res) == CG_OK &&
          res.nrows == 2 && values[3] == 9007199254740992.0);
    CHECK(cg_text_plan_parts(0, 4) == 1 && cg_text_plan_parts(5 * CG_TEXT_BYTES_PER_THREAD, 4) == 4 &&
          cg_text_plan_parts(3 * CG_TEXT_BYTES_PER_THREAD, 4) == 3 && cg_text_plan_parts((size_t)1 << 40, 99) == 16);
    munmap(map, 2 * (size_t)page);
    if (failures) return 1;
    printf("test_text: ok\n");
    return 0;
}
