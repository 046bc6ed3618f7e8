/*
 * input_stages.h -- stages that act on the voltage before the hysteresis and
 * that have no closed form the host could vectorise: today the amplifier's
 * slew limit, as the diagnosis fits it (pysim.core.input_stage.slew_limit).
 *
 * Pure C99, no allocation, no I/O, no libm; build with -ffp-contract=off so
 * that every target computes bit-identical results.
 */
#ifndef PIEZO_INPUT_STAGES_H
#define PIEZO_INPUT_STAGES_H

#include <stddef.h>

#ifdef __cplusplus
extern "C" {
#endif

/* Exported like the hysteresis kernel: the host library for Python defines
 * HYST_API to make the symbols visible. */
#ifndef ISTAGE_API
#ifdef HYST_API
#define ISTAGE_API HYST_API
#else
#define ISTAGE_API
#endif
#endif

/* The command v[0..n-1] (V) followed at most max_change (V) per sample, from
 * rest at v[0]:  x_0 = v_0;  x_k = x_{k-1} + max_change if v_k > x_{k-1} + max_change,
 * x_{k-1} - max_change if v_k < x_{k-1} - max_change, else v_k.  max_change > 0
 * and finite (the caller checks); out may not alias v.  Nothing is done for
 * n = 0 or a NULL array. */
ISTAGE_API void istage_slew_limit(size_t n, const double *v, double max_change, double *out);

#ifdef __cplusplus
}
#endif

#endif
