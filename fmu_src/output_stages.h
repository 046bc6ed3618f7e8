/*
 * output_stages.h -- the one implementation of the output stages that extend
 * the hysteresis model with what a rate-independent model cannot describe:
 * linear dynamics, a pure delay, creep and drift.
 *
 * With h_k the hysteresis output (um) and u_k the shifted input (V) at sample
 * k, and t_k the time (s) since the start of the run, the extended output is
 *
 *     g_k = G[h]_k                      cascade of second-order sections
 *     d_k = (1 - f) g_{k-m} + f g_{k-m-1}   delay of m + f samples (0 <= f < 1)
 *     y_k = d_k + sum_j w_j c_{j,k} + t_k (p_1 + t_k (p_2 + ...))
 *     c_{j,k} = alpha_j c_{j,k-1} + beta_j (u_k + u_{k-1})   creep modes
 *
 * Every stage is a discrete-time recursion at one fixed sample period; the
 * coefficients are computed by the model builder (Python), so this file needs
 * no libm.  Pure C99, no allocation, no I/O; build with -ffp-contract=off so
 * that all targets compute bit-identical results.
 *
 * State (one array of doubles, size ostage_state_size), in this order:
 *     2 per section               transposed direct form II states s1, s2
 *     delay (if m > 0 or f > 0):  1 ring position + (m + 1) past values of g
 *     creep (if n_creep > 0):     u_{k-1}, then c_1 .. c_n
 * The ring position is a whole number stored as a double.
 */
#ifndef PIEZO_OUTPUT_STAGES_H
#define PIEZO_OUTPUT_STAGES_H

#include <stddef.h>

#ifdef __cplusplus
extern "C" {
#endif

/* Exported like the hysteresis kernel: the host library for Python defines
 * HYST_API to make the symbols visible; FMU builds keep them hidden. */
#ifndef OSTAGE_API
#ifdef HYST_API
#define OSTAGE_API HYST_API
#else
#define OSTAGE_API
#endif
#endif

/* Largest delay line accepted (samples): protects the caller's buffer size
 * arithmetic against absurd specs. */
#define OSTAGE_MAX_DELAY 10000000

enum {
    OSTAGE_OK = 0,
    OSTAGE_BAD_COUNT = 1,        /* a negative count, or too long a delay line */
    OSTAGE_NULL_ARRAY = 2,       /* a count > 0 with a NULL coefficient array */
    OSTAGE_BAD_FRACTION = 3,     /* delay fraction outside [0, 1) */
    OSTAGE_NOT_FINITE = 4,       /* a coefficient is NaN or infinite */
    OSTAGE_NO_EQUILIBRIUM = 5,   /* a section or creep mode has a pole at z = 1 */
    OSTAGE_BAD_SPAN = 6          /* drift span negative, NaN or infinite */
};

typedef struct {
    int n_sections;              /* cascaded second-order sections, >= 0 */
    const double *sections;      /* 5 per section: b0 b1 b2 a1 a2 (a0 = 1) */
    int delay_whole;             /* m, samples, >= 0 */
    double delay_fraction;       /* f, 0 <= f < 1 */
    int n_creep;                 /* creep modes, >= 0 */
    const double *creep_alpha;   /* alpha_j (pole) */
    const double *creep_beta;    /* beta_j (input gain, on u_k + u_{k-1}) */
    const double *creep_weights; /* w_j, um/V */
    int n_drift;                 /* drift polynomial degree, >= 0 */
    const double *drift;         /* p_1 .. p_n, um/s^j */
    double drift_span;           /* s, >= 0: from t = drift_span on the drift holds
                                  * the value it has there (the end of the record it
                                  * was identified on; a polynomial says nothing
                                  * beyond); 0: it runs on */
} OutputStages;

/* OSTAGE_OK, or the first problem found (see the enum). */
OSTAGE_API int ostage_check(const OutputStages *s);

/* One-line description of a status code of ostage_check. */
OSTAGE_API const char *ostage_message(int status);

/* Number of doubles of state (0 for an invalid spec). */
OSTAGE_API size_t ostage_state_size(const OutputStages *s);

/* State of a system at rest: the hysteresis output h0 and the shifted input
 * u0 held since forever. */
OSTAGE_API void ostage_init(const OutputStages *s, double h0, double u0, double *state);

/* Output y_k for the hysteresis output h, shifted input u and time t (s),
 * given the state after sample k-1.  When new_state is not NULL the state
 * after sample k is written there (it may be the same array as state); with
 * NULL nothing is committed (an output for a tentative input). */
OSTAGE_API double ostage_output(const OutputStages *s, const double *state, double h,
                                double u, double t, double *new_state);

/* ostage_output over a record, committing every sample; state is carried in
 * and out as in hyst_simulate.  time may be NULL when there is no drift.  The
 * spec is checked once per call, not per sample. */
OSTAGE_API void ostage_run(const OutputStages *s, size_t n_samples, const double *h,
                           const double *u, const double *time, double *state, double *y);

/* ------------------------------------------------------------------------
 * The per-sample path of a caller that checked the spec once (ostage_check,
 * e.g. the plant FMU at initialisation): nothing is checked again.
 * ---------------------------------------------------------------------- */

/* ostage_init for a checked spec. */
OSTAGE_API void ostage_rest(const OutputStages *s, double h0, double u0, double *state);

/* ostage_output for a checked spec, with a state buffer pair instead of a
 * copy: writes the state after sample k into next (NULL: nothing written, an
 * output for a tentative input; or state itself: in place).  A separate next
 * is brought up to date without copying the delay line: it must already hold
 * state's delay line except at the slot written by sample k-1 -- as the
 * buffer of a double-buffered caller does, which holds the state before
 * sample k-1 (or a copy of state).  Every other value of next is written.
 * Double buffering thus costs O(1) per sample for any delay. */
OSTAGE_API double ostage_step(const OutputStages *s, const double *state, double h, double u, double t,
                              double *next);

#ifdef __cplusplus
}
#endif

#endif /* PIEZO_OUTPUT_STAGES_H */
