/*
 * output_stages.c -- see output_stages.h.  No libm: finiteness is tested as
 * x - x == 0 (false for NaN and infinities).  Build with -ffp-contract=off.
 */
#include "output_stages.h"

static int finite(double x)
{
    return x - x == 0.0;
}

static int all_finite(const double *values, size_t n)
{
    for (size_t i = 0; i < n; i++) {
        if (!finite(values[i])) {
            return 0;
        }
    }
    return 1;
}

static int has_delay(const OutputStages *s)
{
    return s->delay_whole > 0 || s->delay_fraction > 0.0;
}

OSTAGE_API int ostage_check(const OutputStages *s)
{
    if (s == NULL) {
        return OSTAGE_NULL_ARRAY;
    }
    if (s->n_sections < 0 || s->delay_whole < 0 || s->n_creep < 0 || s->n_drift < 0
        || s->delay_whole > OSTAGE_MAX_DELAY) {
        return OSTAGE_BAD_COUNT;
    }
    if ((s->n_sections > 0 && s->sections == NULL)
        || (s->n_creep > 0 && (s->creep_alpha == NULL || s->creep_beta == NULL
                               || s->creep_weights == NULL))
        || (s->n_drift > 0 && s->drift == NULL)) {
        return OSTAGE_NULL_ARRAY;
    }
    if (!(s->delay_fraction >= 0.0 && s->delay_fraction < 1.0)) {
        return OSTAGE_BAD_FRACTION;
    }
    if (!(finite(s->drift_span) && s->drift_span >= 0.0)) {
        return OSTAGE_BAD_SPAN;
    }
    if (!all_finite(s->sections, 5 * (size_t)s->n_sections)
        || !all_finite(s->creep_alpha, (size_t)s->n_creep)
        || !all_finite(s->creep_beta, (size_t)s->n_creep)
        || !all_finite(s->creep_weights, (size_t)s->n_creep)
        || !all_finite(s->drift, (size_t)s->n_drift)) {
        return OSTAGE_NOT_FINITE;
    }
    for (int i = 0; i < s->n_sections; i++) {
        const double *c = s->sections + 5 * i;
        if (1.0 + c[3] + c[4] == 0.0) {
            return OSTAGE_NO_EQUILIBRIUM;
        }
    }
    for (int j = 0; j < s->n_creep; j++) {
        if (s->creep_alpha[j] == 1.0) {
            return OSTAGE_NO_EQUILIBRIUM;
        }
    }
    return OSTAGE_OK;
}

OSTAGE_API const char *ostage_message(int status)
{
    switch (status) {
    case OSTAGE_OK:
        return "output stages are valid";
    case OSTAGE_BAD_COUNT:
        return "a section, delay, creep or drift count is negative (or the delay line is too long)";
    case OSTAGE_NULL_ARRAY:
        return "a coefficient array is missing";
    case OSTAGE_BAD_FRACTION:
        return "the delay fraction must lie in [0, 1)";
    case OSTAGE_NOT_FINITE:
        return "a coefficient is NaN or infinite";
    case OSTAGE_NO_EQUILIBRIUM:
        return "a section or creep mode has a pole at z = 1 (no rest state)";
    case OSTAGE_BAD_SPAN:
        return "the drift span must be a finite number of seconds >= 0";
    default:
        return "unknown output-stage status";
    }
}

/* State size of a checked spec. */
static size_t state_size(const OutputStages *s)
{
    size_t n = 2 * (size_t)s->n_sections;
    if (has_delay(s)) {
        n += 2 + (size_t)s->delay_whole;
    }
    if (s->n_creep > 0) {
        n += 1 + (size_t)s->n_creep;
    }
    return n;
}

OSTAGE_API size_t ostage_state_size(const OutputStages *s)
{
    return ostage_check(s) == OSTAGE_OK ? state_size(s) : 0;
}

OSTAGE_API void ostage_rest(const OutputStages *s, double h0, double u0, double *state)
{
    double g = h0;
    size_t k = 0;
    for (int i = 0; i < s->n_sections; i++) {
        const double *c = s->sections + 5 * i;
        /* steady state of the transposed direct form II for input g */
        const double out = g * ((c[0] + c[1] + c[2]) / (1.0 + c[3] + c[4]));
        const double s2 = c[2] * g - c[4] * out;
        const double s1 = c[1] * g - c[3] * out + s2;
        state[k++] = s1;
        state[k++] = s2;
        g = out;
    }
    if (has_delay(s)) {
        state[k++] = 0.0;
        for (int i = 0; i <= s->delay_whole; i++) {
            state[k++] = g;
        }
    }
    if (s->n_creep > 0) {
        state[k++] = u0;
        for (int j = 0; j < s->n_creep; j++) {
            /* rest: c = alpha c + beta 2 u0 */
            state[k++] = (2.0 * s->creep_beta[j] * u0) / (1.0 - s->creep_alpha[j]);
        }
    }
}

OSTAGE_API void ostage_init(const OutputStages *s, double h0, double u0, double *state)
{
    if (ostage_check(s) != OSTAGE_OK || state == NULL) {
        return;
    }
    ostage_rest(s, h0, u0, state);
}

OSTAGE_API double ostage_step(const OutputStages *s, const double *state, double h, double u, double t,
                              double *next)
{
    size_t k = 0;
    double g = h;
    for (int i = 0; i < s->n_sections; i++) {
        const double *c = s->sections + 5 * i;
        const double s1 = state[k];
        const double s2 = state[k + 1];
        const double y = c[0] * g + s1;
        if (next != NULL) {
            next[k] = c[1] * g - c[3] * y + s2;
            next[k + 1] = c[2] * g - c[4] * y;
        }
        k += 2;
        g = y;
    }
    double y = g;
    if (has_delay(s)) {
        const size_t length = (size_t)s->delay_whole + 1;
        const double stored = state[k];
        /* a corrupted position (set from outside) is reset, never used as an index */
        const size_t pos = (stored >= 0.0 && stored < (double)length) ? (size_t)stored : 0;
        const size_t following = (pos + 1 == length) ? 0 : pos + 1;
        const double *line = state + k + 1;
        const double older = line[pos];
        const double newer = (s->delay_whole == 0) ? g : line[following];
        y = (1.0 - s->delay_fraction) * newer + s->delay_fraction * older;
        if (next != NULL) {
            double *next_line = next + k + 1;
            if (next != state) {
                /* the one slot a lagging buffer misses: the one sample k-1 wrote */
                const size_t last = (pos == 0 ? length : pos) - 1;
                next_line[last] = line[last];
            }
            next_line[pos] = g;
            next[k] = (double)following;
        }
        k += 1 + length;
    }
    if (s->n_creep > 0) {
        const double u_prev = state[k];
        double creep = 0.0;
        for (size_t j = 0; j < (size_t)s->n_creep; j++) {
            const double c = s->creep_alpha[j] * state[k + 1 + j] + s->creep_beta[j] * (u + u_prev);
            creep += s->creep_weights[j] * c;
            if (next != NULL) {
                next[k + 1 + j] = c;
            }
        }
        if (next != NULL) {
            next[k] = u;
        }
        y += creep;
    }
    if (s->n_drift > 0) {
        const double td = (s->drift_span > 0.0 && t > s->drift_span) ? s->drift_span : t;
        double p = 0.0;
        for (int j = s->n_drift - 1; j >= 0; j--) {
            p = p * td + s->drift[j];
        }
        y += p * td;
    }
    return y;
}

OSTAGE_API double ostage_output(const OutputStages *s, const double *state, double h,
                                double u, double t, double *new_state)
{
    if (ostage_check(s) != OSTAGE_OK || state == NULL) {
        return h;
    }
    if (new_state != NULL && new_state != state) {
        /* any array: start from a copy (the plant FMU's double buffer needs
         * none, see ostage_step) */
        const size_t n = state_size(s);
        for (size_t i = 0; i < n; i++) {
            new_state[i] = state[i];
        }
        return ostage_step(s, new_state, h, u, t, new_state);
    }
    return ostage_step(s, state, h, u, t, new_state);
}

OSTAGE_API void ostage_run(const OutputStages *s, size_t n_samples, const double *h,
                           const double *u, const double *time, double *state, double *y)
{
    if (h == NULL || y == NULL) {
        return;
    }
    const int ok = ostage_check(s) == OSTAGE_OK && state != NULL
                   && (s->n_creep == 0 || u != NULL) && (s->n_drift == 0 || time != NULL);
    if (!ok) {
        for (size_t k = 0; k < n_samples; k++) {
            y[k] = h[k];                 /* an invalid spec passes h through */
        }
        return;
    }
    for (size_t k = 0; k < n_samples; k++) {
        y[k] = ostage_step(s, state, h[k], u ? u[k] : 0.0, time ? time[k] : 0.0, state);
    }
}
