/*
 * mpi_parameters.h -- the MPI model parameters as FMI variables, shared by the
 * plant and the inverse FMU.
 *
 * Both FMUs expose the same parameters (generated value references in
 * model_config.h): a1 (um/V^3), a2 (um/V), input_offset (V), output_offset
 * (um), voltage_min and voltage_max (V), thresholds r[1..n] (V, at VR_r + i)
 * and weights b[1..n] (um/V, at VR_b + i).  The thresholds and weights are
 * used in place: a HystModel points into the instance's Real variables.
 */
#ifndef PIEZO_MPI_PARAMETERS_H
#define PIEZO_MPI_PARAMETERS_H

#include "hysteresis.h"
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

/* Checks that the model is strictly increasing along every branch over
 * [voltage_min, voltage_max] (the condition for its inverse to exist; the
 * same case analysis as the Python package's invertibility check).  Logs the
 * branch and voltage where it fails; fmi2OK or fmi2Error. */
fmi2Status mpi_check_invertible(struct Instance *inst);

/* The paper's analytic inverse (eq. 11-12) of the linear-plus-operators part,
 * as a PI model with a1 = 0 and no offsets: writes r_hat and b_hat
 * (MODEL_N_OPERATORS each) and fills *inverse.  fmi2Error (logged) when
 * a2 + partial sums of the weights do not stay positive. */
fmi2Status mpi_analytic_inverse(struct Instance *inst, HystModel *inverse,
                                double *r_hat, double *b_hat);

/* Clamps *value into [voltage_min, voltage_max]; fmi2Warning (logged, naming
 * the variable `what`) when it had to. */
fmi2Status mpi_clamp_voltage(struct Instance *inst, const char *what, double *value);

#endif /* PIEZO_MPI_PARAMETERS_H */
