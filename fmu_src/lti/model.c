/*
 * model.c (lti) -- the hooks of the FMI layer for the LTI system.
 *
 * One step of size h with the input u held (the stage row of
 * pysim.cosim.rig.RigSimulation's unit table):
 *     z' = Ad z + Bd u,     y = D u + C z'
 * summed in index order (z'_i = (sum_j Ad_ij z_j) + Bd_i u; y = D u, then
 * + C_i z'_i for i = 1..n), and between steps y = D u + C z for the current
 * input (direct feed-through when D != 0).  The state starts at 0.
 *
 * Continuous system: Ad = e^(A h) and Bd = (integral_0^h e^(A s) ds) B, the
 * exact zero-order-hold discretisation, are the top blocks of the exponential
 * of the augmented matrix [A B; 0 0] h.  For the nominal step (the one the
 * FMU was generated for) and unchanged A and B they are the generator's
 * values (scipy's expm); for any other step they are computed here when the
 * step changes: scaling and squaring with the [13/13] Pade approximant
 * (Higham 2005), the linear system solved by Gaussian elimination with
 * partial pivoting.  Discrete system: Ad = A, Bd = B, and every step must be
 * its sampling time.
 */
#include "fmi2_layer.h"

#if LTI_N > 0
static const double nominal_a[LTI_N * LTI_N] = MODEL_NOMINAL_A;
static const double nominal_b[LTI_N] = MODEL_NOMINAL_B;
static const double nominal_ad[LTI_N * LTI_N] = MODEL_NOMINAL_AD;
static const double nominal_bd[LTI_N] = MODEL_NOMINAL_BD;
#endif

void model_reset(Instance *inst)
{
    inst->model.nominal_ok = 0;
    inst->model.step = 0.0;
}

#if LTI_N > 0 && !MODEL_DISCRETE
/* c = a b for m x m row-major matrices */
static void lti_multiply(const double *a, const double *b, double *c)
{
    for (int i = 0; i < LTI_M; i++) {
        for (int j = 0; j < LTI_M; j++) {
            double s = 0.0;
            for (int k = 0; k < LTI_M; k++) {
                s += a[i * LTI_M + k] * b[k * LTI_M + j];
            }
            c[i * LTI_M + j] = s;
        }
    }
}

/* Solves p x = q in place (q becomes x) for m columns; 0 if p is singular. */
static int lti_solve(double *p, double *q, int *pivot)
{
    for (int k = 0; k < LTI_M; k++) {
        int best = k;
        for (int i = k + 1; i < LTI_M; i++) {
            if (fabs(p[i * LTI_M + k]) > fabs(p[best * LTI_M + k])) {
                best = i;
            }
        }
        pivot[k] = best;
        if (p[best * LTI_M + k] == 0.0) {
            return 0;
        }
        if (best != k) {
            for (int j = 0; j < LTI_M; j++) {
                double t = p[k * LTI_M + j];
                p[k * LTI_M + j] = p[best * LTI_M + j];
                p[best * LTI_M + j] = t;
                t = q[k * LTI_M + j];
                q[k * LTI_M + j] = q[best * LTI_M + j];
                q[best * LTI_M + j] = t;
            }
        }
        for (int i = k + 1; i < LTI_M; i++) {
            const double factor = p[i * LTI_M + k] / p[k * LTI_M + k];
            if (factor != 0.0) {
                for (int j = k; j < LTI_M; j++) {
                    p[i * LTI_M + j] -= factor * p[k * LTI_M + j];
                }
                for (int j = 0; j < LTI_M; j++) {
                    q[i * LTI_M + j] -= factor * q[k * LTI_M + j];
                }
            }
        }
    }
    for (int k = LTI_M - 1; k >= 0; k--) {
        for (int j = 0; j < LTI_M; j++) {
            double s = q[k * LTI_M + j];
            for (int i = k + 1; i < LTI_M; i++) {
                s -= p[k * LTI_M + i] * q[i * LTI_M + j];
            }
            q[k * LTI_M + j] = s / p[k * LTI_M + k];
        }
    }
    return 1;
}

/* ad, bd for the step h from the parameters A, B; 0 if that fails. */
static int lti_discretise(Instance *inst, double h)
{
    static const double c[14] = {
        64764752532480000.0, 32382376266240000.0, 7771770303897600.0, 1187353796428800.0,
        129060195264000.0, 10559470521600.0, 670442572800.0, 33522128640.0, 1323241920.0,
        40840800.0, 960960.0, 16380.0, 182.0, 1.0
    };
    ModelData *model = &inst->model;
    double *x = model->work[0], *x2 = model->work[1], *x4 = model->work[2], *x6 = model->work[3];
    double *u = model->work[4], *v = model->work[5], *inner = model->work[6], *tmp = model->work[7];
    const double *real = inst->real;
    /* x = [A B; 0 0] h and its 1-norm */
    memset(x, 0, sizeof(double) * LTI_M * LTI_M);
    for (int i = 0; i < LTI_N; i++) {
        for (int j = 0; j < LTI_N; j++) {
            x[i * LTI_M + j] = real[VR_A + i * LTI_N + j] * h;
        }
        x[i * LTI_M + LTI_N] = real[VR_B + i] * h;
    }
    /* balance: x = S^-1 x S with S = diag(scale), powers of 2 (exact), so
     * that the rows and columns of a badly scaled realisation (a companion
     * form) are comparable; e^x then follows as S e^(S^-1 x S) S^-1 */
    double *scale = model->scale;
    for (int i = 0; i < LTI_M; i++) {
        scale[i] = 1.0;
    }
    for (int done = 0, sweeps = 0; !done && sweeps < 100; sweeps++) {
        done = 1;
        for (int i = 0; i < LTI_M; i++) {
            double column = 0.0, row = 0.0;
            for (int j = 0; j < LTI_M; j++) {
                if (j != i) {
                    column += fabs(x[j * LTI_M + i]);
                    row += fabs(x[i * LTI_M + j]);
                }
            }
            if (column == 0.0 || row == 0.0) {
                continue;
            }
            const double total = column + row;
            double f = 1.0;
            while (column < row / 2.0) {
                f *= 2.0;
                column *= 4.0;
            }
            while (column > row * 2.0) {
                f /= 2.0;
                column /= 4.0;
            }
            if ((column + row) / f < 0.95 * total) {
                done = 0;
                scale[i] *= f;
                for (int j = 0; j < LTI_M; j++) {
                    x[i * LTI_M + j] /= f;
                    x[j * LTI_M + i] *= f;
                }
            }
        }
    }
    double norm = 0.0;
    for (int j = 0; j < LTI_M; j++) {
        double column = 0.0;
        for (int i = 0; i < LTI_M; i++) {
            column += fabs(x[i * LTI_M + j]);
        }
        norm = column > norm ? column : norm;
    }
    if (!layer_is_finite(norm)) {
        return 0;
    }
    int squarings = 0;
    if (norm > 5.371920351148152) {
        squarings = (int)ceil(log2(norm / 5.371920351148152));
        for (int i = 0; i < LTI_M * LTI_M; i++) {
            x[i] = ldexp(x[i], -squarings);
        }
    }
    lti_multiply(x, x, x2);
    lti_multiply(x2, x2, x4);
    lti_multiply(x4, x2, x6);
    /* u = x [x6 (c13 x6 + c11 x4 + c9 x2) + c7 x6 + c5 x4 + c3 x2 + c1 I]
     * v =    x6 (c12 x6 + c10 x4 + c8 x2) + c6 x6 + c4 x4 + c2 x2 + c0 I */
    for (int i = 0; i < LTI_M * LTI_M; i++) {
        inner[i] = c[13] * x6[i] + c[11] * x4[i] + c[9] * x2[i];
    }
    lti_multiply(x6, inner, tmp);
    for (int i = 0; i < LTI_M * LTI_M; i++) {
        tmp[i] += c[7] * x6[i] + c[5] * x4[i] + c[3] * x2[i];
    }
    for (int i = 0; i < LTI_M; i++) {
        tmp[i * LTI_M + i] += c[1];
    }
    lti_multiply(x, tmp, u);
    for (int i = 0; i < LTI_M * LTI_M; i++) {
        inner[i] = c[12] * x6[i] + c[10] * x4[i] + c[8] * x2[i];
    }
    lti_multiply(x6, inner, v);
    for (int i = 0; i < LTI_M * LTI_M; i++) {
        v[i] += c[6] * x6[i] + c[4] * x4[i] + c[2] * x2[i];
    }
    for (int i = 0; i < LTI_M; i++) {
        v[i * LTI_M + i] += c[0];
    }
    /* (v - u) r = (v + u) */
    double *p = x2, *r = x4;
    for (int i = 0; i < LTI_M * LTI_M; i++) {
        p[i] = v[i] - u[i];
        r[i] = v[i] + u[i];
    }
    if (!lti_solve(p, r, model->pivot)) {
        return 0;
    }
    for (int k = 0; k < squarings; k++) {
        lti_multiply(r, r, tmp);
        memcpy(r, tmp, sizeof(double) * LTI_M * LTI_M);
    }
    for (int i = 0; i < LTI_N; i++) {
        for (int j = 0; j < LTI_N; j++) {
            model->ad[i * LTI_N + j] = r[i * LTI_M + j] * scale[i] / scale[j];
        }
        model->bd[i] = r[i * LTI_M + LTI_N] * scale[i] / scale[LTI_N];
    }
    for (int i = 0; i < LTI_M * LTI_M; i++) {
        if (!layer_is_finite(r[i])) {
            return 0;
        }
    }
    model->step = h;
    return 1;
}
#endif

/* Makes ad and bd those of the step h (computed only when h changes). */
int lti_coefficients(Instance *inst, double h);
int lti_coefficients(Instance *inst, double h)
{
    ModelData *model = &inst->model;
    if (model->step == h) {
        return 1;
    }
#if LTI_N > 0
#if MODEL_DISCRETE
    memcpy(model->ad, &inst->real[VR_A], sizeof(double) * LTI_N * LTI_N);
    memcpy(model->bd, &inst->real[VR_B], sizeof(double) * LTI_N);
#else
    if (!(model->nominal_ok && h == MODEL_NOMINAL_STEP)) {
        return lti_discretise(inst, h);
    }
    memcpy(model->ad, nominal_ad, sizeof nominal_ad);
    memcpy(model->bd, nominal_bd, sizeof nominal_bd);
#endif
#endif
    model->step = h;
    return 1;
}

fmi2Status model_prepare(Instance *inst)
{
    ModelData *model = &inst->model;
    model->step = 0.0;
    model->nominal_ok = 1;
#if LTI_N > 0
    model->nominal_ok = memcmp(&inst->real[VR_A], nominal_a, sizeof nominal_a) == 0 &&
                        memcmp(&inst->real[VR_B], nominal_b, sizeof nominal_b) == 0;
#endif
    if (!lti_coefficients(inst, MODEL_NOMINAL_STEP)) {
        layer_log(inst, fmi2Error, LAYER_LOG_ERROR, "invalid parameters: A and B (A[1,1] = %g, B[1] = %g) "
                  "give no finite discretisation for the step %g s", inst->real[MODEL_N_INPUTS + MODEL_N_OUTPUTS],
                  inst->real[MODEL_N_INPUTS + MODEL_N_OUTPUTS + LTI_N * LTI_N], MODEL_NOMINAL_STEP);
        return fmi2Error;
    }
    return fmi2OK;
}

LAYER_HOT fmi2Status model_update(Instance *inst)
{
    double *real = inst->real;
    const double *memory = inst->memory;
    double *next = inst->scratch;
    double step = memory[RIG_STEP];
    const double u = real[VR_u];
    double y;
    if (memory[RIG_PENDING] != 0.0) {
        const double h = rig_step_size(memory[RIG_T_START], inst->time, step);
        if (!lti_coefficients(inst, h)) {
            layer_log(inst, fmi2Error, LAYER_LOG_ERROR, "fmi2DoStep: A and B give no finite discretisation "
                      "for the step %.17g s", h);
            return fmi2Error;
        }
        const double held = memory[LTI_INPUT];
        for (int i = 0; i < LTI_N; i++) {
            double s = 0.0;
            for (int j = 0; j < LTI_N; j++) {
                s += inst->model.ad[i * LTI_N + j] * memory[LTI_STATE + j];
            }
            next[LTI_STATE + i] = s + inst->model.bd[i] * held;
        }
        step = h;
    } else {
        for (int i = 0; i < LTI_N; i++) {
            next[LTI_STATE + i] = memory[LTI_STATE + i];
        }
    }
    y = real[VR_D] * u;
    for (int i = 0; i < LTI_N; i++) {
        y += real[VR_C + i] * next[LTI_STATE + i];
    }
    real[VR_y] = y;
    next[RIG_PENDING] = 1.0;
    next[RIG_T_START] = inst->time;
    next[RIG_STEP] = step;
    next[LTI_INPUT] = u;
    return fmi2OK;
}
