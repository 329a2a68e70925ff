/* cg_text.c -- one-pass numeric tables from text, and the frame scan (cg_text.h).
 *
 * Speed: a row that starts ncols * QUICK_READ bytes or more before the range's end is first tried by
 * quick_row (no range check per byte, one-digit tokens and d.ddd mantissas decided early, runs of "0 "
 * four per word; on x86-64 the fractions of d.ddd and dd.ddd converted 16 digits at once in SSE2, see
 * sse_fraction, and signs taken by a branch so that a token's loads do not wait on its first byte); a row
 * it does not take, and every row near the end, goes through the general loop,
 * where each token is tried by fast_double / fast_int, which parse the common forms in one pass (digits 8
 * bytes at a time, the last partial word included, no separate scan for the token's end; byte by byte
 * where fewer than 8 bytes of the range remain, so nothing past it is read); everything else (and every
 * error) goes through parse_double / parse_int, the reference path. cg_text_parse_table_threads cuts
 * large ranges at line starts over OpenMP threads. */
#include "cg_text.h"

#include <float.h>
#include <locale.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "cg_text_pow10.h"

#ifdef _OPENMP
#include <omp.h>
#endif
#ifdef __SSE2__
#include <emmintrin.h>
#endif

/* byte classes: token byte, separator, line end */
enum { TOKEN = 0, SPACE = 1, NEWLINE = 2 };
static const unsigned char byte_class[256] = {
    ['\t'] = SPACE, ['\n'] = NEWLINE, ['\v'] = SPACE, ['\f'] = SPACE, ['\r'] = SPACE, [' '] = SPACE,
};

static inline int is_digit(unsigned char c) { return (unsigned)(c - '0') < 10u; }

static inline unsigned char lower(unsigned char c) { return (c >= 'A' && c <= 'Z') ? (unsigned char)(c + 32) : c; }

/* whether [p, end) equals the lower-case word w, ignoring letter case */
static int equals_word(const unsigned char *p, const unsigned char *end, const char *w)
{
    size_t n = strlen(w);
    if ((size_t)(end - p) != n) return 0;
    for (size_t i = 0; i < n; ++i)
        if (lower(p[i]) != (unsigned char)w[i]) return 0;
    return 1;
}

/* nan/inf spellings after the sign; 1 = nan, 2 = inf, 0 = none */
static int special_value(const unsigned char *p, const unsigned char *end)
{
    if (equals_word(p, end, "nan")) return 1;
    if (equals_word(p, end, "inf") || equals_word(p, end, "infinity")) return 2;
    /* MSVC: 1.#INF, 1.#IND, 1.#QNAN, 1.#SNAN, optionally followed by zeros (printf("%f")) */
    if (end - p >= 6 && p[0] == '1' && p[1] == '.' && p[2] == '#') {
        const unsigned char *q = end;
        while (q > p + 3 && q[-1] == '0') --q;
        if (equals_word(p + 3, q, "inf")) return 2;
        if (equals_word(p + 3, q, "ind") || equals_word(p + 3, q, "qnan") || equals_word(p + 3, q, "snan")) return 1;
    }
    return 0;
}

/* ------------------------------------------------------------------ */
/* decimal -> double                                                    */

/* high and low 64 bits of a * b */
static inline uint64_t mul128(uint64_t a, uint64_t b, uint64_t *lo)
{
#if defined(__SIZEOF_INT128__)
    __extension__ typedef unsigned __int128 u128;
    u128 p = (u128)a * b;
    *lo = (uint64_t)p;
    return (uint64_t)(p >> 64);
#else
    uint64_t a0 = (uint32_t)a, a1 = a >> 32, b0 = (uint32_t)b, b1 = b >> 32;
    uint64_t p00 = a0 * b0, p01 = a0 * b1, p10 = a1 * b0, p11 = a1 * b1;
    uint64_t mid = (p00 >> 32) + (uint32_t)p01 + (uint32_t)p10;
    *lo = (mid << 32) | (uint32_t)p00;
    return p11 + (p01 >> 32) + (p10 >> 32) + (mid >> 32);
#endif
}

static inline int leading_zeros(uint64_t x)
{
#if defined(__GNUC__) || defined(__clang__)
    return __builtin_clzll(x);
#else
    int n = 0;
    while (!(x & 0x8000000000000000ULL)) { x <<= 1; ++n; }
    return n;
#endif
}

/*
 * Eisel-Lemire: man * 10^exp10 (man != 0, exp10 in the table's range) to the
 * nearest double, or 0 when the 128-bit product cannot decide the rounding
 * (near halfway, subnormal or overflowing results); the caller then takes the
 * exact path. This is the formulation of Go's strconv (eisel_lemire.go), with
 * the table rounded down.
 */
#if defined(__GNUC__)
#define CG_NOINLINE __attribute__((noinline))
#else
#define CG_NOINLINE
#endif
static CG_NOINLINE int eisel_lemire_full(uint64_t man, int exp10, int neg, double *out)
{
    const uint64_t *pow = cg_pow10_128[exp10 - CG_POW10_MIN_EXP10];
    int clz = leading_zeros(man);
    man <<= clz;
    uint64_t ret_exp2 = (uint64_t)(((217706 * exp10) >> 16) + 64 + 1023) - (uint64_t)clz;
    uint64_t x_lo, x_hi = mul128(man, pow[1], &x_lo);
    if ((x_hi & 0x1FF) == 0x1FF && x_lo + man < man) {
        /* the low bits might carry: widen with the next 64 bits of the power */
        uint64_t y_lo, y_hi = mul128(man, pow[0], &y_lo);
        uint64_t merged_hi = x_hi, merged_lo = x_lo + y_hi;
        if (merged_lo < x_lo) ++merged_hi;
        if ((merged_hi & 0x1FF) == 0x1FF && merged_lo + 1 == 0 && y_lo + man < man) return 0;
        x_hi = merged_hi;
        x_lo = merged_lo;
    }
    uint64_t msb = x_hi >> 63;
    uint64_t ret_man = x_hi >> (msb + 9);
    ret_exp2 -= 1 ^ msb;
    if (x_lo == 0 && (x_hi & 0x1FF) == 0 && (ret_man & 3) == 1) return 0; /* halfway: ambiguous */
    ret_man += ret_man & 1;
    ret_man >>= 1; /* 2^52 .. 2^53: 2^53 when the rounding carried into the next binade */
    if (ret_exp2 + (ret_man >> 53) - 1 >= 0x7FF - 1) return 0; /* subnormal, zero or overflow */
    /* the hidden bit adds 1 to the exponent field (2 when the rounding carried: the mantissa field is then 0) */
    uint64_t bits = ((ret_exp2 - 1) << 52) + ret_man;
    if (neg) bits |= 0x8000000000000000ULL;
    memcpy(out, &bits, sizeof bits);
    return 1;
}

/* eisel_lemire_full where the first product decides (all but about 1 in 500 mantissas): inlined, with nothing of
   the widening kept live (no spills in the row path), which eisel_lemire_full redoes from the start */
static inline int eisel_lemire(uint64_t man, int exp10, int neg, double *out)
{
    const uint64_t *pow = cg_pow10_128[exp10 - CG_POW10_MIN_EXP10];
    const int clz = leading_zeros(man);
    uint64_t x_lo, x_hi = mul128(man << clz, pow[1], &x_lo);
    if ((x_hi & 0x1FF) == 0x1FF || x_lo == 0) return eisel_lemire_full(man, exp10, neg, out);
    const uint64_t msb = x_hi >> 63;
    uint64_t ret_man = x_hi >> (msb + 9);
    const uint64_t ret_exp2 = (uint64_t)(((217706 * exp10) >> 16) + 64 + 1023) - (uint64_t)clz - (1 ^ msb);
    ret_man += ret_man & 1;
    ret_man >>= 1;
    if (ret_exp2 + (ret_man >> 53) - 1 >= 0x7FF - 1) return 0;
    uint64_t bits = ((ret_exp2 - 1) << 52) + ret_man;
    if (neg) bits |= 0x8000000000000000ULL;
    memcpy(out, &bits, sizeof bits);
    return 1;
}

/* exact powers of ten for Clinger's fast path */
static const double exact_pow10[23] = {1e0,  1e1,  1e2,  1e3,  1e4,  1e5,  1e6,  1e7,  1e8,  1e9,  1e10, 1e11,
                                       1e12, 1e13, 1e14, 1e15, 1e16, 1e17, 1e18, 1e19, 1e20, 1e21, 1e22};

/*
 * The exact path: strtod on a NUL-terminated copy of the (already validated)
 * token. strtod follows LC_NUMERIC, so if the process runs in a locale whose
 * decimal point is not '.', the '.' of the copy is replaced by it.
 */
static double exact_strtod(const unsigned char *tok, size_t n)
{
    char small[128];
    char *copy = n < sizeof small ? small : (char *)malloc(n + 1);
    if (!copy) return NAN; /* unreachable in practice: tokens this long are a malformed file anyway */
    memcpy(copy, tok, n);
    copy[n] = '\0';
    char *endp;
    double v = strtod(copy, &endp);
    if (endp != copy + n) {
        const char *point = localeconv()->decimal_point;
        char *dot = memchr(copy, '.', n);
        if (dot && point && point[0] && !point[1]) {
            *dot = point[0];
            v = strtod(copy, &endp);
        }
    }
    if (copy != small) free(copy);
    return v;
}

/* The exponent part at p ('e' or 'E', an optional sign, digits) added to
   *exp10; returns the byte after it, NULL when no digit follows. */
static inline const unsigned char *exponent_part(const unsigned char *p, const unsigned char *end, int64_t *exp10)
{
    ++p;
    int eneg = 0;
    if (p < end && (*p == '+' || *p == '-')) {
        eneg = *p == '-';
        ++p;
    }
    if (p == end || !is_digit(*p)) return NULL;
    int64_t e = 0;
    for (; p < end && is_digit(*p); ++p)
        if (e < 100000000) e = e * 10 + (*p - '0'); /* beyond this the value is 0 or inf anyway */
    *exp10 += eneg ? -e : e;
    return p;
}

/* Parse [tok, end) as a float; returns CG_OK or CG_ERR_TEXT_NUMBER. *special: 0 finite, 1 nan/inf. */
static cg_status parse_double(const unsigned char *tok, const unsigned char *end, double *value, int *special)
{
    const unsigned char *p = tok;
    int neg = 0;
    *special = 0;
    if (p < end && (*p == '+' || *p == '-')) {
        neg = *p == '-';
        ++p;
    }
    if (p == end) return CG_ERR_TEXT_NUMBER;
    if ((!is_digit(*p) && *p != '.') || (end - p >= 3 && p[1] == '.' && p[2] == '#')) {
        int s = special_value(p, end);
        if (!s) return CG_ERR_TEXT_NUMBER;
        *special = 1;
        *value = copysign(s == 1 ? NAN : INFINITY, neg ? -1.0 : 1.0);
        return CG_OK;
    }
    uint64_t man = 0;
    int ndigits = 0, any = 0, dropped = 0;
    int64_t exp10 = 0;
    for (; p < end && is_digit(*p); ++p) {
        unsigned d = *p - '0';
        any = 1;
        if (man == 0 && d == 0) continue;
        if (ndigits < 19) {
            man = man * 10 + d;
            ++ndigits;
        } else {
            ++exp10;
            dropped |= d != 0;
        }
    }
    if (p < end && *p == '.') {
        for (++p; p < end && is_digit(*p); ++p) {
            unsigned d = *p - '0';
            any = 1;
            if (man == 0 && d == 0) {
                --exp10;
                continue;
            }
            if (ndigits < 19) {
                man = man * 10 + d;
                ++ndigits;
                --exp10;
            } else {
                dropped |= d != 0;
            }
        }
    }
    if (!any) return CG_ERR_TEXT_NUMBER;
    if (p < end && (*p == 'e' || *p == 'E') && !(p = exponent_part(p, end, &exp10))) return CG_ERR_TEXT_NUMBER;
    if (p != end) return CG_ERR_TEXT_NUMBER;
    if (man == 0) {
        *value = neg ? -0.0 : 0.0;
        return CG_OK;
    }
    if (!dropped) {
#if FLT_EVAL_METHOD == 0
        /* Clinger: both operands exact, so one correctly rounded operation */
        if (man <= (1ULL << 53) && exp10 >= -22 && exp10 <= 22) {
            double v = (double)man;
            v = exp10 >= 0 ? v * exact_pow10[exp10] : v / exact_pow10[-exp10];
            *value = neg ? -v : v;
            return CG_OK;
        }
#endif
        if (exp10 >= CG_POW10_MIN_EXP10 && exp10 <= CG_POW10_MAX_EXP10 &&
            eisel_lemire(man, (int)exp10, neg, value))
            return CG_OK;
    }
    *value = exact_strtod(tok, (size_t)(end - tok));
    if (!isfinite(*value)) *special = 1; /* overflow to inf */
    return CG_OK;
}

/* ------------------------------------------------------------------ */
/* the fast path: the forms engines write, decided in one pass          */

#if defined(__BYTE_ORDER__) && defined(__ORDER_LITTLE_ENDIAN__) && __BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__
#define CG_TEXT_SWAR 1
/* eight ASCII digits at once (SWAR, as in simdjson and fast_float): which bytes of 8 are digits, and the value of
   the first k of them, without a branch per digit */
static inline uint64_t load8(const unsigned char *p)
{
    uint64_t v;
    memcpy(&v, p, sizeof v);
    return v;
}

/* the high bit of each byte of v that is not an ASCII digit. Exact up to and including the first such byte
   (the digits before it neither borrow in v - '0' nor carry in v + 0x46), which is all that is used. */
static inline uint64_t nondigit_bytes(uint64_t v)
{
    return ((v + 0x4646464646464646ULL) | (v - 0x3030303030303030ULL)) & 0x8080808080808080ULL;
}

/* the number of digits v starts with (0..7), given nondigit_bytes(v) != 0 */
static inline unsigned leading_digits(uint64_t nondigit)
{
    return (unsigned)__builtin_ctzll(nondigit) >> 3;
}

static const uint64_t pow10_u64[9] = {1, 10, 100, 1000, 10000, 100000, 1000000, 10000000, 100000000};

/* the value of the first k (0..8) bytes of v, all digits: they are moved to the top of the word (two shifts of
   32 - 4k bits, both defined for k = 0 and k = 8) so that the bytes below read as leading zeros */
static inline uint64_t digits_value(uint64_t v, unsigned k)
{
    const uint64_t mask = 0x000000FF000000FFULL;
    const uint64_t mul1 = 0x000F424000000064ULL; /* 100 + (1000000 << 32) */
    const uint64_t mul2 = 0x0000271000000001ULL; /* 1 + (10000 << 32) */
    const unsigned s = 32 - 4 * k;
    v = ((v - 0x3030303030303030ULL) << s) << s;
    v = v * 10 + (v >> 8);
    return (uint32_t)((((v & mask) * mul1) + (((v >> 16) & mask) * mul2)) >> 32);
}
#endif

/* digits from p on into *man (man = man * 10 + digit each); returns the first non-digit. 8 bytes at a time
   while they fit in the range: the last, partial word too (a byte loop's exit branch is mispredicted at every
   token of a new length). */
static inline const unsigned char *scan_digits(const unsigned char *p, const unsigned char *end, uint64_t *man)
{
    uint64_t m = *man;
#ifdef CG_TEXT_SWAR
    while (end - p >= 8) {
        const uint64_t v = load8(p);
        const uint64_t nd = nondigit_bytes(v);
        if (nd) {
            const unsigned k = leading_digits(nd);
            *man = m * pow10_u64[k] + digits_value(v, k);
            return p + k;
        }
        m = m * 100000000u + digits_value(v, 8);
        p += 8;
    }
#endif
    for (; p < end && is_digit(*p); ++p) m = m * 10 + (unsigned)(*p - '0');
    *man = m;
    return p;
}

/*
 * A decimal with at most 19 significant digits whose value Clinger's or
 * Eisel-Lemire's path decides, given its mantissa man (wrapped if more than
 * 19 digits), exp10 and ndigits (digits written, leading zeros included);
 * the digits start at digits and the token ends before p. Returns p with
 * *value set, or NULL to let parse_double decide (more digits, halfway
 * cases, subnormals, overflow). Both paths are correctly rounded, so the
 * value is the same.
 */
static inline const unsigned char *decide_value(uint64_t man, int64_t exp10, int neg, const unsigned char *p,
                                                double *value);

static inline const unsigned char *decide_double(uint64_t man, int64_t exp10, int64_t ndigits, int neg,
                                                 const unsigned char *digits, const unsigned char *p, double *value)
{
    if (ndigits > 19) { /* leading zeros count as digits but add no value */
        const unsigned char *q = digits;
        for (; q < p && (*q == '0' || *q == '.'); ++q) ndigits -= *q == '0';
        if (ndigits > 19) return NULL;
    }
    return decide_value(man, exp10, neg, p, value);
}

/* decide_double for a mantissa known to hold at most 19 significant digits (so man did not wrap) */
static inline const unsigned char *decide_value(uint64_t man, int64_t exp10, int neg, const unsigned char *p,
                                                double *value)
{
    if (man == 0) {
        *value = neg ? -0.0 : 0.0;
        return p;
    }
#if FLT_EVAL_METHOD == 0
    if (man <= (1ULL << 53) && exp10 >= -22 && exp10 <= 22) {
        double v = (double)man;
        v = exp10 >= 0 ? v * exact_pow10[exp10] : v / exact_pow10[-exp10];
        *value = neg ? -v : v;
        return p;
    }
#endif
    if (exp10 >= CG_POW10_MIN_EXP10 && exp10 <= CG_POW10_MAX_EXP10 && eisel_lemire(man, (int)exp10, neg, value))
        return p;
    return NULL;
}

/*
 * The one-pass parse of a decimal, without first finding the token's end:
 * each returns the end of the token (a separator, '\n' or the end of the
 * range follows) with *value set, or NULL to let parse_double decide (see
 * decide_double; also nan/inf and malformed tokens). They are the stages
 * of one token: exponent_on from the byte after the mantissa's digits,
 * fraction_on from the byte after the '.', scalar_double from the token's
 * start. man holds the digits so far, ndigits their number (leading zeros
 * included) and digits points at the first of them.
 */
static inline const unsigned char *exponent_on(const unsigned char *p, const unsigned char *end, uint64_t man,
                                               int64_t exp10, int64_t ndigits, int neg, const unsigned char *digits,
                                               double *value)
{
    if (ndigits == 0) return NULL;
    if (p < end && (*p == 'e' || *p == 'E') && !(p = exponent_part(p, end, &exp10))) return NULL;
    if (p < end && byte_class[*p] == TOKEN) return NULL;
    return decide_double(man, exp10, ndigits, neg, digits, p, value);
}

static inline const unsigned char *fraction_on(const unsigned char *p, const unsigned char *end, uint64_t man,
                                               int64_t ndigits, int neg, const unsigned char *digits, double *value)
{
    const unsigned char *fraction = p;
    p = scan_digits(p, end, &man);
    return exponent_on(p, end, man, -(int64_t)(p - fraction), ndigits + (p - fraction), neg, digits, value);
}

static inline const unsigned char *scalar_double(const unsigned char *p, const unsigned char *end, double *value)
{
    int neg = 0;
    if (p < end && (*p == '-' || *p == '+')) {
        neg = *p == '-';
        ++p;
    }
    const unsigned char *digits = p;
    uint64_t man = 0;
    p = scan_digits(p, end, &man);
    if (p < end && *p == '.') return fraction_on(p + 1, end, man, p - digits, neg, digits, value);
    return exponent_on(p, end, man, 0, p - digits, neg, digits, value);
}

/* [+-]?digits with at most 18 digits (no overflow possible), ended like a token; else NULL */
static inline const unsigned char *scalar_int(const unsigned char *p, const unsigned char *end, int64_t *value)
{
    int neg = 0;
    if (p < end && (*p == '-' || *p == '+')) {
        neg = *p == '-';
        ++p;
    }
    const unsigned char *digits = p;
    uint64_t v = 0;
    for (; p < end && is_digit(*p) && p - digits < 18; ++p) v = v * 10 + (unsigned)(*p - '0');
    if (p == digits || (p < end && byte_class[*p] == TOKEN)) return NULL;
    *value = neg ? -(int64_t)v : (int64_t)v;
    return p;
}

#ifdef CG_TEXT_SWAR
/* scalar_int 8 bytes at a time, for a token with at least 17 bytes of the range from p on: at most 15 digits */
static inline const unsigned char *swar_int(const unsigned char *p, int64_t *value)
{
    const int neg = *p == '-';
    p += (*p == '-') | (*p == '+');
    const unsigned char *digits = p;
    uint64_t v = load8(p), nd = nondigit_bytes(v), x = 0;
    if (!nd) { /* 8 digits and more */
        x = digits_value(v, 8);
        p += 8;
        v = load8(p);
        nd = nondigit_bytes(v);
        if (!nd) return NULL;
    }
    const unsigned k = leading_digits(nd);
    x = x * pow10_u64[k] + digits_value(v, k);
    p += k;
    if (p == digits || byte_class[*p] == TOKEN) return NULL;
    *value = neg ? -(int64_t)x : (int64_t)x;
    return p;
}
#endif

/* the fast paths of a float and an integer token starting at p (p <= end); NULL: take the reference path */
static inline const unsigned char *fast_double(const unsigned char *p, const unsigned char *end, double *value)
{
    if (end - p >= 3) { /* one integer digit, the most common start */
        const int neg = *p == '-';
        const unsigned char *q = p + (neg | (*p == '+'));
        if (is_digit(q[0])) {
            if (byte_class[q[1]] != TOKEN) { /* the digit alone: the 0s and 1s of unused columns */
                const double v = (double)(q[0] - '0');
                *value = neg ? -v : v;
                return q + 1;
            }
            if (q[1] == '.') return fraction_on(q + 2, end, (uint64_t)(q[0] - '0'), 1, neg, q, value);
        }
    }
    return scalar_double(p, end, value);
}

static inline const unsigned char *fast_int(const unsigned char *p, const unsigned char *end, int64_t *value)
{
#ifdef CG_TEXT_SWAR
    if (end - p >= 17) return swar_int(p, value);
#endif
    return scalar_int(p, end, value);
}

#ifdef CG_TEXT_SWAR
/*
 * The row path: rows of the usual shape parsed with no range check per byte. A token parser reads at most
 * QUICK_READ bytes from the token's start (digit runs are bounded: longer tokens go to the reference path)
 * and a token it accepts ends, with the byte after it, inside them; so with one separator between tokens
 * the c-th token starts within c * QUICK_READ bytes of the line's start, and a row is taken only if
 * ncols * QUICK_READ bytes remain (after a run of separators, the same for the columns left). Anything
 * unusual (a '+' sign, 16+ integer digits, 24+ fraction digits, 4+ exponent digits, 20+ significant
 * digits, nan/inf, malformed text, blank lines, a row of the wrong length) makes the row return NULL, and
 * the general loop parses that row again from its start: errors and nan/inf counts come only from there.
 */
#define QUICK_READ 48
#if defined(__GNUC__)
#define QUICK_INLINE static inline __attribute__((always_inline)) /* one copy per column kind and end table */
#else
#define QUICK_INLINE static inline
#endif

/* the bytes that may follow a token: a separator (columns before the last), a separator or '\n' (the last) */
static const unsigned char after_mid[256] = {['\t'] = 1, ['\v'] = 1, ['\f'] = 1, ['\r'] = 1, [' '] = 1};
static const unsigned char after_last[256] = {['\t'] = 1, ['\n'] = 1, ['\v'] = 1, ['\f'] = 1, ['\r'] = 1, [' '] = 1};

/* the value of the digits of v before its first non-digit byte nd (!= 0), and their number in *k */
static inline uint64_t word_digits(uint64_t v, uint64_t nd, unsigned *k)
{
    *k = leading_digits(nd);
    return digits_value(v, *k);
}

/* a run of digits from p, appended to *man (which may wrap: callers count the digits): at most `words` whole words
   of 8 digits, then the word that ends the run; NULL if the run is longer. Reads [p, p + 8 * (words + 1)) only */
QUICK_INLINE const unsigned char *quick_digit_run(const unsigned char *p, uint64_t *man, int words)
{
    uint64_t m = *man, w = load8(p), nd = nondigit_bytes(w);
    unsigned k;
    if (nd) { /* the run ends in its first word (peeled: with *man 0 no multiplication) */
        *man = m * pow10_u64[leading_digits(nd)] + word_digits(w, nd, &k);
        return p + k;
    }
    for (; !nd; --words) {
        if (words == 0) return NULL;
        m = m * 100000000u + digits_value(w, 8);
        p += 8;
        w = load8(p);
        nd = nondigit_bytes(w);
    }
    *man = m * pow10_u64[leading_digits(nd)] + word_digits(w, nd, &k);
    return p + k;
}

/* the end of quick_double from the byte after the mantissa's digits (at most 19 significant): an exponent of 1
   to 3 digits, the byte after the token (one of after), the value */
static inline const unsigned char *quick_exponent(const unsigned char *p, const unsigned char *after, uint64_t man,
                                                  int64_t exp10, int neg, double *value)
{
    if ((*p | 0x20) == 'e') {
        ++p;
        const int eneg = *p == '-';
        p += (*p == '-') | (*p == '+');
        if (!is_digit(*p)) return NULL;
        int64_t e = *p++ - '0';
        if (is_digit(*p)) {
            e = e * 10 + (*p++ - '0');
            if (is_digit(*p)) {
                e = e * 10 + (*p++ - '0');
                if (is_digit(*p)) return NULL;
            }
        }
        exp10 += eneg ? -e : e;
    }
    if (!after[*p]) return NULL;
    return decide_value(man, exp10, neg, p, value);
}

#if defined(__SSE2__) && defined(__x86_64__) && !defined(CG_TEXT_NO_SSE2)
#define CG_TEXT_SSE2_FRACTION 1
/*
 * A fraction's first 16 bytes converted in one SSE2 register (every x86-64 has SSE2): the n digits before the
 * first non-digit (their number from two 8-byte words, as in the word path: the next token's start waits on it,
 * and a word load and three integer operations take less time than a vector load, compares and a movemask:
 * 12 % less CPU time on the W1 files) are paired by a 16-bit multiply, then two pmaddwd, about 20 instructions
 * instead of two or three 8-byte word conversions (80 or more). The bytes after the n digits are zeroed, so the
 * register gives x = F * 10^(16 - n): the value is (ip * 10^16 + x) * 10^-16 whatever n, Eisel-Lemire's
 * exponent a constant (its table row and binary exponent folded). Where that does not decide (exact binary
 * values such as 0.5 or 1.5; halfway cases), F follows exactly as (x >> (16 - n)) * (5^(16 - n))^-1 mod 2^64 (x
 * is a multiple of 2^(16-n) * 5^(16-n); 5 is odd, so invertible) for Clinger's path. The loads are at fixed
 * offsets from the token.
 */
static const uint64_t inv5_pow[17] = {
    0x0000000000000001ULL, 0xCCCCCCCCCCCCCCCDULL, 0x8F5C28F5C28F5C29ULL, 0x1CAC083126E978D5ULL, 0xD288CE703AFB7E91ULL,
    0x5D4E8FB00BCBE61DULL, 0x790FB65668C26139ULL, 0xE5032477AE8D46A5ULL, 0xC767074B22E90E21ULL, 0x8E47CE423A2E9C6DULL,
    0x4FA7F60D3ED61F49ULL, 0x0FEE64690C913975ULL, 0x3662E0E1CF503EB1ULL, 0xA47A2CF9F6433FBDULL, 0x54186F653140A659ULL,
    0x7738164770402145ULL, 0xE4A4D1417CD9A041ULL};
/* 10^n for n <= 19; 0 beyond (only ever multiplied by a zero integer part) */
static const uint64_t pow10_frac[24] = {1ULL,
                                        10ULL,
                                        100ULL,
                                        1000ULL,
                                        10000ULL,
                                        100000ULL,
                                        1000000ULL,
                                        10000000ULL,
                                        100000000ULL,
                                        1000000000ULL,
                                        10000000000ULL,
                                        100000000000ULL,
                                        1000000000000ULL,
                                        10000000000000ULL,
                                        100000000000000ULL,
                                        1000000000000000ULL,
                                        10000000000000000ULL,
                                        100000000000000000ULL,
                                        1000000000000000000ULL,
                                        10000000000000000000ULL,
                                        0,
                                        0,
                                        0,
                                        0};
/* 16 bytes from offset 16 - n: n bytes 0xFF, then zeros */
static const unsigned char keep_first[32] = {0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF,
                                             0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF};

/* the value of the first n (0..16) bytes of t, digit values (0..9), times 10^(16 - n) */
static inline uint64_t sse_digits_scaled(__m128i t, unsigned n)
{
    const __m128i d = _mm_and_si128(t, _mm_loadu_si128((const __m128i *)(const void *)(keep_first + 16 - n)));
    /* 16-bit lanes, little-endian: the low byte is the earlier (higher) digit */
    const __m128i pairs = _mm_add_epi16(_mm_mullo_epi16(_mm_and_si128(d, _mm_set1_epi16(0xFF)), _mm_set1_epi16(10)),
                                        _mm_srli_epi16(d, 8));                                    /* 8 x 0..99 */
    const __m128i quads = _mm_madd_epi16(pairs, _mm_set1_epi32(0x00010064));                       /* x100 + x1 */
    const __m128i octs = _mm_madd_epi16(_mm_packs_epi32(quads, quads), _mm_set1_epi32(0x00012710)); /* x10^4 + x1 */
    const uint64_t two = (uint64_t)_mm_cvtsi128_si64(octs);
    return (two & 0xFFFFFFFFu) * 100000000u + (two >> 32);
}

/* the fraction from f (after the '.') of a float whose integer part ip has nip digits (1 or 2): like quick_double
   (the value and the byte after the token), or NULL to let its general code decide (no fraction digit, more
   than 19 significant digits, or an ending quick_exponent refuses). Reads [f, f + 30) at most */
QUICK_INLINE const unsigned char *sse_fraction(const unsigned char *f, uint64_t ip, unsigned nip, int neg,
                                               const unsigned char *after, double *value)
{
    const __m128i t = _mm_sub_epi8(_mm_loadu_si128((const __m128i *)(const void *)f), _mm_set1_epi8('0'));
    /* the digits' number from two words (not from t: see above) */
    const uint64_t nd0 = nondigit_bytes(load8(f)), nd1 = nondigit_bytes(load8(f + 8));
    unsigned n = nd0 ? leading_digits(nd0) : 8 + (nd1 ? leading_digits(nd1) : 8);
    if (n == 0) return NULL;
    const unsigned char *e = f + n;
    if (n < 16 || !is_digit(*e)) { /* the usual: up to 16 fraction digits */
        const uint64_t x = sse_digits_scaled(t, n);
#if FLT_EVAL_METHOD == 0
        if (after[*e]) {
            const uint64_t man = ip * 10000000000000000ULL + x;
            if (man <= (1ULL << 53)) {
                const double v = (double)man / 1e16;
                *value = neg ? -v : v;
                return e;
            }
            if (eisel_lemire(man, -16, neg, value)) return e;
        } else if ((*e | 0x20) == 'e') { /* an exponent: the same value, its exponent added to -16 */
            const uint64_t man = ip * 10000000000000000ULL + x;
            /* two digits with a sign, as %g and %e write most of them: decided here (no Clinger: a mantissa of 17
               digits is above 2^53, and a failure falls back to quick_exponent) */
            const unsigned char *s = e + 1;
            const int eneg = *s == '-';
            s += eneg | (*s == '+');
            const unsigned d0 = (unsigned)(s[0] - '0'), d1 = (unsigned)(s[1] - '0');
            if (d0 < 10 && d1 < 10 && after[s[2]] && man != 0 &&
                eisel_lemire(man, -16 + (eneg ? -(int)(d0 * 10 + d1) : (int)(d0 * 10 + d1)), neg, value))
                return s + 2;
            const unsigned char *q = quick_exponent(e, after, man, -16, neg, value);
            if (q) return q;
        }
#endif
        return quick_exponent(e, after, ip * pow10_frac[n] + ((x >> (16 - n)) * inv5_pow[16 - n]), -(int64_t)n,
                              neg, value);
    }
    /* 17 to 23 (%.17g writes 17 to 19 below 1): their number from the next word, the value as the first 16
       times 10^(n - 16) plus that word's. After a zero integer part the fraction's leading zeros are
       not significant digits: with at most 19 significant ones the value is below 10^19, exact in 64 bits */
    const uint64_t w2 = load8(f + 16), nd2 = nondigit_bytes(w2);
    n = 16 + (nd2 ? leading_digits(nd2) : 8);
    if (n > (ip ? 19 - nip : 19)) { /* the leading zeros counted only when they matter */
        const unsigned zeros =
            (unsigned)__builtin_ctz(~(unsigned)_mm_movemask_epi8(_mm_cmpeq_epi8(t, _mm_setzero_si128())));
        if (ip || n > 23 || n - zeros > 19) return NULL;
    }
    const uint64_t man = ip * pow10_frac[n] + sse_digits_scaled(t, 16) * pow10_frac[n - 16] + digits_value(w2, n - 16);
    e = f + n;
#if FLT_EVAL_METHOD == 0
    if (after[*e] && man != 0 && eisel_lemire(man, -(int)n, neg, value)) return e;
#endif
    return quick_exponent(e, after, man, -(int64_t)n, neg, value);
}
#endif

#ifndef CG_TEXT_SSE2_FRACTION
/* quick_double's d.ddd without SSE2: the digit and 7 of the fraction as one word (the '.' replaced), then a digit
   run. p: the digit */
QUICK_INLINE const unsigned char *word_fraction(const unsigned char *p, int neg, const unsigned char *after,
                                                double *value)
{
    const unsigned char *digits = p;
    uint64_t man;
    unsigned k;
    const uint64_t first = (load8(p + 1) & ~(uint64_t)0xFF) | (uint64_t)p[0];
    const uint64_t nd = nondigit_bytes(first);
    ++p;
    if (nd) {
        man = word_digits(first, nd, &k);
        p += k;
    } else {
        man = digits_value(first, 8);
        if (!(p = quick_digit_run(p + 8, &man, 1))) return NULL;
        /* p - digits - 1 digits, the leading zeros among them those first starts with (up to 7) */
        if (p - digits - 1 > 19 &&
            p - digits - 1 - (int64_t)(__builtin_ctzll((first ^ 0x3030303030303030ULL) | (1ULL << 63)) >> 3) > 19)
            return NULL;
    }
    return quick_exponent(p, after, man, digits + 2 - p, neg, value);
}
#endif

/* [-]?digits[.digits]?([eE][+-]?digits)? followed by a byte of after; returns that byte's address. p: after
   the sign, neg: whether it was '-'; not a digit followed by a byte of after (the row loop takes those). Reads
   [p - 1, p - 1 + QUICK_READ) only: sign 1, integer part <= 16, '.' 1, fraction <= 24, exponent <= 5, the byte
   after 1 (sse_fraction: p + 3 + 30) */
QUICK_INLINE const unsigned char *quick_double(const unsigned char *p, int neg, const unsigned char *after,
                                                double *value)
{
    const unsigned char *digits = p;
    uint64_t man;
    if (is_digit(p[0])) {
#ifdef CG_TEXT_SSE2_FRACTION /* d.ddd and dd.ddd */
        const unsigned char *q = NULL;
        if (p[1] == '.')
            q = sse_fraction(p + 2, (uint64_t)(p[0] - '0'), 1, neg, after, value);
        else if (is_digit(p[1]) && p[2] == '.')
            q = sse_fraction(p + 3, (uint64_t)(p[0] - '0') * 10 + (uint64_t)(p[1] - '0'), 2, neg, after, value);
        if (q) return q;
#else
        if (p[1] == '.') return word_fraction(p, neg, after, value);
#endif
    }
    man = 0;
    if (!(p = quick_digit_run(p, &man, 1))) return NULL;
    int64_t ndigits = p - digits, exp10 = 0;
    if (*p == '.') {
        const unsigned char *fraction = ++p;
        if (!(p = quick_digit_run(p, &man, 2))) return NULL;
        exp10 = fraction - p;
        ndigits += p - fraction;
    }
    if (ndigits == 0) return NULL;
    if (ndigits > 19) { /* leading zeros count as digits but add no value */
        for (const unsigned char *q = digits; q < p && (*q == '0' || *q == '.'); ++q) ndigits -= *q == '0';
        if (ndigits > 19) return NULL;
    }
    return quick_exponent(p, after, man, exp10, neg, value);
}

/* digits (at most 15) followed by a byte of after, negated if neg; reads [p, p + 16] only */
QUICK_INLINE const unsigned char *quick_uint(const unsigned char *p, int neg, const unsigned char *after,
                                             int64_t *value)
{
    uint64_t x = 0;
    const unsigned char *digits = p;
    if (!(p = quick_digit_run(p, &x, 1)) || p == digits) return NULL;
    if (!after[*p]) return NULL;
    *value = neg ? -(int64_t)x : (int64_t)x;
    return p;
}

/* [-]?digits with at most 15 digits followed by a byte of after; reads [p, p + 17] only. The sign is a branch
   (identifiers are not negative: predicted), so the digits' loads do not wait on the first byte */
static inline const unsigned char *quick_int(const unsigned char *p, const unsigned char *after, int64_t *value)
{
    return *p == '-' ? quick_uint(p + 1, 1, after, value) : quick_uint(p, 0, after, value);
}

/*
 * One column of a row (or a block of one-digit ones) from p, the column *c: returns the address after the
 * byte that follows its last token with *c advanced, or after a run of separators with *c unchanged (the
 * column is parsed again from there), or NULL. after: the bytes that may follow a token (after_mid: *c is
 * not the last column).
 */
QUICK_INLINE const unsigned char *quick_column(const unsigned char *p, const unsigned char *end, int64_t *c,
                                                int64_t ncols, const unsigned char *kinds, const unsigned char *run,
                                                double *vrow, int64_t *irow, const unsigned char *after)
{
    const int64_t col = *c;
    const unsigned char *q;
    if (kinds[col]) {
        int64_t iv;
        q = quick_int(p, after, &iv);
        if (q) {
            irow[kinds[col] - 1] = iv; /* not a pointer advanced per column: a chain through memory */
            vrow[col] = (double)iv;
        }
    } else {
        if (*p != '-') { /* the sign is a branch: the token's parse then does not wait on its first byte */
            /* one digit alone: the 0s and 1s of unused columns (d.ddd, the usual float, tested first: one compare) */
            if (p[1] != '.' && is_digit(p[0]) && after[p[1]]) {
                if (run[col] && p[1] == ' ') {
                    /* n tokens "d " (1 to 4) from one word: the first byte that does not fit ("d" <= 9 or
                       " " == 0 after the xor) has its high bit set */
                    const uint64_t t = load8(p) ^ 0x2030203020302030ULL;
                    const uint64_t misfit =
                        (((t & 0x7F7F7F7F7F7F7F7FULL) + 0x7F767F767F767F76ULL) | t) & 0x8080808080808080ULL;
                    unsigned n = misfit ? (unsigned)__builtin_ctzll(misfit) >> 4 : 4;
                    if (run[col] == 4) {
                        /* four values stored whatever n: the columns after the n tokens are stored again when
                           they are parsed (run[col] == 4: all four in this row). t's 16-bit lanes are the four
                           digits while n is 4 (a ' ' is 0 after the xor) */
#ifdef CG_TEXT_SSE2_FRACTION
                        const __m128i d = _mm_unpacklo_epi16(_mm_cvtsi64_si128((long long)t), _mm_setzero_si128());
                        _mm_storeu_pd(vrow + col, _mm_cvtepi32_pd(d));
                        _mm_storeu_pd(vrow + col + 2, _mm_cvtepi32_pd(_mm_unpackhi_epi64(d, d)));
#else
                        for (unsigned i = 0; i < 4; ++i) vrow[col + i] = (double)((t >> 16 * i) & 0xFFFF);
#endif
                    } else {
                        if (n > run[col]) n = run[col];
                        for (unsigned i = 0; i < n; ++i) vrow[col + i] = (double)(p[2 * i] - '0');
                    }
                    *c = col + n;
                    return p + 2 * n;
                }
                vrow[col] = (double)(p[0] - '0');
                q = p + 1;
            } else {
                q = quick_double(p, 0, after, &vrow[col]);
            }
        } else if (p[2] != '.' && is_digit(p[1]) && after[p[2]]) {
            vrow[col] = -(double)(p[1] - '0');
            q = p + 2;
        } else {
            q = quick_double(p + 1, 1, after, &vrow[col]);
        }
    }
    if (q) {
        *c = col + 1;
        return q + 1;
    }
    /* not a token start: more separators, or the reference path */
    if (byte_class[*p] != SPACE) return NULL;
    while (p < end && byte_class[*p] == SPACE) ++p;
    return end - p < (ncols - col) * QUICK_READ ? NULL : p;
}

/*
 * One row from p (a line start with at least ncols * QUICK_READ bytes to end): ncols tokens (kinds[c]: 0
 * for a float column, 1 + the column's place in irow for an integer one) separated by runs of separators, the line ended by '\n' (trailing separators
 * allowed). run[c]: how many float columns from c on may be taken as a block of one-digit tokens each
 * followed by ' ' (not the last column). Returns the start of the next line with vrow and irow filled, or
 * NULL (see above; the row may be partly written).
 */
static const unsigned char *quick_row(const unsigned char *p, const unsigned char *end, int64_t ncols,
                                      const unsigned char *kinds, const unsigned char *run, double *vrow,
                                      int64_t *irow)
{
    const int64_t last = ncols - 1;
    int64_t c = 0;
    while (c < last)
        if (!(p = quick_column(p, end, &c, ncols, kinds, run, vrow, irow, after_mid))) return NULL;
    while (c == last)
        if (!(p = quick_column(p, end, &c, ncols, kinds, run, vrow, irow, after_last))) return NULL;
    if (p[-1] == '\n') return p;
    --p; /* trailing separators */
    while (p < end && byte_class[*p] == SPACE) ++p;
    return p < end && *p == '\n' ? p + 1 : NULL;
}
#endif

cg_status cg_text_parse_double(const char *token, size_t length, double *value)
{
    if (!token || !value) return CG_ERR_ARGUMENT;
    int special;
    return parse_double((const unsigned char *)token, (const unsigned char *)token + length, value, &special);
}

/* [+-]?digits into int64; CG_ERR_TEXT_INTEGER if not of that form, CG_ERR_TEXT_OVERFLOW if too large */
static cg_status parse_int(const unsigned char *p, const unsigned char *end, int64_t *value)
{
    int neg = 0;
    if (p < end && (*p == '+' || *p == '-')) {
        neg = *p == '-';
        ++p;
    }
    if (p == end) return CG_ERR_TEXT_INTEGER;
    const uint64_t limit = neg ? (uint64_t)INT64_MAX + 1 : (uint64_t)INT64_MAX;
    uint64_t v = 0;
    int overflow = 0;
    for (; p < end; ++p) {
        if (!is_digit(*p)) return CG_ERR_TEXT_INTEGER;
        unsigned d = *p - '0';
        if (v > (limit - d) / 10) overflow = 1; /* keep scanning: a later non-digit is the worse error */
        else v = v * 10 + d;
    }
    if (overflow) return CG_ERR_TEXT_OVERFLOW;
    *value = neg ? (int64_t)(0 - v) : (int64_t)v;
    return CG_OK;
}

/* ------------------------------------------------------------------ */

static void set_where(cg_text_where *w, int64_t line, int64_t column, const unsigned char *at, size_t length,
                      const unsigned char *base)
{
    w->line = line;
    w->column = column;
    w->offset = (int64_t)(at - base);
    w->length = (int64_t)length;
}

/* the first byte from p on that is not a separator (or end) */
static inline const unsigned char *skip_space(const unsigned char *p, const unsigned char *end)
{
    while (p < end && byte_class[*p] == SPACE) ++p;
    return p;
}

/* end of the line that contains p (the '\n' or the end of the range) */
static const unsigned char *line_end(const unsigned char *p, const unsigned char *end)
{
    const unsigned char *nl = memchr(p, '\n', (size_t)(end - p));
    return nl ? nl : end;
}

/* the line from start without its trailing separators (so a CR is not quoted) */
static size_t line_length(const unsigned char *start, const unsigned char *end)
{
    const unsigned char *e = line_end(start, end);
    while (e > start && byte_class[e[-1]] == SPACE) --e;
    return (size_t)(e - start);
}

cg_status cg_text_parse_table(const char *text, size_t length, int64_t ncols, const unsigned char *int_columns,
                              int flags, int64_t max_rows, double *values, int64_t *ints, cg_text_result *result)
{
    if (!result) return CG_ERR_ARGUMENT;
    memset(result, 0, sizeof *result);
    if ((!text && length) || ncols < 1 || max_rows < 0 || (!values && max_rows > 0)) return CG_ERR_ARGUMENT;
    int64_t n_int = 0;
    if (int_columns)
        for (int64_t c = 0; c < ncols; ++c) n_int += int_columns[c] != 0;
    if (n_int && !ints && max_rows > 0) return CG_ERR_ARGUMENT;

    const unsigned char *base = (const unsigned char *)text, *p = base, *end = base + length;
    int64_t line = 0, row = 0;
#ifdef CG_TEXT_SWAR
    /* the row path (quick_row) for tables of up to 255 columns, on lines with ncols * QUICK_READ bytes or more
       to the end */
    unsigned char kinds[255], run[255];
    const int quick = ncols <= 255 && length > (size_t)ncols * QUICK_READ;
    if (quick) {
        for (int64_t c = 0, slot = 0; c < ncols; ++c) /* an integer column's place in its row of ints, plus 1 */
            kinds[c] = int_columns && int_columns[c] ? (unsigned char)++slot : 0;
        for (int64_t c = ncols - 1; c >= 0; --c)
            run[c] = c == ncols - 1 || kinds[c] ? 0 : (unsigned char)(run[c + 1] < 4 ? run[c + 1] + 1 : 4);
    }
    const unsigned char *quick_end = quick ? end - ncols * QUICK_READ : base; /* the last line start taken */
#endif
    while (p < end) {
#ifdef CG_TEXT_SWAR
        if (quick && p <= quick_end && row < max_rows) {
            const unsigned char *q = quick_row(p, end, ncols, kinds, run, values + row * ncols,
                                               n_int ? ints + row * n_int : NULL);
            if (q) {
                p = q;
                ++line;
                if (++row == max_rows && (flags & CG_TEXT_STOP_AT_MAX_ROWS)) break;
                continue;
            }
        }
#endif
        const unsigned char *line_start = p;
        while (p < end && byte_class[*p] == SPACE) ++p;
        if (p == end || *p == '\n') { /* a line without tokens (p == end: separators after the last line end) */
            if (!(flags & CG_TEXT_SKIP_BLANK)) {
                set_where(&result->error, line, 0, line_start, line_length(line_start, end), base);
                result->nrows = row;
                return CG_ERR_TEXT_ROW_LENGTH;
            }
            if (p < end) ++p;
            ++line;
            continue;
        }
        if (row == max_rows) {
            set_where(&result->error, line, 0, line_start, line_length(line_start, end), base);
            result->nrows = row;
            return CG_ERR_TEXT_ROWS;
        }
        double *vrow = values + row * ncols;
        int64_t *irow = n_int ? ints + row * n_int : NULL;
        for (int64_t c = 0; c < ncols; p = skip_space(p, end), ++c) { /* p: a token's start or a line end */
            const unsigned char *tok = p; /* the fast paths fail at the line's end too: checked after them */
            if (int_columns && int_columns[c]) {
                int64_t iv;
                const unsigned char *q = fast_int(tok, end, &iv);
                if (q) {
                    *irow++ = iv;
                    vrow[c] = (double)iv;
                    p = q;
                    continue;
                }
            } else {
                const unsigned char *q = fast_double(tok, end, &vrow[c]);
                if (q) {
                    p = q;
                    continue;
                }
            }
            if (p == end || *p == '\n') { /* too few tokens */
                set_where(&result->error, line, c, line_start, line_length(line_start, end), base);
                result->nrows = row;
                return CG_ERR_TEXT_ROW_LENGTH;
            }
            while (p < end && byte_class[*p] == TOKEN) ++p;
            cg_status st;
            if (int_columns && int_columns[c]) {
                int64_t iv = 0;
                st = parse_int(tok, p, &iv);
                if (st == CG_ERR_TEXT_INTEGER) {
                    double dv;
                    int special;
                    if (parse_double(tok, p, &dv, &special) != CG_OK) st = CG_ERR_TEXT_NUMBER;
                }
                if (st == CG_OK) {
                    *irow++ = iv;
                    vrow[c] = (double)iv;
                }
            } else {
                int special;
                st = parse_double(tok, p, &vrow[c], &special);
                if (st == CG_OK && special && result->nonfinite++ == 0)
                    set_where(&result->first_nonfinite, line, c, tok, (size_t)(p - tok), base);
            }
            if (st != CG_OK) {
                set_where(&result->error, line, c, tok, (size_t)(p - tok), base);
                result->nrows = row;
                return st;
            }
        }
        if (p < end && *p != '\n') { /* too many tokens */
            set_where(&result->error, line, ncols, line_start, line_length(line_start, end), base);
            result->nrows = row;
            return CG_ERR_TEXT_ROW_LENGTH;
        }
        if (p < end) ++p;
        ++line;
        ++row;
        if (row == max_rows && (flags & CG_TEXT_STOP_AT_MAX_ROWS)) break;
    }
    result->nrows = row;
    result->end = (int64_t)(p - base);
    return CG_OK;
}

/* the start of the line after the n-th '\n' of [p, end), or end if there are fewer */
static const char *after_lines(const char *p, const char *end, int64_t n)
{
    for (; n > 0 && p < end; --n) {
        const char *nl = memchr(p, '\n', (size_t)(end - p));
        if (!nl) return end;
        p = nl + 1;
    }
    return p;
}

static int64_t count_newlines(const char *text, size_t length);

/* after_lines over a whole table: '\n' counted 64 KB at a time up to the block that holds the n-th, a memchr
   per line only in that block (a memchr per line costs a call per ~60-140-byte row, 5-10 times the count) */
static const char *after_many_lines(const char *p, const char *end, int64_t n)
{
    const size_t block = (size_t)1 << 16;
    while (n > 0 && (size_t)(end - p) > block) {
        const int64_t c = count_newlines(p, block);
        if (c >= n) break;
        n -= c;
        p += block;
    }
    return after_lines(p, end, n);
}

int cg_text_plan_parts(size_t length, int n_threads)
{
    int parts = n_threads < CG_TEXT_MAX_THREADS ? n_threads : CG_TEXT_MAX_THREADS;
    if ((size_t)parts > length / CG_TEXT_BYTES_PER_THREAD) parts = (int)(length / CG_TEXT_BYTES_PER_THREAD);
    return parts < 1 ? 1 : parts;
}

/* part k starts after the first '\n' at or after byte span / parts * k (or at span), never before part k - 1 */
static void cut_parts(const char *text, size_t span, int parts, cg_text_plan *plan)
{
    plan->parts = parts;
    plan->start[0] = 0;
    for (int k = 1; k < parts; ++k) {
        size_t cut = span / (size_t)parts * (size_t)k;
        if (cut < (size_t)plan->start[k - 1]) cut = (size_t)plan->start[k - 1];
        const char *nl = cut < span ? memchr(text + cut, '\n', span - cut) : NULL;
        plan->start[k] = nl ? (int64_t)(nl + 1 - text) : (int64_t)span;
    }
    plan->start[parts] = (int64_t)span;
}

static int64_t part_lines(const char *text, const cg_text_plan *plan, int k)
{
    return cg_text_count_lines(text + plan->start[k], (size_t)(plan->start[k + 1] - plan->start[k]));
}

static void sum_lines(cg_text_plan *plan, const int64_t *lines)
{
    plan->line[0] = 0;
    for (int k = 0; k < plan->parts; ++k) plan->line[k + 1] = plan->line[k] + lines[k];
}

cg_status cg_text_plan_lines(const char *text, size_t length, int parts, cg_text_plan *plan)
{
    if (!plan || parts < 1 || parts > CG_TEXT_MAX_THREADS || (!text && length)) return CG_ERR_ARGUMENT;
    cut_parts(text, length, parts, plan);
    int64_t lines[CG_TEXT_MAX_THREADS];
#ifdef _OPENMP
#pragma omp parallel for num_threads(parts) schedule(static, 1) if (parts > 1)
#endif
    for (int k = 0; k < parts; ++k) lines[k] = part_lines(text, plan, k);
    sum_lines(plan, lines);
    return CG_OK;
}

/* Part k of the plan parses into rows from plan->line[k] on (the lines before it), which leaves room for its rows;
   rows are closed up afterwards where blank lines were skipped. count: the plan's lines are not known yet, each
   part but the last counts its own first (in the same parallel region: no second wake-up of the threads; the
   plan's line[parts] is then not set). Any error: the
   range is parsed again in one pass, so errors are reported exactly as that pass reports them. */
static cg_status parse_parts(const char *text, size_t length, cg_text_plan *plan, int count, int64_t ncols,
                             const unsigned char *int_columns, int64_t n_int, int flags, int64_t max_rows,
                             double *values, int64_t *ints, cg_text_result *result)
{
    const int parts = plan->parts;
    cg_text_result part[CG_TEXT_MAX_THREADS];
    cg_status status[CG_TEXT_MAX_THREADS];
    int64_t lines[CG_TEXT_MAX_THREADS];
#ifdef _OPENMP
#pragma omp parallel num_threads(parts)
#endif
    {
        if (count) { /* the last part's lines place no rows: not counted (its thread waits at the barrier) */
#ifdef _OPENMP
#pragma omp for schedule(static, 1)
#endif
            for (int k = 0; k < parts; ++k) lines[k] = k + 1 < parts ? part_lines(text, plan, k) : 0;
        }
#ifdef _OPENMP
#pragma omp for schedule(static, 1)
#endif
        for (int k = 0; k < parts; ++k) {
            int64_t first = 0;
            if (count) /* each thread sums the counts itself: no third barrier */
                for (int j = 0; j < k; ++j) first += lines[j];
            else
                first = plan->line[k];
            const int64_t room = max_rows > first ? max_rows - first : 0; /* 0: any row is an error */
            status[k] = cg_text_parse_table(text + plan->start[k], (size_t)(plan->start[k + 1] - plan->start[k]),
                                            ncols, int_columns, flags & ~CG_TEXT_STOP_AT_MAX_ROWS, room,
                                            room ? values + first * ncols : values,
                                            n_int ? (room ? ints + first * n_int : ints) : NULL, &part[k]);
        }
    }
    if (count) sum_lines(plan, lines); /* line[parts] is wrong (the last part was not counted): unused */
    memset(result, 0, sizeof *result);
    for (int k = 0; k < parts; ++k) {
        if (status[k] != CG_OK)
            return cg_text_parse_table(text, length, ncols, int_columns, flags, max_rows, values, ints, result);
        const int64_t first = plan->line[k];
        if (result->nrows != first && part[k].nrows) { /* blank lines were skipped before: close up */
            memmove(values + result->nrows * ncols, values + first * ncols,
                    (size_t)(part[k].nrows * ncols) * sizeof *values);
            if (n_int)
                memmove(ints + result->nrows * n_int, ints + first * n_int,
                        (size_t)(part[k].nrows * n_int) * sizeof *ints);
        }
        if (part[k].nonfinite) {
            if (result->nonfinite == 0) {
                result->first_nonfinite = part[k].first_nonfinite;
                result->first_nonfinite.line += first;
                result->first_nonfinite.offset += plan->start[k];
            }
            result->nonfinite += part[k].nonfinite;
        }
        result->nrows += part[k].nrows;
    }
    result->end = plan->start[parts];
    return CG_OK;
}

/* the checks every threaded entry shares: 1 if the range must be parsed in one pass (bad arguments included:
   cg_text_parse_table reports them); *n_int set otherwise */
static int one_pass(const char *text, int64_t ncols, const unsigned char *int_columns, int flags, int64_t max_rows,
                    const double *values, const int64_t *ints, const cg_text_result *result, int64_t *n_int)
{
    if (!result || !text || ncols < 1 || max_rows < 0 || !values) return 1;
    /* with both, every line may be skipped or a row: the table's end is only known by parsing */
    if ((flags & CG_TEXT_STOP_AT_MAX_ROWS) && (flags & CG_TEXT_SKIP_BLANK)) return 1;
    /* no row allowed: the first line is already the error (the parts of an empty table would find none) */
    if ((flags & CG_TEXT_STOP_AT_MAX_ROWS) && max_rows == 0) return 1;
    *n_int = 0;
    if (int_columns)
        for (int64_t c = 0; c < ncols; ++c) *n_int += int_columns[c] != 0;
    return *n_int && !ints;
}

/* the table's bytes: with CG_TEXT_STOP_AT_MAX_ROWS (and no blank lines allowed) every line up to the end is a
   row or an error, so the table is the first max_rows lines */
static size_t table_span(const char *text, size_t length, int flags, int64_t max_rows)
{
    if (!(flags & CG_TEXT_STOP_AT_MAX_ROWS)) return length;
    return (size_t)(after_many_lines(text, text + length, max_rows) - text);
}

cg_status cg_text_parse_table_parts(const char *text, size_t length, int64_t ncols, const unsigned char *int_columns,
                                    int flags, int64_t max_rows, double *values, int64_t *ints,
                                    cg_text_result *result, int parts)
{
    int64_t n_int;
    if (parts < 2 || one_pass(text, ncols, int_columns, flags, max_rows, values, ints, result, &n_int))
        return cg_text_parse_table(text, length, ncols, int_columns, flags, max_rows, values, ints, result);
    cg_text_plan plan;
    cut_parts(text, table_span(text, length, flags, max_rows), parts < CG_TEXT_MAX_THREADS ? parts : CG_TEXT_MAX_THREADS,
              &plan);
    return parse_parts(text, length, &plan, 1, ncols, int_columns, n_int, flags, max_rows, values, ints, result);
}

cg_status cg_text_parse_table_threads(const char *text, size_t length, int64_t ncols,
                                      const unsigned char *int_columns, int flags, int64_t max_rows, double *values,
                                      int64_t *ints, cg_text_result *result, int n_threads)
{
    int64_t n_int;
    if (n_threads < 2 || length < 2 * CG_TEXT_BYTES_PER_THREAD ||
        one_pass(text, ncols, int_columns, flags, max_rows, values, ints, result, &n_int))
        return cg_text_parse_table(text, length, ncols, int_columns, flags, max_rows, values, ints, result);
    const size_t span = table_span(text, length, flags, max_rows);
    const int parts = cg_text_plan_parts(span, n_threads);
    if (parts < 2) return cg_text_parse_table(text, length, ncols, int_columns, flags, max_rows, values, ints, result);
    cg_text_plan plan;
    cut_parts(text, span, parts, &plan);
    return parse_parts(text, length, &plan, 1, ncols, int_columns, n_int, flags, max_rows, values, ints, result);
}

cg_status cg_text_parse_table_plan(const char *text, size_t length, const cg_text_plan *plan, int64_t ncols,
                                   const unsigned char *int_columns, int flags, int64_t max_rows, double *values,
                                   int64_t *ints, cg_text_result *result)
{
    if (!plan || plan->parts < 1 || plan->parts > CG_TEXT_MAX_THREADS || plan->start[0] != 0 ||
        plan->start[plan->parts] != (int64_t)length || plan->line[0] != 0)
        return CG_ERR_ARGUMENT;
    for (int k = 0; k < plan->parts; ++k)
        if (plan->start[k + 1] < plan->start[k] || plan->line[k + 1] < plan->line[k]) return CG_ERR_ARGUMENT;
    int64_t n_int;
    if (plan->parts < 2 || one_pass(text, ncols, int_columns, flags, max_rows, values, ints, result, &n_int))
        return cg_text_parse_table(text, length, ncols, int_columns, flags, max_rows, values, ints, result);
    if (flags & CG_TEXT_STOP_AT_MAX_ROWS) /* the plan covers the range, the table only its first max_rows lines */
        return cg_text_parse_table_parts(text, length, ncols, int_columns, flags, max_rows, values, ints, result,
                                         plan->parts);
    cg_text_plan copy = *plan;
    return parse_parts(text, length, &copy, 0, ncols, int_columns, n_int, flags, max_rows, values, ints, result);
}

/* '\n' bytes in a word: a byte b is zero in x = w ^ 0x0a..0a iff the high bit of ~(((x & 0x7f..7f) + 0x7f..7f) | x
   | 0x7f..7f) is set (exact: the masked add cannot carry across bytes). Those high bits are counted by moving
   each to its byte's low bit and summing the eight bytes into the top one with one multiplication (at most 8,
   so no carry): a builtin popcount without -mpopcnt is a library call per word, three times slower. */
static int newlines_in_word(uint64_t w)
{
    const uint64_t low7 = 0x7f7f7f7f7f7f7f7fULL;
    const uint64_t x = w ^ 0x0a0a0a0a0a0a0a0aULL;
    const uint64_t zero = ~(((x & low7) + low7) | x | low7);
    return (int)(((zero >> 7) * 0x0101010101010101ULL) >> 56);
}

static int64_t count_newlines(const char *text, size_t length)
{
    /* counted 8 bytes at a time (a memchr per line costs a call per ~60-byte row); with SSE2 (every x86-64)
       16 at a time: each '\n' adds 1 to its byte lane (subtracting the compare's -1), the lanes summed by psadbw
       before any can wrap (255 blocks), about 0.2 instructions per byte instead of 1.5 */
    int64_t n = 0;
    size_t k = 0;
#ifdef __SSE2__
    const __m128i nl = _mm_set1_epi8('\n'), zero = _mm_setzero_si128();
    while (k + 16 <= length) {
        size_t blocks = (length - k) / 16;
        if (blocks > 255) blocks = 255;
        __m128i lanes = zero;
        for (size_t b = 0; b < blocks; ++b, k += 16)
            lanes = _mm_sub_epi8(lanes, _mm_cmpeq_epi8(_mm_loadu_si128((const __m128i *)(const void *)(text + k)), nl));
        const __m128i sums = _mm_sad_epu8(lanes, zero);
        n += _mm_cvtsi128_si32(sums) + _mm_cvtsi128_si32(_mm_unpackhi_epi64(sums, sums));
    }
#endif
    for (; k + 8 <= length; k += 8) {
        uint64_t w;
        memcpy(&w, text + k, 8);
        n += newlines_in_word(w);
    }
    for (; k < length; ++k) n += text[k] == '\n';
    return n;
}

int64_t cg_text_count_lines(const char *text, size_t length)
{
    if (!text || !length) return 0;
    return count_newlines(text, length) + (text[length - 1] != '\n');
}

int64_t cg_text_count_lines_threads(const char *text, size_t length, int n_threads)
{
    if (!text || !length) return 0;
    int parts = n_threads < CG_TEXT_MAX_THREADS ? n_threads : CG_TEXT_MAX_THREADS;
    if ((size_t)parts > length / CG_TEXT_BYTES_PER_THREAD) parts = (int)(length / CG_TEXT_BYTES_PER_THREAD);
    if (parts < 2) return cg_text_count_lines(text, length);
    /* newlines add up over any cut, so the parts are plain byte ranges */
    int64_t n = 0;
#ifdef _OPENMP
#pragma omp parallel for num_threads(parts) schedule(static, 1) reduction(+ : n)
#endif
    for (int k = 0; k < parts; ++k) {
        const size_t step = length / (size_t)parts, a = step * (size_t)k;
        const size_t b = k + 1 < parts ? a + step : length;
        n += count_newlines(text + a, b - a);
    }
    return n + (text[length - 1] != '\n');
}

/* where find_lines puts what it finds: offsets[0 .. capacity) and a count beyond it; grow: a part's own list,
   doubled as needed (failed: no memory) */
typedef struct line_hits {
    int64_t *at, n, capacity;
    int grow, failed;
} line_hits;

static void add_hit(line_hits *h, int64_t offset)
{
    if (h->n == h->capacity && h->grow && !h->failed) {
        const int64_t more = h->capacity ? 2 * h->capacity : 1024;
        int64_t *at = realloc(h->at, (size_t)more * sizeof *at);
        if (at) {
            h->at = at;
            h->capacity = more;
        } else {
            h->failed = 1;
        }
    }
    if (h->n < h->capacity) h->at[h->n] = offset;
    ++h->n;
}

/* the lines of [text, text + length) that start in [from, to) with the prefix */
static void find_lines_in(const char *text, size_t length, size_t from, size_t to, const char *prefix,
                          size_t prefix_length, line_hits *hits)
{
    const char *p = text + from, *stop = text + to, *end = text + length;
    if (prefix_length == 0) {
        /* every line start */
        if (from > 0 && p[-1] != '\n') { /* inside a line: from the next one */
            const char *nl = memchr(p, '\n', (size_t)(end - p));
            if (!nl) return;
            p = nl + 1;
        }
        while (p < stop) {
            add_hit(hits, p - text);
            const char *nl = memchr(p, '\n', (size_t)(end - p));
            if (!nl) break;
            p = nl + 1;
        }
        return;
    }
    /* jump between occurrences of the prefix's first byte (rare in numeric
       rows for the prefixes we use: 'I' of ITEM:, '#'), keep those at a line start */
    const char first = prefix[0];
    while (p < stop) {
        const char *hit = memchr(p, first, (size_t)(stop - p));
        if (!hit) break;
        if ((hit == text || hit[-1] == '\n') && (size_t)(end - hit) >= prefix_length &&
            memcmp(hit, prefix, prefix_length) == 0) {
            add_hit(hits, hit - text);
            const char *nl = memchr(hit, '\n', (size_t)(end - hit));
            if (!nl) break;
            p = nl + 1;
        } else {
            p = hit + 1;
        }
    }
}

cg_status cg_text_find_lines(const char *text, size_t length, const char *prefix, size_t prefix_length,
                             int64_t *offsets, int64_t capacity, int64_t *count)
{
    return cg_text_find_lines_threads(text, length, prefix, prefix_length, offsets, capacity, count, 1);
}

cg_status cg_text_find_lines_threads(const char *text, size_t length, const char *prefix, size_t prefix_length,
                                     int64_t *offsets, int64_t capacity, int64_t *count, int n_threads)
{
    if (!count || capacity < 0 || (capacity > 0 && !offsets) || (!text && length) || (!prefix && prefix_length))
        return CG_ERR_ARGUMENT;
    const int parts = n_threads < 2 || length < 2 * CG_TEXT_BYTES_PER_THREAD ? 1 : cg_text_plan_parts(length, n_threads);
    if (parts > 1) {
        /* byte ranges (a line belongs to the part it starts in), each listed on its own thread: the first pass
           over a fresh mapping of a file is mostly page faults, which the threads then share */
        line_hits part[CG_TEXT_MAX_THREADS];
        memset(part, 0, sizeof part);
#ifdef _OPENMP
#pragma omp parallel for num_threads(parts) schedule(static, 1)
#endif
        for (int k = 0; k < parts; ++k) {
            part[k].grow = 1;
            find_lines_in(text, length, length / (size_t)parts * (size_t)k,
                          k + 1 < parts ? length / (size_t)parts * (size_t)(k + 1) : length, prefix, prefix_length,
                          &part[k]);
        }
        int failed = 0;
        int64_t n = 0;
        for (int k = 0; k < parts; ++k) {
            failed |= part[k].failed;
            for (int64_t j = 0; j < part[k].n && !failed; ++j, ++n)
                if (n < capacity) offsets[n] = part[k].at[j];
            free(part[k].at);
        }
        if (!failed) {
            *count = n;
            return CG_OK;
        }
    }
    line_hits hits = {offsets, 0, capacity, 0, 0}; /* one pass (also when a part's list found no memory) */
    find_lines_in(text, length, 0, length, prefix, prefix_length, &hits);
    *count = hits.n;
    return CG_OK;
}
