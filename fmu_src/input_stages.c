/*
 * input_stages.c -- see input_stages.h.  Build with -ffp-contract=off.
 */
#include "input_stages.h"

ISTAGE_API void istage_slew_limit(size_t n, const double *v, double max_change, double *out)
{
    if (n == 0 || v == NULL || out == NULL) {
        return;
    }
    double x = v[0];
    for (size_t k = 0; k < n; k++) {
        const double target = v[k];
        if (target > x + max_change) {
            x += max_change;
        } else if (target < x - max_change) {
            x -= max_change;
        } else {
            x = target;
        }
        out[k] = x;
    }
}
