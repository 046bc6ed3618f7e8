/*
 * model.h (lti) -- a single-input single-output linear time-invariant system
 * in state-space form (a python-control system): input u, output y.  A
 * continuous system is discretised exactly for the communication step (zero-
 * order hold: the input is held over the step); a discrete one steps at its
 * sampling time only.  Sizes and value references come from the generated
 * model_config.h.
 */
#ifndef PIEZO_LTI_MODEL_H
#define PIEZO_LTI_MODEL_H

#include "model_config.h"
#include "rig_part.h"

#define LTI_N MODEL_N_STATES
#define LTI_M (MODEL_N_STATES + 1)          /* size of the augmented matrix [A B; 0 0] */
#define LTI_STORAGE(n) ((n) > 0 ? (n) : 1)

#if MODEL_N_STATES == 0
/* a static gain has no A, B, C: the loops over the states never run */
#define VR_A VR_D
#define VR_B VR_D
#define VR_C VR_D
#endif

/* memory: the rig-part head, the state z (n values), the held input u */
#define LTI_STATE RIG_HEAD
#define LTI_INPUT (RIG_HEAD + MODEL_N_STATES)
#define MODEL_N_MEMORY (RIG_HEAD + MODEL_N_STATES + 1)

typedef struct {
    int nominal_ok;                        /* A and B are the ones the FMU was generated for */
    double step;                           /* s: the step ad and bd belong to (0: none) */
    double ad[LTI_STORAGE(LTI_N * LTI_N)]; /* e^(A h), row-major */
    double bd[LTI_STORAGE(LTI_N)];         /* integral of e^(A s) ds B over [0, h] */
    double work[8][LTI_M * LTI_M];         /* matrix exponential workspace */
    double scale[LTI_M];                   /* balancing */
    int pivot[LTI_M];
} ModelData;

#endif /* PIEZO_LTI_MODEL_H */
