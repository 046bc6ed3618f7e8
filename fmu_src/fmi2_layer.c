/*
 * fmi2_layer.c -- every fmi2* function of the FMI 2.0 co-simulation
 * interface, shared by all models (see fmi2_layer.h).
 *
 * Conventions:
 * - Each function first checks the instance pointer and that the call is
 *   allowed in the current state (the masks below follow the state table of
 *   the FMI 2.0 co-simulation chapter).  A rejected call -- wrong state, NULL
 *   array with a non-zero count, unknown value reference, non-finite value,
 *   step size <= 0, bad FMU state -- returns fmi2Error, logs why and has no
 *   effect: the instance stays as it was.
 * - An invalid parameter set found at fmi2ExitInitializationMode puts the
 *   instance into the Error state; fmi2Reset, fmi2SetFMUstate or
 *   fmi2FreeInstance go on from there.
 * - Messages of status fmi2Error always reach the logger; others only when
 *   logging is on for their category.
 * - fmi2SetReal, fmi2GetReal and fmi2DoStep have a short path for the
 *   per-step case (StepComplete, one value), recognised by one comparison of
 *   the instance tag; everything else takes the general path with the full
 *   checks and messages.
 */
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>

#include "fmi2_layer.h"

#if defined(__GNUC__) || defined(__clang__)
#define LAYER_COLD __attribute__((cold, noinline))
#else
#define LAYER_COLD
#endif

#define LAYER_SNAPSHOT_MAGIC 0x4d505353u      /* "MPSS" */
#define LAYER_MESSAGE_SIZE 512

/* ------------------------------------------------------------ state masks */
#define ALIVE (LAYER_INSTANTIATED | LAYER_INITIALIZATION_MODE | LAYER_STEP_COMPLETE | \
               LAYER_STEP_IN_PROGRESS | LAYER_STEP_FAILED | LAYER_STEP_CANCELED | \
               LAYER_TERMINATED | LAYER_ERROR)
#define MASK_SET_DEBUG_LOGGING ALIVE
#define MASK_RESET (ALIVE & ~LAYER_STEP_IN_PROGRESS)
#define MASK_SETUP_EXPERIMENT LAYER_INSTANTIATED
#define MASK_ENTER_INITIALIZATION LAYER_INSTANTIATED
#define MASK_EXIT_INITIALIZATION LAYER_INITIALIZATION_MODE
#define MASK_TERMINATE (LAYER_STEP_COMPLETE | LAYER_STEP_FAILED)
#define MASK_GET (LAYER_INITIALIZATION_MODE | LAYER_STEP_COMPLETE | LAYER_STEP_FAILED | \
                  LAYER_STEP_CANCELED | LAYER_TERMINATED | LAYER_ERROR)
#define MASK_SET (LAYER_INSTANTIATED | LAYER_INITIALIZATION_MODE | LAYER_STEP_COMPLETE)
#define MASK_SET_PARAMETER (LAYER_INSTANTIATED | LAYER_INITIALIZATION_MODE)
#define MASK_FMU_STATE MASK_RESET
#define MASK_DIRECTIONAL_DERIVATIVE MASK_GET
#define MASK_SET_INPUT_DERIVATIVES MASK_SET
#define MASK_GET_OUTPUT_DERIVATIVES (LAYER_STEP_COMPLETE | LAYER_STEP_FAILED | LAYER_STEP_CANCELED | \
                                     LAYER_TERMINATED | LAYER_ERROR)
#define MASK_DO_STEP LAYER_STEP_COMPLETE
#define MASK_CANCEL_STEP LAYER_STEP_IN_PROGRESS
#define MASK_GET_STATUS (LAYER_STEP_COMPLETE | LAYER_STEP_IN_PROGRESS | LAYER_STEP_FAILED | \
                         LAYER_TERMINATED)
/* states an FMU state snapshot may hold */
#define SNAPSHOT_STATES (LAYER_INSTANTIATED | LAYER_INITIALIZATION_MODE | LAYER_STEP_COMPLETE | \
                         LAYER_TERMINATED | LAYER_ERROR)

/* ------------------------------------------------------- variable tables */
static const char *const real_names[MODEL_N_REALS] = MODEL_REAL_NAMES;
static const double real_start[MODEL_N_REALS] = MODEL_REAL_STARTS;
#if MODEL_N_BOOLEANS > 0
static const char *const boolean_names[MODEL_N_BOOLEANS] = MODEL_BOOLEAN_NAMES;
static const fmi2Boolean boolean_start[MODEL_N_BOOLEANS] = MODEL_BOOLEAN_STARTS;
#endif

const char *layer_real_name(fmi2ValueReference vr)
{
    return vr < MODEL_N_REALS ? real_names[vr] : "?";
}

#define is_finite layer_is_finite
#define STEP_TAG LAYER_TAG(LAYER_STEP_COMPLETE)         /* everything up to date */
#define STEP_STALE (STEP_TAG | LAYER_STALE)             /* inputs changed since */

/* ---------------------------------------------------------------- logging */
static const char *category_name(unsigned int category)
{
    switch (category) {
    case LAYER_LOG_EVENTS: return "logEvents";
    case LAYER_LOG_WARNING: return "logStatusWarning";
    default: return "logStatusError";
    }
}

static const char *state_name(unsigned int state)
{
    switch (state) {
    case LAYER_INSTANTIATED: return "Instantiated";
    case LAYER_INITIALIZATION_MODE: return "InitializationMode";
    case LAYER_STEP_COMPLETE: return "StepComplete";
    case LAYER_STEP_IN_PROGRESS: return "StepInProgress";
    case LAYER_STEP_FAILED: return "StepFailed";
    case LAYER_STEP_CANCELED: return "StepCanceled";
    case LAYER_TERMINATED: return "Terminated";
    case LAYER_ERROR: return "Error";
    default: return "Fatal";
    }
}

/* Formats a message; '%' is replaced so that a logger that treats the
 * message as a format string cannot misread it. */
static void format_message(char *buffer, size_t size, const char *format, va_list args)
{
    vsnprintf(buffer, size, format, args);
    buffer[size - 1] = '\0';
    for (char *p = buffer; *p; p++) {
        if (*p == '%') {
            *p = '?';
        }
    }
}

void layer_log(const Instance *inst, fmi2Status status, unsigned int category, const char *format, ...)
{
    if (!inst->logger || (status < fmi2Error && !(inst->log_categories & category))) {
        return;
    }
    char message[LAYER_MESSAGE_SIZE];
    va_list args;
    va_start(args, format);
    format_message(message, sizeof message, format, args);
    va_end(args);
    inst->logger(inst->environment, inst->instance_name, status, category_name(category), message);
}

/* For fmi2Instantiate, before there is an instance. */
static void log_instantiation_error(const fmi2CallbackFunctions *functions, fmi2String name,
                                    const char *format, ...) LAYER_PRINTF(3, 4);
static void log_instantiation_error(const fmi2CallbackFunctions *functions, fmi2String name,
                                    const char *format, ...)
{
    if (!functions->logger) {
        return;
    }
    char message[LAYER_MESSAGE_SIZE];
    va_list args;
    va_start(args, format);
    format_message(message, sizeof message, format, args);
    va_end(args);
    functions->logger(functions->componentEnvironment, name ? name : "", fmi2Error,
                      category_name(LAYER_LOG_ERROR), message);
}

/* ------------------------------------------------- rejected calls (cold) */
static LAYER_COLD fmi2Status wrong_state(const Instance *inst, const char *function)
{
    layer_log(inst, fmi2Error, LAYER_LOG_ERROR, "%s: not allowed in state %s", function,
              state_name(layer_state(inst)));
    return fmi2Error;
}

static LAYER_COLD fmi2Status null_argument(const Instance *inst, const char *function, const char *what)
{
    layer_log(inst, fmi2Error, LAYER_LOG_ERROR, "%s: %s is NULL", function, what);
    return fmi2Error;
}

static LAYER_COLD fmi2Status unknown_reference(const Instance *inst, const char *function,
                                               const char *type, fmi2ValueReference vr)
{
    layer_log(inst, fmi2Error, LAYER_LOG_ERROR, "%s: no %s variable has value reference %u", function,
              type, (unsigned int)vr);
    return fmi2Error;
}

static LAYER_COLD fmi2Status unsupported(const Instance *inst, const char *function, const char *why)
{
    layer_log(inst, fmi2Error, LAYER_LOG_ERROR, "%s: not supported (%s)", function, why);
    return fmi2Error;
}

static LAYER_COLD fmi2Status rejected_real(const Instance *inst, fmi2ValueReference vr, double value)
{
    if (LAYER_IS_OUTPUT(vr)) {
        layer_log(inst, fmi2Error, LAYER_LOG_ERROR, "fmi2SetReal: %s is an output and cannot be set",
                  real_names[vr]);
    } else if (LAYER_IS_CONSTANT(vr)) {
        layer_log(inst, fmi2Error, LAYER_LOG_ERROR,
                  "fmi2SetReal: %s is a constant of this FMU and cannot be set (rebuild the FMU to change it)",
                  real_names[vr]);
    } else if (!is_finite(value)) {
        layer_log(inst, fmi2Error, LAYER_LOG_ERROR,
                  "fmi2SetReal: %s = %g is not a finite number; value not accepted", real_names[vr], value);
    } else {
        layer_log(inst, fmi2Error, LAYER_LOG_ERROR,
                  "fmi2SetReal: parameter %s can be set only before fmi2ExitInitializationMode (state %s)",
                  real_names[vr], state_name(layer_state(inst)));
    }
    return fmi2Error;
}

/* The check every function starts with.  Without a valid instance there is
 * no logger to report to. */
#define BEGIN(c, mask, function)                                   \
    Instance *inst = (Instance *)(c);                              \
    if (!inst || (inst->tag >> 16) != LAYER_MAGIC) {               \
        return fmi2Error;                                          \
    }                                                              \
    if (!(inst->tag & (mask))) {                                   \
        return wrong_state(inst, function);                        \
    }

#define CHECK_ARRAYS(function, nvr, vr, value)                     \
    if ((nvr) > 0 && (!(vr) || !(value))) {                        \
        return null_argument(inst, function, !(vr) ? "vr[]" : "value[]"); \
    }

static fmi2Status worst(fmi2Status a, fmi2Status b)
{
    return a > b ? a : b;
}

/* ------------------------------------------------------ instance helpers */
/* Moves the instance to state, keeping its staleness bits. */
static void set_state(Instance *inst, unsigned int state)
{
    inst->tag = LAYER_TAG(state) | (inst->tag & LAYER_STALE);
}

static void reset_instance(Instance *inst)
{
    memcpy(inst->real, real_start, sizeof real_start);
#if MODEL_N_BOOLEANS > 0
    memcpy(inst->boolean, boolean_start, sizeof boolean_start);
#else
    inst->boolean[0] = fmi2False;
#endif
    memset(inst->memory_a, 0, sizeof inst->memory_a);
    memset(inst->memory_b, 0, sizeof inst->memory_b);
    inst->memory = inst->memory_a;
    inst->scratch = inst->memory_b;
    inst->time = inst->start_time = inst->stop_time = 0.0;
    inst->stop_time_defined = 0;
    inst->parameters_changed = 1;
    inst->tag = LAYER_TAG(LAYER_INSTANTIATED) | LAYER_STALE;
    model_reset(inst);
}

/* Checks changed parameters before they are used.  Not on the per-step
 * path: parameters are fixed after initialisation. */
static LAYER_COLD fmi2Status prepare(Instance *inst)
{
    const fmi2Status status = model_prepare(inst);
    if (status <= fmi2Warning) {
        inst->parameters_changed = 0;
    }
    return status;
}

/* Extreme (finite) parameters can overflow the model's arithmetic: an output
 * that is not finite is refused with fmi2Error instead of being handed out
 * as a valid number, and the step that produced it is not committed.  The
 * outputs stay stale (recomputed before any read); they are zeroed so that
 * an FMU state taken now holds finite numbers only. */
static LAYER_COLD fmi2Status non_finite_output(Instance *inst)
{
    for (int i = MODEL_N_INPUTS; i < MODEL_N_INPUTS + MODEL_N_OUTPUTS; i++) {
        if (!is_finite(inst->real[i])) {
            layer_log(inst, fmi2Error, LAYER_LOG_ERROR,
                      "%s = %g is not a finite number: the parameters overflow the model's arithmetic",
                      real_names[i], inst->real[i]);
            inst->real[i] = 0.0;
        }
    }
    return fmi2Error;
}

/* model_update, with its outputs checked (on the per-step path: inlined). */
static LAYER_HOT fmi2Status run_model(Instance *inst)
{
    const fmi2Status status = model_update(inst);
    int finite = 1;
    for (int i = MODEL_N_INPUTS; i < MODEL_N_INPUTS + MODEL_N_OUTPUTS; i++) {
        finite &= is_finite(inst->real[i]);
    }
    return (finite || status > fmi2Warning) ? status : non_finite_output(inst);
}

/* Brings outputs and tentative memory up to date with inputs and parameters. */
static LAYER_COLD fmi2Status update(Instance *inst)
{
    fmi2Status status = fmi2OK;
    if (inst->parameters_changed) {
        status = prepare(inst);
        if (status > fmi2Warning) {
            return status;
        }
    }
    const fmi2Status computed = run_model(inst);
    if (computed <= fmi2Warning) {
        inst->tag &= ~(uint32_t)LAYER_STALE;
    }
    return worst(status, computed);
}

/* ========================================================= common functions */
FMI2_Export const char *fmi2GetTypesPlatform(void)
{
    return fmi2TypesPlatform;
}

FMI2_Export const char *fmi2GetVersion(void)
{
    return fmi2Version;
}

FMI2_Export fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean loggingOn, size_t nCategories,
                                           const fmi2String categories[])
{
    BEGIN(c, MASK_SET_DEBUG_LOGGING, "fmi2SetDebugLogging")
    if (nCategories == 0) {
        inst->log_categories = loggingOn ? LAYER_LOG_ALL : 0u;
        return fmi2OK;
    }
    if (!categories) {
        return null_argument(inst, "fmi2SetDebugLogging", "categories[]");
    }
    unsigned int selected = 0;
    for (size_t i = 0; i < nCategories; i++) {
        const char *name = categories[i];
        unsigned int bit = 0;
        for (unsigned int b = LAYER_LOG_EVENTS; b <= LAYER_LOG_ERROR; b <<= 1) {
            if (name && strcmp(name, category_name(b)) == 0) {
                bit = b;
            }
        }
        if (!bit) {
            layer_log(inst, fmi2Error, LAYER_LOG_ERROR,
                      "fmi2SetDebugLogging: categories[%lu] is not a log category of this FMU "
                      "(logEvents, logStatusWarning, logStatusError)", (unsigned long)i);
            return fmi2Error;
        }
        selected |= bit;
    }
    if (loggingOn) {
        inst->log_categories |= selected;
    } else {
        inst->log_categories &= ~selected;
    }
    return fmi2OK;
}

/* The standard asks for an instance name with at least one character that
 * is not white space. */
static int has_visible_character(const char *name)
{
    for (; name && *name; name++) {
        if (*name != ' ' && *name != '\t' && *name != '\n' && *name != '\r' && *name != '\v' && *name != '\f') {
            return 1;
        }
    }
    return 0;
}

FMI2_Export fmi2Component fmi2Instantiate(fmi2String instanceName, fmi2Type fmuType, fmi2String fmuGUID,
                                          fmi2String fmuResourceLocation,
                                          const fmi2CallbackFunctions *functions, fmi2Boolean visible,
                                          fmi2Boolean loggingOn)
{
    (void)fmuResourceLocation;
    (void)visible;
    if (!functions) {
        return NULL;
    }
    if (!has_visible_character(instanceName)) {
        log_instantiation_error(functions, instanceName,
                                "fmi2Instantiate: instanceName is NULL, empty or only white space");
        return NULL;
    }
    if (!functions->allocateMemory || !functions->freeMemory) {
        log_instantiation_error(functions, instanceName,
                                "fmi2Instantiate: allocateMemory and freeMemory callbacks are required");
        return NULL;
    }
    if (fmuType != fmi2CoSimulation) {
        log_instantiation_error(functions, instanceName,
                                "fmi2Instantiate: %s supports co-simulation only", MODEL_IDENTIFIER_STRING);
        return NULL;
    }
    if (!fmuGUID || strcmp(fmuGUID, MODEL_GUID) != 0) {
        log_instantiation_error(functions, instanceName,
                                "fmi2Instantiate: fmuGUID does not match this binary's GUID %s", MODEL_GUID);
        return NULL;
    }
    Instance *inst = (Instance *)functions->allocateMemory(1, sizeof(Instance));
    const size_t name_size = strlen(instanceName) + 1;
    char *name = (char *)functions->allocateMemory(name_size, 1);
    if (!inst || !name) {
        if (inst) {
            functions->freeMemory(inst);
        }
        if (name) {
            functions->freeMemory(name);
        }
        log_instantiation_error(functions, instanceName, "fmi2Instantiate: out of memory");
        return NULL;
    }
    memset(inst, 0, sizeof *inst);
    memcpy(name, instanceName, name_size);
    inst->instance_name = name;
    inst->logger = functions->logger;
    inst->free_memory = functions->freeMemory;
    inst->environment = functions->componentEnvironment;
    inst->allocate_memory = functions->allocateMemory;
    inst->log_categories = loggingOn ? LAYER_LOG_ALL : 0u;
    reset_instance(inst);                /* makes the tag valid */
    layer_log(inst, fmi2OK, LAYER_LOG_EVENTS, "instantiated %s (GUID %s)", MODEL_IDENTIFIER_STRING, MODEL_GUID);
    return inst;
}

FMI2_Export void fmi2FreeInstance(fmi2Component c)
{
    Instance *inst = (Instance *)c;
    if (!inst || (inst->tag >> 16) != LAYER_MAGIC) {
        return;
    }
    inst->tag = 0;                       /* the instance is dead from here on */
    fmi2CallbackFreeMemory free_memory = inst->free_memory;
    free_memory(inst->instance_name);
    free_memory(inst);
}

FMI2_Export fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean toleranceDefined, fmi2Real tolerance,
                                           fmi2Real startTime, fmi2Boolean stopTimeDefined, fmi2Real stopTime)
{
    BEGIN(c, MASK_SETUP_EXPERIMENT, "fmi2SetupExperiment")
    (void)toleranceDefined;             /* nothing is integrated: no tolerance */
    (void)tolerance;
    if (!is_finite(startTime) || (stopTimeDefined && !(is_finite(stopTime) && stopTime >= startTime))) {
        layer_log(inst, fmi2Error, LAYER_LOG_ERROR,
                  "fmi2SetupExperiment: startTime = %g s and stopTime = %g s must be finite with "
                  "startTime <= stopTime", startTime, stopTime);
        return fmi2Error;
    }
    inst->start_time = inst->time = startTime;
    inst->stop_time = stopTimeDefined ? stopTime : 0.0;
    inst->stop_time_defined = stopTimeDefined ? 1 : 0;
    return fmi2OK;
}

FMI2_Export fmi2Status fmi2EnterInitializationMode(fmi2Component c)
{
    BEGIN(c, MASK_ENTER_INITIALIZATION, "fmi2EnterInitializationMode")
    set_state(inst, LAYER_INITIALIZATION_MODE);
    layer_log(inst, fmi2OK, LAYER_LOG_EVENTS, "initialization mode at t = %g s", inst->time);
    return fmi2OK;
}

FMI2_Export fmi2Status fmi2ExitInitializationMode(fmi2Component c)
{
    BEGIN(c, MASK_EXIT_INITIALIZATION, "fmi2ExitInitializationMode")
    const fmi2Status status = prepare(inst);
    if (status > fmi2Warning) {
        set_state(inst, LAYER_ERROR);
        layer_log(inst, status, LAYER_LOG_ERROR,
                  "fmi2ExitInitializationMode: invalid parameters (see above); call fmi2Reset to start again");
        return status;
    }
    /* from here on the parameters are fixed and prepared: the per-step
     * path relies on that */
    inst->tag = STEP_STALE;
    layer_log(inst, fmi2OK, LAYER_LOG_EVENTS, "initialized: parameters checked");
    return status;
}

FMI2_Export fmi2Status fmi2Terminate(fmi2Component c)
{
    BEGIN(c, MASK_TERMINATE, "fmi2Terminate")
    set_state(inst, LAYER_TERMINATED);
    layer_log(inst, fmi2OK, LAYER_LOG_EVENTS, "terminated at t = %g s", inst->time);
    return fmi2OK;
}

FMI2_Export fmi2Status fmi2Reset(fmi2Component c)
{
    BEGIN(c, MASK_RESET, "fmi2Reset")
    reset_instance(inst);
    layer_log(inst, fmi2OK, LAYER_LOG_EVENTS, "reset to the start values");
    return fmi2OK;
}

/* ------------------------------------------------------------ Real values
 * The per-step calls -- one value, in StepComplete -- take a short path;
 * everything else (several values, parameters, other states, rejected
 * values) the general one.  In StepComplete the parameters are always
 * prepared (fmi2ExitInitializationMode and fmi2SetFMUstate see to it), so
 * the short path only has to bring the outputs up to date. */
static LAYER_COLD fmi2Status get_reals(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                       fmi2Real value[])
{
    BEGIN(c, MASK_GET, "fmi2GetReal")
    CHECK_ARRAYS("fmi2GetReal", nvr, vr, value)
    fmi2Status status = fmi2OK;
    for (size_t i = 0; i < nvr; i++) {
        const fmi2ValueReference r = vr[i];
        if (r >= MODEL_N_REALS) {
            return unknown_reference(inst, "fmi2GetReal", "Real", r);
        }
        if ((inst->tag & LAYER_STALE_OUTPUTS) && LAYER_IS_OUTPUT(r)) {
            status = worst(status, update(inst));
            if (status > fmi2Warning) {
                return status;
            }
        }
        value[i] = inst->real[r];
    }
    return status;
}

FMI2_Export fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                   fmi2Real value[])
{
    Instance *inst = (Instance *)c;
    if (inst && nvr == 1 && vr && value) {
        const uint32_t tag = inst->tag;
        const fmi2ValueReference r = vr[0];
        if (tag == STEP_STALE) {
            if (LAYER_IS_OUTPUT(r)) {
                const fmi2Status status = run_model(inst);
                if (status <= fmi2Warning) {
                    inst->tag = STEP_TAG;
                    value[0] = inst->real[r];
                }
                return status;
            }
        } else if ((tag | LAYER_STALE_NEXT) == (STEP_TAG | LAYER_STALE_NEXT)) {
            if (r < MODEL_N_REALS) {
                value[0] = inst->real[r];   /* the outputs are up to date */
                return fmi2OK;
            }
        }
    }
    return get_reals(c, vr, nvr, value);
}

static LAYER_COLD fmi2Status set_reals(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                       const fmi2Real value[])
{
    BEGIN(c, MASK_SET, "fmi2SetReal")
    CHECK_ARRAYS("fmi2SetReal", nvr, vr, value)
    /* Check everything first: a rejected call changes nothing. */
    for (size_t i = 0; i < nvr; i++) {
        const fmi2ValueReference r = vr[i];
        if (r >= MODEL_N_REALS) {
            return unknown_reference(inst, "fmi2SetReal", "Real", r);
        }
        if (LAYER_IS_OUTPUT(r) || LAYER_IS_CONSTANT(r) || !is_finite(value[i]) ||
            (!LAYER_IS_INPUT(r) && !(inst->tag & MASK_SET_PARAMETER))) {
            return rejected_real(inst, r, value[i]);
        }
    }
    fmi2Status status = fmi2OK;
    for (size_t i = 0; i < nvr; i++) {
        const fmi2ValueReference r = vr[i];
        double v = value[i];
        if (LAYER_IS_INPUT(r)) {
            if (!model_input_ok(inst, r, v)) {
                status = worst(status, model_accept_input(inst, r, &v));
            }
        } else {
            inst->parameters_changed = 1;
        }
        inst->real[r] = v;
    }
    if (nvr > 0) {
        inst->tag |= LAYER_STALE;
    }
    return status;
}

FMI2_Export fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                   const fmi2Real value[])
{
    Instance *inst = (Instance *)c;
    if (inst && (inst->tag | LAYER_STALE) == STEP_STALE && nvr == 1 && vr && value) {
        const fmi2ValueReference r = vr[0];
        if (LAYER_IS_INPUT(r) && model_input_ok(inst, r, value[0])) {
            inst->real[r] = value[0];
            inst->tag = STEP_STALE;
            return fmi2OK;
        }
    }
    return set_reals(c, vr, nvr, value);
}

/* --------------------------------------------------------- Boolean values */
/* Index of the Boolean variable with value reference vr, or -1. */
static int boolean_index(fmi2ValueReference vr)
{
#if MODEL_N_BOOLEANS > 0
    if (vr >= MODEL_FIRST_BOOLEAN_VR && vr - MODEL_FIRST_BOOLEAN_VR < MODEL_N_BOOLEANS) {
        return (int)(vr - MODEL_FIRST_BOOLEAN_VR);
    }
#else
    (void)vr;
#endif
    return -1;
}

FMI2_Export fmi2Status fmi2GetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                      fmi2Boolean value[])
{
    BEGIN(c, MASK_GET, "fmi2GetBoolean")
    CHECK_ARRAYS("fmi2GetBoolean", nvr, vr, value)
    for (size_t i = 0; i < nvr; i++) {
        const int index = boolean_index(vr[i]);
        if (index < 0) {
            return unknown_reference(inst, "fmi2GetBoolean", "Boolean", vr[i]);
        }
        value[i] = inst->boolean[index];
    }
    return fmi2OK;
}

/* Every Boolean variable is a parameter (e.g. the inverse's method switch). */
FMI2_Export fmi2Status fmi2SetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                      const fmi2Boolean value[])
{
    BEGIN(c, MASK_SET, "fmi2SetBoolean")
    CHECK_ARRAYS("fmi2SetBoolean", nvr, vr, value)
    for (size_t i = 0; i < nvr; i++) {
        const int index = boolean_index(vr[i]);
        if (index < 0) {
            return unknown_reference(inst, "fmi2SetBoolean", "Boolean", vr[i]);
        }
        if (!(inst->tag & MASK_SET_PARAMETER)) {
#if MODEL_N_BOOLEANS > 0
            layer_log(inst, fmi2Error, LAYER_LOG_ERROR,
                      "fmi2SetBoolean: parameter %s can be set only before fmi2ExitInitializationMode",
                      boolean_names[index]);
#endif
            return fmi2Error;
        }
    }
    for (size_t i = 0; i < nvr; i++) {
        inst->boolean[boolean_index(vr[i])] = value[i] ? fmi2True : fmi2False;
    }
    if (nvr > 0) {
        inst->tag |= LAYER_STALE;
        inst->parameters_changed = 1;
    }
    return fmi2OK;
}

/* ------------------------------------- Integer and String: none exist */
FMI2_Export fmi2Status fmi2GetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                      fmi2Integer value[])
{
    BEGIN(c, MASK_GET, "fmi2GetInteger")
    CHECK_ARRAYS("fmi2GetInteger", nvr, vr, value)
    return nvr ? unknown_reference(inst, "fmi2GetInteger", "Integer", vr[0]) : fmi2OK;
}

FMI2_Export fmi2Status fmi2SetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                      const fmi2Integer value[])
{
    BEGIN(c, MASK_SET, "fmi2SetInteger")
    CHECK_ARRAYS("fmi2SetInteger", nvr, vr, value)
    return nvr ? unknown_reference(inst, "fmi2SetInteger", "Integer", vr[0]) : fmi2OK;
}

FMI2_Export fmi2Status fmi2GetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                     fmi2String value[])
{
    BEGIN(c, MASK_GET, "fmi2GetString")
    CHECK_ARRAYS("fmi2GetString", nvr, vr, value)
    return nvr ? unknown_reference(inst, "fmi2GetString", "String", vr[0]) : fmi2OK;
}

FMI2_Export fmi2Status fmi2SetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                     const fmi2String value[])
{
    BEGIN(c, MASK_SET, "fmi2SetString")
    CHECK_ARRAYS("fmi2SetString", nvr, vr, value)
    return nvr ? unknown_reference(inst, "fmi2SetString", "String", vr[0]) : fmi2OK;
}

/* ============================================================= FMU state
 * One byte layout serves both the in-memory snapshot and the serialised
 * form, little-endian as on every supported platform:
 *   header  magic "piezoMPI", format version, total size, hash of the GUID,
 *           number of Reals, Booleans and memory values, machine state
 *   body    time, start time, stop time (s), stop-time flag, Reals,
 *           Booleans (int32), committed model memory
 *   trailer FNV-1a 64 checksum of everything before it
 * A blob is accepted only if every field checks out, so a truncated or
 * corrupted one is refused with fmi2Error instead of being trusted. */
#define SERIAL_VERSION 1u
#define SERIAL_HEADER_SIZE 40u
#define SERIAL_BODY_SIZE (32u + 8u * MODEL_N_REALS + 4u * MODEL_N_BOOLEANS + 8u * MODEL_N_MEMORY)
#define SERIAL_SIZE (SERIAL_HEADER_SIZE + SERIAL_BODY_SIZE + 8u)

static const char serial_magic[8] = { 'p', 'i', 'e', 'z', 'o', 'M', 'P', 'I' };

typedef struct {
    unsigned int magic;                 /* LAYER_SNAPSHOT_MAGIC while alive */
    unsigned char bytes[SERIAL_SIZE];
} Snapshot;

static uint64_t fnv1a(const unsigned char *bytes, size_t size)
{
    uint64_t hash = UINT64_C(14695981039346656037);
    for (size_t i = 0; i < size; i++) {
        hash ^= bytes[i];
        hash *= UINT64_C(1099511628211);
    }
    return hash;
}

static uint64_t guid_hash(void)
{
    return fnv1a((const unsigned char *)MODEL_GUID, sizeof MODEL_GUID - 1);
}

static unsigned char *put(unsigned char *p, const void *value, size_t size)
{
    memcpy(p, value, size);
    return p + size;
}

static const unsigned char *get(const unsigned char *p, void *value, size_t size)
{
    memcpy(value, p, size);
    return p + size;
}

static void serialize(const Instance *inst, unsigned char *bytes)
{
    const uint32_t header[6] = { SERIAL_VERSION, SERIAL_SIZE, MODEL_N_REALS, MODEL_N_BOOLEANS,
                                 MODEL_N_MEMORY, layer_state(inst) };
    const uint64_t hash = guid_hash();
    const double times[3] = { inst->time, inst->start_time, inst->stop_time };
    const uint32_t flags[2] = { (uint32_t)inst->stop_time_defined, 0u };
    unsigned char *p = bytes;
    p = put(p, serial_magic, sizeof serial_magic);
    p = put(p, &header[0], 8);                      /* version, size */
    p = put(p, &hash, sizeof hash);
    p = put(p, &header[2], 16);                     /* counts, state */
    p = put(p, times, sizeof times);
    p = put(p, flags, sizeof flags);
    p = put(p, inst->real, sizeof inst->real);
    for (int i = 0; i < MODEL_N_BOOLEANS; i++) {
        const int32_t b = inst->boolean[i];
        p = put(p, &b, sizeof b);
    }
    p = put(p, inst->memory, 8u * MODEL_N_MEMORY);
    const uint64_t checksum = fnv1a(bytes, (size_t)(p - bytes));
    put(p, &checksum, sizeof checksum);
}

static LAYER_COLD fmi2Status bad_state_blob(const Instance *inst, const char *function, const char *why)
{
    layer_log(inst, fmi2Error, LAYER_LOG_ERROR, "%s: not an FMU state of this FMU (%s)", function, why);
    return fmi2Error;
}

/* Checks a serialised state completely before anything is restored. */
static fmi2Status check_serialized(const Instance *inst, const char *function, const unsigned char *bytes,
                                   size_t size)
{
    if (size != SERIAL_SIZE) {
        layer_log(inst, fmi2Error, LAYER_LOG_ERROR,
                  "%s: serialized FMU state has %lu bytes, this FMU writes %lu", function,
                  (unsigned long)size, (unsigned long)SERIAL_SIZE);
        return fmi2Error;
    }
    uint32_t header[6];
    uint64_t hash, checksum;
    const unsigned char *p = bytes;
    if (memcmp(p, serial_magic, sizeof serial_magic) != 0) {
        return bad_state_blob(inst, function, "wrong magic number");
    }
    p = get(p + sizeof serial_magic, &header[0], 8);
    p = get(p, &hash, sizeof hash);
    get(p, &header[2], 16);
    get(bytes + SERIAL_SIZE - 8, &checksum, sizeof checksum);
    if (header[0] != SERIAL_VERSION) {
        return bad_state_blob(inst, function, "unknown format version");
    }
    if (header[1] != SERIAL_SIZE || header[2] != MODEL_N_REALS || header[3] != MODEL_N_BOOLEANS ||
        header[4] != MODEL_N_MEMORY || hash != guid_hash()) {
        return bad_state_blob(inst, function, "written by a different model");
    }
    if (checksum != fnv1a(bytes, SERIAL_SIZE - 8)) {
        return bad_state_blob(inst, function, "checksum mismatch: the data is corrupted");
    }
    const uint32_t state = header[5];
    if (!(state & SNAPSHOT_STATES) || (state & (state - 1u))) {
        return bad_state_blob(inst, function, "invalid machine state");
    }
    /* every number must be finite, every Boolean 0 or 1 */
    p = bytes + SERIAL_HEADER_SIZE;
    const size_t n_doubles_before = 3;
    for (size_t i = 0; i < n_doubles_before; i++) {
        double x;
        p = get(p, &x, sizeof x);
        if (!is_finite(x)) {
            return bad_state_blob(inst, function, "non-finite time");
        }
    }
    uint32_t flags[2];
    p = get(p, flags, sizeof flags);
    if (flags[0] > 1u || flags[1] != 0u) {
        return bad_state_blob(inst, function, "invalid flags");
    }
    for (int i = 0; i < MODEL_N_REALS; i++) {
        double x;
        p = get(p, &x, sizeof x);
        if (!is_finite(x)) {
            return bad_state_blob(inst, function, "non-finite variable value");
        }
    }
    for (int i = 0; i < MODEL_N_BOOLEANS; i++) {
        int32_t b;
        p = get(p, &b, sizeof b);
        if (b != 0 && b != 1) {
            return bad_state_blob(inst, function, "invalid Boolean value");
        }
    }
    for (int i = 0; i < MODEL_N_MEMORY; i++) {
        double x;
        p = get(p, &x, sizeof x);
        if (!is_finite(x)) {
            return bad_state_blob(inst, function, "non-finite model memory");
        }
    }
    return fmi2OK;
}

/* Restores a checked serialised state.  After initialisation the restored
 * parameters are prepared at once (the per-step path relies on it). */
static fmi2Status restore(Instance *inst, const unsigned char *bytes)
{
    uint32_t state, flags[2];
    double times[3];
    get(bytes + 36, &state, sizeof state);
    const unsigned char *p = get(bytes + SERIAL_HEADER_SIZE, times, sizeof times);
    p = get(p, flags, sizeof flags);
    p = get(p, inst->real, sizeof inst->real);
    for (int i = 0; i < MODEL_N_BOOLEANS; i++) {
        int32_t b;
        p = get(p, &b, sizeof b);
        inst->boolean[i] = b;
    }
    get(p, inst->memory, 8u * MODEL_N_MEMORY);
    inst->time = times[0];
    inst->start_time = times[1];
    inst->stop_time = times[2];
    inst->stop_time_defined = (int)flags[0];
    inst->tag = LAYER_TAG(state) | LAYER_STALE;
    inst->parameters_changed = 1;
    if (state & (LAYER_STEP_COMPLETE | LAYER_TERMINATED)) {
        const fmi2Status status = prepare(inst);
        if (status > fmi2Warning) {
            set_state(inst, LAYER_ERROR);
            return status;
        }
    }
    return fmi2OK;
}

/* The snapshot behind an fmi2FMUstate, or NULL when it is not one of this
 * FMU's.  Every snapshot of this layer starts with the magic and the header;
 * the size and model hash there tell a snapshot of another FMU loaded in the
 * same process, which may be shorter than ours, before anything past the
 * header is read. */
static Snapshot *as_snapshot(fmi2FMUstate state)
{
    Snapshot *snapshot = (Snapshot *)state;
    if (!snapshot || snapshot->magic != LAYER_SNAPSHOT_MAGIC) {
        return NULL;
    }
    uint32_t size;
    uint64_t hash;
    get(snapshot->bytes + 12, &size, sizeof size);
    get(snapshot->bytes + 16, &hash, sizeof hash);
    return (size == SERIAL_SIZE && hash == guid_hash()) ? snapshot : NULL;
}

/* A snapshot to write into: *state if it is one of ours, else a new one. */
static Snapshot *writable_snapshot(Instance *inst, const char *function, fmi2FMUstate *state)
{
    if (*state) {
        Snapshot *snapshot = as_snapshot(*state);
        if (!snapshot) {
            bad_state_blob(inst, function, "*FMUstate is neither NULL nor a state of this FMU");
        }
        return snapshot;
    }
    Snapshot *snapshot = (Snapshot *)inst->allocate_memory(1, sizeof(Snapshot));
    if (!snapshot) {
        layer_log(inst, fmi2Error, LAYER_LOG_ERROR, "%s: out of memory", function);
        return NULL;
    }
    snapshot->magic = LAYER_SNAPSHOT_MAGIC;
    return snapshot;
}

FMI2_Export fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate *FMUstate)
{
    BEGIN(c, MASK_FMU_STATE, "fmi2GetFMUstate")
    if (!FMUstate) {
        return null_argument(inst, "fmi2GetFMUstate", "FMUstate");
    }
    Snapshot *snapshot = writable_snapshot(inst, "fmi2GetFMUstate", FMUstate);
    if (!snapshot) {
        return fmi2Error;
    }
    serialize(inst, snapshot->bytes);
    *FMUstate = snapshot;
    return fmi2OK;
}

FMI2_Export fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate FMUstate)
{
    BEGIN(c, MASK_FMU_STATE, "fmi2SetFMUstate")
    const Snapshot *snapshot = as_snapshot(FMUstate);
    if (!snapshot) {
        return bad_state_blob(inst, "fmi2SetFMUstate", FMUstate ? "unknown pointer" : "NULL");
    }
    const fmi2Status status = check_serialized(inst, "fmi2SetFMUstate", snapshot->bytes, SERIAL_SIZE);
    if (status != fmi2OK) {
        return status;
    }
    return restore(inst, snapshot->bytes);
}

FMI2_Export fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate *FMUstate)
{
    BEGIN(c, MASK_FMU_STATE, "fmi2FreeFMUstate")
    if (!FMUstate) {
        return null_argument(inst, "fmi2FreeFMUstate", "FMUstate");
    }
    if (!*FMUstate) {
        return fmi2OK;
    }
    Snapshot *snapshot = as_snapshot(*FMUstate);
    if (!snapshot) {
        return bad_state_blob(inst, "fmi2FreeFMUstate", "unknown pointer");
    }
    snapshot->magic = 0;
    inst->free_memory(snapshot);
    *FMUstate = NULL;
    return fmi2OK;
}

FMI2_Export fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate FMUstate, size_t *size)
{
    BEGIN(c, MASK_FMU_STATE, "fmi2SerializedFMUstateSize")
    if (!size) {
        return null_argument(inst, "fmi2SerializedFMUstateSize", "size");
    }
    if (!as_snapshot(FMUstate)) {
        return bad_state_blob(inst, "fmi2SerializedFMUstateSize", FMUstate ? "unknown pointer" : "NULL");
    }
    *size = SERIAL_SIZE;
    return fmi2OK;
}

FMI2_Export fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate FMUstate,
                                             fmi2Byte serializedState[], size_t size)
{
    BEGIN(c, MASK_FMU_STATE, "fmi2SerializeFMUstate")
    const Snapshot *snapshot = as_snapshot(FMUstate);
    if (!snapshot) {
        return bad_state_blob(inst, "fmi2SerializeFMUstate", FMUstate ? "unknown pointer" : "NULL");
    }
    if (!serializedState) {
        return null_argument(inst, "fmi2SerializeFMUstate", "serializedState[]");
    }
    if (size < SERIAL_SIZE) {
        layer_log(inst, fmi2Error, LAYER_LOG_ERROR,
                  "fmi2SerializeFMUstate: buffer of %lu bytes is too small for %lu", (unsigned long)size,
                  (unsigned long)SERIAL_SIZE);
        return fmi2Error;
    }
    memcpy(serializedState, snapshot->bytes, SERIAL_SIZE);
    return fmi2OK;
}

FMI2_Export fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte serializedState[],
                                               size_t size, fmi2FMUstate *FMUstate)
{
    BEGIN(c, MASK_FMU_STATE, "fmi2DeSerializeFMUstate")
    if (!serializedState || !FMUstate) {
        return null_argument(inst, "fmi2DeSerializeFMUstate", !FMUstate ? "FMUstate" : "serializedState[]");
    }
    const unsigned char *bytes = (const unsigned char *)serializedState;
    const fmi2Status status = check_serialized(inst, "fmi2DeSerializeFMUstate", bytes, size);
    if (status != fmi2OK) {
        return status;
    }
    Snapshot *snapshot = writable_snapshot(inst, "fmi2DeSerializeFMUstate", FMUstate);
    if (!snapshot) {
        return fmi2Error;
    }
    memcpy(snapshot->bytes, bytes, SERIAL_SIZE);
    *FMUstate = snapshot;
    return fmi2OK;
}

FMI2_Export fmi2Status fmi2GetDirectionalDerivative(fmi2Component c, const fmi2ValueReference vUnknown_ref[],
                                                    size_t nUnknown, const fmi2ValueReference vKnown_ref[],
                                                    size_t nKnown, const fmi2Real dvKnown[],
                                                    fmi2Real dvUnknown[])
{
    BEGIN(c, MASK_DIRECTIONAL_DERIVATIVE, "fmi2GetDirectionalDerivative")
    (void)vUnknown_ref; (void)nUnknown; (void)vKnown_ref; (void)nKnown; (void)dvKnown; (void)dvUnknown;
    return unsupported(inst, "fmi2GetDirectionalDerivative", "providesDirectionalDerivative is false");
}

/* ==================================================== co-simulation only */
FMI2_Export fmi2Status fmi2SetRealInputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                                   const fmi2Integer order[], const fmi2Real value[])
{
    BEGIN(c, MASK_SET_INPUT_DERIVATIVES, "fmi2SetRealInputDerivatives")
    (void)vr; (void)nvr; (void)order; (void)value;
    return unsupported(inst, "fmi2SetRealInputDerivatives", "canInterpolateInputs is false");
}

FMI2_Export fmi2Status fmi2GetRealOutputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                                    const fmi2Integer order[], fmi2Real value[])
{
    BEGIN(c, MASK_GET_OUTPUT_DERIVATIVES, "fmi2GetRealOutputDerivatives")
    (void)vr; (void)nvr; (void)order; (void)value;
    return unsupported(inst, "fmi2GetRealOutputDerivatives", "maxOutputDerivativeOrder is 0");
}

/* Commits the tentative memory, computed for the input held over the step,
 * and moves on to the end of the step at time next (s). */
static inline void commit(Instance *inst, double next)
{
    double *committed = inst->scratch;
    inst->scratch = inst->memory;
    inst->memory = committed;
    inst->tag = STEP_TAG | LAYER_STALE_NEXT | (model_outputs_hold(inst) ? 0u : LAYER_STALE_OUTPUTS);
    inst->time = next;
}

/* A positive finite double (NaN fails the first comparison). */
static inline int is_positive_finite(double x)
{
    return x > 0.0 && !(x > 1.7976931348623157e308);
}

#ifdef MODEL_FIXED_STEP_SIZE
/* The step h at time t is the model's fixed step up to the rounding of the
 * importer's time arithmetic (e.g. h = (n + 1) T - n T). */
static inline int step_size_ok(double t, double h)
{
    const double error = h - MODEL_FIXED_STEP_SIZE;
    const double tolerance = 1e-9 * MODEL_FIXED_STEP_SIZE + 1e-15 * (t < 0.0 ? -t : t);
    return error <= tolerance && error >= -tolerance;
}
#else
#define step_size_ok(t, h) 1
#endif

/* fmi2DoStep when the short path does not apply: checks the arguments, with
 * a tolerance on the time, and computes the step's outputs if stale. */
static LAYER_COLD fmi2Status do_step(fmi2Component c, double t, double h)
{
    BEGIN(c, MASK_DO_STEP, "fmi2DoStep")
    const double now = inst->time;
    /* the importer's time may differ from ours by rounding only */
    const double tolerance = 1e-9 * (1.0 + (now < 0.0 ? -now : now));
    const double offset = t - now;
    if (!is_positive_finite(h)) {
        layer_log(inst, fmi2Error, LAYER_LOG_ERROR,
                  "fmi2DoStep: communicationStepSize = %g s must be positive and finite", h);
        return fmi2Error;
    }
#ifdef MODEL_FIXED_STEP_SIZE
    if (!step_size_ok(t, h)) {
        layer_log(inst, fmi2Error, LAYER_LOG_ERROR,
                  "fmi2DoStep: communicationStepSize = %.17g s, but this FMU steps at its sample period "
                  "%.17g s only", h, MODEL_FIXED_STEP_SIZE);
        return fmi2Error;
    }
#endif
    if (!(offset <= tolerance && offset >= -tolerance)) {
        layer_log(inst, fmi2Error, LAYER_LOG_ERROR,
                  "fmi2DoStep: currentCommunicationPoint = %.17g s does not match the FMU's time %.17g s",
                  t, now);
        return fmi2Error;
    }
    if (!is_finite(t + h)) {
        layer_log(inst, fmi2Error, LAYER_LOG_ERROR,
                  "fmi2DoStep: the step from %.17g s by %.17g s would end at an infinite time", t, h);
        return fmi2Error;
    }
    fmi2Status status = fmi2OK;
    if (inst->tag & LAYER_STALE_NEXT) {
        status = update(inst);
        if (status > fmi2Warning) {
            return status;
        }
    }
    commit(inst, t + h);
    return status;
}

FMI2_Export fmi2Status fmi2DoStep(fmi2Component c, fmi2Real currentCommunicationPoint,
                                  fmi2Real communicationStepSize, fmi2Boolean noSetFMUStatePriorToCurrentPoint)
{
    (void)noSetFMUStatePriorToCurrentPoint;
    Instance *inst = (Instance *)c;
    const double t = currentCommunicationPoint;
    const double h = communicationStepSize;
    const double next = t + h;
    /* short path: StepComplete, t is the FMU's time, 0 < h (the fixed step,
     * if any) and t + h finite (NaN fails every comparison) */
    if (inst && (inst->tag | LAYER_STALE) == STEP_STALE && t == inst->time && next > t &&
        !(next > 1.7976931348623157e308) && step_size_ok(t, h)) {
        fmi2Status status = fmi2OK;
        if (inst->tag & LAYER_STALE_NEXT) {
            /* parameters are prepared in StepComplete: only the model runs */
            status = run_model(inst);
            if (status > fmi2Warning) {
                return status;
            }
        }
        commit(inst, next);
        return status;
    }
    return do_step(c, t, h);
}

FMI2_Export fmi2Status fmi2CancelStep(fmi2Component c)
{
    /* doStep never returns fmi2Pending, so there is never a step to cancel */
    BEGIN(c, MASK_CANCEL_STEP, "fmi2CancelStep")
    return fmi2Error;
}

static fmi2Status status_not_available(const Instance *inst, const char *function)
{
    layer_log(inst, fmi2Discard, LAYER_LOG_WARNING,
              "%s: this status is not available (doStep is synchronous and never discards)", function);
    return fmi2Discard;
}

FMI2_Export fmi2Status fmi2GetStatus(fmi2Component c, const fmi2StatusKind s, fmi2Status *value)
{
    BEGIN(c, MASK_GET_STATUS, "fmi2GetStatus")
    (void)s;
    if (!value) {
        return null_argument(inst, "fmi2GetStatus", "value");
    }
    return status_not_available(inst, "fmi2GetStatus");
}

FMI2_Export fmi2Status fmi2GetRealStatus(fmi2Component c, const fmi2StatusKind s, fmi2Real *value)
{
    BEGIN(c, MASK_GET_STATUS, "fmi2GetRealStatus")
    if (!value) {
        return null_argument(inst, "fmi2GetRealStatus", "value");
    }
    if (s == fmi2LastSuccessfulTime) {
        *value = inst->time;
        return fmi2OK;
    }
    return status_not_available(inst, "fmi2GetRealStatus");
}

FMI2_Export fmi2Status fmi2GetIntegerStatus(fmi2Component c, const fmi2StatusKind s, fmi2Integer *value)
{
    BEGIN(c, MASK_GET_STATUS, "fmi2GetIntegerStatus")
    (void)s;
    if (!value) {
        return null_argument(inst, "fmi2GetIntegerStatus", "value");
    }
    return status_not_available(inst, "fmi2GetIntegerStatus");
}

FMI2_Export fmi2Status fmi2GetBooleanStatus(fmi2Component c, const fmi2StatusKind s, fmi2Boolean *value)
{
    BEGIN(c, MASK_GET_STATUS, "fmi2GetBooleanStatus")
    if (!value) {
        return null_argument(inst, "fmi2GetBooleanStatus", "value");
    }
    if (s == fmi2Terminated) {
        *value = fmi2False;             /* the FMU never asks to stop */
        return fmi2OK;
    }
    return status_not_available(inst, "fmi2GetBooleanStatus");
}

FMI2_Export fmi2Status fmi2GetStringStatus(fmi2Component c, const fmi2StatusKind s, fmi2String *value)
{
    BEGIN(c, MASK_GET_STATUS, "fmi2GetStringStatus")
    (void)s;
    if (!value) {
        return null_argument(inst, "fmi2GetStringStatus", "value");
    }
    return status_not_available(inst, "fmi2GetStringStatus");
}
