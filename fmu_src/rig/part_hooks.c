/*
 * part_hooks.c -- the input hooks of the shared FMI layer, the same for every
 * rig part (amplifier, controller, sensor, LTI system): any finite input is
 * taken as given (the layer refuses NaN and infinities before the hooks), and
 * no part holds its outputs over a step (each output is the part's state or
 * the next sample), so the layer never skips a recomputation.
 */

int model_input_ok(const Instance *inst, fmi2ValueReference vr, double value)
{
    (void)inst;
    (void)vr;
    return layer_is_finite(value);
}

fmi2Status model_accept_input(Instance *inst, fmi2ValueReference vr, double *value)
{
    (void)inst;                      /* never called: model_input_ok accepts every finite input */
    (void)vr;
    (void)value;
    return fmi2OK;
}

int model_outputs_hold(const Instance *inst)
{
    (void)inst;                      /* the outputs move over a step */
    return 0;
}
