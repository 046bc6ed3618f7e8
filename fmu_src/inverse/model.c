/*
 * model.c (inverse) -- the hooks of the FMI layer for the inverse compensator.
 *
 * Two methods, chosen by the Boolean parameter use_previous_sample:
 *   exact (default)  voltage = the v in [voltage_min, voltage_max] with
 *                    H[v] = displacement_ref given the committed operator
 *                    state, solved to machine precision (hyst_invert);
 *   previous sample  the paper's Fig. 7 loop: the analytic inverse of the
 *                    linear-plus-operators part (eq. 11-12, computed here from
 *                    the parameters) fed with displacement_ref - a1 u^3, u
 *                    from the previous step; one step is one loop sample.
 * Both need a model that is strictly increasing along every branch; that is
 * checked at initialisation.
 */
#include <string.h>

#include "fmi2_layer.h"

#define PREVIOUS_SAMPLE_INDEX (VR_use_previous_sample - MODEL_FIRST_BOOLEAN_VR)

void model_reset(Instance *inst)
{
    inst->model.previous_sample = 0;    /* memory: demagnetised (all zero) */
}

fmi2Status model_prepare(Instance *inst)
{
    if (mpi_check_parameters(inst) != fmi2OK || mpi_check_invertible(inst) != fmi2OK) {
        return fmi2Error;
    }
    ModelData *model = &inst->model;
    model->previous_sample = inst->boolean[PREVIOUS_SAMPLE_INDEX] ? 1 : 0;
    if (model->previous_sample) {
        return mpi_analytic_inverse(inst, &model->inverse, model->r_hat, model->b_hat);
    }
    return fmi2OK;
}

int model_input_ok(const Instance *inst, fmi2ValueReference vr, double value)
{
    (void)inst;                          /* any finite displacement: the */
    (void)vr;                            /* voltage saturates if need be */
    return layer_is_finite(value);
}

fmi2Status model_accept_input(Instance *inst, fmi2ValueReference vr, double *value)
{
    (void)inst;                          /* never called: everything finite is ok */
    (void)vr;
    (void)value;
    return fmi2OK;
}

int model_outputs_hold(const Instance *inst)
{
    /* exact: the committed state still maps the voltage to the reference;
     * previous sample: the next loop sample differs even for a held input */
    return !inst->model.previous_sample;
}

LAYER_HOT fmi2Status model_update(Instance *inst)
{
    const double *real = inst->real;
    const double target = real[VR_displacement_ref];
    const double v_lo = real[VR_voltage_min];
    const double v_hi = real[VR_voltage_max];
    double voltage;
    if (inst->model.previous_sample) {
        memcpy(inst->scratch, inst->memory, sizeof(double) * MODEL_N_MEMORY);
        hyst_invert_previous_sample_run(&inst->model.inverse, real[VR_a1], real[VR_input_offset],
                                        real[VR_output_offset], 1, &target, inst->scratch,
                                        &inst->scratch[MODEL_N_OPERATORS], v_lo, v_hi, &voltage);
        inst->real[VR_voltage] = voltage;
        return fmi2OK;
    }
    const HystModel forward = MPI_MODEL(real);
    const int solved = hyst_invert(&forward, target, inst->memory, v_lo, v_hi, &voltage, inst->scratch);
    inst->scratch[MODEL_N_OPERATORS] = 0.0;
    inst->real[VR_voltage] = voltage;
    if (solved != HYST_INVERSE_OK) {
        layer_log(inst, fmi2Warning, LAYER_LOG_WARNING,
                  "displacement_ref = %.17g um lies %s what [%g, %g] V can reach: voltage saturated at %.17g V",
                  target, solved == HYST_INVERSE_BELOW ? "below" : "above", v_lo, v_hi, voltage);
        return fmi2Warning;
    }
    return fmi2OK;
}
