/*
 * hysteresis.c -- see hysteresis.h.  Kept free of libm so that every target
 * (gcc, clang, zig for Windows/Linux/macOS) computes bit-identical results;
 * build with -ffp-contract=off so no compiler fuses a*b+c.
 */
#include "hysteresis.h"

/* Operators go through a local block: the compiler then knows that the new
 * states overlap neither the old ones nor the parameters and packs the min/max
 * into vector instructions (an FMU, whose operator count is a compile-time
 * constant, gets it unrolled); the weighted sum keeps its left-to-right order,
 * so every build adds in the same order and gives the same bits. */
#define HYST_BLOCK 32

HYST_API double hyst_output(const HystModel *m, double voltage,
                            const double *state, double *new_state)
{
    const double u = voltage - m->input_offset;
    double y = (m->a1 * u * u + m->a2) * u;
    for (int start = 0; start < m->n_operators; start += HYST_BLOCK) {
        const int rest = m->n_operators - start;
        const int count = rest < HYST_BLOCK ? rest : HYST_BLOCK;
        double w[HYST_BLOCK];
        for (int i = 0; i < count; i++) {
            w[i] = hyst_operator_step(m->operator_kind, u, m->thresholds[start + i], state[start + i]);
        }
        for (int i = 0; i < count; i++) {
            y += m->weights[start + i] * w[i];
        }
        for (int i = 0; i < count; i++) {
            new_state[start + i] = w[i];
        }
    }
    return y + m->output_offset;
}

/* hyst_output in place, in one pass: with a run-time operator count the
 * local block only adds loop overhead, so a record loop (the host library's)
 * updates its state directly.  Same operations in the same order as
 * hyst_output, hence the same bits (tested).  threshold_scale multiplies every
 * threshold at this sample (1.0 leaves each one's bits as they are). */
static double output_in_place(const HystModel *m, double voltage, double threshold_scale, double *state)
{
    const double u = voltage - m->input_offset;
    double y = (m->a1 * u * u + m->a2) * u;
    for (int i = 0; i < m->n_operators; i++) {
        state[i] = hyst_operator_step(m->operator_kind, u, m->thresholds[i] * threshold_scale, state[i]);
        y += m->weights[i] * state[i];
    }
    return y + m->output_offset;
}

HYST_API void hyst_simulate_scaled(const HystModel *m, size_t n_samples,
                                   const double *voltage, const double *threshold_scale,
                                   double *state, double *displacement, double *operator_outputs)
{
    const size_t n = (size_t)m->n_operators;
    for (size_t k = 0; k < n_samples; k++) {
        const double scale = threshold_scale ? threshold_scale[k] : 1.0;
        displacement[k] = output_in_place(m, voltage[k], scale, state);
        if (operator_outputs) {
            for (size_t i = 0; i < n; i++) {
                operator_outputs[k * n + i] = state[i];
            }
        }
    }
}

HYST_API void hyst_simulate(const HystModel *m, size_t n_samples,
                            const double *voltage, double *state,
                            double *displacement, double *operator_outputs)
{
    hyst_simulate_scaled(m, n_samples, voltage, NULL, state, displacement, operator_outputs);
}

/* h(u) - target for the shifted input u, with the operator state frozen at
 * `state` (the output the forward model would give for u). */
static double residual(const HystModel *m, const double *state, double u, double target)
{
    double y = (m->a1 * u * u + m->a2) * u + m->output_offset;
    for (int i = 0; i < m->n_operators; i++) {
        y += m->weights[i] * hyst_operator_step(m->operator_kind, u, m->thresholds[i], state[i]);
    }
    return y - target;
}

/* Between two neighbouring breakpoints every operator is either pinned to its
 * memory or follows the input, so h(u) = a1 u^3 + slope u + constant there.
 * Classifies the operators at u_mid and returns slope and constant. */
static void segment_polynomial(const HystModel *m, const double *state, double u_mid,
                               double *slope, double *constant)
{
    const double s = (m->operator_kind == HYST_PLAY) ? 1.0 : 0.0;
    double k = m->a2;
    double c = m->output_offset;
    for (int i = 0; i < m->n_operators; i++) {
        const double r = m->thresholds[i];
        const double b = m->weights[i];
        if (u_mid < state[i] - s * r) {          /* pushed down by the input */
            k += b;
            c += b * s * r;
        } else if (u_mid > state[i] + r) {       /* pulled up by the input */
            k += b;
            c -= b * r;
        } else {                                 /* holds its memory */
            c += b * state[i];
        }
    }
    *slope = k;
    *constant = c;
}

/* Root of a1 u^3 + k u + c0 = 0 in [a, b] given f(a) <= 0 <= f(b):
 * Newton's method, kept inside the bracket by bisection. */
static double solve_cubic_in_bracket(double a1, double k, double c0, double a, double b)
{
    if (a1 == 0.0) {
        if (k <= 0.0) {
            return 0.5 * (a + b);
        }
        const double u = -c0 / k;
        return u < a ? a : (u > b ? b : u);
    }
    double u = 0.5 * (a + b);
    for (int iter = 0; iter < 200; iter++) {
        const double f = (a1 * u * u + k) * u + c0;
        if (f == 0.0) {
            return u;
        }
        if (f < 0.0) {
            a = u;
        } else {
            b = u;
        }
        const double df = 3.0 * a1 * u * u + k;
        double next = (df > 0.0) ? u - f / df : 0.5 * (a + b);
        if (!(next > a && next < b)) {
            next = 0.5 * (a + b);
        }
        if (next == u || b - a <= 0.0) {
            return next;
        }
        u = next;
        if (!(a < u && u < b)) {
            break;
        }
    }
    return u;
}

HYST_API int hyst_invert(const HystModel *m, double displacement,
                         const double *state, double v_lo, double v_hi,
                         double *voltage, double *new_state)
{
    const double s = (m->operator_kind == HYST_PLAY) ? 1.0 : 0.0;
    double a = v_lo - m->input_offset;
    double b = v_hi - m->input_offset;
    int status = HYST_INVERSE_OK;
    double u;

    const double f_a = residual(m, state, a, displacement);
    const double f_b = residual(m, state, b, displacement);
    if (f_a >= 0.0) {
        u = a;
        status = (f_a > 0.0) ? HYST_INVERSE_BELOW : HYST_INVERSE_OK;
    } else if (f_b <= 0.0) {
        u = b;
        status = (f_b < 0.0) ? HYST_INVERSE_ABOVE : HYST_INVERSE_OK;
    } else {
        /* Shrink [a, b] onto one smooth piece: each pass moves an end onto the
         * breakpoint inside the bracket that lies nearest the secant estimate,
         * so it ends after at most 2n passes, usually after very few. */
        double fa = f_a, fb = f_b;
        for (int pass = 0; pass <= 2 * m->n_operators; pass++) {
            const double guess = a + (b - a) * (-fa / (fb - fa));
            double best = 0.0, best_distance = -1.0;
            for (int i = 0; i < m->n_operators; i++) {
                const double r = m->thresholds[i];
                const double candidates[2] = { state[i] - s * r, state[i] + r };
                for (int j = 0; j < 2; j++) {
                    const double p = candidates[j];
                    if (p > a && p < b) {
                        const double d = (p > guess) ? p - guess : guess - p;
                        if (best_distance < 0.0 || d < best_distance) {
                            best = p;
                            best_distance = d;
                        }
                    }
                }
            }
            if (best_distance < 0.0) {
                break;                      /* no breakpoint left inside */
            }
            const double f_p = residual(m, state, best, displacement);
            if (f_p == 0.0) {
                a = b = best;
                break;
            }
            if (f_p < 0.0) {
                a = best;
                fa = f_p;
            } else {
                b = best;
                fb = f_p;
            }
        }
        if (a == b) {
            u = a;
        } else {
            double slope, constant;
            segment_polynomial(m, state, 0.5 * (a + b), &slope, &constant);
            u = solve_cubic_in_bracket(m->a1, slope, constant - displacement, a, b);
        }
    }
    for (int i = 0; i < m->n_operators; i++) {
        new_state[i] = hyst_operator_step(m->operator_kind, u, m->thresholds[i], state[i]);
    }
    *voltage = u + m->input_offset;
    return status;
}

HYST_API size_t hyst_invert_run(const HystModel *m, size_t n_samples,
                                const double *displacement, double *state,
                                double v_lo, double v_hi, double *voltage)
{
    size_t saturated = 0;
    for (size_t k = 0; k < n_samples; k++) {
        if (hyst_invert(m, displacement[k], state, v_lo, v_hi, &voltage[k], state) != HYST_INVERSE_OK) {
            saturated++;
        }
    }
    return saturated;
}

HYST_API void hyst_invert_previous_sample_run(const HystModel *inverse_pi,
                                              double a1, double input_offset,
                                              double output_offset,
                                              size_t n_samples,
                                              const double *displacement,
                                              double *inverse_state,
                                              double *u_prev, double v_lo,
                                              double v_hi, double *voltage)
{
    const double u_lo = v_lo - input_offset;
    const double u_hi = v_hi - input_offset;
    double up = *u_prev;
    for (size_t k = 0; k < n_samples; k++) {
        /* Fig. 7: w = y_d - a1 v^3 with v taken from the previous sample. */
        const double w = displacement[k] - output_offset - a1 * up * up * up;
        double u = hyst_output(inverse_pi, w, inverse_state, inverse_state);
        u = u < u_lo ? u_lo : (u > u_hi ? u_hi : u);
        voltage[k] = u + input_offset;
        up = u;
    }
    *u_prev = up;
}
