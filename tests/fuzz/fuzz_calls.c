/*
 * fuzz_calls.c -- libFuzzer target: the fuzz input is a program of FMI calls,
 * with their arguments, on up to two instances of one FMU and up to three FMU
 * states.  Each byte picks the next call; the bytes after it give the
 * instance, value references, values (finite, non-finite, huge, any bit
 * pattern), step sizes and communication points.
 *
 * Found (abort) when a call returns a status other than OK, Warning, Discard
 * or Error; an fmi2Error comes without a log message; fmi2Instantiate with
 * valid arguments fails; a Real read with status OK or Warning is not finite;
 * or memory the FMU allocated is not freed once everything is freed.  The
 * sanitizers find the rest (out-of-bounds access, use after free, undefined
 * behaviour, leaks).
 */
#include "fuzz_support.h"

#define N_SLOTS 2
#define N_STATES 3

typedef struct {
    fmi2Component c;
    double time;                        /* where the FMU's time should be, s */
} Slot;

static Slot slots[N_SLOTS];
static fmi2FMUstate states[N_STATES];
static fmi2Byte blob[2 * SERIAL_SIZE];
static size_t blob_size;

/* The instance to call: a live slot, or (rarely) none at all. */
static fmi2Component pick(FuzzInput *in, int *slot)
{
    const uint8_t b = take_byte(in);
    *slot = b % N_SLOTS;
    return (b >= 250) ? NULL : slots[*slot].c;
}

static fmi2ValueReference take_reference(FuzzInput *in)
{
    const uint8_t b = take_byte(in);
    return (b == 255) ? 0xffffffffu : (fmi2ValueReference)(b % (MODEL_N_REALS + MODEL_N_BOOLEANS + 2));
}

/* A live instance to free FMU states with (any instance of the FMU may). */
static fmi2Component any_instance(void)
{
    for (int i = 0; i < N_SLOTS; i++) {
        if (slots[i].c) {
            return slots[i].c;
        }
    }
    return NULL;
}

static void free_states(fmi2Component c)
{
    for (int i = 0; i < N_STATES; i++) {
        if (states[i]) {
            FUZZ_REQUIRE(fmi2FreeFMUstate(c, &states[i]) == fmi2OK && !states[i], "freeing a state failed");
        }
    }
}

static void step_program(FuzzInput *in)
{
    int s = 0;
    const uint8_t op = take_byte(in) % 20;
    const long before = fuzz_messages;
    fmi2Component c = pick(in, &s);
    const int live = c != NULL;
    fmi2Status status = fmi2OK;
    const double v_lo = real_start_values[VR_voltage_min], v_hi = real_start_values[VR_voltage_max];
    switch (op) {
    case 0: {                                           /* instantiate */
        if (slots[s].c) {
            return;
        }
        const uint8_t how = take_byte(in);
        const char *guid = (how & 1) ? "{not-the-guid}" : MODEL_GUID;
        const fmi2Type type = (how & 2) ? fmi2ModelExchange : fmi2CoSimulation;
        const char *name = (how & 4) ? "" : "fuzz";
        fuzz_fail_allocations = (how & 8) ? 1 + (how >> 6) : 0;
        slots[s].c = fmi2Instantiate(name, type, guid, "", &fuzz_callbacks, fmi2False, (how & 16) ? fmi2True : fmi2False);
        const int valid = !(how & 15);
        fuzz_fail_allocations = 0;
        FUZZ_REQUIRE(!valid || slots[s].c, "fmi2Instantiate with valid arguments failed");
        FUZZ_REQUIRE(valid || !slots[s].c, "fmi2Instantiate accepted invalid arguments");
        FUZZ_REQUIRE(valid || fuzz_messages > before, "fmi2Instantiate refused without a log message");
        slots[s].time = 0.0;
        return;
    }
    case 1:                                             /* free */
        if (c) {
            /* states outlive their instance only if another one can free them */
            int others = 0;
            for (int i = 0; i < N_SLOTS; i++) {
                others += i != s && slots[i].c != NULL;
            }
            if (!others) {
                free_states(c);
            }
        }
        fmi2FreeInstance(c);
        if (c) {
            slots[s].c = NULL;
        }
        return;
    case 2: {
        const double start = take_value(in, 0.0, 10.0);
        const int stop_defined = take_byte(in) & 1;
        const double stop = take_value(in, 0.0, 10.0);
        status = fmi2SetupExperiment(c, fmi2False, 0.0, start, stop_defined, stop);
        if (status == fmi2OK) {
            slots[s].time = start;
        }
        break;
    }
    case 3:
        status = fmi2EnterInitializationMode(c);
        break;
    case 4:
        status = fmi2ExitInitializationMode(c);
        break;
    case 5: {                                           /* set Reals */
        fmi2ValueReference vr[3];
        double value[3];
        const size_t n = take_byte(in) % 4;
        for (size_t i = 0; i < n; i++) {
            vr[i] = take_reference(in);
            value[i] = take_value(in, vr[i] == VR_r ? 0.0 : v_lo, vr[i] == VR_r ? 5.0 : v_hi);
        }
        status = fmi2SetReal(c, (take_byte(in) == 255) ? NULL : vr, n, value);
        break;
    }
    case 6: {                                           /* get Reals */
        fmi2ValueReference vr[3];
        double value[3];
        const size_t n = take_byte(in) % 4;
        for (size_t i = 0; i < n; i++) {
            vr[i] = take_reference(in);
        }
        status = fmi2GetReal(c, vr, n, value);
        if (status <= fmi2Warning) {
            for (size_t i = 0; i < n; i++) {
                FUZZ_REQUIRE(layer_is_finite(value[i]), "fmi2GetReal returned a non-finite value");
            }
        }
        break;
    }
    case 7: {                                           /* Booleans */
        fmi2ValueReference vr = take_reference(in);
        fmi2Boolean value = take_byte(in);
        status = (take_byte(in) & 1) ? fmi2SetBoolean(c, &vr, 1, &value) : fmi2GetBoolean(c, &vr, 1, &value);
        break;
    }
    case 8:
    case 9: {                                           /* doStep */
        const uint8_t how = take_byte(in);
        double t = slots[s].time;
        if (how & 1) {
            t = take_value(in, 0.0, 10.0);
        } else if (how & 2) {
            t += 1e-12 * t;                             /* rounding: tolerated */
        }
        const double h = (how & 4) ? take_value(in, 0.0, 1.0) : 1e-3;
        status = fmi2DoStep(c, t, h, fmi2True);
        if (status <= fmi2Warning && live) {
            slots[s].time = t + h;
            FUZZ_REQUIRE(layer_is_finite(slots[s].time), "a step ended at an infinite time");
        }
        break;
    }
    case 10:
        status = fmi2Terminate(c);
        break;
    case 11:
        status = fmi2Reset(c);
        if (status == fmi2OK) {
            slots[s].time = 0.0;
        }
        break;
    case 12: {                                          /* get state */
        const int k = take_byte(in) % N_STATES;
        status = fmi2GetFMUstate(c, &states[k]);
        break;
    }
    case 13: {                                          /* set state */
        const int k = take_byte(in) % N_STATES;
        status = fmi2SetFMUstate(c, states[k]);
        if (status == fmi2OK) {
            fmi2GetRealStatus(c, fmi2LastSuccessfulTime, &slots[s].time);
        }
        break;
    }
    case 14: {                                          /* free state */
        const int k = take_byte(in) % N_STATES;
        status = fmi2FreeFMUstate(c, &states[k]);
        break;
    }
    case 15: {                                          /* serialize */
        const int k = take_byte(in) % N_STATES;
        size_t size = 0;
        status = fmi2SerializedFMUstateSize(c, states[k], &size);
        if (status == fmi2OK) {
            FUZZ_REQUIRE(size == SERIAL_SIZE, "unexpected serialized size");
            const size_t offered = (take_byte(in) & 1) ? size : size - 1;
            status = fmi2SerializeFMUstate(c, states[k], blob, offered);
            blob_size = (status == fmi2OK) ? size : 0;
        }
        break;
    }
    case 16: {                                          /* deserialize, maybe damaged */
        const int k = take_byte(in) % N_STATES;
        size_t size = blob_size;
        const uint8_t damage = take_byte(in);
        if (damage & 1 && size) {
            blob[take_byte(in) % size] ^= (fmi2Byte)(1 + take_byte(in) % 255);
        }
        if (damage & 2) {
            size = take_byte(in) % (sizeof blob + 1);
        }
        status = fmi2DeSerializeFMUstate(c, blob, size, &states[k]);
        break;
    }
    case 17: {                                          /* logging */
        static const char *const names[4] = { "logEvents", "logStatusWarning", "logStatusError", "logBogus" };
        const uint8_t how = take_byte(in);
        fmi2String categories[2] = { names[how & 3], names[(how >> 2) & 3] };
        status = fmi2SetDebugLogging(c, (how >> 4) & 1, (how >> 5) % 3, (how & 128) ? NULL : categories);
        break;
    }
    case 18: {                                          /* status queries */
        const fmi2StatusKind kind = (fmi2StatusKind)(take_byte(in) % 4);
        fmi2Status st;
        fmi2Real r;
        fmi2Integer i;
        fmi2Boolean b;
        fmi2String str;
        switch (take_byte(in) % 5) {
        case 0: status = fmi2GetStatus(c, kind, &st); break;
        case 1: status = fmi2GetRealStatus(c, kind, &r); break;
        case 2: status = fmi2GetIntegerStatus(c, kind, &i); break;
        case 3: status = fmi2GetBooleanStatus(c, kind, &b); break;
        default: status = fmi2GetStringStatus(c, kind, &str); break;
        }
        break;
    }
    default: {                                          /* what the FMUs do not have */
        fmi2ValueReference vr = take_reference(in);
        fmi2Integer i = 0;
        fmi2Real r = 0.0;
        fmi2String str = "x";
        switch (take_byte(in) % 6) {
        case 0: status = fmi2GetInteger(c, &vr, 1, &i); break;
        case 1: status = fmi2SetString(c, &vr, 1, &str); break;
        case 2: status = fmi2GetDirectionalDerivative(c, &vr, 1, &vr, 1, &r, &r); break;
        case 3: status = fmi2SetRealInputDerivatives(c, &vr, 1, &i, &r); break;
        case 4: status = fmi2CancelStep(c); break;
        default: status = fmi2GetRealOutputDerivatives(c, &vr, 1, &i, &r); break;
        }
        break;
    }
    }
    if (live) {
        require_explained(status, before);
    } else {
        FUZZ_REQUIRE(status == fmi2Error, "a call without an instance did not return fmi2Error");
    }
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    FuzzInput in = { data, size };
    for (int steps = 0; in.size > 0 && steps < 400; steps++) {
        step_program(&in);
    }
    /* free everything: then nothing the FMU allocated may remain */
    fmi2Component c = any_instance();
    if (!c) {
        int any_state = 0;
        for (int i = 0; i < N_STATES; i++) {
            any_state |= states[i] != NULL;
        }
        if (any_state) {
            c = fmi2Instantiate("cleanup", fmi2CoSimulation, MODEL_GUID, "", &fuzz_callbacks, fmi2False, fmi2False);
            FUZZ_REQUIRE(c != NULL, "fmi2Instantiate for the clean-up failed");
            slots[0].c = c;
        }
    }
    if (c) {
        free_states(c);
    }
    for (int i = 0; i < N_SLOTS; i++) {
        fmi2FreeInstance(slots[i].c);
        slots[i].c = NULL;
    }
    blob_size = 0;
    FUZZ_REQUIRE(fuzz_live_blocks == 0, "memory allocated by the FMU was not freed");
    return 0;
}
