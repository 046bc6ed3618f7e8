/*
 * fmu_misuse.c -- the FMI 2.0 misuse suite: calls an importer gets wrong, made
 * on the plant and the inverse FMU binaries of one spec, loaded into one
 * process (as a simulator that holds both would).
 *
 * usage:
 *   fmu_misuse cases       PLANT_LIB PLANT_GUID INVERSE_LIB INVERSE_GUID N_REALS
 *   fmu_misuse cycles N    PLANT_LIB PLANT_GUID INVERSE_LIB INVERSE_GUID N_REALS
 *
 * N_REALS is the number of Real variables (the same in both FMUs; value
 * references: 0 input, 1 output, 2..7 a1, a2, input_offset, output_offset,
 * voltage_min, voltage_max, then r[i] and b[i]; the inverse's one Boolean,
 * use_previous_sample, follows the Reals).
 *
 * cases: every case prints one line
 *     case FMU/NAME expected=X got=Y logged=yes|no|- rule=R ok|FAILED
 * where X and Y are FMI statuses (OK, Warning, Discard, Error), NULL or
 * instance (fmi2Instantiate), a number, or true/false (a property checked);
 * R says what is asked of the logger:
 *     must-log     a refused or adjusted call: the FMU must call the logger
 *     no-instance  no valid instance, hence no logger the FMU could reach:
 *                  the call must return and log nothing
 *     may-log      an accepted call (or a property): logging is not checked
 * A case is handled when the status (or value) is the expected one and the
 * logging rule holds; the last line is "N cases tried, M handled" and the
 * exit code is 0 when M == N.
 *
 * cycles: N times, on both FMUs: instantiate, set up, set a parameter,
 * initialise, simulate, get/serialize/deserialize/set the FMU state,
 * continue, a refused call, terminate, reset, free -- for a memory checker.
 * Every cycle must give the same outputs bit for bit.
 *
 * Lines "# section NAME" group the cases that follow them.
 *
 * The logger records every message (and checks the environment pointer it
 * receives); the allocator counts blocks and can be told to fail, so out-of-
 * memory paths are exercised and every block is seen freed.  Portable C99:
 * builds for Linux (dlopen) and Windows (LoadLibrary).
 */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmi2_api.h"

#define N_SAMPLES 48            /* samples of the standard input sequence */
#define N_MANY 500              /* instances alive at once */
#define STEP 1e-3               /* communication step, s */

enum { VR_IN = 0, VR_OUT = 1, VR_A1 = 2, VR_A2 = 3, VR_VMIN = 6, VR_VMAX = 7, VR_R1 = 8 };

/* The FMI state bits and layout of a serialized FMU state (fmi2_layer.c);
 * the suite builds well-sealed blobs with wrong contents from them. */
enum { ST_INSTANTIATED = 1, ST_STEP_COMPLETE = 4, ST_STEP_IN_PROGRESS = 8, ST_ERROR = 128, ST_FATAL = 256 };
enum { OFF_VERSION = 8, OFF_SIZE = 12, OFF_HASH = 16, OFF_N_REALS = 24, OFF_N_BOOLEANS = 28,
       OFF_N_MEMORY = 32, OFF_STATE = 36, OFF_TIME = 40, OFF_START = 48, OFF_FLAGS = 64, OFF_REALS = 72 };

typedef struct {
    const char *name;                   /* "plant" or "inverse" */
    Fmi2Api api;
    Fmi2Library lib;
    const char *guid;
    fmi2ValueReference n_reals;
    fmi2ValueReference n_booleans;
    double v_min, v_max;                /* voltage range, V */
    double inputs[N_SAMPLES];           /* the standard input sequence */
} Fmu;

/* ----------------------------------------------------------- the logger */
static struct {
    long messages;
    long bad_arguments;                 /* wrong environment or NULL strings */
    int echo;                           /* copy messages to stderr */
    char since[4096];                   /* the messages since begin() */
} logbook;
static int environment;                 /* its address is the componentEnvironment */

static void logger(fmi2ComponentEnvironment env, fmi2String instance, fmi2Status status,
                   fmi2String category, fmi2String message, ...)
{
    logbook.messages++;
    if (env != (fmi2ComponentEnvironment)&environment || !instance || !category || !message) {
        logbook.bad_arguments++;
    }
    const size_t used = strlen(logbook.since);
    if (message && used + 1 < sizeof logbook.since) {
        strncat(logbook.since, message, sizeof logbook.since - used - 2);
        strcat(logbook.since, "\n");
    }
    if (logbook.echo) {
        fprintf(stderr, "    log [%d %s] %.60s: %s\n", (int)status, category ? category : "?",
                instance ? instance : "?", message ? message : "(NULL)");
    }
}

/* --------------------------------------------------- a counting allocator */
static long live_blocks;                /* allocated by an FMU, not yet freed */
static long allocations_left = -1;      /* < 0: no limit */

static void *counting_calloc(size_t n, size_t size)
{
    if (allocations_left == 0) {
        return NULL;
    }
    if (allocations_left > 0) {
        allocations_left--;
    }
    void *p = calloc(n, size);
    live_blocks += p != NULL;
    return p;
}

static void counting_free(void *p)
{
    live_blocks -= p != NULL;
    free(p);
}

static const fmi2CallbackFunctions callbacks = { logger, counting_calloc, counting_free, NULL, &environment };

/* ------------------------------------------------------------ the cases */
typedef enum { MUST_LOG, NO_INSTANCE, MAY_LOG } LogRule;
static const char *const rule_names[] = { "must-log", "no-instance", "may-log" };
static const char *suite = "";          /* FMU name in the case lines */
static long tried, handled, mark;

static const char *status_name(fmi2Status s)
{
    static const char *const names[] = { "OK", "Warning", "Discard", "Error", "Fatal", "Pending" };
    return ((int)s >= 0 && (int)s < 6) ? names[s] : "invalid";
}

static void begin(void)
{
    mark = logbook.messages;
    logbook.since[0] = '\0';
}

static void result(const char *name, const char *expected, const char *got, int match, LogRule rule,
                   int is_call)
{
    const int logged = logbook.messages > mark;
    const int log_ok = rule == MAY_LOG || (rule == MUST_LOG && logged) || (rule == NO_INSTANCE && !logged);
    const int ok = match && log_ok;
    tried++;
    handled += ok;
    printf("case %s/%s expected=%s got=%s logged=%s rule=%s %s\n", suite, name, expected, got,
           is_call ? (logged ? "yes" : "no") : "-", rule_names[rule], ok ? "ok" : "FAILED");
    fflush(stdout);
}

static void status_case(const char *name, fmi2Status expected, fmi2Status got, LogRule rule)
{
    result(name, status_name(expected), status_name(got), got == expected, rule, 1);
}

/* A call and its expected status; the logger's messages since begin() count. */
#define CALL(name, expected, rule, call)                                        \
    do {                                                                        \
        begin();                                                                \
        const fmi2Status got_ = (call);                                         \
        status_case(name, expected, got_, rule);                                \
    } while (0)

static void check_case(const char *name, int condition)
{
    begin();
    result(name, "true", condition ? "true" : "false", condition, MAY_LOG, 0);
}

static uint64_t bits_of(double x)
{
    uint64_t u;
    memcpy(&u, &x, sizeof u);
    return u;
}

static void value_case(const char *name, double expected, double got)
{
    char e[32], g[32];
    sprintf(e, "%.17g", expected);
    sprintf(g, "%.17g", got);
    begin();
    result(name, e, g, bits_of(expected) == bits_of(got), MAY_LOG, 0);
}

/* Groups the following cases (for the summary tables). */
static void section(const char *name)
{
    printf("# section %s\n", name);
}

static void fatal(const char *what)
{
    printf("# FAILED %s/%s: cannot go on\n", suite, what);
    printf("%ld cases tried, %ld handled\n", tried, handled);
    exit(1);
}

/* ------------------------------------------------------------- helpers */
static fmi2Component create(const Fmu *f, const char *name, fmi2Boolean logging)
{
    return f->api.Instantiate(name, fmi2CoSimulation, f->guid, "", &callbacks, fmi2False, logging);
}

/* An instance in StepComplete at time 0 (default parameters). */
static fmi2Component ready(const Fmu *f, const char *name, fmi2Boolean logging)
{
    fmi2Component c = create(f, name, logging);
    if (!c || f->api.SetupExperiment(c, fmi2False, 0.0, 0.0, fmi2False, 0.0) != fmi2OK ||
        f->api.EnterInitializationMode(c) != fmi2OK || f->api.ExitInitializationMode(c) != fmi2OK) {
        fatal("instantiate and initialise");
    }
    return c;
}

static fmi2Status worst(fmi2Status a, fmi2Status b)
{
    return a > b ? a : b;
}

/* One communication step: set the input, step, read the output. */
static fmi2Status step(const Fmu *f, fmi2Component c, double *t, double input, double *output)
{
    const fmi2ValueReference in = VR_IN, out = VR_OUT;
    fmi2Status s = f->api.SetReal(c, &in, 1, &input);
    s = worst(s, f->api.DoStep(c, *t, STEP, fmi2True));
    s = worst(s, f->api.GetReal(c, &out, 1, output));
    *t += STEP;
    return s;
}

/* Samples [from, to) of the standard sequence, rotated by shift. */
static fmi2Status run(const Fmu *f, fmi2Component c, double *t, int from, int to, int shift, double *out)
{
    fmi2Status s = fmi2OK;
    for (int k = from; k < to; k++) {
        s = worst(s, step(f, c, t, f->inputs[(k + shift) % N_SAMPLES], &out[k - from]));
    }
    return s;
}

static double get_real(const Fmu *f, fmi2Component c, fmi2ValueReference vr)
{
    double x = NAN;
    f->api.GetReal(c, &vr, 1, &x);
    return x;
}

static int same_bits(const double *a, const double *b, int n)
{
    for (int i = 0; i < n; i++) {
        if (bits_of(a[i]) != bits_of(b[i])) {
            return 0;
        }
    }
    return 1;
}

/* ------------------------------------------- serialized-state surgery */
static uint64_t fnv1a(const unsigned char *bytes, size_t size)
{
    uint64_t hash = UINT64_C(14695981039346656037);
    for (size_t i = 0; i < size; i++) {
        hash ^= bytes[i];
        hash *= UINT64_C(1099511628211);
    }
    return hash;
}

static void reseal(unsigned char *blob, size_t size)
{
    const uint64_t checksum = fnv1a(blob, size - 8);
    memcpy(blob + size - 8, &checksum, 8);
}

static void put_u32(unsigned char *blob, size_t offset, uint32_t x)
{
    memcpy(blob + offset, &x, 4);
}

static void put_f64(unsigned char *blob, size_t offset, double x)
{
    memcpy(blob + offset, &x, 8);
}

/* The serialized state of c; *size receives its length (caller frees). */
static unsigned char *serialized(const Fmu *f, fmi2Component c, size_t *size)
{
    fmi2FMUstate s = NULL;
    unsigned char *blob = NULL;
    if (f->api.GetFMUstate(c, &s) != fmi2OK || f->api.SerializedFMUstateSize(c, s, size) != fmi2OK ||
        !(blob = (unsigned char *)malloc(*size)) ||
        f->api.SerializeFMUstate(c, s, (fmi2Byte *)blob, *size) != fmi2OK) {
        fatal("serialize a state");
    }
    f->api.FreeFMUstate(c, &s);
    return blob;
}

/* fmi2DeSerializeFMUstate of blob: the expected status, and a state handed
 * out exactly when it succeeds. */
static void deserialize_case(const Fmu *f, fmi2Component c, const char *name, const unsigned char *blob,
                             size_t size, fmi2Status expected)
{
    fmi2FMUstate s = NULL;
    begin();
    const fmi2Status got = f->api.DeSerializeFMUstate(c, (const fmi2Byte *)blob, size, &s);
    result(name, status_name(expected), status_name(got), got == expected && (got == fmi2OK) == (s != NULL),
           expected == fmi2OK ? MAY_LOG : MUST_LOG, 1);
    if (s) {
        f->api.FreeFMUstate(c, &s);
    }
}

/* ================================================================ cases */
static void library_cases(const Fmu *f)
{
    check_case("fmi2GetVersion_is_2.0", strcmp(f->api.GetVersion(), "2.0") == 0);
    check_case("fmi2GetTypesPlatform_is_default", strcmp(f->api.GetTypesPlatform(), "default") == 0);
}

static void instantiate_case(const Fmu *f, const char *name, int expect_instance, LogRule rule,
                             fmi2String instance_name, fmi2Type type, fmi2String guid,
                             const fmi2CallbackFunctions *functions)
{
    begin();
    fmi2Component c = f->api.Instantiate(instance_name, type, guid, "", functions, fmi2False, fmi2True);
    result(name, expect_instance ? "instance" : "NULL", c ? "instance" : "NULL", (c != NULL) == expect_instance,
           rule, 1);
    if (c) {
        f->api.FreeInstance(c);
    }
}

static void instantiation_cases(const Fmu *f, const Fmu *other)
{
    static char long_name[10001];
    memset(long_name, 'x', sizeof long_name - 1);
    fmi2CallbackFunctions no_logger = callbacks, no_allocate = callbacks, no_free = callbacks;
    no_logger.logger = NULL;
    no_allocate.allocateMemory = NULL;
    no_free.freeMemory = NULL;

    instantiate_case(f, "instantiate_NULL_callbacks", 0, NO_INSTANCE, "i", fmi2CoSimulation, f->guid, NULL);
    instantiate_case(f, "instantiate_NULL_instanceName", 0, MUST_LOG, NULL, fmi2CoSimulation, f->guid, &callbacks);
    instantiate_case(f, "instantiate_empty_instanceName", 0, MUST_LOG, "", fmi2CoSimulation, f->guid, &callbacks);
    instantiate_case(f, "instantiate_blank_instanceName", 0, MUST_LOG, " \t ", fmi2CoSimulation, f->guid,
                     &callbacks);
    instantiate_case(f, "instantiate_wrong_GUID", 0, MUST_LOG, "i", fmi2CoSimulation,
                     "{00000000-0000-0000-0000-000000000000}", &callbacks);
    instantiate_case(f, "instantiate_GUID_of_the_other_FMU", 0, MUST_LOG, "i", fmi2CoSimulation, other->guid,
                     &callbacks);
    instantiate_case(f, "instantiate_NULL_GUID", 0, MUST_LOG, "i", fmi2CoSimulation, NULL, &callbacks);
    instantiate_case(f, "instantiate_ModelExchange", 0, MUST_LOG, "i", fmi2ModelExchange, f->guid, &callbacks);
    instantiate_case(f, "instantiate_invalid_fmuType", 0, MUST_LOG, "i", (fmi2Type)7, f->guid, &callbacks);
    instantiate_case(f, "instantiate_NULL_allocateMemory", 0, MUST_LOG, "i", fmi2CoSimulation, f->guid,
                     &no_allocate);
    instantiate_case(f, "instantiate_NULL_freeMemory", 0, MUST_LOG, "i", fmi2CoSimulation, f->guid, &no_free);

    const long blocks = live_blocks;
    allocations_left = 0;
    instantiate_case(f, "instantiate_out_of_memory", 0, MUST_LOG, "i", fmi2CoSimulation, f->guid, &callbacks);
    allocations_left = 1;
    instantiate_case(f, "instantiate_out_of_memory_at_second_block", 0, MUST_LOG, "i", fmi2CoSimulation,
                     f->guid, &callbacks);
    allocations_left = -1;
    check_case("failed_instantiations_free_what_they_allocated", live_blocks == blocks);

    /* no logger: accepted (nothing can be logged), refused calls stay silent */
    begin();
    fmi2Component c = f->api.Instantiate("quiet", fmi2CoSimulation, f->guid, "", &no_logger, fmi2False, fmi2True);
    result("instantiate_NULL_logger", "instance", c ? "instance" : "NULL", c != NULL, NO_INSTANCE, 1);
    if (c) {
        CALL("doStep_refused_without_a_logger", fmi2Error, NO_INSTANCE, f->api.DoStep(c, 0.0, STEP, fmi2True));
        f->api.FreeInstance(c);
    }

    instantiate_case(f, "instantiate_10000_character_instanceName", 1, MAY_LOG, long_name, fmi2CoSimulation,
                     f->guid, &callbacks);
    c = create(f, "%s%n%x", fmi2True);
    check_case("instantiate_percent_signs_in_instanceName", c != NULL);
    if (c) {
        CALL("refused_call_logs_for_instance_named_with_percent_signs", fmi2Error, MUST_LOG,
             f->api.DoStep(c, 0.0, STEP, fmi2True));
        f->api.FreeInstance(c);
    }
}

/* Calls without a valid instance: nothing to log to, must not crash. */
static void no_instance_cases(const Fmu *f)
{
    const fmi2ValueReference vr = VR_IN;
    double x = 1.0;
    fmi2Integer i = 0;
    fmi2Boolean b = fmi2False;
    fmi2String s = "";
    fmi2Status status;
    fmi2FMUstate state = NULL;
    size_t size = 0;
    fmi2Byte byte = 0;
    const Fmi2Api *a = &f->api;
    CALL("NULL_component_SetDebugLogging", fmi2Error, NO_INSTANCE, a->SetDebugLogging(NULL, fmi2True, 0, NULL));
    CALL("NULL_component_SetupExperiment", fmi2Error, NO_INSTANCE,
         a->SetupExperiment(NULL, fmi2False, 0.0, 0.0, fmi2False, 0.0));
    CALL("NULL_component_EnterInitializationMode", fmi2Error, NO_INSTANCE, a->EnterInitializationMode(NULL));
    CALL("NULL_component_ExitInitializationMode", fmi2Error, NO_INSTANCE, a->ExitInitializationMode(NULL));
    CALL("NULL_component_Terminate", fmi2Error, NO_INSTANCE, a->Terminate(NULL));
    CALL("NULL_component_Reset", fmi2Error, NO_INSTANCE, a->Reset(NULL));
    CALL("NULL_component_GetReal", fmi2Error, NO_INSTANCE, a->GetReal(NULL, &vr, 1, &x));
    CALL("NULL_component_SetReal", fmi2Error, NO_INSTANCE, a->SetReal(NULL, &vr, 1, &x));
    CALL("NULL_component_GetInteger", fmi2Error, NO_INSTANCE, a->GetInteger(NULL, &vr, 1, &i));
    CALL("NULL_component_SetInteger", fmi2Error, NO_INSTANCE, a->SetInteger(NULL, &vr, 1, &i));
    CALL("NULL_component_GetBoolean", fmi2Error, NO_INSTANCE, a->GetBoolean(NULL, &vr, 1, &b));
    CALL("NULL_component_SetBoolean", fmi2Error, NO_INSTANCE, a->SetBoolean(NULL, &vr, 1, &b));
    CALL("NULL_component_GetString", fmi2Error, NO_INSTANCE, a->GetString(NULL, &vr, 1, &s));
    CALL("NULL_component_SetString", fmi2Error, NO_INSTANCE, a->SetString(NULL, &vr, 1, &s));
    CALL("NULL_component_GetFMUstate", fmi2Error, NO_INSTANCE, a->GetFMUstate(NULL, &state));
    CALL("NULL_component_SetFMUstate", fmi2Error, NO_INSTANCE, a->SetFMUstate(NULL, state));
    CALL("NULL_component_FreeFMUstate", fmi2Error, NO_INSTANCE, a->FreeFMUstate(NULL, &state));
    CALL("NULL_component_SerializedFMUstateSize", fmi2Error, NO_INSTANCE,
         a->SerializedFMUstateSize(NULL, state, &size));
    CALL("NULL_component_SerializeFMUstate", fmi2Error, NO_INSTANCE, a->SerializeFMUstate(NULL, state, &byte, 1));
    CALL("NULL_component_DeSerializeFMUstate", fmi2Error, NO_INSTANCE,
         a->DeSerializeFMUstate(NULL, &byte, 1, &state));
    CALL("NULL_component_GetDirectionalDerivative", fmi2Error, NO_INSTANCE,
         a->GetDirectionalDerivative(NULL, &vr, 1, &vr, 1, &x, &x));
    CALL("NULL_component_SetRealInputDerivatives", fmi2Error, NO_INSTANCE,
         a->SetRealInputDerivatives(NULL, &vr, 1, &i, &x));
    CALL("NULL_component_GetRealOutputDerivatives", fmi2Error, NO_INSTANCE,
         a->GetRealOutputDerivatives(NULL, &vr, 1, &i, &x));
    CALL("NULL_component_DoStep", fmi2Error, NO_INSTANCE, a->DoStep(NULL, 0.0, STEP, fmi2True));
    CALL("NULL_component_CancelStep", fmi2Error, NO_INSTANCE, a->CancelStep(NULL));
    CALL("NULL_component_GetStatus", fmi2Error, NO_INSTANCE, a->GetStatus(NULL, fmi2DoStepStatus, &status));
    CALL("NULL_component_GetRealStatus", fmi2Error, NO_INSTANCE, a->GetRealStatus(NULL, fmi2LastSuccessfulTime, &x));
    CALL("NULL_component_GetIntegerStatus", fmi2Error, NO_INSTANCE, a->GetIntegerStatus(NULL, fmi2DoStepStatus, &i));
    CALL("NULL_component_GetBooleanStatus", fmi2Error, NO_INSTANCE, a->GetBooleanStatus(NULL, fmi2Terminated, &b));
    CALL("NULL_component_GetStringStatus", fmi2Error, NO_INSTANCE, a->GetStringStatus(NULL, fmi2DoStepStatus, &s));
    begin();
    a->FreeInstance(NULL);
    result("NULL_component_FreeInstance_returns", "returned", "returned", 1, NO_INSTANCE, 1);
}

/* The calling sequence out of order, with the state table's answers. */
static void wrong_state_cases(const Fmu *f)
{
    const fmi2ValueReference in = VR_IN, out = VR_OUT, a2 = VR_A2;
    double x = 0.0, nan_value = NAN;
    fmi2Boolean b = fmi2False;
    const Fmi2Api *a = &f->api;
    fmi2Component c = create(f, "states", fmi2True);
    if (!c) {
        fatal("instantiate");
    }
    /* Instantiated */
    CALL("doStep_before_initialisation", fmi2Error, MUST_LOG, a->DoStep(c, 0.0, STEP, fmi2True));
    CALL("getReal_in_Instantiated", fmi2Error, MUST_LOG, a->GetReal(c, &out, 1, &x));
    CALL("getBoolean_in_Instantiated", fmi2Error, MUST_LOG, a->GetBoolean(c, &in, 1, &b));
    CALL("terminate_in_Instantiated", fmi2Error, MUST_LOG, a->Terminate(c));
    CALL("exitInitializationMode_in_Instantiated", fmi2Error, MUST_LOG, a->ExitInitializationMode(c));
    CALL("getRealStatus_in_Instantiated", fmi2Error, MUST_LOG, a->GetRealStatus(c, fmi2LastSuccessfulTime, &x));
    CALL("cancelStep_in_Instantiated", fmi2Error, MUST_LOG, a->CancelStep(c));
    CALL("setupExperiment_stop_before_start", fmi2Error, MUST_LOG,
         a->SetupExperiment(c, fmi2False, 0.0, 1.0, fmi2True, 0.5));
    CALL("setupExperiment_NaN_start", fmi2Error, MUST_LOG,
         a->SetupExperiment(c, fmi2False, 0.0, NAN, fmi2False, 0.0));
    CALL("setupExperiment_infinite_stop", fmi2Error, MUST_LOG,
         a->SetupExperiment(c, fmi2False, 0.0, 0.0, fmi2True, INFINITY));
    CALL("setReal_NaN_parameter_in_Instantiated", fmi2Error, MUST_LOG, a->SetReal(c, &a2, 1, &nan_value));
    CALL("setupExperiment_valid", fmi2OK, MAY_LOG, a->SetupExperiment(c, fmi2True, 1e-6, 0.0, fmi2True, 10.0));
    x = f->inputs[0];
    CALL("setReal_input_in_Instantiated", fmi2OK, MAY_LOG, a->SetReal(c, &in, 1, &x));
    /* Initialization Mode */
    CALL("enterInitializationMode", fmi2OK, MAY_LOG, a->EnterInitializationMode(c));
    CALL("enterInitializationMode_twice", fmi2Error, MUST_LOG, a->EnterInitializationMode(c));
    CALL("setupExperiment_in_InitializationMode", fmi2Error, MUST_LOG,
         a->SetupExperiment(c, fmi2False, 0.0, 0.0, fmi2False, 0.0));
    CALL("doStep_in_InitializationMode", fmi2Error, MUST_LOG, a->DoStep(c, 0.0, STEP, fmi2True));
    CALL("terminate_in_InitializationMode", fmi2Error, MUST_LOG, a->Terminate(c));
    CALL("getReal_output_in_InitializationMode", fmi2OK, MAY_LOG, a->GetReal(c, &out, 1, &x));
    CALL("exitInitializationMode", fmi2OK, MAY_LOG, a->ExitInitializationMode(c));
    /* Step Complete */
    CALL("exitInitializationMode_twice", fmi2Error, MUST_LOG, a->ExitInitializationMode(c));
    CALL("enterInitializationMode_after_initialisation", fmi2Error, MUST_LOG, a->EnterInitializationMode(c));
    CALL("setupExperiment_after_initialisation", fmi2Error, MUST_LOG,
         a->SetupExperiment(c, fmi2False, 0.0, 0.0, fmi2False, 0.0));
    CALL("cancelStep_without_a_pending_step", fmi2Error, MUST_LOG, a->CancelStep(c));
    CALL("doStep", fmi2OK, MAY_LOG, a->DoStep(c, 0.0, STEP, fmi2True));
    /* Terminated */
    CALL("terminate", fmi2OK, MAY_LOG, a->Terminate(c));
    CALL("terminate_twice", fmi2Error, MUST_LOG, a->Terminate(c));
    CALL("doStep_after_terminate", fmi2Error, MUST_LOG, a->DoStep(c, STEP, STEP, fmi2True));
    x = f->inputs[1];
    CALL("setReal_input_after_terminate", fmi2Error, MUST_LOG, a->SetReal(c, &in, 1, &x));
    CALL("getReal_after_terminate", fmi2OK, MAY_LOG, a->GetReal(c, &out, 1, &x));
    CALL("exitInitializationMode_after_terminate", fmi2Error, MUST_LOG, a->ExitInitializationMode(c));
    CALL("reset_after_terminate", fmi2OK, MAY_LOG, a->Reset(c));
    CALL("doStep_after_reset", fmi2Error, MUST_LOG, a->DoStep(c, 0.0, STEP, fmi2True));
    CALL("enterInitializationMode_after_reset", fmi2OK, MAY_LOG, a->EnterInitializationMode(c));
    a->FreeInstance(c);
}

/* Refused calls on an instance in Step Complete; a reference instance gets
 * only the valid calls, and both must go on to the same outputs. */
static void step_complete_cases(const Fmu *f)
{
    const Fmi2Api *a = &f->api;
    const int half = N_SAMPLES / 2;
    double y_victim[N_SAMPLES], y_reference[N_SAMPLES];
    double t = 0.0, t_reference = 0.0, x = 0.0, pair[2];
    fmi2Component c = ready(f, "victim", fmi2True);
    fmi2Component r = ready(f, "reference", fmi2False);
    if (run(f, c, &t, 0, half, 0, y_victim) > fmi2Warning || run(f, r, &t_reference, 0, half, 0, y_reference) >
        fmi2Warning) {
        fatal("run the first half");
    }
    const double held = f->inputs[half - 1];
    const fmi2ValueReference in = VR_IN, out = VR_OUT, a2 = VR_A2, unknown = f->n_reals,
                             huge_vr = 0xffffffffu, boolean_vr = f->n_reals + f->n_booleans + 7;
    const fmi2ValueReference two_inputs[2] = { VR_IN, VR_IN };
    const double non_finite[3] = { NAN, INFINITY, -INFINITY };
    const char *const non_finite_names[3] = { "setReal_NaN_input", "setReal_+inf_input", "setReal_-inf_input" };
    for (int i = 0; i < 3; i++) {
        CALL(non_finite_names[i], fmi2Error, MUST_LOG, a->SetReal(c, &in, 1, &non_finite[i]));
    }
    pair[0] = f->inputs[3];
    pair[1] = NAN;
    CALL("setReal_second_value_NaN", fmi2Error, MUST_LOG, a->SetReal(c, two_inputs, 2, pair));
    value_case("refused_setReal_changed_no_value", held, get_real(f, c, VR_IN));
    x = 1.0;
    CALL("setReal_on_an_output", fmi2Error, MUST_LOG, a->SetReal(c, &out, 1, &x));
    CALL("setReal_parameter_after_initialisation", fmi2Error, MUST_LOG, a->SetReal(c, &a2, 1, &x));
    fmi2Boolean yes = fmi2True;
    const fmi2ValueReference first_boolean = f->n_reals;
    if (f->n_booleans) {
        CALL("setBoolean_parameter_after_initialisation", fmi2Error, MUST_LOG,
             a->SetBoolean(c, &first_boolean, 1, &yes));
    } else {
        CALL("setBoolean_without_Boolean_variables", fmi2Error, MUST_LOG, a->SetBoolean(c, &first_boolean, 1, &yes));
    }
    /* unknown value references */
    CALL("getReal_unknown_vr", fmi2Error, MUST_LOG, a->GetReal(c, &unknown, 1, &x));
    CALL("getReal_vr_0xffffffff", fmi2Error, MUST_LOG, a->GetReal(c, &huge_vr, 1, &x));
    CALL("setReal_unknown_vr", fmi2Error, MUST_LOG, a->SetReal(c, &unknown, 1, &x));
    CALL("setReal_vr_0xffffffff", fmi2Error, MUST_LOG, a->SetReal(c, &huge_vr, 1, &x));
    fmi2Boolean b = fmi2False;
    fmi2Integer i = 0;
    fmi2String s = "text";
    CALL("getBoolean_unknown_vr", fmi2Error, MUST_LOG, a->GetBoolean(c, &boolean_vr, 1, &b));
    CALL("setBoolean_unknown_vr", fmi2Error, MUST_LOG, a->SetBoolean(c, &boolean_vr, 1, &b));
    CALL("getInteger_no_Integer_variables", fmi2Error, MUST_LOG, a->GetInteger(c, &in, 1, &i));
    CALL("setInteger_no_Integer_variables", fmi2Error, MUST_LOG, a->SetInteger(c, &in, 1, &i));
    CALL("getString_no_String_variables", fmi2Error, MUST_LOG, a->GetString(c, &in, 1, &s));
    CALL("setString_no_String_variables", fmi2Error, MUST_LOG, a->SetString(c, &in, 1, &s));
    /* NULL arrays with a non-zero count; with a zero count there is nothing to do */
    CALL("getReal_NULL_vr", fmi2Error, MUST_LOG, a->GetReal(c, NULL, 1, &x));
    CALL("getReal_NULL_values", fmi2Error, MUST_LOG, a->GetReal(c, &in, 1, NULL));
    CALL("setReal_NULL_vr", fmi2Error, MUST_LOG, a->SetReal(c, NULL, 1, &x));
    CALL("setReal_NULL_values", fmi2Error, MUST_LOG, a->SetReal(c, &in, 1, NULL));
    CALL("getInteger_NULL_vr", fmi2Error, MUST_LOG, a->GetInteger(c, NULL, 1, &i));
    CALL("getInteger_NULL_values", fmi2Error, MUST_LOG, a->GetInteger(c, &in, 1, NULL));
    CALL("setInteger_NULL_vr", fmi2Error, MUST_LOG, a->SetInteger(c, NULL, 1, &i));
    CALL("setInteger_NULL_values", fmi2Error, MUST_LOG, a->SetInteger(c, &in, 1, NULL));
    CALL("getBoolean_NULL_vr", fmi2Error, MUST_LOG, a->GetBoolean(c, NULL, 1, &b));
    CALL("getBoolean_NULL_values", fmi2Error, MUST_LOG, a->GetBoolean(c, &in, 1, NULL));
    CALL("setBoolean_NULL_vr", fmi2Error, MUST_LOG, a->SetBoolean(c, NULL, 1, &b));
    CALL("setBoolean_NULL_values", fmi2Error, MUST_LOG, a->SetBoolean(c, &in, 1, NULL));
    CALL("getString_NULL_vr", fmi2Error, MUST_LOG, a->GetString(c, NULL, 1, &s));
    CALL("getString_NULL_values", fmi2Error, MUST_LOG, a->GetString(c, &in, 1, NULL));
    CALL("setString_NULL_vr", fmi2Error, MUST_LOG, a->SetString(c, NULL, 1, &s));
    CALL("setString_NULL_values", fmi2Error, MUST_LOG, a->SetString(c, &in, 1, NULL));
    CALL("getReal_NULL_arrays_count_0", fmi2OK, MAY_LOG, a->GetReal(c, NULL, 0, NULL));
    CALL("setReal_NULL_arrays_count_0", fmi2OK, MAY_LOG, a->SetReal(c, NULL, 0, NULL));
    CALL("getInteger_NULL_arrays_count_0", fmi2OK, MAY_LOG, a->GetInteger(c, NULL, 0, NULL));
    CALL("setInteger_NULL_arrays_count_0", fmi2OK, MAY_LOG, a->SetInteger(c, NULL, 0, NULL));
    CALL("getBoolean_NULL_arrays_count_0", fmi2OK, MAY_LOG, a->GetBoolean(c, NULL, 0, NULL));
    CALL("setBoolean_NULL_arrays_count_0", fmi2OK, MAY_LOG, a->SetBoolean(c, NULL, 0, NULL));
    CALL("getString_NULL_arrays_count_0", fmi2OK, MAY_LOG, a->GetString(c, NULL, 0, NULL));
    CALL("setString_NULL_arrays_count_0", fmi2OK, MAY_LOG, a->SetString(c, NULL, 0, NULL));
    /* step sizes and communication points */
    const double bad_steps[5] = { 0.0, -STEP, NAN, INFINITY, -INFINITY };
    const char *const bad_step_names[5] = { "doStep_zero_step", "doStep_negative_step", "doStep_NaN_step",
                                           "doStep_+inf_step", "doStep_-inf_step" };
    for (int k = 0; k < 5; k++) {
        CALL(bad_step_names[k], fmi2Error, MUST_LOG, a->DoStep(c, t, bad_steps[k], fmi2True));
    }
    const double bad_points[6] = { t + 1.0, t - STEP, t + 1e-6, NAN, INFINITY, -INFINITY };
    const char *const bad_point_names[6] = { "doStep_communication_point_ahead", "doStep_communication_point_behind",
                                            "doStep_communication_point_off_by_1e-6_s",
                                            "doStep_NaN_communication_point", "doStep_+inf_communication_point",
                                            "doStep_-inf_communication_point" };
    for (int k = 0; k < 6; k++) {
        CALL(bad_point_names[k], fmi2Error, MUST_LOG, a->DoStep(c, bad_points[k], STEP, fmi2True));
    }
    /* logging categories */
    const fmi2String unknown_category[1] = { "logNoSuchThing" };
    const fmi2String null_category[1] = { NULL };
    const fmi2String events[1] = { "logEvents" };
    CALL("setDebugLogging_unknown_category", fmi2Error, MUST_LOG, a->SetDebugLogging(c, fmi2True, 1, unknown_category));
    CALL("setDebugLogging_NULL_category", fmi2Error, MUST_LOG, a->SetDebugLogging(c, fmi2True, 1, null_category));
    CALL("setDebugLogging_NULL_categories_count_1", fmi2Error, MUST_LOG, a->SetDebugLogging(c, fmi2True, 1, NULL));
    CALL("setDebugLogging_logEvents", fmi2OK, MAY_LOG, a->SetDebugLogging(c, fmi2True, 1, events));
    CALL("setDebugLogging_all", fmi2OK, MAY_LOG, a->SetDebugLogging(c, fmi2True, 0, NULL));
    /* capabilities the FMU does not have */
    CALL("getDirectionalDerivative_not_provided", fmi2Error, MUST_LOG,
         a->GetDirectionalDerivative(c, &out, 1, &in, 1, &x, &x));
    CALL("setRealInputDerivatives_not_provided", fmi2Error, MUST_LOG, a->SetRealInputDerivatives(c, &in, 1, &i, &x));
    CALL("getRealOutputDerivatives_not_provided", fmi2Error, MUST_LOG,
         a->GetRealOutputDerivatives(c, &out, 1, &i, &x));
    /* status queries: doStep is synchronous, so most have nothing to say */
    fmi2Status status = fmi2OK;
    CALL("getStatus_doStepStatus", fmi2Discard, MUST_LOG, a->GetStatus(c, fmi2DoStepStatus, &status));
    CALL("getStatus_NULL_value", fmi2Error, MUST_LOG, a->GetStatus(c, fmi2DoStepStatus, NULL));
    CALL("getIntegerStatus", fmi2Discard, MUST_LOG, a->GetIntegerStatus(c, fmi2DoStepStatus, &i));
    CALL("getStringStatus", fmi2Discard, MUST_LOG, a->GetStringStatus(c, fmi2PendingStatus, &s));
    CALL("getRealStatus_lastSuccessfulTime", fmi2OK, MAY_LOG, a->GetRealStatus(c, fmi2LastSuccessfulTime, &x));
    value_case("lastSuccessfulTime_is_the_FMU_time", t, x);
    CALL("getBooleanStatus_terminated", fmi2OK, MAY_LOG, a->GetBooleanStatus(c, fmi2Terminated, &b));
    check_case("getBooleanStatus_terminated_is_false", b == fmi2False);
    CALL("getFMUstate_NULL_pointer", fmi2Error, MUST_LOG, a->GetFMUstate(c, NULL));

    if (run(f, c, &t, half, N_SAMPLES, 0, y_victim + half) > fmi2Warning ||
        run(f, r, &t_reference, half, N_SAMPLES, 0, y_reference + half) > fmi2Warning) {
        fatal("run the second half");
    }
    check_case("refused_calls_left_the_instance_unchanged", same_bits(y_victim, y_reference, N_SAMPLES));
    a->FreeInstance(c);
    a->FreeInstance(r);
}

/* A time at which t + h overflows: the step cannot end at a finite time. */
static void time_overflow_cases(const Fmu *f)
{
    fmi2Component c = create(f, "late", fmi2True);
    const double start = 1.5e308;
    if (!c || f->api.SetupExperiment(c, fmi2False, 0.0, start, fmi2False, 0.0) != fmi2OK ||
        f->api.EnterInitializationMode(c) != fmi2OK || f->api.ExitInitializationMode(c) != fmi2OK) {
        fatal("initialise at a late start time");
    }
    CALL("doStep_ending_at_an_infinite_time", fmi2Error, MUST_LOG, f->api.DoStep(c, start, start, fmi2True));
    double t = 0.0;
    f->api.GetRealStatus(c, fmi2LastSuccessfulTime, &t);
    value_case("time_unchanged_after_refused_step", start, t);
    CALL("doStep_after_refused_overflow", fmi2OK, MAY_LOG, f->api.DoStep(c, start, 1.0, fmi2True));
    f->api.FreeInstance(c);
}

/* Voltages outside [voltage_min, voltage_max]: the plant clamps the input,
 * the inverse saturates its output; both return fmi2Warning and log why. */
static void range_cases(const Fmu *f, const Fmu *plant)
{
    const Fmi2Api *a = &f->api;
    const fmi2ValueReference in = VR_IN, out = VR_OUT;
    double y = 0.0, y_edge = 0.0, x;
    if (f == plant) {
        const double beyond[4] = { f->v_max + 10.0, f->v_min - 10.0, 1e308, -1e308 };
        const char *const names[4] = { "voltage_above_range", "voltage_below_range", "voltage_1e308",
                                       "voltage_-1e308" };
        for (int k = 0; k < 4; k++) {
            const double edge = beyond[k] > f->v_max ? f->v_max : f->v_min;
            char name[96];
            fmi2Component c = ready(f, "clamped", fmi2True), e = ready(f, "edge", fmi2False);
            sprintf(name, "setReal_%s_clamped_with_warning", names[k]);
            CALL(name, fmi2Warning, MUST_LOG, a->SetReal(c, &in, 1, &beyond[k]));
            sprintf(name, "%s_stored_as_range_end", names[k]);
            value_case(name, edge, get_real(f, c, VR_IN));
            a->SetReal(e, &in, 1, &edge);
            a->GetReal(c, &out, 1, &y);
            a->GetReal(e, &out, 1, &y_edge);
            sprintf(name, "%s_displacement_as_at_range_end", names[k]);
            value_case(name, y_edge, y);
            sprintf(name, "%s_doStep_after_clamp", names[k]);
            CALL(name, fmi2OK, MAY_LOG, a->DoStep(c, 0.0, STEP, fmi2True));
            a->FreeInstance(c);
            a->FreeInstance(e);
        }
        return;
    }
    /* inverse: any finite reference is accepted; an unreachable one saturates */
    const double beyond[4] = { 1e6, -1e6, 1e308, -1e308 };
    const char *const names[4] = { "reference_1e6_um", "reference_-1e6_um", "reference_1e308_um",
                                   "reference_-1e308_um" };
    for (int k = 0; k < 4; k++) {
        char name[96];
        const double edge = beyond[k] > 0 ? f->v_max : f->v_min;
        fmi2Component c = ready(f, "saturated", fmi2True);
        sprintf(name, "setReal_%s_accepted", names[k]);
        CALL(name, fmi2OK, MAY_LOG, a->SetReal(c, &in, 1, &beyond[k]));
        sprintf(name, "getReal_%s_saturated_with_warning", names[k]);
        CALL(name, fmi2Warning, MUST_LOG, a->GetReal(c, &out, 1, &y));
        sprintf(name, "%s_voltage_at_range_end", names[k]);
        value_case(name, edge, y);
        x = beyond[k];
        a->SetReal(c, &in, 1, &x);
        sprintf(name, "doStep_%s_without_getReal_warns", names[k]);
        CALL(name, fmi2Warning, MUST_LOG, a->DoStep(c, 0.0, STEP, fmi2True));
        x = f->inputs[5];
        a->SetReal(c, &in, 1, &x);
        sprintf(name, "getReal_reachable_after_%s", names[k]);
        CALL(name, fmi2OK, MAY_LOG, a->GetReal(c, &out, 1, &y));
        a->FreeInstance(c);
    }
}

/* Parameters that cannot work: refused at fmi2ExitInitializationMode. */
static void parameter_cases(const Fmu *f, int is_inverse)
{
    const Fmi2Api *a = &f->api;
    const fmi2ValueReference r1 = VR_R1, vmin = VR_VMIN, a1 = VR_A1;
    double x;
    struct {
        const char *name;
        fmi2ValueReference vr;
        double value;
    } bad[3] = {
        { "exitInitializationMode_negative_threshold", r1, -1.0 },
        { "exitInitializationMode_voltage_min_above_max", vmin, f->v_max + 1.0 },
        { "exitInitializationMode_not_invertible", a1, -1.0 },
    };
    const int n_bad = is_inverse ? 3 : 2;
    for (int k = 0; k < n_bad; k++) {
        char name[128];
        fmi2Component c = create(f, "parameters", fmi2True);
        if (!c || a->EnterInitializationMode(c) != fmi2OK) {
            fatal("enter initialisation mode");
        }
        x = bad[k].value;
        a->SetReal(c, &bad[k].vr, 1, &x);
        CALL(bad[k].name, fmi2Error, MUST_LOG, a->ExitInitializationMode(c));
        if (k == 2) {
            /* with a1 < 0 the slope a2 + b + 3 a1 u^2 is smallest at the top
             * of the range: the message must name that voltage */
            char where[64];
            sprintf(where, " at %g V", f->v_max);
            check_case("not_invertible_message_names_the_voltage",
                       strstr(logbook.since, "not invertible") != NULL && strstr(logbook.since, where) != NULL);
        }
        const char *what = bad[k].name + strlen("exitInitializationMode_");
        sprintf(name, "doStep_in_Error_state_after_%s", what);
        CALL(name, fmi2Error, MUST_LOG, a->DoStep(c, 0.0, STEP, fmi2True));
        sprintf(name, "getReal_in_Error_state_after_%s", what);
        CALL(name, fmi2OK, MAY_LOG, a->GetReal(c, &bad[k].vr, 1, &x));
        sprintf(name, "reset_from_Error_state_after_%s", what);
        CALL(name, fmi2OK, MAY_LOG, a->Reset(c));
        if (a->EnterInitializationMode(c) != fmi2OK) {
            fatal("enter initialisation mode after reset");
        }
        sprintf(name, "start_values_accepted_after_reset_from_%s", what);
        CALL(name, fmi2OK, MAY_LOG, a->ExitInitializationMode(c));
        a->FreeInstance(c);
    }
}

/* FMU states: NULL and foreign pointers, truncated, corrupted and
 * well-sealed but invalid serialized states, allocation failures. */
static void state_cases(const Fmu *f, const Fmu *other)
{
    const Fmi2Api *a = &f->api;
    double y[N_SAMPLES], t = 0.0, t_other = 0.0, y_other[N_SAMPLES];
    fmi2Component c = ready(f, "states", fmi2True);
    fmi2Component o = ready(other, "foreign", fmi2True);
    run(f, c, &t, 0, 20, 0, y);
    run(other, o, &t_other, 0, 20, 0, y_other);
    size_t size = 0, other_size = 0;
    unsigned char *blob = serialized(f, c, &size);
    unsigned char *foreign = serialized(other, o, &other_size);
    unsigned char *work = (unsigned char *)malloc(2 * size + 16);
    unsigned char garbage[256];
    memset(garbage, 0x5a, sizeof garbage);
    fmi2FMUstate state = NULL, saved = NULL, other_state = NULL;
    size_t n = 0;
    fmi2Byte small[8];

    CALL("getFMUstate", fmi2OK, MAY_LOG, a->GetFMUstate(c, &saved));
    CALL("setFMUstate_NULL", fmi2Error, MUST_LOG, a->SetFMUstate(c, NULL));
    CALL("setFMUstate_pointer_to_garbage", fmi2Error, MUST_LOG, a->SetFMUstate(c, garbage));
    CALL("freeFMUstate_NULL_pointer", fmi2Error, MUST_LOG, a->FreeFMUstate(c, NULL));
    state = NULL;
    CALL("freeFMUstate_NULL_state", fmi2OK, MAY_LOG, a->FreeFMUstate(c, &state));
    state = garbage;
    CALL("freeFMUstate_pointer_to_garbage", fmi2Error, MUST_LOG, a->FreeFMUstate(c, &state));
    CALL("getFMUstate_into_pointer_to_garbage", fmi2Error, MUST_LOG, a->GetFMUstate(c, &state));
    CALL("serializedFMUstateSize_NULL_size", fmi2Error, MUST_LOG, a->SerializedFMUstateSize(c, saved, NULL));
    CALL("serializedFMUstateSize_NULL_state", fmi2Error, MUST_LOG, a->SerializedFMUstateSize(c, NULL, &n));
    CALL("serializeFMUstate_NULL_buffer", fmi2Error, MUST_LOG, a->SerializeFMUstate(c, saved, NULL, size));
    CALL("serializeFMUstate_buffer_too_small", fmi2Error, MUST_LOG,
         a->SerializeFMUstate(c, saved, small, sizeof small));
    CALL("serializeFMUstate_size_one_short", fmi2Error, MUST_LOG,
         a->SerializeFMUstate(c, saved, (fmi2Byte *)work, size - 1));
    CALL("serializeFMUstate_pointer_to_garbage", fmi2Error, MUST_LOG,
         a->SerializeFMUstate(c, garbage, (fmi2Byte *)work, size));
    CALL("deSerializeFMUstate_NULL_buffer", fmi2Error, MUST_LOG, a->DeSerializeFMUstate(c, NULL, size, &state));
    CALL("deSerializeFMUstate_NULL_result", fmi2Error, MUST_LOG,
         a->DeSerializeFMUstate(c, (const fmi2Byte *)blob, size, NULL));
    state = garbage;
    CALL("deSerializeFMUstate_into_pointer_to_garbage", fmi2Error, MUST_LOG,
         a->DeSerializeFMUstate(c, (const fmi2Byte *)blob, size, &state));

    /* a state of the other FMU (a snapshot handle of the same layer, of another model) */
    CALL("other_FMU_getFMUstate", fmi2OK, MAY_LOG, other->api.GetFMUstate(o, &other_state));
    CALL("setFMUstate_of_the_other_FMU", fmi2Error, MUST_LOG, a->SetFMUstate(c, other_state));
    CALL("serializedFMUstateSize_of_the_other_FMU", fmi2Error, MUST_LOG,
         a->SerializedFMUstateSize(c, other_state, &n));
    CALL("serializeFMUstate_of_the_other_FMU", fmi2Error, MUST_LOG,
         a->SerializeFMUstate(c, other_state, (fmi2Byte *)work, 2 * size + 16));
    CALL("freeFMUstate_of_the_other_FMU", fmi2Error, MUST_LOG, a->FreeFMUstate(c, &other_state));
    CALL("other_FMU_frees_its_own_state", fmi2OK, MAY_LOG, other->api.FreeFMUstate(o, &other_state));
    deserialize_case(f, c, "deSerializeFMUstate_blob_of_the_other_FMU", foreign, other_size, fmi2Error);

    /* truncated and extended */
    memcpy(work, blob, size);
    memset(work + size, 0, size + 16);
    const size_t lengths[7] = { 0, 1, 39, 40, size / 2, size - 8, size - 1 };
    for (int k = 0; k < 7; k++) {
        char name[64];
        sprintf(name, "deSerializeFMUstate_truncated_to_%lu_bytes", (unsigned long)lengths[k]);
        deserialize_case(f, c, name, work, lengths[k], fmi2Error);
    }
    deserialize_case(f, c, "deSerializeFMUstate_one_byte_extra", work, size + 1, fmi2Error);
    deserialize_case(f, c, "deSerializeFMUstate_twice_the_size", work, 2 * size, fmi2Error);
    memset(work, 0, size);
    deserialize_case(f, c, "deSerializeFMUstate_all_zero", work, size, fmi2Error);
    memset(work, 0xff, size);
    deserialize_case(f, c, "deSerializeFMUstate_all_ones", work, size, fmi2Error);
    /* one corrupted byte in each field (the checksum is not fixed up) */
    const size_t n_reals = f->n_reals, n_booleans = f->n_booleans;
    const size_t off_booleans = OFF_REALS + 8 * n_reals;
    const size_t off_memory = off_booleans + 4 * n_booleans;
    const struct { const char *field; size_t offset; } fields[] = {
        { "magic", 0 }, { "version", OFF_VERSION }, { "size", OFF_SIZE }, { "model_hash", OFF_HASH },
        { "n_reals", OFF_N_REALS }, { "n_booleans", OFF_N_BOOLEANS }, { "n_memory", OFF_N_MEMORY },
        { "machine_state", OFF_STATE }, { "time", OFF_TIME + 7 }, { "flags", OFF_FLAGS },
        { "input", OFF_REALS + 3 }, { "a2", OFF_REALS + 8 * VR_A2 + 6 }, { "memory", off_memory + 2 },
        { "checksum", size - 1 },
    };
    for (size_t k = 0; k < sizeof fields / sizeof fields[0]; k++) {
        char name[80];
        memcpy(work, blob, size);
        work[fields[k].offset] ^= 0x10;
        sprintf(name, "deSerializeFMUstate_corrupted_%s", fields[k].field);
        deserialize_case(f, c, name, work, size, fmi2Error);
    }
    /* well sealed (valid checksum) but wrong contents */
    struct { const char *what; size_t offset; int is_double; uint32_t u; double d; } sealed[] = {
        { "unknown_version", OFF_VERSION, 0, 2u, 0.0 },
        { "wrong_size_field", OFF_SIZE, 0, 0u, 0.0 },
        { "wrong_model_hash", OFF_HASH, 0, 12345u, 0.0 },
        { "wrong_n_reals", OFF_N_REALS, 0, 1u, 0.0 },
        { "no_machine_state", OFF_STATE, 0, 0u, 0.0 },
        { "two_machine_states", OFF_STATE, 0, ST_INSTANTIATED | ST_STEP_COMPLETE, 0.0 },
        { "machine_state_StepInProgress", OFF_STATE, 0, ST_STEP_IN_PROGRESS, 0.0 },
        { "machine_state_Fatal", OFF_STATE, 0, ST_FATAL, 0.0 },
        { "NaN_time", OFF_TIME, 1, 0u, NAN },
        { "infinite_start_time", OFF_START, 1, 0u, INFINITY },
        { "stop_time_flag_2", OFF_FLAGS, 0, 2u, 0.0 },
        { "reserved_flag_set", OFF_FLAGS + 4, 0, 1u, 0.0 },
        { "NaN_input", OFF_REALS, 1, 0u, NAN },
        { "infinite_a2", OFF_REALS + 8 * VR_A2, 1, 0u, INFINITY },
        { "NaN_memory", 0, 1, 0u, NAN },
        { "Boolean_2", 0, 0, 2u, 0.0 },
    };
    sealed[14].offset = off_memory;
    sealed[15].offset = off_booleans;
    const size_t n_sealed = sizeof sealed / sizeof sealed[0] - (n_booleans ? 0 : 1);
    for (size_t k = 0; k < n_sealed; k++) {
        char name[80];
        memcpy(work, blob, size);
        if (sealed[k].is_double) {
            put_f64(work, sealed[k].offset, sealed[k].d);
        } else {
            put_u32(work, sealed[k].offset, sealed[k].u);
        }
        reseal(work, size);
        sprintf(name, "deSerializeFMUstate_sealed_%s", sealed[k].what);
        deserialize_case(f, c, name, work, size, fmi2Error);
    }

    /* well formed, but parameters that fail at fmi2SetFMUstate: Error state */
    memcpy(work, blob, size);
    put_f64(work, OFF_REALS + 8 * VR_R1, -1.0);
    reseal(work, size);
    state = NULL;
    CALL("deSerializeFMUstate_negative_threshold_is_well_formed", fmi2OK, MAY_LOG,
         a->DeSerializeFMUstate(c, (const fmi2Byte *)work, size, &state));
    CALL("setFMUstate_negative_threshold", fmi2Error, MUST_LOG, a->SetFMUstate(c, state));
    CALL("doStep_after_setFMUstate_failed", fmi2Error, MUST_LOG, a->DoStep(c, t, STEP, fmi2True));
    fmi2FMUstate reused = state;
    CALL("deSerializeFMUstate_into_an_existing_state", fmi2OK, MAY_LOG,
         a->DeSerializeFMUstate(c, (const fmi2Byte *)blob, size, &state));
    check_case("deSerializeFMUstate_reuses_the_existing_state", state == reused);
    CALL("setFMUstate_recovers_from_Error_state", fmi2OK, MAY_LOG, a->SetFMUstate(c, state));
    double y_after[N_SAMPLES - 20], y_saved[N_SAMPLES - 20], t_saved = t;
    run(f, c, &t, 20, N_SAMPLES, 0, y_after);
    CALL("setFMUstate_saved", fmi2OK, MAY_LOG, a->SetFMUstate(c, saved));
    run(f, c, &t_saved, 20, N_SAMPLES, 0, y_saved);
    check_case("restored_states_continue_identically", same_bits(y_after, y_saved, N_SAMPLES - 20));
    CALL("freeFMUstate", fmi2OK, MAY_LOG, a->FreeFMUstate(c, &state));
    check_case("freeFMUstate_sets_the_pointer_to_NULL", state == NULL);

    /* out of memory while taking a state */
    allocations_left = 0;
    state = NULL;
    CALL("getFMUstate_out_of_memory", fmi2Error, MUST_LOG, a->GetFMUstate(c, &state));
    CALL("deSerializeFMUstate_out_of_memory", fmi2Error, MUST_LOG,
         a->DeSerializeFMUstate(c, (const fmi2Byte *)blob, size, &state));
    allocations_left = -1;
    check_case("no_state_handed_out_without_memory", state == NULL);
    CALL("getFMUstate_in_Terminated", fmi2OK, MAY_LOG,
         (a->Terminate(c), a->GetFMUstate(c, &saved)));    /* overwrites the saved state in place */
    a->FreeFMUstate(c, &saved);
    a->FreeInstance(c);
    other->api.FreeInstance(o);
    free(work);
    free(blob);
    free(foreign);
}

/* A component of the other FMU passed to this FMU's functions. */
static void foreign_instance_cases(const Fmu *f, const Fmu *other)
{
    fmi2Component o = ready(other, "other", fmi2True);
    double x = f->inputs[2], t = 0.0;
    const fmi2ValueReference in = VR_IN, out = VR_OUT;
    CALL("setReal_on_an_instance_of_the_other_FMU", fmi2Error, NO_INSTANCE, f->api.SetReal(o, &in, 1, &x));
    CALL("getReal_on_an_instance_of_the_other_FMU", fmi2Error, NO_INSTANCE, f->api.GetReal(o, &out, 1, &x));
    CALL("doStep_on_an_instance_of_the_other_FMU", fmi2Error, NO_INSTANCE, f->api.DoStep(o, t, STEP, fmi2True));
    CALL("reset_on_an_instance_of_the_other_FMU", fmi2Error, NO_INSTANCE, f->api.Reset(o));
    begin();
    f->api.FreeInstance(o);           /* must leave it alone */
    result("freeInstance_on_an_instance_of_the_other_FMU_is_ignored", "returned", "returned", 1, NO_INSTANCE, 1);
    CALL("the_other_FMU_still_steps_its_instance", fmi2OK, MAY_LOG, other->api.DoStep(o, t, STEP, fmi2True));
    other->api.FreeInstance(o);
}

/* N_MANY instances alive at once, interleaved; each must give the outputs
 * it gives alone. */
static void many_instances_cases(const Fmu *f)
{
    enum { STEPS = 8 };
    fmi2Component *c = (fmi2Component *)malloc(N_MANY * sizeof *c);
    double (*y)[STEPS] = malloc(N_MANY * sizeof *y);
    double t[N_MANY];
    int created = 0, stepped = 1, alone = 1;
    if (!c || !y) {
        fatal("allocate the instance table");
    }
    for (int i = 0; i < N_MANY; i++) {
        char name[32];
        sprintf(name, "many-%d", i);
        c[i] = create(f, name, fmi2False);
        if (c[i] && f->api.SetupExperiment(c[i], fmi2False, 0.0, 0.0, fmi2False, 0.0) == fmi2OK &&
            f->api.EnterInitializationMode(c[i]) == fmi2OK && f->api.ExitInitializationMode(c[i]) == fmi2OK) {
            created++;
        }
        t[i] = 0.0;
    }
    char name[64];
    sprintf(name, "%d_instances_alive_at_once", N_MANY);
    value_case(name, N_MANY, created);
    if (created != N_MANY) {
        fatal("instantiate many");
    }
    for (int k = 0; k < STEPS; k++) {
        for (int i = 0; i < N_MANY; i++) {
            stepped &= step(f, c[i], &t[i], f->inputs[(k + i) % N_SAMPLES], &y[i][k]) == fmi2OK;
        }
    }
    for (int i = 0; i < N_MANY; i++) {
        f->api.FreeInstance(c[i]);
    }
    for (int i = 0; i < N_MANY; i += 1) {
        double y_alone[STEPS], t_alone = 0.0;
        fmi2Component single = ready(f, "alone", fmi2False);
        run(f, single, &t_alone, 0, STEPS, i, y_alone);
        alone &= same_bits(y_alone, y[i], STEPS);
        f->api.FreeInstance(single);
    }
    sprintf(name, "%d_instances_step_interleaved", N_MANY);
    check_case(name, stepped);
    sprintf(name, "%d_instances_each_as_if_alone", N_MANY);
    check_case(name, alone);
    free(c);
    free(y);
}

/* Reads the voltage range and makes the standard input sequence: voltages
 * inside the range for the plant, their plant outputs for the inverse. */
static void prepare_inputs(Fmu *plant, Fmu *inverse)
{
    static const double extrema[] = { 0.05, 0.95, 0.30, 0.80, 0.10, 0.60, 0.45 };
    const int n_segments = (int)(sizeof extrema / sizeof extrema[0]) - 1;
    fmi2Component c = create(plant, "range", fmi2False);
    if (!c || plant->api.EnterInitializationMode(c) != fmi2OK) {
        fatal("read the voltage range");
    }
    plant->v_min = inverse->v_min = get_real(plant, c, VR_VMIN);
    plant->v_max = inverse->v_max = get_real(plant, c, VR_VMAX);
    plant->api.FreeInstance(c);
    for (int k = 0; k < N_SAMPLES; k++) {
        const double position = (double)k * n_segments / N_SAMPLES;
        const int segment = (int)position;
        const double s = extrema[segment] + (extrema[segment + 1] - extrema[segment]) * (position - segment);
        plant->inputs[k] = plant->v_min + (plant->v_max - plant->v_min) * s;
    }
    double t = 0.0;
    c = ready(plant, "inputs", fmi2False);
    if (run(plant, c, &t, 0, N_SAMPLES, 0, inverse->inputs) != fmi2OK) {
        fatal("make the inverse's inputs");
    }
    plant->api.FreeInstance(c);
}

/* ======================================================== memory cycles */
static int cycles(Fmu *fmus, long n_cycles)
{
    enum { FIRST = 16, LATER = 8 };
    double reference[2][3][FIRST + LATER];
    int identical = 1;
    long failures = 0;
    for (long cycle = 0; cycle < n_cycles; cycle++) {
        for (int m = 0; m < 2; m++) {
            const Fmu *f = &fmus[m];
            const Fmi2Api *a = &f->api;
            double y[FIRST + LATER], t = 0.0, t_state;
            const fmi2ValueReference a2 = VR_A2;
            double a2_value = 0.0;
            fmi2Component c = create(f, "cycle", fmi2False);
            fmi2FMUstate state = NULL, restored = NULL;
            size_t size = 0;
            fmi2Status s = c ? fmi2OK : fmi2Error;
            if (!c) {
                failures++;
                continue;
            }
            s = worst(s, a->SetupExperiment(c, fmi2False, 0.0, 0.0, fmi2False, 0.0));
            s = worst(s, a->EnterInitializationMode(c));
            s = worst(s, a->GetReal(c, &a2, 1, &a2_value));
            s = worst(s, a->SetReal(c, &a2, 1, &a2_value));
            s = worst(s, a->ExitInitializationMode(c));
            s = worst(s, run(f, c, &t, 0, FIRST, (int)(cycle % 3), y));
            s = worst(s, a->GetFMUstate(c, &state));
            s = worst(s, a->SerializedFMUstateSize(c, state, &size));
            fmi2Byte *blob = (fmi2Byte *)malloc(size);
            s = worst(s, blob ? a->SerializeFMUstate(c, state, blob, size) : fmi2Error);
            s = worst(s, blob ? a->DeSerializeFMUstate(c, blob, size, &restored) : fmi2Error);
            free(blob);
            t_state = t;
            s = worst(s, run(f, c, &t, FIRST, FIRST + LATER, (int)(cycle % 3), y + FIRST));
            s = worst(s, a->SetFMUstate(c, restored));
            double again[LATER];
            s = worst(s, run(f, c, &t_state, FIRST, FIRST + LATER, (int)(cycle % 3), again));
            identical &= same_bits(again, y + FIRST, LATER);
            if (a->DoStep(c, t_state, 0.0, fmi2True) != fmi2Error) {   /* a refused call: logged */
                failures++;
            }
            s = worst(s, a->FreeFMUstate(c, &state));
            s = worst(s, a->FreeFMUstate(c, &restored));
            s = worst(s, a->Terminate(c));
            s = worst(s, a->Reset(c));
            a->FreeInstance(c);
            if (s > fmi2Warning) {
                failures++;
            }
            /* the outputs depend on the rotation of the inputs, cycle % 3 */
            if (cycle < 3) {
                memcpy(reference[m][cycle], y, sizeof y);
            } else {
                identical &= same_bits(reference[m][cycle % 3], y, FIRST + LATER);
            }
        }
    }
    printf("# %ld cycles on both FMUs: %ld failed calls, outputs %s, %ld blocks not freed\n", n_cycles,
           failures, identical ? "identical in every cycle" : "DIFFERENT", live_blocks);
    return failures == 0 && identical && live_blocks == 0 ? 0 : 1;
}

/* ================================================================= main */
static void load(Fmu *f, const char *name, const char *path, const char *guid, fmi2ValueReference n_reals,
                 fmi2ValueReference n_booleans)
{
    f->name = name;
    f->guid = guid;
    f->n_reals = n_reals;
    f->n_booleans = n_booleans;
    f->lib = fmi2_load(path, &f->api);
    if (!f->lib) {
        exit(3);
    }
}

int main(int argc, char **argv)
{
    const int is_cycles = argc == 8 && strcmp(argv[1], "cycles") == 0;
    if (!(argc == 7 && strcmp(argv[1], "cases") == 0) && !is_cycles) {
        fprintf(stderr, "usage: fmu_misuse cases PLANT_LIB PLANT_GUID INVERSE_LIB INVERSE_GUID N_REALS\n"
                        "       fmu_misuse cycles N PLANT_LIB PLANT_GUID INVERSE_LIB INVERSE_GUID N_REALS\n");
        return 2;
    }
    char **args = argv + (is_cycles ? 3 : 2);
    const fmi2ValueReference n_reals = (fmi2ValueReference)strtoul(args[4], NULL, 10);
    Fmu fmus[2];
    load(&fmus[0], "plant", args[0], args[1], n_reals, 0);
    load(&fmus[1], "inverse", args[2], args[3], n_reals, 1);
    Fmu *plant = &fmus[0], *inverse = &fmus[1];
    prepare_inputs(plant, inverse);

    if (is_cycles) {
        const int code = cycles(fmus, strtol(argv[2], NULL, 10));
        fmi2_close_library(plant->lib);
        fmi2_close_library(inverse->lib);
        return code;
    }

    logbook.echo = 1;
    printf("# not tried: calls after fmi2FreeInstance and a freed or uninitialised fmi2FMUstate -- the memory "
           "they point to is gone or was never there; reading it is undefined behaviour in the importer, which "
           "no FMU can detect\n");
    for (int m = 0; m < 2; m++) {
        Fmu *f = &fmus[m];
        const Fmu *other = &fmus[1 - m];
        suite = f->name;
        section("library");
        library_cases(f);
        section("instantiation");
        instantiation_cases(f, other);
        section("no-instance");
        no_instance_cases(f);
        section("wrong-state");
        wrong_state_cases(f);
        section("step-complete");
        step_complete_cases(f);
        time_overflow_cases(f);
        section("voltage-range");
        range_cases(f, plant);
        section("parameters");
        parameter_cases(f, f == inverse);
        section("fmu-state");
        state_cases(f, other);
        section("foreign-instance");
        foreign_instance_cases(f, other);
        section("many-instances");
        many_instances_cases(f);
    }
    suite = "both";
    section("whole-run");
    check_case("logger_always_got_the_environment_and_strings", logbook.bad_arguments == 0);
    check_case("every_block_allocated_was_freed", live_blocks == 0);
    fmi2_close_library(plant->lib);
    fmi2_close_library(inverse->lib);
    printf("%ld cases tried, %ld handled\n", tried, handled);
    return tried == handled ? 0 : 1;
}
