/*
 * model.c (amplifier) -- the hooks of the FMI layer for the amplifier.
 *
 * One step of size h with the command c held (pysim.core.rig.Amplifier):
 *     alpha      = 1 - exp(-2 pi f_bw h)      (1 without bandwidth limit)
 *     max_change = (I_max / C) h              (inf without current limit)
 *     change     = clip(alpha (gain c - a), -max_change, max_change)
 *     a'         = clip(a + change, output_low, output_high)
 * The output is the state: a' after the step (no direct feed-through).  At
 * rest the output is 0 V clipped into the range.  bandwidth = 0 and
 * current_limit = 0 mean "no limit" (FMI parameters cannot be infinite).
 */
#include "fmi2_layer.h"

void model_reset(Instance *inst)
{
    inst->model.step = 0.0;
}

fmi2Status model_prepare(Instance *inst)
{
    const double *real = inst->real;
    const char *bad = NULL;
    if (!(real[VR_gain] > 0.0)) {
        bad = "gain must be > 0";
    } else if (!(real[VR_capacitance] > 0.0)) {
        bad = "capacitance must be > 0";
    } else if (!(real[VR_bandwidth] >= 0.0)) {
        bad = "bandwidth must be >= 0 (0: no bandwidth limit)";
    } else if (!(real[VR_current_limit] >= 0.0)) {
        bad = "current_limit must be >= 0 (0: no slew limit)";
    } else if (!(real[VR_output_low] < real[VR_output_high])) {
        bad = "output_low must be < output_high";
    }
    if (bad) {
        layer_log(inst, fmi2Error, LAYER_LOG_ERROR, "invalid parameters: %s (gain = %g, capacitance = %g, "
                  "bandwidth = %g, current_limit = %g, output_low = %g, output_high = %g)", bad,
                  real[VR_gain], real[VR_capacitance], real[VR_bandwidth], real[VR_current_limit],
                  real[VR_output_low], real[VR_output_high]);
        return fmi2Error;
    }
    inst->model.step = 0.0;          /* coefficients recomputed for the next step */
    return fmi2OK;
}

/* alpha and max_change for the step h, in the operations of Amplifier.coefficients. */
void amp_coefficients(Instance *inst, double h);
void amp_coefficients(Instance *inst, double h)
{
    const double *real = inst->real;
    ModelData *model = &inst->model;
    const double bandwidth = real[VR_bandwidth];
    const double current = real[VR_current_limit];
    model->alpha = bandwidth == 0.0 ? 1.0 : -expm1(-2.0 * RIG_PI * bandwidth * h);
    model->max_change = current == 0.0 ? HUGE_VAL : current / real[VR_capacitance] * h;
    model->step = h;
}

LAYER_HOT fmi2Status model_update(Instance *inst)
{
    double *real = inst->real;
    const double *memory = inst->memory;
    double *next = inst->scratch;
    const double low = real[VR_output_low];
    const double high = real[VR_output_high];
    double a, step = memory[RIG_STEP];
    if (memory[RIG_PENDING] != 0.0) {
        const double h = rig_step_size(memory[RIG_T_START], inst->time, step);
        if (h != inst->model.step) {
            amp_coefficients(inst, h);
        }
        const double max_change = inst->model.max_change;
        a = memory[AMP_OUTPUT];
        const double change = rig_clip(inst->model.alpha * (real[VR_gain] * memory[AMP_COMMAND] - a),
                                       -max_change, max_change);
        a = rig_clip(a + change, low, high);
        step = h;
    } else {
        a = rig_clip(0.0, low, high);            /* at rest at 0 V */
    }
    real[VR_voltage] = a;
    next[RIG_PENDING] = 1.0;
    next[RIG_T_START] = inst->time;
    next[RIG_STEP] = step;
    next[AMP_OUTPUT] = a;
    next[AMP_COMMAND] = real[VR_command];
    return fmi2OK;
}
