/*
 * model.h (inverse) -- the inverse compensator of the MPI model: desired
 * displacement (um) in, voltage (V) out.  Sizes and value references come
 * from the generated model_config.h.
 */
#ifndef PIEZO_INVERSE_MODEL_H
#define PIEZO_INVERSE_MODEL_H

#include "hysteresis.h"
#include "model_config.h"
#include "mpi_parameters.h"

/* Committed memory, n + 1 values; its meaning depends on the method:
 *   exact            forward operator states w_1..w_n, then 0
 *   previous sample  inverse operator states, then the previous shifted
 *                    voltage u_{k-1} (V) that closes the Fig. 7 loop */
#define MODEL_N_MEMORY (MODEL_N_OPERATORS + 1)

typedef struct {
    int previous_sample;                  /* method chosen at initialisation */
    HystModel inverse;                    /* analytic inverse (previous sample) */
    double r_hat[MODEL_N_OPERATORS];      /* its thresholds, um */
    double b_hat[MODEL_N_OPERATORS];      /* its weights, V/um */
} ModelData;

#endif /* PIEZO_INVERSE_MODEL_H */
