/*
 * model.h (plant) -- the MPI hysteresis plant: voltage (V) in, displacement
 * (um) out; for an extended model followed by output stages (dynamics,
 * delay, creep, drift; see output_stages.h).  Sizes and value references come
 * from the generated model_config.h, which defines MODEL_HAS_OUTPUT_STAGES
 * for an extended model.
 */
#ifndef PIEZO_PLANT_MODEL_H
#define PIEZO_PLANT_MODEL_H

#include "hysteresis.h"
#include "model_config.h"
#include "mpi_parameters.h"

#ifdef MODEL_HAS_OUTPUT_STAGES
#include "output_stages.h"

/* Committed memory: the operator states w_1..w_n, the stage state
 * (MODEL_STAGE_STATE_SIZE values), and the number k of committed steps (a
 * whole number stored as a double).  k = 0 means "no sample yet": the first
 * sample starts the stages at rest; the drift's time is k * sample period. */
#define MODEL_STAGE_MEMORY MODEL_N_OPERATORS
#define MODEL_STEP_COUNT (MODEL_N_OPERATORS + MODEL_STAGE_STATE_SIZE)
#define MODEL_N_MEMORY (MODEL_STEP_COUNT + 1)

/* The stage state is double-buffered like the rest of the memory, without a
 * per-step copy of its delay line: once the two buffers are paired, the
 * tentative one always holds the committed delay line except at the slot the
 * last committed sample wrote, and ostage_step brings just that slot up to
 * date.  They are paired by one copy at the second sample and after anything
 * that replaced the committed memory (model_prepare runs after
 * fmi2SetFMUstate; model_reset). */
typedef struct {
    OutputStages stages;         /* built-in coefficients, creep_weight[] and drift[] */
    int buffers_paired;          /* nonzero: the tentative delay line lags by one slot only */
} ModelData;

#else

/* Committed memory: the operator states w_1..w_n. */
#define MODEL_N_MEMORY MODEL_N_OPERATORS

/* The hysteresis alone derives nothing from its parameters (it reads them in
 * place). */
typedef struct {
    int unused;                  /* C has no empty structs */
} ModelData;

#endif /* MODEL_HAS_OUTPUT_STAGES */

#endif /* PIEZO_PLANT_MODEL_H */
