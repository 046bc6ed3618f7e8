/*
 * model.c (controller) -- the hooks of the FMI layer for the controller.
 *
 * One step of size h with reference r, measurement m and feedforward x held
 * (the controller row of pysim.cosim.rig.RigSimulation's unit table):
 *     f = ff_scale x + ff_offset                          (V)
 *     feedback:  e = r - m,  u = f + kp e + i,  out = clip(u, output_low, output_high)
 *                i' = i + ki h e  unless u > output_high and e > 0, or u < output_low and e < 0
 *     otherwise: out = clip(f, output_low, output_high)   (i unchanged)
 *     command' = DAC(out / amplifier_gain)
 * The output is the command after the step: computed during the sample from
 * the inputs held over it, applied at its end (one sample of computation
 * delay; no direct feed-through).  Before the first step it is 0 V.
 */
#include "fmi2_layer.h"

#define FEEDBACK_INDEX (VR_feedback - MODEL_FIRST_BOOLEAN_VR)

void model_reset(Instance *inst)
{
    inst->model.feedback = 0;
    inst->model.dac_bits = 0;
    inst->model.dac_lsb = 0.0;
}

fmi2Status model_prepare(Instance *inst)
{
    const double *real = inst->real;
    const char *bad = NULL;
    if (!(real[VR_kp] >= 0.0)) {
        bad = "kp must be >= 0";
    } else if (!(real[VR_ki] >= 0.0)) {
        bad = "ki must be >= 0";
    } else if (!(real[VR_output_low] < real[VR_output_high])) {
        bad = "output_low must be < output_high";
    } else if (!(real[VR_amplifier_gain] > 0.0)) {
        bad = "amplifier_gain must be > 0";
    } else if (!rig_whole(real[VR_dac_bits], 0.0, 32.0)) {
        bad = "dac_bits must be a whole number 0-32";
    } else if (!(real[VR_dac_low] < real[VR_dac_high])) {
        bad = "dac_low must be < dac_high";
    }
    if (bad) {
        layer_log(inst, fmi2Error, LAYER_LOG_ERROR, "invalid parameters: %s (kp = %g, ki = %g, "
                  "output_low = %g, output_high = %g, amplifier_gain = %g, dac_bits = %g, dac_low = %g, "
                  "dac_high = %g)", bad, real[VR_kp], real[VR_ki], real[VR_output_low], real[VR_output_high],
                  real[VR_amplifier_gain], real[VR_dac_bits], real[VR_dac_low], real[VR_dac_high]);
        return fmi2Error;
    }
    ModelData *model = &inst->model;
    model->feedback = inst->boolean[FEEDBACK_INDEX] ? 1 : 0;
    model->dac_bits = (int)real[VR_dac_bits];
    model->dac_lsb = rig_lsb(model->dac_bits, real[VR_dac_low], real[VR_dac_high]);
    return fmi2OK;
}

LAYER_HOT fmi2Status model_update(Instance *inst)
{
    double *real = inst->real;
    const double *memory = inst->memory;
    double *next = inst->scratch;
    const ModelData *model = &inst->model;
    double integrator = memory[CTRL_INTEGRATOR];
    double command = memory[CTRL_COMMAND];
    double step = memory[RIG_STEP];
    if (memory[RIG_PENDING] != 0.0) {
        const double h = rig_step_size(memory[RIG_T_START], inst->time, step);
        const double low = real[VR_output_low];
        const double high = real[VR_output_high];
        const double f = real[VR_ff_scale] * memory[CTRL_FEEDFORWARD] + real[VR_ff_offset];
        double out;
        if (model->feedback) {
            const double error = memory[CTRL_REFERENCE] - memory[CTRL_MEASUREMENT];
            const double u = f + real[VR_kp] * error + integrator;
            out = rig_clip(u, low, high);
            const int winding = (u > high && error > 0.0) || (u < low && error < 0.0);
            if (!winding) {
                integrator = integrator + real[VR_ki] * h * error;
            }
        } else {
            out = rig_clip(f, low, high);
        }
        command = rig_convert(out / real[VR_amplifier_gain], model->dac_bits, real[VR_dac_low],
                              real[VR_dac_high], model->dac_lsb);
        step = h;
    }
    real[VR_command] = command;
    next[RIG_PENDING] = 1.0;
    next[RIG_T_START] = inst->time;
    next[RIG_STEP] = step;
    next[CTRL_INTEGRATOR] = integrator;
    next[CTRL_COMMAND] = command;
    next[CTRL_REFERENCE] = real[VR_reference];
    next[CTRL_MEASUREMENT] = real[VR_measurement];
    next[CTRL_FEEDFORWARD] = real[VR_feedforward];
    return fmi2OK;
}
