/*
 * rig_part.h -- what the FMUs of the rig parts (amplifier, controller, sensor,
 * LTI system) share: the layout of their memory, the size of the step
 * just taken, clipping and the converter.
 *
 * Outputs are the values at the end of the step.  The shared FMI layer asks a
 * model for its outputs and its memory after the current inputs before it
 * knows the step size (model_update has no step argument), so these models
 * keep the step *pending*: the committed memory holds the state at the start
 * of the step, the inputs held over it and its start time, and the next call
 * of model_update -- at the end of the step, when the layer's time has moved
 * on by the step -- advances the state over [t_start, time) with those
 * inputs.  The step size is thus the difference of the two times; a
 * difference that equals the previous step or the nominal step (the one the
 * FMU was generated for) up to the rounding of time arithmetic is taken as
 * that step exactly, so a fixed-step run uses exactly the step it asked for.
 *
 * Memory layout (doubles): RIG_PENDING (1 once a step is pending), RIG_T_START
 * (s), RIG_STEP (s, the step last used, 0 before the first), then the model's
 * own state and the held inputs from RIG_HEAD on.
 */
#ifndef PIEZO_RIG_PART_H
#define PIEZO_RIG_PART_H

#include <math.h>
#include <stdint.h>

#include "model_config.h"

#define RIG_PENDING 0
#define RIG_T_START 1
#define RIG_STEP 2
#define RIG_HEAD 3

#define RIG_PI 3.141592653589793

/* Python's min(max(x, low), high), the same comparisons in the same order. */
double rig_clip(double x, double low, double high);
double rig_clip(double x, double low, double high)
{
    x = (low > x) ? low : x;
    return (high < x) ? high : x;
}

int rig_close(double a, double b, double now);
int rig_close(double a, double b, double now)
{
    const double error = a - b;
    const double tolerance = 1e-9 * b + 1e-15 * fabs(now);
    return error <= tolerance && error >= -tolerance;
}

/* Size (s) of the step from t_start to now: the previous step or the nominal
 * step if the difference is one of them up to the rounding of the importer's
 * time arithmetic, else the difference itself. */
double rig_step_size(double t_start, double now, double previous);
double rig_step_size(double t_start, double now, double previous)
{
    const double h = now - t_start;
    if (previous > 0.0 && rig_close(h, previous, now)) {
        return previous;
    }
    if (rig_close(h, MODEL_NOMINAL_STEP, now)) {
        return MODEL_NOMINAL_STEP;
    }
    return h;
}

/* A bits-bit converter over [low, high] with code step lsb (0 bits: ideal):
 * saturate, then round to the nearest code, ties to even (nearbyint under the
 * default rounding mode is Python's round). */
double rig_convert(double value, int bits, double low, double high, double lsb);
double rig_convert(double value, int bits, double low, double high, double lsb)
{
    const double x = rig_clip(value, low, high);
    if (bits == 0) {
        return x;
    }
    return low + nearbyint((x - low) / lsb) * lsb;
}

/* Code step of a bits-bit converter over [low, high] (0 for bits = 0). */
double rig_lsb(int bits, double low, double high);
double rig_lsb(int bits, double low, double high)
{
    return bits == 0 ? 0.0 : (high - low) / (double)((UINT64_C(1) << bits) - 1u);
}

/* A parameter that must be a whole number in [low, high]. */
int rig_whole(double x, double low, double high);
int rig_whole(double x, double low, double high)
{
    return x >= low && x <= high && x == floor(x);
}

#endif /* PIEZO_RIG_PART_H */
