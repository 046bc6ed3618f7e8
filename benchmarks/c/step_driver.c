/*
 * step_driver.c -- the per-step cost of an FMU binary: loads the library,
 * instantiates and initialises one instance, then runs CYCLES cycles of
 *
 *     fmi2SetReal(input) ; fmi2DoStep ; fmi2GetReal(output)
 *
 * as a tight importer loop would.  Value reference 0 is the input and 1 the
 * output (true for the plant and the inverse FMU).
 *
 * usage: step_driver LIBRARY GUID count|time CYCLES INPUT_LO INPUT_HI
 *
 *   count  runs the cycles once and prints the sum of the outputs (as the 16
 *          hex digits of the double); run it under valgrind's callgrind for
 *          CYCLES = K and 2 K: the difference of the two instruction totals
 *          over K is the cost of one cycle, with everything else (loading,
 *          set-up, tear-down) cancelled out.  For an exact cancellation
 *          everything outside the loop must cost the same in both runs: the
 *          sum is printed by a fixed-length loop (printf's cost would depend
 *          on the number) and CYCLES should be written with the same number
 *          of digits (leading zeros are fine).
 *   time   runs the cycles five times after a warm-up and prints the best
 *          wall-clock time per cycle in nanoseconds.
 *
 * The inputs come from a table of 1024 samples between INPUT_LO and INPUT_HI
 * filled before the loop: two sines (periods 1024 and 1024/7 samples), so the
 * operators see major and minor loops.  The table and everything else outside
 * the loop has a fixed cost, so it cancels in the count difference; inside the
 * loop the driver adds only the table look-up and the status check.
 */
#define _POSIX_C_SOURCE 199309L
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "fmi2_api.h"        /* Fmi2Api: every fmi2* function, loaded (shared with tests/c) */

#define TABLE_SIZE 1024u
#define REPEATS 5

static void logger(fmi2ComponentEnvironment env, fmi2String instance, fmi2Status status,
                   fmi2String category, fmi2String message, ...)
{
    (void)env;
    fprintf(stderr, "[%d %s] %s: %s\n", (int)status, category, instance, message);
}

/* The bit pattern of x as 16 hex digits, at a cost independent of x. */
static void print_bits(const char *label, double x)
{
    static const char digits[] = "0123456789abcdef";
    unsigned long long u;
    char text[17];
    memcpy(&u, &x, sizeof u);
    for (int i = 0; i < 16; i++) {
        text[i] = digits[(u >> (60 - 4 * i)) & 15u];
    }
    text[16] = '\0';
    fputs(label, stdout);
    fputs(text, stdout);
    fputs("\n", stdout);
}

static double now_ns(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return 1e9 * (double)ts.tv_sec + (double)ts.tv_nsec;
}

/* The measured loop; kept out of line so that a profile shows it as one
 * function.  Returns the worst status seen; *time_s carries the FMU's time. */
static __attribute__((noinline)) fmi2Status run_cycles(const Fmi2Api *api, fmi2Component c,
                                                       const double *table, size_t cycles,
                                                       double *time_s, double *checksum)
{
    const fmi2ValueReference in = 0, out = 1;
    const double h = 1e-4;
    double t = *time_s, sum = 0.0, y = 0.0;
    int status = fmi2OK;
    for (size_t k = 0; k < cycles; k++) {
        status |= api->SetReal(c, &in, 1, &table[k & (TABLE_SIZE - 1u)]);
        status |= api->DoStep(c, t, h, fmi2True);
        status |= api->GetReal(c, &out, 1, &y);
        sum += y;
        t += h;
    }
    *time_s = t;
    *checksum += sum;
    return (fmi2Status)status;
}

int main(int argc, char **argv)
{
    if (argc != 7 || (strcmp(argv[3], "count") != 0 && strcmp(argv[3], "time") != 0)) {
        fprintf(stderr, "usage: step_driver LIBRARY GUID count|time CYCLES INPUT_LO INPUT_HI\n");
        return 2;
    }
    const int timing = strcmp(argv[3], "time") == 0;
    char *end = NULL;
    const unsigned long long cycles = strtoull(argv[4], &end, 10);
    const double lo = strtod(argv[5], NULL), hi = strtod(argv[6], NULL);
    if (*end != '\0' || cycles == 0 || !(hi > lo)) {
        fprintf(stderr, "step_driver: CYCLES must be a positive integer and INPUT_LO < INPUT_HI\n");
        return 2;
    }

    Fmi2Api api;
    Fmi2Library lib = fmi2_load(argv[1], &api);
    if (!lib) {
        const char *why = dlerror();      /* fmi2_load said what failed; dlerror says why */
        if (why) {
            fprintf(stderr, "step_driver: %s\n", why);
        }
        return 3;
    }

    double table[TABLE_SIZE];
    const double pi = 3.14159265358979323846;
    for (unsigned k = 0; k < TABLE_SIZE; k++) {
        const double phase = 2.0 * pi * (double)k / TABLE_SIZE;
        const double x = 0.5 - 0.3 * cos(phase) + 0.15 * sin(7.0 * phase);   /* within [0.05, 0.95] */
        table[k] = lo + (hi - lo) * x;
    }

    const fmi2CallbackFunctions callbacks = { logger, calloc, free, NULL, NULL };
    fmi2Component c = api.Instantiate("bench", fmi2CoSimulation, argv[2], "", &callbacks, fmi2False, fmi2False);
    if (!c || api.SetupExperiment(c, fmi2False, 0.0, 0.0, fmi2False, 0.0) != fmi2OK ||
        api.EnterInitializationMode(c) != fmi2OK || api.ExitInitializationMode(c) != fmi2OK) {
        fprintf(stderr, "step_driver: the FMU did not initialise\n");
        return 1;
    }

    double t = 0.0, checksum = 0.0;
    fmi2Status status;
    if (timing) {
        status = run_cycles(&api, c, table, cycles, &t, &checksum);        /* warm-up */
        double best = -1.0;
        for (int r = 0; r < REPEATS && status <= fmi2Warning; r++) {
            const double start = now_ns();
            status = run_cycles(&api, c, table, cycles, &t, &checksum);
            const double ns = (now_ns() - start) / (double)cycles;
            if (best < 0.0 || ns < best) {
                best = ns;
            }
        }
        printf("ns_per_cycle %.3f\n", best);
    } else {
        status = run_cycles(&api, c, table, cycles, &t, &checksum);
    }
    print_bits("checksum ", checksum);
    if (status > fmi2Warning) {
        fprintf(stderr, "step_driver: a call returned status %d\n", (int)status);
    }
    api.Terminate(c);
    api.FreeInstance(c);
    fmi2_close_library(lib);
    return status > fmi2Warning ? 1 : 0;
}
