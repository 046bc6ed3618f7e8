/*
 * mpi_parameters.h -- the MPI model parameters: their mathematics (the
 * invertibility check and the paper's analytic inverse) and, in the FMUs,
 * the same parameters as FMI variables, shared by the plant and the inverse.
 *
 * Both FMUs expose the same parameters (generated value references in
 * model_config.h): a1 (um/V^3), a2 (um/V), input_offset (V), output_offset
 * (um), voltage_min and voltage_max (V), thresholds r[1..n] (V, at VR_r + i)
 * and weights b[1..n] (um/V, at VR_b + i).  The thresholds and weights are
 * used in place: a HystModel points into the instance's Real variables.
 *
 * The mathematics (mpi_invertibility, mpi_inverse_parameters) works on a
 * HystModel alone.  The host library that the Python package loads
 * (pysim/core/kernel.py) compiles this file for that part only: it defines
 * HYST_API on the command line and has no model configuration, and it
 * exports the functions, so that the tests cross-check them against the
 * Python package (tests/test_c_python_agreement.py).  Every FMU build
 * includes model_config.h before this header (all.c, model.h) or does not
 * define HYST_API (a file compiled on its own), and gets the FMI part too.
 */
#ifndef PIEZO_MPI_PARAMETERS_H
#define PIEZO_MPI_PARAMETERS_H

#if defined(HYST_API) && !defined(MODEL_N_OPERATORS)
#define MPI_HOST_LIBRARY 1
#endif

#include <stddef.h>

#include "hysteresis.h"

/* ------------------------------------------------------------------------
 * The mathematics (pure C99: no libm, no allocation, no I/O).
 * ---------------------------------------------------------------------- */

/* Result of mpi_invertibility; the fields after `invertible` mean what the
 * fields of the same names in pysim.core.invertibility.Invertibility mean. */
typedef struct {
    int invertible;          /* 1: strictly increasing along every branch */
    int descending;          /* branch of the smallest slope: 0 ascending, 1 descending */
    int n_active;            /* operators following the input there */
    double min_slope;        /* smallest slope over every branch, um/V */
    double worst_voltage;    /* where it is reached, V */
} MpiInvertibility;

/* Doubles of workspace mpi_invertibility needs for n operators. */
#define MPI_INVERTIBILITY_WORK(n) (2 * (size_t)(n) + 10)

/* Is the model strictly increasing along every branch over [voltage_min,
 * voltage_max] (the condition for its inverse to exist)?  Along a branch the
 * slope is a2 + 3 a1 u^2 + the weights of the operators that follow the
 * input (u = v - input_offset); with the thresholds ascending, "k operators
 * follow" holds for a known interval of u on each branch, and the slope's
 * minimum there sits at an end of the u^2 range.  The same case analysis as
 * pysim.core.invertibility.  The sign of each case's minimum is decided
 * exactly (error-free transformations of the doubles involved, for |a1| and
 * |u| within 1e-70..1e70 or zero; beyond, in rounded arithmetic), so a model
 * exactly at the boundary gets the mathematically right verdict.  min_slope
 * and worst_voltage are evaluated in double (the case of the smallest
 * rounded slope).  work: MPI_INVERTIBILITY_WORK(n_operators) doubles. */
HYST_API void mpi_invertibility(const HystModel *m, double voltage_min, double voltage_max, double *work,
                                MpiInvertibility *result);

/* The paper's analytic inverse (eq. 11-12) of the linear-plus-operators part,
 * as pysim.core.model.analytic_inverse returns it: a PI model of the same
 * operator kind with a1 = 0, a2 = 1/a2, thresholds r_hat and weights b_hat
 * (n_operators each), input_offset = the model's output offset and
 * output_offset = its input offset.  Needs every sum a2 + b_1 + ... + b_j
 * (j = 0..n) positive; returns -1, or the j of the first that is not (its
 * value in *failed_sum when that is not NULL; nothing else written). */
HYST_API int mpi_inverse_parameters(const HystModel *m, HystModel *inverse, double *r_hat, double *b_hat,
                                    double *failed_sum);

#ifdef MPI_HOST_LIBRARY
/* ------------------------------------------------------------------------
 * Host library only: what the tests need to check the Python mirrors.
 * ---------------------------------------------------------------------- */

/* Entry `index` (0, 1, ...) of the layout table of the structs that Python
 * mirrors with ctypes (HystModel, OutputStages, MpiInvertibility): the struct,
 * a field of it (NULL for the struct itself), the field's offsetof (0 for
 * the struct) and its sizeof (the struct's).  Returns 0 past the end. */
HYST_API int mpi_host_layout(size_t index, const char **structure, const char **field, size_t *offset,
                             size_t *size);

/* The longest delay line the output stages accept (OSTAGE_MAX_DELAY). */
HYST_API long mpi_host_max_delay(void);

#else
/* ------------------------------------------------------------------------
 * FMUs: the parameters as FMI variables.
 * ---------------------------------------------------------------------- */

#include "fmi2Functions.h"
#include "model_config.h"

struct Instance;

/* The forward model described by the current parameter values.  Kind and
 * operator count are compile-time constants, so a compiler that inlines
 * hyst_output can unroll its loop. */
#define MPI_MODEL(real) { MODEL_OPERATOR_KIND, MODEL_N_OPERATORS, \
    (real)[VR_a1], (real)[VR_a2], (real)[VR_input_offset], (real)[VR_output_offset], \
    &(real)[VR_r], &(real)[VR_b] }

/* Checks what every MPI model needs: thresholds >= 0 and ascending,
 * voltage_min < voltage_max.  Logs the first problem; fmi2OK or fmi2Error. */
fmi2Status mpi_check_parameters(struct Instance *inst);

/* mpi_invertibility of the current parameters.  Logs the branch and voltage
 * of the smallest slope when the model is not invertible; fmi2OK or
 * fmi2Error. */
fmi2Status mpi_check_invertible(struct Instance *inst);

/* mpi_inverse_parameters of the current parameters, with the offsets left
 * out (zero): the Fig. 7 loop, hyst_invert_previous_sample_run, applies
 * them itself.  Writes r_hat and b_hat (MODEL_N_OPERATORS each) and fills
 * *inverse; fmi2Error (logged) when a2 + partial sums of the weights do not
 * stay positive. */
fmi2Status mpi_analytic_inverse(struct Instance *inst, HystModel *inverse,
                                double *r_hat, double *b_hat);

/* Clamps *value into [voltage_min, voltage_max]; fmi2Warning (logged, naming
 * the variable `what`) when it had to. */
fmi2Status mpi_clamp_voltage(struct Instance *inst, const char *what, double *value);

#endif /* MPI_HOST_LIBRARY */

#endif /* PIEZO_MPI_PARAMETERS_H */
