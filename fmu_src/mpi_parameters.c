/*
 * mpi_parameters.c -- checks and derived quantities of the MPI parameters
 * (see mpi_parameters.h).  Runs at fmi2ExitInitializationMode, never per step.
 */
#include "mpi_parameters.h"
#include "fmi2_layer.h"

fmi2Status mpi_check_parameters(struct Instance *inst)
{
    const double *real = inst->real;
    const double *r = &real[VR_r];
    for (int i = 0; i < MODEL_N_OPERATORS; i++) {
        if (!(r[i] >= 0.0)) {
            layer_log(inst, fmi2Error, LAYER_LOG_ERROR,
                      "invalid parameters: threshold r[%d] = %.17g V is negative", i + 1, r[i]);
            return fmi2Error;
        }
        if (i > 0 && r[i] < r[i - 1]) {
            layer_log(inst, fmi2Error, LAYER_LOG_ERROR,
                      "invalid parameters: thresholds must be ascending, but r[%d] = %.17g V < r[%d] = %.17g V",
                      i + 1, r[i], i, r[i - 1]);
            return fmi2Error;
        }
    }
    if (!(real[VR_voltage_min] < real[VR_voltage_max])) {
        layer_log(inst, fmi2Error, LAYER_LOG_ERROR,
                  "invalid parameters: voltage_min = %.17g V must be below voltage_max = %.17g V",
                  real[VR_voltage_min], real[VR_voltage_max]);
        return fmi2Error;
    }
    return fmi2OK;
}

/* Where on [u_from, u_to] the slope S + 3 a1 u^2 is smallest. */
static double worst_input(double a1, double u_from, double u_to)
{
    const double m_from = u_from < 0.0 ? -u_from : u_from;
    const double m_to = u_to < 0.0 ? -u_to : u_to;
    if (a1 < 0.0) {
        return m_from > m_to ? u_from : u_to;          /* largest |u| */
    }
    if (u_from <= 0.0 && 0.0 <= u_to) {
        return 0.0;                                    /* smallest |u| */
    }
    return m_from < m_to ? u_from : u_to;
}

fmi2Status mpi_check_invertible(struct Instance *inst)
{
    const double *real = inst->real;
    const double *r = &real[VR_r];
    const double *b = &real[VR_b];
    const double a1 = real[VR_a1];
    const double offset = real[VR_input_offset];
    const double u_lo = real[VR_voltage_min] - offset;
    const double u_hi = real[VR_voltage_max] - offset;
    const double span = u_hi - u_lo;
    /* a classical play operator's band is 2 r wide, a one-sided one's r */
    const double band = (MODEL_OPERATOR_KIND == HYST_PLAY) ? 2.0 : 1.0;
    double slope_sum = real[VR_a2];     /* a2 + weights of the k narrowest operators */

    /* With the thresholds ascending, "k operators follow the input" means the
     * distance d travelled since the last reversal satisfies
     * band r[k-1] < d <= band r[k]; d ranges over (0, span]. */
    for (int k = 0; k <= MODEL_N_OPERATORS; k++) {
        const double lower = (k > 0) ? band * r[k - 1] : 0.0;
        if (k > 0) {
            slope_sum += b[k - 1];
        }
        if ((k < MODEL_N_OPERATORS && band * r[k] <= lower) || (k > 0 && lower >= span)) {
            continue;                   /* no distance gives exactly k */
        }
        for (int descending = 0; descending <= 1; descending++) {
            const double u_from = descending ? u_lo : u_lo + lower;
            const double u_to = descending ? u_hi - lower : u_hi;
            const double u = worst_input(a1, u_from, u_to);
            const double slope = slope_sum + 3.0 * a1 * u * u;
            if (!(slope > 0.0)) {
                layer_log(inst, fmi2Error, LAYER_LOG_ERROR,
                          "model not invertible: on the %s branch with %d operator(s) following the input "
                          "the slope falls to %.6g um/V at %.6g V (inside [%g, %g] V)",
                          descending ? "descending" : "ascending", k, slope, u + offset,
                          real[VR_voltage_min], real[VR_voltage_max]);
                return fmi2Error;
            }
        }
    }
    return fmi2OK;
}

fmi2Status mpi_analytic_inverse(struct Instance *inst, HystModel *inverse,
                                double *r_hat, double *b_hat)
{
    const double *real = inst->real;
    const double *r = &real[VR_r];
    const double *b = &real[VR_b];
    const double a2 = real[VR_a2];
    double before = a2;                 /* a2 + sum_{i<j} b_i */
    for (int j = 0; j < MODEL_N_OPERATORS; j++) {
        const double after = before + b[j];
        if (!(before > 0.0) || !(after > 0.0)) {
            layer_log(inst, fmi2Error, LAYER_LOG_ERROR,
                      "no analytic inverse: a2 plus the first %d weight(s) is %.17g um/V; it must stay positive",
                      j + (before > 0.0 ? 1 : 0), before > 0.0 ? after : before);
            return fmi2Error;
        }
        double shift = 0.0;             /* sum_{i<j} b_i (r_j - r_i) */
        for (int i = 0; i < j; i++) {
            shift += b[i] * (r[j] - r[i]);
        }
        r_hat[j] = a2 * r[j] + shift;
        b_hat[j] = -b[j] / (before * after);
        before = after;
    }
    inverse->operator_kind = MODEL_OPERATOR_KIND;
    inverse->n_operators = MODEL_N_OPERATORS;
    inverse->a1 = 0.0;
    inverse->a2 = 1.0 / a2;
    inverse->input_offset = 0.0;
    inverse->output_offset = 0.0;
    inverse->thresholds = r_hat;
    inverse->weights = b_hat;
    return fmi2OK;
}

fmi2Status mpi_clamp_voltage(struct Instance *inst, const char *what, double *value)
{
    const double lo = inst->real[VR_voltage_min];
    const double hi = inst->real[VR_voltage_max];
    const double v = *value;
    if (v >= lo && v <= hi) {
        return fmi2OK;
    }
    *value = (v < lo) ? lo : hi;
    layer_log(inst, fmi2Warning, LAYER_LOG_WARNING,
              "%s = %.17g V is outside [%.17g, %.17g] V: clamped to %.17g V", what, v, lo, hi, *value);
    return fmi2Warning;
}
