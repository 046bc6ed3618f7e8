/*
 * fmi2_api.h -- the test programs' view of an FMU binary: every fmi2*
 * function of the co-simulation interface resolved from a shared library
 * (dlopen on Linux, LoadLibrary on Windows), as a table of typed pointers.
 *
 * Header-only (static functions), portable C99; include it in one .c file.
 */
#ifndef PIEZO_TESTS_FMI2_API_H
#define PIEZO_TESTS_FMI2_API_H

#include <stdio.h>
#include <string.h>

#include "fmi2TypesPlatform.h"
#include "fmi2FunctionTypes.h"

#ifdef _WIN32
#include <windows.h>
typedef HMODULE Fmi2Library;
static Fmi2Library fmi2_open_library(const char *path) { return LoadLibraryA(path); }
static void fmi2_load_symbol(Fmi2Library lib, const char *name, void (**target)(void))
{
    FARPROC f = GetProcAddress(lib, name);
    memcpy(target, &f, sizeof *target);
}
static void fmi2_close_library(Fmi2Library lib) { FreeLibrary(lib); }
#else
#include <dlfcn.h>
typedef void *Fmi2Library;
static Fmi2Library fmi2_open_library(const char *path) { return dlopen(path, RTLD_NOW | RTLD_LOCAL); }
static void fmi2_load_symbol(Fmi2Library lib, const char *name, void (**target)(void))
{
    void *f = dlsym(lib, name);
    memcpy(target, &f, sizeof *target);   /* object to function pointer: via bytes */
}
static void fmi2_close_library(Fmi2Library lib) { dlclose(lib); }
#endif

typedef struct {
    fmi2GetTypesPlatformTYPE *GetTypesPlatform;
    fmi2GetVersionTYPE *GetVersion;
    fmi2SetDebugLoggingTYPE *SetDebugLogging;
    fmi2InstantiateTYPE *Instantiate;
    fmi2FreeInstanceTYPE *FreeInstance;
    fmi2SetupExperimentTYPE *SetupExperiment;
    fmi2EnterInitializationModeTYPE *EnterInitializationMode;
    fmi2ExitInitializationModeTYPE *ExitInitializationMode;
    fmi2TerminateTYPE *Terminate;
    fmi2ResetTYPE *Reset;
    fmi2GetRealTYPE *GetReal;
    fmi2GetIntegerTYPE *GetInteger;
    fmi2GetBooleanTYPE *GetBoolean;
    fmi2GetStringTYPE *GetString;
    fmi2SetRealTYPE *SetReal;
    fmi2SetIntegerTYPE *SetInteger;
    fmi2SetBooleanTYPE *SetBoolean;
    fmi2SetStringTYPE *SetString;
    fmi2GetFMUstateTYPE *GetFMUstate;
    fmi2SetFMUstateTYPE *SetFMUstate;
    fmi2FreeFMUstateTYPE *FreeFMUstate;
    fmi2SerializedFMUstateSizeTYPE *SerializedFMUstateSize;
    fmi2SerializeFMUstateTYPE *SerializeFMUstate;
    fmi2DeSerializeFMUstateTYPE *DeSerializeFMUstate;
    fmi2GetDirectionalDerivativeTYPE *GetDirectionalDerivative;
    fmi2SetRealInputDerivativesTYPE *SetRealInputDerivatives;
    fmi2GetRealOutputDerivativesTYPE *GetRealOutputDerivatives;
    fmi2DoStepTYPE *DoStep;
    fmi2CancelStepTYPE *CancelStep;
    fmi2GetStatusTYPE *GetStatus;
    fmi2GetRealStatusTYPE *GetRealStatus;
    fmi2GetIntegerStatusTYPE *GetIntegerStatus;
    fmi2GetBooleanStatusTYPE *GetBooleanStatus;
    fmi2GetStringStatusTYPE *GetStringStatus;
} Fmi2Api;

/* In the order of the members of Fmi2Api. */
static const char *const fmi2_api_names[] = {
    "fmi2GetTypesPlatform", "fmi2GetVersion", "fmi2SetDebugLogging", "fmi2Instantiate",
    "fmi2FreeInstance", "fmi2SetupExperiment", "fmi2EnterInitializationMode",
    "fmi2ExitInitializationMode", "fmi2Terminate", "fmi2Reset", "fmi2GetReal", "fmi2GetInteger",
    "fmi2GetBoolean", "fmi2GetString", "fmi2SetReal", "fmi2SetInteger", "fmi2SetBoolean",
    "fmi2SetString", "fmi2GetFMUstate", "fmi2SetFMUstate", "fmi2FreeFMUstate",
    "fmi2SerializedFMUstateSize", "fmi2SerializeFMUstate", "fmi2DeSerializeFMUstate",
    "fmi2GetDirectionalDerivative", "fmi2SetRealInputDerivatives", "fmi2GetRealOutputDerivatives",
    "fmi2DoStep", "fmi2CancelStep", "fmi2GetStatus", "fmi2GetRealStatus", "fmi2GetIntegerStatus",
    "fmi2GetBooleanStatus", "fmi2GetStringStatus",
};
#define FMI2_N_API (sizeof fmi2_api_names / sizeof fmi2_api_names[0])
typedef char fmi2_api_table_matches_names[sizeof(Fmi2Api) == FMI2_N_API * sizeof(void (*)(void)) ? 1 : -1];

/* Loads path and resolves every function into *api.  Returns the library, or
 * NULL (with a line on stderr) when it cannot be loaded or lacks a function. */
static Fmi2Library fmi2_load(const char *path, Fmi2Api *api)
{
    Fmi2Library lib = fmi2_open_library(path);
    if (!lib) {
        fprintf(stderr, "cannot load %s\n", path);
        return NULL;
    }
    void (*functions[FMI2_N_API])(void);
    for (size_t i = 0; i < FMI2_N_API; i++) {
        fmi2_load_symbol(lib, fmi2_api_names[i], &functions[i]);
        if (!functions[i]) {
            fprintf(stderr, "%s does not export %s\n", path, fmi2_api_names[i]);
            fmi2_close_library(lib);
            return NULL;
        }
    }
    memcpy(api, functions, sizeof *api);
    return lib;
}

#endif /* PIEZO_TESTS_FMI2_API_H */
