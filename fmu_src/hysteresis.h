/*
 * hysteresis.h -- the one implementation of the play-operator recursion, the
 * (modified) Prandtl-Ishlinskii forward model and its exact per-sample inverse.
 *
 * Model (Gu, Zhu, Su, IEEE TIE 2014, eq. 7, extended with an input shift and an
 * output offset so that bipolar inputs and sensor offsets can be described):
 *
 *     u = v - input_offset                                  [V]
 *     y = a1 u^3 + a2 u + sum_i b_i F_{r_i}[u] + output_offset   [um]
 *
 * Operator kinds (state w_i, threshold r_i >= 0):
 *     HYST_OSP   one-sided play (eq. 3-4):  w = max(u - r, min(u,     w_prev))
 *     HYST_PLAY  classical play  (eq. 1-2): w = max(u - r, min(u + r, w_prev))
 * Both are "clamp w_prev into the band [u - r, u + s r]" with s = 0 or 1.
 *
 * The same file is compiled into every FMU and, for the host, into the shared
 * library that the Python package calls, so the FMUs and the Python model share
 * this code bit for bit.  Pure C99, no allocation, no I/O.
 */
#ifndef PIEZO_HYSTERESIS_H
#define PIEZO_HYSTERESIS_H

#include <stddef.h>

#ifdef __cplusplus
extern "C" {
#endif

/* Symbols are hidden in FMU builds (only fmi2* is exported there); the host
 * library for Python defines HYST_API to make them visible. */
#ifndef HYST_API
#define HYST_API
#endif

enum { HYST_OSP = 0, HYST_PLAY = 1 };

/* Status of hyst_invert. */
enum {
    HYST_INVERSE_OK = 0,         /* solved to machine precision */
    HYST_INVERSE_BELOW = 1,      /* target below h(u_lo): saturated at u_lo */
    HYST_INVERSE_ABOVE = 2       /* target above h(u_hi): saturated at u_hi */
};

typedef struct {
    int operator_kind;          /* HYST_OSP or HYST_PLAY */
    int n_operators;            /* number of operators, >= 0 */
    double a1;                  /* cubic coefficient, um/V^3 (0 for CPI) */
    double a2;                  /* linear coefficient, um/V */
    double input_offset;        /* V, subtracted from the voltage */
    double output_offset;       /* um, added to the displacement */
    const double *thresholds;   /* r_i, V, n_operators entries, each >= 0 */
    const double *weights;      /* b_i, um/V, n_operators entries */
} HystModel;

/* One operator update: clamp w_prev into [u - r, u + s r]. */
static inline double hyst_operator_step(int kind, double u, double r, double w_prev)
{
    const double lower = u - r;
    const double upper = (kind == HYST_PLAY) ? u + r : u;
    const double w = (w_prev < upper) ? w_prev : upper;
    return (w > lower) ? w : lower;
}

/* Displacement (um) for the input voltage (V) given the committed operator
 * state; writes the operator outputs for this input into new_state (which may
 * be state itself, but must not overlap it otherwise).  One sample of the
 * forward model. */
HYST_API double hyst_output(const HystModel *m, double voltage,
                            const double *state, double *new_state);

/* Runs the forward model over n_samples voltages.  state (n_operators) holds
 * the operator state before the first sample on entry and after the last
 * sample on return, so a long record can be processed in pieces.
 * operator_outputs (n_samples x n_operators, row-major) may be NULL. */
HYST_API void hyst_simulate(const HystModel *m, size_t n_samples,
                            const double *voltage, double *state,
                            double *displacement, double *operator_outputs);

/* hyst_simulate with every threshold of sample k multiplied by
 * threshold_scale[k] (>= 0; NULL: 1): operators whose thresholds change with
 * time, such as thresholds that grow with the input's rate (host only). */
HYST_API void hyst_simulate_scaled(const HystModel *m, size_t n_samples,
                                   const double *voltage, const double *threshold_scale,
                                   double *state, double *displacement, double *operator_outputs);

/* Exact inverse of one sample: finds the voltage v in [v_lo, v_hi] with
 * hyst_output(m, v, state) == displacement, to machine precision, for a model
 * that is strictly increasing along every branch.  Writes the voltage and the
 * operator state that the forward model would have after that voltage.
 * Returns HYST_INVERSE_OK, or BELOW/ABOVE when the target lies outside what
 * the voltage range can reach (the voltage is then the range end). */
HYST_API int hyst_invert(const HystModel *m, double displacement,
                         const double *state, double v_lo, double v_hi,
                         double *voltage, double *new_state);

/* hyst_invert over a record; state is carried as in hyst_simulate.  Returns
 * the number of samples that had to be saturated. */
HYST_API size_t hyst_invert_run(const HystModel *m, size_t n_samples,
                                const double *displacement, double *state,
                                double v_lo, double v_hi, double *voltage);

/* The paper's Fig. 7 compensator with the previous sample closing the implicit
 * loop: v_k = Pinv[y_k - a1 u_{k-1}^3] where Pinv is the analytic inverse of
 * the linear-plus-operators part, given here as its own PI model (inverse_pi,
 * a1 = 0, thresholds r_hat, weights b_hat, a2 = 1/a2).  u_prev is carried in
 * *u_prev (V, shifted input).  Saturates to [v_lo, v_hi]. */
HYST_API void hyst_invert_previous_sample_run(const HystModel *inverse_pi,
                                              double a1, double input_offset,
                                              double output_offset,
                                              size_t n_samples,
                                              const double *displacement,
                                              double *inverse_state,
                                              double *u_prev, double v_lo,
                                              double v_hi, double *voltage);

#ifdef __cplusplus
}
#endif

#endif /* PIEZO_HYSTERESIS_H */
