/*
 * fmu_driver.c -- runs an FMU binary through the whole FMI 2.0
 * co-simulation calling sequence, the way an importing tool does, and prints
 * every output as the bit pattern of the double (16 hex digits), so that runs
 * on different platforms can be compared bit for bit.
 *
 * usage: fmu_driver LIBRARY GUID INPUT_FILE
 *
 * INPUT_FILE holds one input sample per line, as the 16-hex-digit bit pattern
 * of a double.  Value reference 0 is the input and 1 the output (true for the
 * plant and the inverse FMU).  The sequence:
 *   - resolve every fmi2* function of the co-simulation interface;
 *   - instantiate two instances, set up, initialise;
 *   - per sample and on both instances: fmi2SetReal(input), then
 *     fmi2GetReal(output) and fmi2DoStep with a varying step size -- get
 *     before step on one instance, after it on the other (the output for an
 *     input held over a step does not change, so they must agree exactly);
 *   - halfway: fmi2GetFMUstate and fmi2SerializeFMUstate; at the end replay
 *     the second half from the deserialised state and from the saved state
 *     (both must reproduce the outputs bit for bit);
 *   - terminate and free everything.
 * Lines starting with '#' report the checks; the exit code is 0 when all
 * passed.  Portable C99: builds for Linux (dlopen) and Windows (LoadLibrary).
 */
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmi2_api.h"        /* Fmi2Api: every fmi2* function, loaded */

static int failures = 0;

static void logger(fmi2ComponentEnvironment env, fmi2String instance, fmi2Status status,
                   fmi2String category, fmi2String message, ...)
{
    (void)env;
    fprintf(stderr, "[%d %s] %s: %s\n", (int)status, category, instance, message);
}

static void check(fmi2Status status, const char *what)
{
    if (status > fmi2Warning) {
        printf("# FAILED %s: status %d\n", what, (int)status);
        failures++;
    }
}

static uint64_t bits_of(double x)
{
    uint64_t u;
    memcpy(&u, &x, sizeof u);
    return u;
}

/* 16 hex digits, independent of the C runtime's printf */
static void print_bits(double x)
{
    static const char digits[] = "0123456789abcdef";
    const uint64_t u = bits_of(x);
    char text[18];
    for (int i = 0; i < 16; i++) {
        text[i] = digits[(u >> (60 - 4 * i)) & 15u];
    }
    text[16] = '\n';
    text[17] = '\0';
    fputs(text, stdout);
}

static int parse_bits(const char *line, double *x)
{
    uint64_t u = 0;
    int n = 0;
    for (const char *p = line; *p && *p != '\n' && *p != '\r'; p++, n++) {
        const char c = *p;
        const int d = (c >= '0' && c <= '9') ? c - '0' : (c >= 'a' && c <= 'f') ? c - 'a' + 10 : -1;
        if (d < 0 || n >= 16) {
            return 0;
        }
        u = (u << 4) | (uint64_t)d;
    }
    memcpy(x, &u, sizeof u);
    return n == 16;
}

static double step_size(size_t k)
{
    return 1e-3 * (double)(1 + k % 3);  /* variable communication steps */
}

/* One sample on one instance: set the input, then get the output before or
 * after the step (the output for a held input does not change over a step,
 * so both orders must give the same numbers). */
static double sample(const Fmi2Api *api, fmi2Component c, double input, double t, size_t k, int get_first)
{
    const fmi2ValueReference in = 0, out = 1;
    double output = 0.0;
    check(api->SetReal(c, &in, 1, &input), "fmi2SetReal");
    if (get_first) {
        check(api->GetReal(c, &out, 1, &output), "fmi2GetReal");
    }
    check(api->DoStep(c, t, step_size(k), fmi2True), "fmi2DoStep");
    if (!get_first) {
        check(api->GetReal(c, &out, 1, &output), "fmi2GetReal");
    }
    return output;
}

int main(int argc, char **argv)
{
    if (argc != 4) {
        fprintf(stderr, "usage: fmu_driver LIBRARY GUID INPUT_FILE\n");
        return 2;
    }
    FILE *file = fopen(argv[3], "r");
    if (!file) {
        fprintf(stderr, "fmu_driver: cannot open %s\n", argv[3]);
        return 2;
    }
    size_t n = 0, capacity = 1024;
    double *inputs = (double *)malloc(capacity * sizeof(double));
    char line[64];
    while (inputs && fgets(line, sizeof line, file)) {
        if (n == capacity) {
            capacity *= 2;
            double *grown = (double *)realloc(inputs, capacity * sizeof(double));
            if (!grown) {
                break;
            }
            inputs = grown;
        }
        if (!parse_bits(line, &inputs[n])) {
            fprintf(stderr, "fmu_driver: bad input line %lu\n", (unsigned long)(n + 1));
            return 2;
        }
        n++;
    }
    fclose(file);
    if (!inputs || n < 2) {
        fprintf(stderr, "fmu_driver: need at least two input samples\n");
        return 2;
    }

    Fmi2Api api;
    Fmi2Library lib = fmi2_load(argv[1], &api);
    if (!lib) {
        printf("# FAILED cannot load %s with every fmi2* function\n", argv[1]);
        return 3;
    }
    printf("# exports all %lu co-simulation functions\n", (unsigned long)FMI2_N_API);
    printf("# version %s, types platform %s\n", api.GetVersion(), api.GetTypesPlatform());

    const fmi2CallbackFunctions callbacks = { logger, calloc, free, NULL, NULL };
    fmi2Component a = api.Instantiate("a", fmi2CoSimulation, argv[2], "", &callbacks, fmi2False, fmi2False);
    fmi2Component b = api.Instantiate("b", fmi2CoSimulation, argv[2], "", &callbacks, fmi2False, fmi2False);
    if (!a || !b) {
        printf("# FAILED fmi2Instantiate\n");
        return 1;
    }
    fmi2Component both[2] = { a, b };
    for (int i = 0; i < 2; i++) {
        check(api.SetupExperiment(both[i], fmi2False, 0.0, 0.0, fmi2False, 0.0), "fmi2SetupExperiment");
        check(api.EnterInitializationMode(both[i]), "fmi2EnterInitializationMode");
        check(api.ExitInitializationMode(both[i]), "fmi2ExitInitializationMode");
    }

    double *outputs = (double *)malloc(n * sizeof(double));
    const size_t half = n / 2;
    fmi2FMUstate saved = NULL, restored = NULL;
    fmi2Byte *blob = NULL;
    size_t blob_size = 0;
    double t = 0.0, t_half = 0.0;
    int instances_agree = 1;
    for (size_t k = 0; k < n; k++) {
        if (k == half) {
            t_half = t;
            check(api.GetFMUstate(a, &saved), "fmi2GetFMUstate");
            check(api.SerializedFMUstateSize(a, saved, &blob_size), "fmi2SerializedFMUstateSize");
            blob = (fmi2Byte *)malloc(blob_size);
            check(api.SerializeFMUstate(a, saved, blob, blob_size), "fmi2SerializeFMUstate");
        }
        outputs[k] = sample(&api, a, inputs[k], t, k, 1);
        const double other = sample(&api, b, inputs[k], t, k, 0);
        instances_agree &= bits_of(other) == bits_of(outputs[k]);
        t += step_size(k);
        print_bits(outputs[k]);
    }
    printf("# instances %s\n", instances_agree ? "identical" : "DIFFERENT");
    failures += !instances_agree;

    /* replay the second half from the deserialised and from the saved state */
    check(api.DeSerializeFMUstate(a, blob, blob_size, &restored), "fmi2DeSerializeFMUstate");
    fmi2FMUstate starts[2] = { restored, saved };
    const char *labels[2] = { "deserialized", "saved" };
    for (int r = 0; r < 2; r++) {
        check(api.SetFMUstate(a, starts[r]), "fmi2SetFMUstate");
        double tr = t_half;
        size_t first_difference = n;
        for (size_t k = half; k < n; k++) {
            const double y = sample(&api, a, inputs[k], tr, k, 1);
            if (bits_of(y) != bits_of(outputs[k]) && first_difference == n) {
                first_difference = k;
            }
            tr += step_size(k);
        }
        if (first_difference == n) {
            printf("# replay from %s state identical\n", labels[r]);
        } else {
            printf("# replay from %s state DIFFERENT from sample %lu\n", labels[r],
                   (unsigned long)first_difference);
            failures++;
        }
    }

    for (int i = 0; i < 2; i++) {
        check(api.Terminate(both[i]), "fmi2Terminate");
    }
    check(api.FreeFMUstate(a, &saved), "fmi2FreeFMUstate");
    check(api.FreeFMUstate(a, &restored), "fmi2FreeFMUstate");
    api.FreeInstance(a);
    api.FreeInstance(b);
    fmi2_close_library(lib);
    free(blob);
    free(outputs);
    free(inputs);
    printf("# %s\n", failures ? "FAILED" : "passed");
    return failures ? 1 : 0;
}
