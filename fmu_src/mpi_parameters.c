/*
 * mpi_parameters.c -- the mathematics of the MPI parameters and, in the
 * FMUs, their checks as FMI variables (see mpi_parameters.h).  Runs at
 * fmi2ExitInitializationMode, never per step.  No libm; build with
 * -ffp-contract=off: the error-free transformations below need every sum
 * and product rounded on its own.
 */
#include "mpi_parameters.h"

#ifdef MPI_HOST_LIBRARY
#include "output_stages.h"
#else
#include "fmi2_layer.h"
#endif

/* ------------------------------------------------------ exact slope signs
 * Knuth's TwoSum and Dekker's TwoProduct (with Veltkamp's split) turn the
 * sum or the product of two doubles into two doubles whose sum is exactly
 * the result; Shewchuk's expansions keep a sum of many doubles exactly, as
 * non-overlapping components of increasing magnitude, the sign of the sum
 * being that of the last (largest) component.  Exact in IEEE double with
 * round-to-nearest, barring overflow and underflow (see exact_range). */

static void two_sum(double a, double b, double *sum, double *error)
{
    const double s = a + b;
    const double b_virtual = s - a;
    const double a_virtual = s - b_virtual;
    *error = (a - a_virtual) + (b - b_virtual);
    *sum = s;
}

static void split(double a, double *high, double *low)
{
    const double c = 134217729.0 * a;           /* 2^27 + 1 */
    const double big = c - a;
    *high = c - big;
    *low = a - *high;
}

static void two_product(double a, double b, double *product, double *error)
{
    const double p = a * b;
    double a_high, a_low, b_high, b_low;
    split(a, &a_high, &a_low);
    split(b, &b_high, &b_low);
    const double e1 = p - a_high * b_high;
    const double e2 = e1 - a_low * b_high;
    const double e3 = e2 - a_high * b_low;
    *error = a_low * b_low - e3;
    *product = p;
}

/* Adds x to the expansion e[0..length) in place; returns the new length, at
 * most length + 1 (zero components are dropped; an exact zero is one). */
static int grow_expansion(double *e, int length, double x)
{
    double q = x;
    int out = 0;
    for (int i = 0; i < length; i++) {
        double sum, error;
        two_sum(q, e[i], &sum, &error);
        q = sum;
        if (error != 0.0) {
            e[out++] = error;
        }
    }
    if (q != 0.0 || out == 0) {
        e[out++] = q;
    }
    return out;
}

/* Magnitudes for which the products in slope_positive are exact: no
 * overflow in the split, no underflow in the error terms. */
static int exact_range(double x)
{
    const double m = x < 0.0 ? -x : x;
    return x == 0.0 || (m >= 1e-70 && m <= 1e70);
}

/* Is sum + 3 a1 u^2 > 0, with sum[0..length) an expansion?  Exactly when a1
 * and u are in exact_range, else by the rounded slope.  total: workspace of
 * length + 8 doubles. */
static int slope_positive(const double *sum, int length, double a1, double u, double rounded,
                          double *total)
{
    if (!exact_range(a1) || !exact_range(u)) {
        return rounded > 0.0;
    }
    for (int i = 0; i < length; i++) {
        total[i] = sum[i];
    }
    double square[2];
    two_product(u, u, &square[0], &square[1]);                /* u^2 = square[0] + square[1] */
    for (int i = 0; i < 2; i++) {
        double term[2];
        two_product(a1, square[i], &term[0], &term[1]);      /* a1 u^2: four terms */
        for (int j = 0; j < 2; j++) {
            length = grow_expansion(total, length, term[j]); /* 3 t = t + 2 t */
            length = grow_expansion(total, length, 2.0 * term[j]);
        }
    }
    return total[length - 1] > 0.0;
}

/* ---------------------------------------------------------- invertibility */

/* Where on [u_from, u_to] the slope S + 3 a1 u^2 is smallest (as
 * pysim.core.invertibility picks it: the end of the u^2 range). */
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

HYST_API void mpi_invertibility(const HystModel *m, double voltage_min, double voltage_max, double *work,
                                MpiInvertibility *result)
{
    const int n = m->n_operators;
    const double *r = m->thresholds;
    const double *b = m->weights;
    const double a1 = m->a1;
    const double u_lo = voltage_min - m->input_offset;
    const double u_hi = voltage_max - m->input_offset;
    const double span = u_hi - u_lo;
    /* a classical play operator's band is 2 r wide, a one-sided one's r */
    const double band = (m->operator_kind == HYST_PLAY) ? 2.0 : 1.0;
    double slope_sum = m->a2;           /* a2 + weights of the k narrowest operators, rounded */
    double *sum = work;                 /* ... and exactly (at most n + 1 components) */
    double *total = work + n + 1;
    int length = grow_expansion(sum, 0, m->a2);
    int found = 0;
    result->invertible = 1;
    result->descending = 0;
    result->n_active = 0;
    result->min_slope = 0.0;
    result->worst_voltage = 0.0;

    /* With the thresholds ascending, "k operators follow the input" means the
     * distance d travelled since the last reversal satisfies
     * band r[k-1] < d <= band r[k]; d ranges over (0, span]. */
    for (int k = 0; k <= n; k++) {
        const double lower = (k > 0) ? band * r[k - 1] : 0.0;
        if (k > 0) {
            slope_sum += b[k - 1];
            length = grow_expansion(sum, length, b[k - 1]);
        }
        if ((k < n && band * r[k] <= lower) || (k > 0 && lower >= span)) {
            continue;                   /* no distance gives exactly k */
        }
        for (int descending = 0; descending <= 1; descending++) {
            const double u_from = descending ? u_lo : u_lo + lower;
            const double u_to = descending ? u_hi - lower : u_hi;
            const double u = worst_input(a1, u_from, u_to);
            const double slope = slope_sum + 3.0 * a1 * (u * u);
            if (!found || slope < result->min_slope) {
                found = 1;
                result->descending = descending;
                result->n_active = k;
                result->min_slope = slope;
                result->worst_voltage = u + m->input_offset;
            }
            if (result->invertible && !slope_positive(sum, length, a1, u, slope, total)) {
                result->invertible = 0;
            }
        }
    }
}

/* ------------------------------------------------------- analytic inverse */

HYST_API int mpi_inverse_parameters(const HystModel *m, HystModel *inverse, double *r_hat, double *b_hat,
                                    double *failed_sum)
{
    const int n = m->n_operators;
    const double *r = m->thresholds;
    const double *b = m->weights;
    const double a2 = m->a2;
    /* Every a2 + (b_1 + ... + b_j) is a2 plus the running partial sum (the
     * order of numpy's cumsum, so that both give the same bits). */
    double partial = 0.0;
    for (int j = 0; j <= n; j++) {
        if (j > 0) {
            partial += b[j - 1];
        }
        const double sum = a2 + partial;
        if (!(sum > 0.0)) {
            if (failed_sum != NULL) {
                *failed_sum = sum;
            }
            return j;
        }
    }
    partial = 0.0;
    double before = a2 + partial;       /* a2 + sum_{i<j} b_i */
    for (int j = 0; j < n; j++) {
        partial += b[j];
        const double after = a2 + partial;
        double shift = 0.0;             /* sum_{i<j} b_i (r_j - r_i) */
        for (int i = 0; i < j; i++) {
            shift += b[i] * (r[j] - r[i]);
        }
        r_hat[j] = a2 * r[j] + shift;
        b_hat[j] = -b[j] / (before * after);
        before = after;
    }
    inverse->operator_kind = m->operator_kind;
    inverse->n_operators = n;
    inverse->a1 = 0.0;
    inverse->a2 = 1.0 / a2;
    inverse->input_offset = m->output_offset;
    inverse->output_offset = m->input_offset;
    inverse->thresholds = r_hat;
    inverse->weights = b_hat;
    return -1;
}

#ifdef MPI_HOST_LIBRARY
/* ----------------------------------------------------- host library only */

typedef struct {
    const char *structure;
    const char *field;
    size_t offset;
    size_t size;
} LayoutEntry;

#define LAYOUT_STRUCT(type) { #type, NULL, 0, sizeof(type) }
#define LAYOUT_FIELD(type, name) { #type, #name, offsetof(type, name), sizeof(((type *)0)->name) }

static const LayoutEntry layout[] = {
    LAYOUT_STRUCT(HystModel),
    LAYOUT_FIELD(HystModel, operator_kind),
    LAYOUT_FIELD(HystModel, n_operators),
    LAYOUT_FIELD(HystModel, a1),
    LAYOUT_FIELD(HystModel, a2),
    LAYOUT_FIELD(HystModel, input_offset),
    LAYOUT_FIELD(HystModel, output_offset),
    LAYOUT_FIELD(HystModel, thresholds),
    LAYOUT_FIELD(HystModel, weights),
    LAYOUT_STRUCT(OutputStages),
    LAYOUT_FIELD(OutputStages, n_sections),
    LAYOUT_FIELD(OutputStages, sections),
    LAYOUT_FIELD(OutputStages, delay_whole),
    LAYOUT_FIELD(OutputStages, delay_fraction),
    LAYOUT_FIELD(OutputStages, n_creep),
    LAYOUT_FIELD(OutputStages, creep_alpha),
    LAYOUT_FIELD(OutputStages, creep_beta),
    LAYOUT_FIELD(OutputStages, creep_weights),
    LAYOUT_FIELD(OutputStages, n_drift),
    LAYOUT_FIELD(OutputStages, drift),
    LAYOUT_FIELD(OutputStages, drift_span),
    LAYOUT_STRUCT(MpiInvertibility),
    LAYOUT_FIELD(MpiInvertibility, invertible),
    LAYOUT_FIELD(MpiInvertibility, descending),
    LAYOUT_FIELD(MpiInvertibility, n_active),
    LAYOUT_FIELD(MpiInvertibility, min_slope),
    LAYOUT_FIELD(MpiInvertibility, worst_voltage),
};

HYST_API int mpi_host_layout(size_t index, const char **structure, const char **field, size_t *offset,
                             size_t *size)
{
    if (index >= sizeof layout / sizeof layout[0]) {
        return 0;
    }
    *structure = layout[index].structure;
    *field = layout[index].field;
    *offset = layout[index].offset;
    *size = layout[index].size;
    return 1;
}

HYST_API long mpi_host_max_delay(void)
{
    return OSTAGE_MAX_DELAY;
}

#else
/* --------------------------------------------- FMUs: the FMI parameters */

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

fmi2Status mpi_check_invertible(struct Instance *inst)
{
    const double *real = inst->real;
    const HystModel model = MPI_MODEL(real);
    double work[MPI_INVERTIBILITY_WORK(MODEL_N_OPERATORS)];
    MpiInvertibility result;
    mpi_invertibility(&model, real[VR_voltage_min], real[VR_voltage_max], work, &result);
    if (!result.invertible) {
        layer_log(inst, fmi2Error, LAYER_LOG_ERROR,
                  "model not invertible: on the %s branch with %d operator(s) following the input "
                  "the slope falls to %.6g um/V at %.6g V (inside [%g, %g] V)",
                  result.descending ? "descending" : "ascending", result.n_active, result.min_slope,
                  result.worst_voltage, real[VR_voltage_min], real[VR_voltage_max]);
        return fmi2Error;
    }
    return fmi2OK;
}

fmi2Status mpi_analytic_inverse(struct Instance *inst, HystModel *inverse,
                                double *r_hat, double *b_hat)
{
    const HystModel model = MPI_MODEL(inst->real);
    double failed_sum = 0.0;
    const int failed = mpi_inverse_parameters(&model, inverse, r_hat, b_hat, &failed_sum);
    if (failed >= 0) {
        layer_log(inst, fmi2Error, LAYER_LOG_ERROR,
                  "no analytic inverse: a2 plus the first %d weight(s) is %.17g um/V; it must stay positive",
                  failed, failed_sum);
        return fmi2Error;
    }
    /* the Fig. 7 loop (hyst_invert_previous_sample_run) applies the offsets */
    inverse->input_offset = 0.0;
    inverse->output_offset = 0.0;
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

#endif /* MPI_HOST_LIBRARY */
