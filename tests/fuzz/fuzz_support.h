/*
 * fuzz_support.h -- what both fuzz targets share: the FMU compiled into the
 * target itself (all.c of a built FMU's sources/, so the sanitizers and the
 * fuzzer's coverage see every line), a reader that turns fuzz bytes into
 * call arguments, a logger and allocator that count, and the checks whose
 * failure is reported as a crash (abort).
 *
 * Build (the FMU's sources and fmpy's FMI headers on the include path):
 *   clang -g -O1 -fsanitize=fuzzer,address,undefined -fno-sanitize-recover=all
 *         -I SOURCES -I FMI_HEADERS fuzz_calls.c -o fuzz_calls
 */
#ifndef PIEZO_FUZZ_SUPPORT_H
#define PIEZO_FUZZ_SUPPORT_H

#include "all.c"                /* the FMU: fmi2* and its internals, one unit */

#include <float.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* A check that must hold whatever the input: a violation is a finding. */
#define FUZZ_REQUIRE(condition, what)                                             \
    do {                                                                          \
        if (!(condition)) {                                                       \
            fprintf(stderr, "fuzz check failed: %s (%s:%d)\n", what, __FILE__, __LINE__); \
            abort();                                                              \
        }                                                                         \
    } while (0)

/* ------------------------------------------------------------ the input */
typedef struct {
    const uint8_t *data;
    size_t size;
} FuzzInput;

static inline uint8_t take_byte(FuzzInput *in)
{
    if (in->size == 0) {
        return 0;
    }
    in->size--;
    return *in->data++;
}

static inline uint32_t take_u32(FuzzInput *in)
{
    uint32_t x = 0;
    for (int i = 0; i < 4; i++) {
        x |= (uint32_t)take_byte(in) << (8 * i);
    }
    return x;
}

static inline double take_raw_double(FuzzInput *in)
{
    uint64_t u = 0;
    for (int i = 0; i < 8; i++) {
        u |= (uint64_t)take_byte(in) << (8 * i);
    }
    double x;
    memcpy(&x, &u, sizeof x);
    return x;
}

/* A double: mostly inside [low, high], often a value at an edge of what a
 * double can be, sometimes any bit pattern. */
static inline double take_value(FuzzInput *in, double low, double high)
{
    static const double special[16] = { 0.0, -0.0, 1.0, -1.0, 1e-3, 0.5, 1e308, -1e308,
                                         DBL_MAX, -DBL_MAX, DBL_MIN, 5e-324, NAN, INFINITY, -INFINITY, 1e-300 };
    const uint8_t kind = take_byte(in);
    if (kind < 48) {
        return special[kind % 16];
    }
    if (kind < 224) {
        return low + (high - low) * (take_byte(in) / 255.0);
    }
    return take_raw_double(in);
}

/* -------------------------------------------- logger and allocator */
static long fuzz_messages;               /* logger calls so far */
static long fuzz_live_blocks;            /* blocks allocated, not yet freed */
static int fuzz_fail_allocations;        /* the next allocations fail */

static void fuzz_logger(fmi2ComponentEnvironment env, fmi2String instance, fmi2Status status,
                        fmi2String category, fmi2String message, ...)
{
    (void)env;
    FUZZ_REQUIRE(instance && category && message, "logger called with a NULL string");
    FUZZ_REQUIRE(status >= fmi2OK && status <= fmi2Fatal, "logger called with an invalid status");
    FUZZ_REQUIRE(strchr(message, '%') == NULL, "a message with a '%' (a logger may use it as a format)");
    fuzz_messages++;
}

static void *fuzz_calloc(size_t n, size_t size)
{
    if (fuzz_fail_allocations > 0) {
        fuzz_fail_allocations--;
        return NULL;
    }
    void *p = calloc(n, size);
    fuzz_live_blocks += p != NULL;
    return p;
}

static void fuzz_free(void *p)
{
    fuzz_live_blocks -= p != NULL;
    free(p);
}

static const fmi2CallbackFunctions fuzz_callbacks = { fuzz_logger, fuzz_calloc, fuzz_free, NULL, NULL };

/* The statuses a co-simulation call of these FMUs may return: doStep is
 * synchronous (never Pending) and nothing is fatal. */
static inline void require_status(fmi2Status s)
{
    FUZZ_REQUIRE(s == fmi2OK || s == fmi2Warning || s == fmi2Discard || s == fmi2Error,
                 "a status other than OK, Warning, Discard, Error");
}

/* A refused call says why: an fmi2Error always reaches the logger. */
static inline void require_explained(fmi2Status s, long messages_before)
{
    require_status(s);
    if (s == fmi2Error) {
        FUZZ_REQUIRE(fuzz_messages > messages_before, "fmi2Error without a log message");
    }
}

static const double real_start_values[MODEL_N_REALS] = MODEL_REAL_STARTS;

#endif /* PIEZO_FUZZ_SUPPORT_H */
