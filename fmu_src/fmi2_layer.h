/*
 * fmi2_layer.h -- the FMI 2.0 co-simulation layer shared by every model FMU.
 *
 * The layer (fmi2_layer.c) implements all fmi2* functions of the
 * co-simulation interface: the standard's state machine with the calls it
 * allows in each state, logging through the importer's logger, get/set of the
 * variables with value-reference checks, FMU state snapshots and their
 * checksummed serialisation.  A model (model.c in its own folder) supplies
 * the numbers: what its variables are (the generated model_config.h), how its
 * outputs follow from its inputs and memory, and which parameter sets are
 * valid (the model_* hooks below).
 *
 * Memory model of a step: `memory` holds the committed model memory (the
 * operator states).  model_update computes the outputs for the current inputs
 * from `memory` and writes the memory the model would have after that input
 * into `scratch` (tentative); fmi2DoStep commits it by swapping the two
 * buffers.  No allocation and no copy on the per-step path, and the work is
 * done once per step whether the importer reads the outputs before or after
 * fmi2DoStep.
 *
 * All sizes are compile-time constants from the model's headers, so one
 * instance is a single block of memory and several instances share nothing.
 */
#ifndef PIEZO_FMI2_LAYER_H
#define PIEZO_FMI2_LAYER_H

#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include "fmi2Functions.h"
#include "model.h"          /* per model: ModelData, MODEL_N_MEMORY */

#ifdef __cplusplus
extern "C" {
#endif

/* States of the FMI 2.0 co-simulation state machine, as bits so that each
 * function can be checked against the mask of states it is allowed in. */
enum {
    LAYER_INSTANTIATED = 1u << 0,
    LAYER_INITIALIZATION_MODE = 1u << 1,
    LAYER_STEP_COMPLETE = 1u << 2,
    LAYER_STEP_IN_PROGRESS = 1u << 3,   /* never entered: doStep is synchronous */
    LAYER_STEP_FAILED = 1u << 4,        /* never entered: doStep does not discard */
    LAYER_STEP_CANCELED = 1u << 5,      /* never entered */
    LAYER_TERMINATED = 1u << 6,
    LAYER_ERROR = 1u << 7,
    LAYER_FATAL = 1u << 8               /* never entered: no error is fatal */
};

/* Log categories (the names listed in modelDescription.xml). */
enum {
    LAYER_LOG_EVENTS = 1u << 0,          /* "logEvents": state changes */
    LAYER_LOG_WARNING = 1u << 1,         /* "logStatusWarning" */
    LAYER_LOG_ERROR = 1u << 2,           /* "logStatusError" */
    LAYER_LOG_ALL = (1u << 3) - 1u
};

/* Real value references are laid out as inputs [0, MODEL_N_INPUTS), outputs
 * [MODEL_N_INPUTS, MODEL_N_INPUTS + MODEL_N_OUTPUTS), then parameters, then
 * MODEL_N_CONSTANTS constants (read only). */
#define LAYER_IS_INPUT(vr) ((vr) < MODEL_N_INPUTS)
#define LAYER_IS_OUTPUT(vr) ((fmi2ValueReference)((vr) - MODEL_N_INPUTS) < MODEL_N_OUTPUTS)
#ifndef MODEL_N_CONSTANTS
#define MODEL_N_CONSTANTS 0
#endif
#define LAYER_IS_CONSTANT(vr) ((fmi2ValueReference)(vr) >= (fmi2ValueReference)(MODEL_N_REALS - MODEL_N_CONSTANTS))

/* A model whose configuration defines MODEL_FIXED_STEP_SIZE (s) -- a
 * sampled-data model -- accepts only communication steps of that size
 * (canHandleVariableCommunicationStepSize is false); fmi2DoStep refuses
 * others with fmi2Error. */

#define LAYER_STORAGE(n) ((n) > 0 ? (n) : 1)   /* C has no empty arrays */

/* The tag of a live instance holds this FMU's magic number (high half,
 * generated from the GUID: another FMU's instance never passes as ours), its
 * state (one LAYER_* bit) and two staleness bits: LAYER_STALE_OUTPUTS when
 * the outputs are not computed for the current inputs and committed memory,
 * LAYER_STALE_NEXT when the tentative memory is not.  One comparison of the
 * tag thus checks "alive, of this FMU, in StepComplete, what is up to date"
 * on the per-step path. */
#define LAYER_MAGIC MODEL_INSTANCE_MAGIC
#define LAYER_STALE_OUTPUTS (1u << 15)
#define LAYER_STALE_NEXT (1u << 14)
#define LAYER_STALE (LAYER_STALE_OUTPUTS | LAYER_STALE_NEXT)
#define LAYER_TAG(state) ((uint32_t)((LAYER_MAGIC << 16) | (state)))

typedef struct Instance {
    uint32_t tag;                    /* LAYER_TAG(state) [| LAYER_STALE]; 0 after free */
    uint32_t parameters_changed;     /* parameters set since model_prepare */
    uint32_t log_categories;         /* LAYER_LOG_* bits enabled */
    int stop_time_defined;
    double time;                     /* communication point, s */
    double start_time;               /* s */
    double stop_time;                /* s */
    double *memory;                  /* committed model memory */
    double *scratch;                 /* tentative model memory */
    double real[MODEL_N_REALS];      /* every Real variable, by value reference */
    fmi2Boolean boolean[LAYER_STORAGE(MODEL_N_BOOLEANS)];
    ModelData model;                 /* the model's derived quantities */
    double memory_a[LAYER_STORAGE(MODEL_N_MEMORY)];
    double memory_b[LAYER_STORAGE(MODEL_N_MEMORY)];
    fmi2CallbackLogger logger;
    fmi2CallbackAllocateMemory allocate_memory;
    fmi2CallbackFreeMemory free_memory;
    fmi2ComponentEnvironment environment;
    char *instance_name;
} Instance;

/* The state (one LAYER_* bit) of an instance. */
static inline unsigned int layer_state(const Instance *inst)
{
    return inst->tag & (LAYER_STALE_NEXT - 1u);
}

/* Logging for models and layer.  Messages with status fmi2Error or worse
 * always reach the logger; others only when logging is on for category. */
#if defined(__GNUC__) || defined(__clang__)
#define LAYER_PRINTF(fmt, args) __attribute__((format(printf, fmt, args)))
#else
#define LAYER_PRINTF(fmt, args)
#endif
void layer_log(const Instance *inst, fmi2Status status, unsigned int category,
               const char *format, ...) LAYER_PRINTF(4, 5);

/* Name of the Real variable with value reference vr (for messages). */
const char *layer_real_name(fmi2ValueReference vr);

/* Finite without libm and robust against -ffast-math: exponent not all ones. */
static inline int layer_is_finite(double x)
{
    uint64_t bits;
    memcpy(&bits, &x, sizeof bits);
    return (bits & UINT64_C(0x7ff0000000000000)) != UINT64_C(0x7ff0000000000000);
}

/* ------------------------------------------------------------------------
 * Hooks every model implements (model.c).
 * ---------------------------------------------------------------------- */

/* Sets the model's memory (inst->memory, MODEL_N_MEMORY values) to its
 * initial value; called at instantiation and reset. */
void model_reset(Instance *inst);

/* Checks the parameters in inst->real / inst->boolean and derives what the
 * model needs from them; called at fmi2ExitInitializationMode, after
 * fmi2SetFMUstate, and before outputs are computed in initialisation mode
 * with changed parameters.  Logs the first problem and returns fmi2Error for
 * an invalid set; fmi2Warning when it had to adjust an input. */
fmi2Status model_prepare(Instance *inst);

/* Per-step fast check: nonzero when value can be stored as the input vr as it
 * is.  Must be zero for a value that is not finite. */
int model_input_ok(const Instance *inst, fmi2ValueReference vr, double value);

/* Accepts a finite value of the input vr that model_input_ok refused; may
 * adjust it (and return fmi2Warning with a log line). */
fmi2Status model_accept_input(Instance *inst, fmi2ValueReference vr, double *value);

/* Nonzero when the outputs computed before a step are still the outputs for
 * the same inputs after the step committed the memory -- true when updating
 * the memory twice with the same inputs changes nothing, as for the play
 * operators; then reading the outputs after fmi2DoStep computes nothing. */
int model_outputs_hold(const Instance *inst);

/* Computes every output in inst->real for the current inputs from the
 * committed memory, and brings inst->scratch to the memory after these
 * inputs (all MODEL_N_MEMORY values; values that the buffer swap leaves
 * right, like most of the plant's delay line, need not be rewritten).
 * Defined with LAYER_HOT: it is the per-step work and belongs inlined into
 * fmi2GetReal and fmi2DoStep. */
fmi2Status model_update(Instance *inst);

#if defined(__GNUC__) || defined(__clang__)
#define LAYER_HOT __attribute__((always_inline)) inline
#else
#define LAYER_HOT
#endif

#ifdef __cplusplus
}
#endif

#endif /* PIEZO_FMI2_LAYER_H */
