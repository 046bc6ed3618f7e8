/*
 * all.c -- the whole FMU as one translation unit: the file an importer
 * compiles (listed in modelDescription.xml), and the one the binaries are
 * built from, so the compiler sees the per-step path in one piece.
 *
 * The hysteresis arithmetic must not be contracted into fused multiply-adds:
 * the FMUs compute bit for bit what the Python package computes.
 */
#if defined(__clang__)
#pragma STDC FP_CONTRACT OFF
#elif defined(__GNUC__)
#pragma GCC optimize("fp-contract=off")
#elif defined(_MSC_VER)
#pragma fp_contract(off)
#endif

/* only the fmi2* functions (declared with default visibility) are exported */
#if defined(__GNUC__) && !defined(_WIN32)
#pragma GCC visibility push(hidden)
#endif

#include "hysteresis.c"
#include "mpi_parameters.c"
#include "model.c"
#include "fmi2_layer.c"

#if defined(__GNUC__) && !defined(_WIN32)
#pragma GCC visibility pop
#endif
