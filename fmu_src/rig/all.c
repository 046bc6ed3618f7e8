/*
 * all.c (rig parts) -- the whole FMU of a rig part (amplifier, controller,
 * sensor, LTI system) as one translation unit: the file an importer compiles
 * (listed in modelDescription.xml), and the one the binaries are built from.
 *
 * The arithmetic must not be contracted into fused multiply-adds: the FMUs
 * compute bit for bit what the Python reference equations compute.
 */
#if defined(__clang__)
#pragma STDC FP_CONTRACT OFF
#elif defined(__GNUC__)
#pragma GCC optimize("fp-contract=off")
#elif defined(_MSC_VER)
#pragma fp_contract(off)
#endif

/* The library headers come first: they must keep their default visibility. */
#include <math.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmi2Functions.h"

/* Only the fmi2* functions, declared with default visibility by
 * fmi2Functions.h, are exported; everything below is internal. */
#if defined(__GNUC__) && !defined(_WIN32)
#pragma GCC visibility push(hidden)
#endif

#include "model_config.h"
#include "model.c"
#include "part_hooks.c"
#include "fmi2_layer.c"

#if defined(__GNUC__) && !defined(_WIN32)
#pragma GCC visibility pop
#endif
