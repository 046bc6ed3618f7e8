/*
 * model.h (plant) -- the MPI hysteresis plant: voltage (V) in, displacement
 * (um) out.  Sizes and value references come from the generated
 * model_config.h.
 */
#ifndef PIEZO_PLANT_MODEL_H
#define PIEZO_PLANT_MODEL_H

#include "hysteresis.h"
#include "model_config.h"
#include "mpi_parameters.h"

/* Committed memory: the operator states w_1..w_n.  Output stages that follow
 * the hysteresis (dynamics, creep, delay) append their states here. */
#define MODEL_N_MEMORY MODEL_N_OPERATORS

/* Quantities derived from the parameters at initialisation.  The hysteresis
 * stage needs none (it reads the parameters in place); later output stages
 * keep their discretised coefficients here. */
typedef struct {
    int n_stages;                /* stages after the hysteresis (none yet) */
} ModelData;

#endif /* PIEZO_PLANT_MODEL_H */
