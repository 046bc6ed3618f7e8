/*
 * model.c (plant) -- the hooks of the FMI layer for the MPI plant.
 *
 *     h_k = H[voltage]_k            (hyst_output, one sample per step)
 *     displacement_k = h_k          (MPI model), or for an extended model
 *     displacement_k = S[h, u]_k    (ostage_step: the output stages, with
 *                                    u = voltage - input_offset and the time
 *                                    t_k = k * sample period, k committed steps)
 *
 * One step is one sample.  The stages are discrete at the model's sample
 * period, so an extended plant steps at that period only (the layer refuses
 * other step sizes).  At the first sample they start at rest, as if that
 * sample's input had been held since forever -- what ExtendedModel.simulate
 * does -- so the FMU and the Python model compute the same numbers.
 *
 * The stage coefficients are checked once, when the parameters are
 * (model_prepare: fmi2ExitInitializationMode, fmi2SetFMUstate); an invalid
 * set is refused there with fmi2Error and a message.  The per-step path
 * (model_update) checks nothing and copies no stage state: the output for the
 * pending input is computed from the committed state, the state after it is
 * written into the tentative buffer, and fmi2DoStep commits it by the
 * layer's buffer swap (see ModelData in model.h for the delay line).
 */
#include "fmi2_layer.h"

#ifdef MODEL_HAS_OUTPUT_STAGES
static const double stage_sections[] = MODEL_SECTIONS;
static const double stage_creep_alpha[] = MODEL_CREEP_ALPHA;
static const double stage_creep_beta[] = MODEL_CREEP_BETA;

/* Points the stages at their coefficients -- the built-in ones and the
 * parameters creep_weight[] and drift[] in place -- and checks them: the one
 * check of the stages, which the per-step path relies on. */
static fmi2Status prepare_stages(Instance *inst)
{
    OutputStages *s = &inst->model.stages;
    s->n_sections = MODEL_N_SECTIONS;
    s->sections = stage_sections;
    s->delay_whole = MODEL_DELAY_WHOLE;
    s->delay_fraction = MODEL_DELAY_FRACTION;
    s->n_creep = MODEL_N_CREEP;
    s->creep_alpha = stage_creep_alpha;
    s->creep_beta = stage_creep_beta;
#if MODEL_N_CREEP > 0
    s->creep_weights = &inst->real[VR_creep_weight];
#else
    s->creep_weights = NULL;
#endif
    s->n_drift = MODEL_N_DRIFT;
#if MODEL_N_DRIFT > 0
    s->drift = &inst->real[VR_drift];
#else
    s->drift = NULL;
#endif
    s->drift_span = MODEL_DRIFT_SPAN;
    const int status = ostage_check(s);
    if (status != OSTAGE_OK) {
        layer_log(inst, fmi2Error, LAYER_LOG_ERROR, "invalid output stages: %s", ostage_message(status));
        return fmi2Error;
    }
    if (ostage_state_size(s) != (size_t)MODEL_STAGE_STATE_SIZE) {
        layer_log(inst, fmi2Error, LAYER_LOG_ERROR,
                  "the output stages need %lu state values, but the FMU was built with %d",
                  (unsigned long)ostage_state_size(s), MODEL_STAGE_STATE_SIZE);
        return fmi2Error;
    }
    return fmi2OK;
}
#endif

void model_reset(Instance *inst)
{
    /* memory all zero: demagnetised, k = 0 */
#ifdef MODEL_HAS_OUTPUT_STAGES
    inst->model.buffers_paired = 0;
#else
    (void)inst;
#endif
}

fmi2Status model_prepare(Instance *inst)
{
#ifdef MODEL_HAS_OUTPUT_STAGES
    inst->model.buffers_paired = 0;      /* the committed memory may have been replaced */
#endif
    if (mpi_check_parameters(inst) != fmi2OK) {
        return fmi2Error;
    }
#ifdef MODEL_HAS_OUTPUT_STAGES
    if (prepare_stages(inst) != fmi2OK) {
        return fmi2Error;
    }
#endif
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
    (void)inst;
#ifdef MODEL_HAS_OUTPUT_STAGES
    return 0;                            /* the stages move on with every sample */
#else
    return 1;                            /* play operators: idempotent update */
#endif
}

LAYER_HOT fmi2Status model_update(Instance *inst)
{
    const HystModel hysteresis = MPI_MODEL(inst->real);
    const double voltage = inst->real[VR_voltage];
    const double h = hyst_output(&hysteresis, voltage, inst->memory, inst->scratch);
#ifdef MODEL_HAS_OUTPUT_STAGES
    ModelData *model = &inst->model;
    const double k = inst->memory[MODEL_STEP_COUNT];
    const double u = voltage - inst->real[VR_input_offset];
    const double *state = &inst->memory[MODEL_STAGE_MEMORY];
    double *next = &inst->scratch[MODEL_STAGE_MEMORY];
    if (k == 0.0) {
        /* first sample: the stages at rest at this sample's input, stepped in
         * place in the tentative buffer -- whose delay line the committed
         * buffer does not share */
        ostage_rest(&model->stages, h, u, next);
        state = next;
        model->buffers_paired = 0;
    } else if (!model->buffers_paired) {
        /* once per run (and after a restored state): pair the buffers */
        memcpy(next, state, sizeof(double) * MODEL_STAGE_STATE_SIZE);
        model->buffers_paired = 1;
    }
    inst->real[VR_displacement] = ostage_step(&model->stages, state, h, u, k * MODEL_SAMPLE_PERIOD, next);
    inst->scratch[MODEL_STEP_COUNT] = k + 1.0;
#else
    inst->real[VR_displacement] = h;
#endif
    return fmi2OK;
}
