/*
 * fuzz_state.c -- libFuzzer target for the FMU state deserializer.
 *
 * The first byte chooses what fmi2DeSerializeFMUstate gets:
 *   0  the remaining bytes as they are;
 *   1  a valid serialized state (taken from an instance after a few steps)
 *      with bytes changed at offsets the input gives;
 *   2  the same with the checksum made valid again, so that the checks
 *      behind it (header, machine state, finite numbers, flags) are reached;
 *   3  a valid state cut or extended to a length the input gives.
 * Whatever is accepted must then be usable: fmi2SetFMUstate returns OK, or
 * fmi2Error with a log message (parameters that cannot work), and the
 * instance steps on with statuses <= Warning and finite outputs, or refuses
 * with a logged fmi2Error.  A refused state must come with fmi2Error, a log
 * message and no state handed out.  The sanitizers watch every byte read.
 */
#include "fuzz_support.h"

static fmi2Byte valid[SERIAL_SIZE];

/* A serialized state after a few steps (the same for every input). */
static void make_valid_state(void)
{
    static int made = 0;
    if (made) {
        return;
    }
    fmi2Component c = fmi2Instantiate("source", fmi2CoSimulation, MODEL_GUID, "", &fuzz_callbacks, fmi2False,
                                      fmi2False);
    FUZZ_REQUIRE(c != NULL, "instantiate");
    FUZZ_REQUIRE(fmi2SetupExperiment(c, fmi2False, 0.0, 0.0, fmi2False, 0.0) == fmi2OK &&
                 fmi2EnterInitializationMode(c) == fmi2OK && fmi2ExitInitializationMode(c) == fmi2OK,
                 "initialise");
    const double v_lo = real_start_values[VR_voltage_min], v_hi = real_start_values[VR_voltage_max];
    const fmi2ValueReference in = 0, out = 1;
    double t = 0.0;
    for (int k = 0; k < 12; k++) {
        /* inputs inside the range of either FMU's input (for the inverse, a
         * displacement of the order of the range is reachable or saturates) */
        const double x = v_lo + (v_hi - v_lo) * (0.5 + 0.4 * ((k % 5) - 2) / 2.0);
        double y;
        FUZZ_REQUIRE(fmi2SetReal(c, &in, 1, &x) <= fmi2Warning, "set");
        FUZZ_REQUIRE(fmi2DoStep(c, t, 1e-3, fmi2True) <= fmi2Warning, "step");
        FUZZ_REQUIRE(fmi2GetReal(c, &out, 1, &y) <= fmi2Warning, "get");
        t += 1e-3;
    }
    fmi2FMUstate s = NULL;
    FUZZ_REQUIRE(fmi2GetFMUstate(c, &s) == fmi2OK && fmi2SerializeFMUstate(c, s, valid, sizeof valid) == fmi2OK,
                 "serialize");
    fmi2FreeFMUstate(c, &s);
    fmi2FreeInstance(c);
    made = 1;
}

/* After an accepted state: set it and step on; everything must be explained. */
static void use_state(fmi2Component c, fmi2FMUstate s, FuzzInput *in)
{
    long before = fuzz_messages;
    fmi2Status status = fmi2SetFMUstate(c, s);
    require_explained(status, before);
    double t = 0.0;
    fmi2GetRealStatus(c, fmi2LastSuccessfulTime, &t);
    const double v_lo = real_start_values[VR_voltage_min], v_hi = real_start_values[VR_voltage_max];
    for (int k = 0; k < 4; k++) {
        const fmi2ValueReference in_vr = 0, out_vr = 1;
        const double x = take_value(in, v_lo, v_hi);
        double y = 0.0;
        before = fuzz_messages;
        status = fmi2SetReal(c, &in_vr, 1, &x);
        require_explained(status, before);
        before = fuzz_messages;
        status = fmi2GetReal(c, &out_vr, 1, &y);
        require_explained(status, before);
        if (status <= fmi2Warning) {
            FUZZ_REQUIRE(layer_is_finite(y), "a restored state gave a non-finite output");
        }
        before = fuzz_messages;
        status = fmi2DoStep(c, t, 1e-3, fmi2True);
        require_explained(status, before);
        if (status <= fmi2Warning) {
            t += 1e-3;
        }
    }
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    make_valid_state();
    FuzzInput in = { data, size };
    static fmi2Byte bytes[2 * SERIAL_SIZE + 64];
    size_t n = 0;
    const uint8_t mode = take_byte(&in) % 4;
    if (mode == 0) {
        n = in.size < sizeof bytes ? in.size : sizeof bytes;
        memcpy(bytes, in.data, n);
        in.size -= n;
        in.data += n;
    } else if (mode == 3) {
        memcpy(bytes, valid, SERIAL_SIZE);
        n = (size_t)take_u32(&in) % sizeof bytes;
        for (size_t i = SERIAL_SIZE; i < n; i++) {
            bytes[i] = (fmi2Byte)take_byte(&in);
        }
    } else {
        memcpy(bytes, valid, SERIAL_SIZE);
        n = SERIAL_SIZE;
        const int changes = 1 + take_byte(&in) % 8;
        for (int k = 0; k < changes; k++) {
            const size_t offset = (take_byte(&in) | (size_t)take_byte(&in) << 8) % SERIAL_SIZE;
            const uint8_t how = take_byte(&in);
            if (how < 64) {
                double x = take_value(&in, -200.0, 200.0);     /* a number in place */
                memcpy(bytes + (offset & ~(size_t)7), &x, sizeof x);
            } else {
                bytes[offset] ^= how;
            }
        }
        if (mode == 2) {
            const uint64_t checksum = fnv1a((const unsigned char *)bytes, SERIAL_SIZE - 8);
            memcpy(bytes + SERIAL_SIZE - 8, &checksum, sizeof checksum);
        }
    }

    fmi2Component c = fmi2Instantiate("target", fmi2CoSimulation, MODEL_GUID, "", &fuzz_callbacks, fmi2False,
                                      fmi2False);
    FUZZ_REQUIRE(c != NULL, "instantiate");
    fmi2FMUstate s = NULL;
    const long before = fuzz_messages;
    const fmi2Status status = fmi2DeSerializeFMUstate(c, bytes, n, &s);
    require_explained(status, before);
    if (status == fmi2OK) {
        FUZZ_REQUIRE(s != NULL, "fmi2DeSerializeFMUstate returned OK without a state");
        FUZZ_REQUIRE(n == SERIAL_SIZE, "a state of the wrong size was accepted");
        use_state(c, s, &in);
        FUZZ_REQUIRE(fmi2FreeFMUstate(c, &s) == fmi2OK, "free the state");
    } else {
        FUZZ_REQUIRE(status == fmi2Error && s == NULL, "a refused state came with a status other than "
                                                       "fmi2Error, or a state was handed out");
    }
    fmi2FreeInstance(c);
    FUZZ_REQUIRE(fuzz_live_blocks == 0, "memory allocated by the FMU was not freed");
    return 0;
}
