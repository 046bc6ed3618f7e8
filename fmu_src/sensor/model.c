/*
 * model.c (sensor) -- the hooks of the FMI layer for the sensor.
 *
 * One step with the displacement s held (the sensor row of
 * pysim.cosim.rig.RigSimulation's unit table):
 *     measurement' = ADC(s + noise_rms n)    n the next standard-normal number
 *     measurement' = ADC(s)                  if noise_rms = 0 (no number drawn)
 * n: xorshift64* (shifts 12, 25, 27, multiplier 0x2545F4914F6CDD1D), 53 bits
 * to (0, 1], Box-Muller with the sine kept as the next number -- the
 * operations of pysim.core.rig.XorShiftNormal in the same order.  The
 * generator starts from the parameter seed (a whole number; 0 gives the
 * golden-ratio constant) at the first step.  The output is the measurement
 * after the step (no direct feed-through); 0 um before the first step.
 */
#include "fmi2_layer.h"

#define SENSOR_ZERO_SEED UINT64_C(0x9E3779B97F4A7C15)

void model_reset(Instance *inst)
{
    inst->model.adc_bits = 0;
    inst->model.adc_lsb = 0.0;
}

fmi2Status model_prepare(Instance *inst)
{
    const double *real = inst->real;
    const char *bad = NULL;
    if (!(real[VR_noise_rms] >= 0.0)) {
        bad = "noise_rms must be >= 0";
    } else if (!rig_whole(real[VR_seed], -9007199254740992.0, 9007199254740992.0)) {
        bad = "seed must be a whole number of magnitude <= 2^53";
    } else if (!rig_whole(real[VR_adc_bits], 0.0, 32.0)) {
        bad = "adc_bits must be a whole number 0-32";
    } else if (!(real[VR_adc_low] < real[VR_adc_high])) {
        bad = "adc_low must be < adc_high";
    }
    if (bad) {
        layer_log(inst, fmi2Error, LAYER_LOG_ERROR, "invalid parameters: %s (noise_rms = %g, seed = %.17g, "
                  "adc_bits = %g, adc_low = %g, adc_high = %g)", bad, real[VR_noise_rms], real[VR_seed],
                  real[VR_adc_bits], real[VR_adc_low], real[VR_adc_high]);
        return fmi2Error;
    }
    inst->model.adc_bits = (int)real[VR_adc_bits];
    inst->model.adc_lsb = rig_lsb(inst->model.adc_bits, real[VR_adc_low], real[VR_adc_high]);
    return fmi2OK;
}

/* (0, 1]: one xorshift64* step, 53 bits. */
double sensor_uniform(uint64_t *state);
double sensor_uniform(uint64_t *state)
{
    uint64_t x = *state;
    x ^= x >> 12;
    x ^= x << 25;
    x ^= x >> 27;
    *state = x;
    return (double)((x * UINT64_C(0x2545F4914F6CDD1D)) >> 11) * (1.0 / 9007199254740992.0) +
           (1.0 / 9007199254740992.0);
}

LAYER_HOT fmi2Status model_update(Instance *inst)
{
    double *real = inst->real;
    const double *memory = inst->memory;
    double *next = inst->scratch;
    double measurement = memory[SENSOR_MEASUREMENT];
    double has_spare = memory[SENSOR_HAS_SPARE];
    double spare = memory[SENSOR_SPARE];
    uint64_t state;
    if (memory[SENSOR_SEEDED] != 0.0) {
        state = ((uint64_t)memory[SENSOR_STATE_HIGH] << 32) | (uint64_t)memory[SENSOR_STATE_LOW];
    } else {
        state = (uint64_t)(int64_t)real[VR_seed];
        if (state == 0) {
            state = SENSOR_ZERO_SEED;
        }
    }
    if (memory[RIG_PENDING] != 0.0) {
        const double rms = real[VR_noise_rms];
        double x = memory[SENSOR_DISPLACEMENT];
        if (rms != 0.0) {
            double n;
            if (has_spare != 0.0) {
                n = spare;
                has_spare = 0.0;
                spare = 0.0;
            } else {
                const double u1 = sensor_uniform(&state);
                const double u2 = sensor_uniform(&state);
                const double radius = sqrt(-2.0 * log(u1));
                const double angle = 2.0 * RIG_PI * u2;
                spare = radius * sin(angle);
                has_spare = 1.0;
                n = radius * cos(angle);
            }
            x = x + rms * n;
        }
        measurement = rig_convert(x, inst->model.adc_bits, real[VR_adc_low], real[VR_adc_high],
                                  inst->model.adc_lsb);
    }
    real[VR_measurement] = measurement;
    next[RIG_PENDING] = 1.0;
    next[RIG_T_START] = inst->time;
    next[RIG_STEP] = memory[RIG_PENDING] != 0.0 ? rig_step_size(memory[RIG_T_START], inst->time,
                                                                memory[RIG_STEP]) : memory[RIG_STEP];
    next[SENSOR_MEASUREMENT] = measurement;
    next[SENSOR_DISPLACEMENT] = real[VR_displacement];
    next[SENSOR_SEEDED] = 1.0;
    next[SENSOR_STATE_HIGH] = (double)(uint32_t)(state >> 32);
    next[SENSOR_STATE_LOW] = (double)(uint32_t)state;
    next[SENSOR_HAS_SPARE] = has_spare;
    next[SENSOR_SPARE] = spare;
    return fmi2OK;
}
