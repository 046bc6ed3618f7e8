/*
 * model.h (sensor) -- the displacement sensor with its ADC: displacement (um)
 * in, measurement (um) out; white noise of a given RMS from a seeded
 * xorshift64* / Box-Muller generator (pysim.core.rig.XorShiftNormal), then the
 * ADC (pysim.core.rig.Converter).  Sizes and value references come from the
 * generated model_config.h.
 */
#ifndef PIEZO_SENSOR_MODEL_H
#define PIEZO_SENSOR_MODEL_H

#include "model_config.h"
#include "rig_part.h"

/* memory: the rig-part head, the measurement (um), the held displacement
 * (um), then the generator: seeded flag, its 64-bit state as two 32-bit
 * halves (the layer keeps finite doubles only), spare flag and spare value */
#define SENSOR_MEASUREMENT (RIG_HEAD + 0)
#define SENSOR_DISPLACEMENT (RIG_HEAD + 1)
#define SENSOR_SEEDED (RIG_HEAD + 2)
#define SENSOR_STATE_HIGH (RIG_HEAD + 3)
#define SENSOR_STATE_LOW (RIG_HEAD + 4)
#define SENSOR_HAS_SPARE (RIG_HEAD + 5)
#define SENSOR_SPARE (RIG_HEAD + 6)
#define MODEL_N_MEMORY (RIG_HEAD + 7)

typedef struct {
    int adc_bits;         /* ADC resolution (0: ideal) */
    double adc_lsb;       /* um per code */
} ModelData;

#endif /* PIEZO_SENSOR_MODEL_H */
