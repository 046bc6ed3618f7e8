/*
 * model.h (amplifier) -- a piezo amplifier: command (V) in, output voltage (V)
 * out; gain, first-order small-signal bandwidth, slew limit I_max / C and
 * output range (pysim.core.rig.Amplifier).  Sizes and value references come
 * from the generated model_config.h.
 */
#ifndef PIEZO_AMPLIFIER_MODEL_H
#define PIEZO_AMPLIFIER_MODEL_H

#include "model_config.h"
#include "rig_part.h"

/* memory: the rig-part head, the output a (V), the held command (V) */
#define AMP_OUTPUT (RIG_HEAD + 0)
#define AMP_COMMAND (RIG_HEAD + 1)
#define MODEL_N_MEMORY (RIG_HEAD + 2)

typedef struct {
    double step;          /* s: the step alpha and max_change belong to (0: none yet) */
    double alpha;         /* 1 - exp(-2 pi f_bw step) */
    double max_change;    /* V per step: slew rate times step */
} ModelData;

#endif /* PIEZO_AMPLIFIER_MODEL_H */
