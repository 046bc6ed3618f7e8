/*
 * model.h (controller) -- the rig's real-time controller: reference and
 * measurement (um) and a feedforward in, the DAC's command (V) out; a
 * discrete PI with conditional integration (anti-windup) and output limits
 * (pysim.core.rig.PIController), the DAC (pysim.core.rig.Converter), one
 * sample of computation delay.  Sizes and value references come from the
 * generated model_config.h.
 */
#ifndef PIEZO_CONTROLLER_MODEL_H
#define PIEZO_CONTROLLER_MODEL_H

#include "model_config.h"
#include "rig_part.h"

/* memory: the rig-part head, the integrator (V), the command (V), then the
 * held reference (um), measurement (um) and feedforward */
#define CTRL_INTEGRATOR (RIG_HEAD + 0)
#define CTRL_COMMAND (RIG_HEAD + 1)
#define CTRL_REFERENCE (RIG_HEAD + 2)
#define CTRL_MEASUREMENT (RIG_HEAD + 3)
#define CTRL_FEEDFORWARD (RIG_HEAD + 4)
#define MODEL_N_MEMORY (RIG_HEAD + 5)

typedef struct {
    int feedback;         /* the Boolean parameter feedback */
    int dac_bits;         /* DAC resolution (0: ideal) */
    double dac_lsb;       /* V per code */
} ModelData;

#endif /* PIEZO_CONTROLLER_MODEL_H */
