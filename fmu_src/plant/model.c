/*
 * model.c (plant) -- the hooks of the FMI layer for the MPI plant.
 *
 *     displacement = H[voltage]     (hyst_output, one sample per step)
 *
 * The output is a chain of stages; today it is the rate-independent
 * hysteresis alone.  A stage after it takes the hysteresis output, reads its
 * own state from inst->memory and writes its next state to inst->scratch.
 */
#include "fmi2_layer.h"

void model_reset(Instance *inst)
{
    inst->model.n_stages = 0;           /* memory: demagnetised (all zero) */
}

fmi2Status model_prepare(Instance *inst)
{
    if (mpi_check_parameters(inst) != fmi2OK) {
        return fmi2Error;
    }
    /* the range may have changed after the voltage was set */
    return mpi_clamp_voltage(inst, "voltage", &inst->real[VR_voltage]);
}

int model_input_ok(const Instance *inst, fmi2ValueReference vr, double value)
{
    (void)vr;                            /* inside the range, hence finite */
    return value >= inst->real[VR_voltage_min] && !(value > inst->real[VR_voltage_max]);
}

fmi2Status model_accept_input(Instance *inst, fmi2ValueReference vr, double *value)
{
    (void)vr;                            /* the only input: voltage */
    return mpi_clamp_voltage(inst, "voltage", value);
}

int model_outputs_hold(const Instance *inst)
{
    (void)inst;                          /* play operators: idempotent update */
    return 1;
}

LAYER_HOT fmi2Status model_update(Instance *inst)
{
    const HystModel hysteresis = MPI_MODEL(inst->real);
    /* inline: operator count and kind are constants here, so it unrolls */
    const double displacement = hyst_evaluate(&hysteresis, inst->real[VR_voltage], inst->memory,
                                              inst->scratch);
    inst->real[VR_displacement] = displacement;
    return fmi2OK;
}
