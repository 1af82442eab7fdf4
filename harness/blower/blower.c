/* Blower: the air supply of an inflated cushion, an FMI 2.0 Co-Simulation FMU.
 *
 * A blower with a fan curve pushes air from the atmosphere into the cushion; a relief valve
 * to the atmosphere, opened by a PI controller on the pressure error, holds the pressure at a
 * set point. Isothermal ideal gas. The gas in the cushion is counted as its volume N at the
 * atmosphere's pressure (m³, so that (p + p_atm) V = p_atm N: Velarium's `gas` input is N - V⁰,
 * the output dN = N - N_ref with the parameter N_ref = V⁰, docs/coupling.md).
 *
 *   fan:        dp0 (1 - a q - (1 - a) q²) = p,   q = Q_fan / Q_max   (a = fan_shape)
 *   valve:      Q_valve = u K_valve p / sqrt(|p| + p_lam)
 *   controller: e = p - p_set,  dI/dt = e,  u = clamp(u0 + Kp e + Ki I, 0, 1)
 *   gas:        dN/dt = Q_fan(p) - Q_valve(p, u),   p = p_atm N / V - p_atm (gauge)
 *
 * A step [t, t+h] is one backward-Euler step with the inputs V and p_set held at their values
 * (the end-of-step values when a master iterates): a scalar Newton solve in N to 1e-14.
 * GetDirectionalDerivative gives the derivative of the outputs after the last DoStep with respect
 * to that step's inputs (the step taken again with other inputs, which is what a strongly coupling
 * master needs); before the first step, the direct feedthrough at the current state.
 * Get/Set/Serialize FMU state hold the whole state. No dependencies beyond libc and libm.
 */
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

typedef void *fmi2Component;
typedef void *fmi2ComponentEnvironment;
typedef void *fmi2FMUstate;
typedef unsigned int fmi2ValueReference;
typedef double fmi2Real;
typedef int fmi2Integer;
typedef int fmi2Boolean;
typedef char fmi2Char;
typedef const fmi2Char *fmi2String;
typedef char fmi2Byte;
typedef enum { fmi2OK, fmi2Warning, fmi2Discard, fmi2Error, fmi2Fatal, fmi2Pending } fmi2Status;
typedef enum { fmi2ModelExchange, fmi2CoSimulation } fmi2Type;
typedef enum { fmi2DoStepStatus, fmi2PendingStatus, fmi2LastSuccessfulTime, fmi2Terminated } fmi2StatusKind;
typedef void (*fmi2CallbackLogger)(fmi2ComponentEnvironment, fmi2String, fmi2Status, fmi2String, fmi2String, ...);
typedef struct {
    fmi2CallbackLogger logger;
    void *(*allocateMemory)(size_t, size_t);
    void (*freeMemory)(void *);
    void (*stepFinished)(fmi2ComponentEnvironment, fmi2Status);
    fmi2ComponentEnvironment componentEnvironment;
} fmi2CallbackFunctions;

#define EXPORT __attribute__((visibility("default")))
#define GUID "{5b1c3e0a-7f2d-4c59-9a3e-b10e3c0a5e10}"

/* Value references (modelDescription.xml). */
enum {
    VR_V = 0, VR_PSET = 1,                                   /* inputs */
    VR_P = 2, VR_N = 3, VR_U = 4, VR_QFAN = 5, VR_QVALVE = 6, VR_DN = 7, /* outputs */
    VR_PATM = 10, VR_DP0 = 11, VR_QMAX = 12, VR_SHAPE = 13, VR_KV = 14, VR_PLAM = 15,
    VR_KP = 16, VR_KI = 17, VR_U0 = 18, VR_V0 = 19, VR_P0 = 20, VR_NREF = 21, /* parameters */
    NPAR_FIRST = 10, NPAR_LAST = 21
};

#define MAGIC 0x42c0u

/* Everything a state holds: plain doubles, so a state is a memcpy. */
typedef struct {
    unsigned magic;
    double par[NPAR_LAST + 1]; /* indexed by value reference */
    double V, p_set;           /* inputs */
    double N, I, t;            /* state */
    double N_prev, I_prev, h;  /* the last step's start, for the derivative */
    int stepped, initialized;
} State;

typedef struct {
    State s;
    fmi2CallbackFunctions cb;
    char name[128];
    int logging;
} Blower;

static void say(Blower *b, fmi2Status st, const char *fmt, ...) {
    char msg[512];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(msg, sizeof msg, fmt, ap);
    va_end(ap);
    if (b->cb.logger) b->cb.logger(b->cb.componentEnvironment, b->name, st, st >= fmi2Error ? "logStatusError" : "logAll", "%s", msg);
}

/* ---- the model ---- */

static double pressure(const State *s, double N, double V) { return s->par[VR_PATM] * N / V - s->par[VR_PATM]; }

/* Fan volume flow at gauge pressure p and its derivative. Beyond the curve's vertex (p above
 * dp0 (1 + a²/(4(1-a)))) the flow holds the vertex's value. */
static double fan(const State *s, double p, double *dq) {
    double dp0 = s->par[VR_DP0], qmax = s->par[VR_QMAX], a = s->par[VR_SHAPE];
    double c = 1.0 - a;
    double disc = a * a + 4.0 * c * (1.0 - p / dp0);
    if (c <= 0.0) { /* linear curve */
        *dq = -qmax / dp0;
        return qmax * (1.0 - p / dp0);
    }
    if (disc <= 0.0) {
        *dq = 0.0;
        return qmax * (-a) / (2.0 * c);
    }
    double r = sqrt(disc);
    *dq = qmax * (-4.0 * c / dp0) / (2.0 * r) / (2.0 * c);
    return qmax * (-a + r) / (2.0 * c);
}

/* Valve opening from the pressure error e and the integral I (already updated). */
static double opening(const State *s, double e, double I, double *du_de, double *du_dI) {
    double u = s->par[VR_U0] + s->par[VR_KP] * e + s->par[VR_KI] * I;
    *du_de = s->par[VR_KP];
    *du_dI = s->par[VR_KI];
    if (u < 0.0 || u > 1.0) {
        *du_de = 0.0;
        *du_dI = 0.0;
        u = u < 0.0 ? 0.0 : 1.0;
    }
    return u;
}

static double valve(const State *s, double p, double u, double *dp_, double *du_) {
    double pl = s->par[VR_PLAM], kv = s->par[VR_KV];
    double w = sqrt(fabs(p) + pl);
    double g = p / w;
    double dg = 1.0 / w - 0.5 * p * (p >= 0 ? 1.0 : -1.0) / (w * w * w);
    *dp_ = u * kv * dg;
    *du_ = kv * g;
    return u * kv * g;
}

/* Net inflow G(p) over a backward-Euler step of length h from integral I0 (the integral's
 * update uses the same p), dG/dp and dG/dp_set; the valve's opening out through u. */
static double inflow(const State *s, double p, double I0, double h, double *dG, double *dGset, double *u_out) {
    double e = p - s->p_set, du_de, du_dI, dqf, dvp, dvu;
    double I1 = I0 + h * e;
    double u = opening(s, e, I1, &du_de, &du_dI);
    double qf = fan(s, p, &dqf);
    double qv = valve(s, p, u, &dvp, &dvu);
    *dG = dqf - dvp - dvu * (du_de + du_dI * h);
    if (dGset) *dGset = dvu * (du_de + du_dI * h);
    if (u_out) *u_out = u;
    return qf - qv;
}

/* One backward-Euler step of length h from (N0, I0) at volume V: solves
 * F(N) = N - N0 - h G(p(N, V)) = 0. F increases with N (the fan delivers less and the valve,
 * opened further by the controller, lets out more as the pressure rises), so the root is
 * bracketed first and Newton's steps that leave the bracket are replaced by bisection; the
 * answer is good to a few units in the last place. Returns 0, or -1 on a non-finite model. */
static double residual_F(const State *s, double N, double N0, double I0, double V, double h, double *dF) {
    double dG, p = pressure(s, N, V);
    double F = N - N0 - h * inflow(s, p, I0, h, &dG, NULL, NULL);
    *dF = 1.0 - h * dG * s->par[VR_PATM] / V;
    return F;
}

static int solve_step(const State *s, double N0, double I0, double V, double h, double *N_out) {
    double dF, lo = N0, hi = N0, F = residual_F(s, N0, N0, I0, V, h, &dF);
    if (!isfinite(F)) return -1;
    if (F == 0.0) {
        *N_out = N0;
        return 0;
    }
    double width = 1e-3 * (fabs(N0) + 1e-9);
    for (int k = 0; k < 200; k++) { /* bracket */
        if (F < 0) hi = N0 + width;
        else lo = N0 - width;
        if (lo <= 0) lo = 0.5 * (F < 0 ? N0 : lo + width);
        double Fo = residual_F(s, F < 0 ? hi : lo, N0, I0, V, h, &dF);
        if (!isfinite(Fo)) return -1;
        if ((F < 0) != (Fo < 0) || Fo == 0.0) break;
        width *= 2.0;
        if (k == 199) return -1;
    }
    double Flo = residual_F(s, lo, N0, I0, V, h, &dF);
    double N = 0.5 * (lo + hi);
    if (Flo > 0) return -1;
    for (int k = 0; k < 200; k++) {
        F = residual_F(s, N, N0, I0, V, h, &dF);
        if (!isfinite(F)) return -1;
        if (F == 0.0) break;
        if (F < 0) lo = N;
        else hi = N;
        double next = N - F / dF;
        if (!(dF > 0) || !(next > lo && next < hi)) next = 0.5 * (lo + hi);
        if (fabs(next - N) <= 2e-16 * fabs(N) || hi - lo <= 4e-16 * fabs(N)) {
            N = next;
            break;
        }
        N = next;
    }
    *N_out = N;
    return 0;
}

/* ---- FMI 2 ---- */

EXPORT const char *fmi2GetTypesPlatform(void) { return "default"; }
EXPORT const char *fmi2GetVersion(void) { return "2.0"; }

static void defaults(State *s) {
    memset(s, 0, sizeof *s);
    s->magic = MAGIC;
    s->par[VR_PATM] = 101325.0;
    s->par[VR_DP0] = 1500.0;
    s->par[VR_QMAX] = 0.2;
    s->par[VR_SHAPE] = 0.5;
    s->par[VR_KV] = 0.02;
    s->par[VR_PLAM] = 10.0;
    s->par[VR_KP] = 2e-3;
    s->par[VR_KI] = 2e-3;
    s->par[VR_U0] = 0.5;
    s->par[VR_V0] = 1.0;
    s->par[VR_P0] = 0.0;
    s->par[VR_NREF] = 0.0;
    s->V = 1.0;
}

EXPORT fmi2Component fmi2Instantiate(fmi2String name, fmi2Type type, fmi2String guid, fmi2String location,
                                     const fmi2CallbackFunctions *cb, fmi2Boolean visible, fmi2Boolean logging) {
    (void)location;
    (void)visible;
    if (!cb || !name) return NULL;
    Blower *b = calloc(1, sizeof *b);
    if (!b) return NULL;
    b->cb = *cb;
    snprintf(b->name, sizeof b->name, "%s", name);
    b->logging = logging;
    if (type != fmi2CoSimulation) {
        say(b, fmi2Error, "fmi2Instantiate: Blower is a Co-Simulation FMU only");
        free(b);
        return NULL;
    }
    if (guid && strcmp(guid, GUID) != 0) {
        say(b, fmi2Error, "fmi2Instantiate: GUID %s does not match this binary's %s", guid, GUID);
        free(b);
        return NULL;
    }
    defaults(&b->s);
    return b;
}

EXPORT void fmi2FreeInstance(fmi2Component c) { free(c); }

EXPORT fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean on, size_t n, const fmi2String cats[]) {
    (void)n;
    (void)cats;
    if (!c) return fmi2Error;
    ((Blower *)c)->logging = on;
    return fmi2OK;
}

EXPORT fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean tolDef, fmi2Real tol, fmi2Real t0, fmi2Boolean stopDef,
                                      fmi2Real tstop) {
    (void)tolDef;
    (void)tol;
    (void)stopDef;
    (void)tstop;
    if (!c) return fmi2Error;
    ((Blower *)c)->s.t = t0;
    return fmi2OK;
}

EXPORT fmi2Status fmi2EnterInitializationMode(fmi2Component c) { return c ? fmi2OK : fmi2Error; }

EXPORT fmi2Status fmi2ExitInitializationMode(fmi2Component c) {
    Blower *b = c;
    if (!b) return fmi2Error;
    State *s = &b->s;
    const char *bad = NULL;
    if (!(s->par[VR_PATM] > 0)) bad = "p_atm";
    else if (!(s->par[VR_DP0] > 0)) bad = "dp0";
    else if (!(s->par[VR_QMAX] > 0)) bad = "Q_max";
    else if (!(s->par[VR_SHAPE] >= 0 && s->par[VR_SHAPE] <= 1)) bad = "fan_shape";
    else if (!(s->par[VR_KV] >= 0)) bad = "K_valve";
    else if (!(s->par[VR_PLAM] > 0)) bad = "p_lam";
    else if (!(s->par[VR_V0] > 0)) bad = "V0";
    else if (!(s->par[VR_P0] > -s->par[VR_PATM])) bad = "p0";
    else if (!isfinite(s->par[VR_NREF])) bad = "N_ref";
    if (bad) {
        say(b, fmi2Error, "fmi2ExitInitializationMode: parameter %s is out of its range", bad);
        return fmi2Error;
    }
    s->N = s->par[VR_V0] * (s->par[VR_P0] + s->par[VR_PATM]) / s->par[VR_PATM];
    s->I = 0.0;
    s->stepped = 0;
    s->initialized = 1;
    return fmi2OK;
}

EXPORT fmi2Status fmi2Terminate(fmi2Component c) { return c ? fmi2OK : fmi2Error; }

EXPORT fmi2Status fmi2Reset(fmi2Component c) {
    if (!c) return fmi2Error;
    defaults(&((Blower *)c)->s);
    return fmi2OK;
}

static double output(const State *s, fmi2ValueReference vr, int *ok) {
    double p = pressure(s, s->N, s->V), dG, u, dq, dp_, du_;
    *ok = 1;
    switch (vr) {
    case VR_V: return s->V;
    case VR_PSET: return s->p_set;
    case VR_P: return p;
    case VR_N: return s->N;
    case VR_DN: return s->N - s->par[VR_NREF];
    case VR_U:
        inflow(s, p, s->stepped ? s->I_prev : s->I, s->stepped ? s->h : 0.0, &dG, NULL, &u);
        return u;
    case VR_QFAN: return fan(s, p, &dq);
    case VR_QVALVE:
        inflow(s, p, s->stepped ? s->I_prev : s->I, s->stepped ? s->h : 0.0, &dG, NULL, &u);
        return valve(s, p, u, &dp_, &du_);
    default:
        if (vr >= NPAR_FIRST && vr <= NPAR_LAST) return s->par[vr];
        *ok = 0;
        return 0.0;
    }
}

EXPORT fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Real value[]) {
    Blower *b = c;
    if (!b || (n && (!vr || !value))) return fmi2Error;
    for (size_t k = 0; k < n; k++) {
        int ok;
        value[k] = output(&b->s, vr[k], &ok);
        if (!ok) {
            say(b, fmi2Error, "fmi2GetReal: no Real variable has value reference %u", vr[k]);
            return fmi2Error;
        }
    }
    return fmi2OK;
}

EXPORT fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Real value[]) {
    Blower *b = c;
    if (!b || (n && (!vr || !value))) return fmi2Error;
    for (size_t k = 0; k < n; k++) {
        double x = value[k];
        if (!isfinite(x)) {
            say(b, fmi2Error, "fmi2SetReal: value reference %u: %g is not a finite number", vr[k], x);
            return fmi2Error;
        }
        if (vr[k] == VR_V) {
            if (!(x > 0)) {
                say(b, fmi2Error, "fmi2SetReal: V (value reference 0): %g is not a positive volume in m3", x);
                return fmi2Error;
            }
            b->s.V = x;
        } else if (vr[k] == VR_PSET) {
            b->s.p_set = x;
        } else if (vr[k] >= NPAR_FIRST && vr[k] <= NPAR_LAST) {
            if (b->s.initialized) {
                say(b, fmi2Error, "fmi2SetReal: value reference %u is a fixed parameter, set before initialization", vr[k]);
                return fmi2Error;
            }
            b->s.par[vr[k]] = x;
        } else {
            say(b, fmi2Error, "fmi2SetReal: value reference %u is not an input or a parameter", vr[k]);
            return fmi2Error;
        }
    }
    return fmi2OK;
}

#define NO_TYPE(T, name)                                                                              \
    EXPORT fmi2Status fmi2Get##name(fmi2Component c, const fmi2ValueReference vr[], size_t n, T v[]) { \
        (void)vr;                                                                                     \
        (void)v;                                                                                      \
        if (!c) return fmi2Error;                                                                     \
        if (n) say(c, fmi2Error, "fmi2Get" #name ": Blower has no variables of this type");         \
        return n ? fmi2Error : fmi2OK;                                                                \
    }                                                                                                 \
    EXPORT fmi2Status fmi2Set##name(fmi2Component c, const fmi2ValueReference vr[], size_t n, const T v[]) { \
        (void)vr;                                                                                     \
        (void)v;                                                                                      \
        if (!c) return fmi2Error;                                                                     \
        if (n) say(c, fmi2Error, "fmi2Set" #name ": Blower has no variables of this type");         \
        return n ? fmi2Error : fmi2OK;                                                                \
    }
NO_TYPE(fmi2Integer, Integer)
NO_TYPE(fmi2Boolean, Boolean)
NO_TYPE(fmi2String, String)

EXPORT fmi2Status fmi2DoStep(fmi2Component c, fmi2Real t, fmi2Real h, fmi2Boolean noPrior) {
    (void)noPrior;
    Blower *b = c;
    if (!b) return fmi2Error;
    State *s = &b->s;
    if (!s->initialized) {
        say(b, fmi2Error, "fmi2DoStep: call fmi2ExitInitializationMode first");
        return fmi2Error;
    }
    if (!(h > 0) || !isfinite(h)) {
        say(b, fmi2Error, "fmi2DoStep: communication step %g is not positive", h);
        return fmi2Error;
    }
    if (fabs(t - s->t) > 1e-9 * (1.0 + fabs(t))) {
        say(b, fmi2Error, "fmi2DoStep: current time %.17g is not the FMU's time %.17g", t, s->t);
        return fmi2Error;
    }
    double N1;
    if (solve_step(s, s->N, s->I, s->V, h, &N1) != 0) {
        say(b, fmi2Discard, "fmi2DoStep: the gas balance did not converge at t = %g, h = %g (V = %g m3); state kept", t, h, s->V);
        return fmi2Discard;
    }
    double p = pressure(s, N1, s->V);
    s->N_prev = s->N;
    s->I_prev = s->I;
    s->h = h;
    s->N = N1;
    s->I = s->I + h * (p - s->p_set);
    s->t = t + h;
    s->stepped = 1;
    return fmi2OK;
}

EXPORT fmi2Status fmi2CancelStep(fmi2Component c) { return c ? fmi2OK : fmi2Error; }

/* dp/dV and dp/dp_set of the last step (or the feedthrough before it). */
static void derivatives(const State *s, double *dV, double *dPset) {
    double patm = s->par[VR_PATM], V = s->V, N = s->N;
    double p = pressure(s, N, V);
    double pN = patm / V, pV = -patm * N / (V * V);
    if (!s->stepped) {
        *dV = pV;
        *dPset = 0.0;
        return;
    }
    double h = s->h, dG, dGset;
    inflow(s, p, s->I_prev, h, &dG, &dGset, NULL);
    /* F(N; V, p_set) = N - N0 - h G(p(N, V); p_set) = 0. */
    double FN = 1.0 - h * dG * pN;
    double dN_dV = h * dG * pV / FN;
    double dN_dset = h * dGset / FN;
    *dV = pV + pN * dN_dV;
    *dPset = pN * dN_dset;
}

EXPORT fmi2Status fmi2GetDirectionalDerivative(fmi2Component c, const fmi2ValueReference unknown[], size_t nu,
                                               const fmi2ValueReference known[], size_t nk, const fmi2Real dk[],
                                               fmi2Real du[]) {
    Blower *b = c;
    if (!b || (nu && (!unknown || !du)) || (nk && (!known || !dk))) return fmi2Error;
    double dV, dPset;
    derivatives(&b->s, &dV, &dPset);
    double pN = b->s.par[VR_PATM] / b->s.V;
    double dNdV = (dV - (-b->s.par[VR_PATM] * b->s.N / (b->s.V * b->s.V))) / pN, dNdset = dPset / pN;
    for (size_t i = 0; i < nu; i++) {
        double acc = 0.0;
        for (size_t j = 0; j < nk; j++) {
            double d;
            int gas = unknown[i] == VR_N || unknown[i] == VR_DN; /* dN = N - N_ref: N's derivative */
            if (known[j] == VR_V) d = unknown[i] == VR_P ? dV : gas ? dNdV : NAN;
            else if (known[j] == VR_PSET) d = unknown[i] == VR_P ? dPset : gas ? dNdset : NAN;
            else d = NAN;
            if (isnan(d)) {
                say(b, fmi2Error, "fmi2GetDirectionalDerivative: derivative of value reference %u with respect to %u is not provided (unknowns: p 2, N 3, dN 7; knowns: V 0, p_set 1)", unknown[i], known[j]);
                return fmi2Error;
            }
            acc += d * dk[j];
        }
        du[i] = acc;
    }
    return fmi2OK;
}

EXPORT fmi2Status fmi2SetRealInputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Integer o[],
                                              const fmi2Real v[]) {
    (void)vr;
    (void)o;
    (void)v;
    if (!c) return fmi2Error;
    if (n) say(c, fmi2Error, "fmi2SetRealInputDerivatives: not supported (canInterpolateInputs is false)");
    return n ? fmi2Error : fmi2OK;
}

EXPORT fmi2Status fmi2GetRealOutputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Integer o[],
                                               fmi2Real v[]) {
    (void)vr;
    (void)o;
    (void)v;
    if (!c) return fmi2Error;
    if (n) say(c, fmi2Error, "fmi2GetRealOutputDerivatives: not supported (maxOutputDerivativeOrder is 0)");
    return n ? fmi2Error : fmi2OK;
}

EXPORT fmi2Status fmi2GetStatus(fmi2Component c, const fmi2StatusKind k, fmi2Status *v) {
    (void)k;
    if (!c || !v) return fmi2Error;
    *v = fmi2OK;
    return fmi2OK;
}
EXPORT fmi2Status fmi2GetRealStatus(fmi2Component c, const fmi2StatusKind k, fmi2Real *v) {
    if (!c || !v) return fmi2Error;
    if (k != fmi2LastSuccessfulTime) return fmi2Discard;
    *v = ((Blower *)c)->s.t;
    return fmi2OK;
}
EXPORT fmi2Status fmi2GetIntegerStatus(fmi2Component c, const fmi2StatusKind k, fmi2Integer *v) {
    (void)k;
    (void)v;
    return c ? fmi2Discard : fmi2Error;
}
EXPORT fmi2Status fmi2GetBooleanStatus(fmi2Component c, const fmi2StatusKind k, fmi2Boolean *v) {
    if (!c || !v) return fmi2Error;
    if (k != fmi2Terminated) return fmi2Discard;
    *v = 0;
    return fmi2OK;
}
EXPORT fmi2Status fmi2GetStringStatus(fmi2Component c, const fmi2StatusKind k, fmi2String *v) {
    (void)k;
    (void)v;
    return c ? fmi2Discard : fmi2Error;
}

/* ---- FMU state ---- */

EXPORT fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate *out) {
    Blower *b = c;
    if (!b || !out) return fmi2Error;
    State *s = *out;
    if (!s) {
        s = malloc(sizeof *s);
        if (!s) {
            say(b, fmi2Error, "fmi2GetFMUstate: out of memory");
            return fmi2Error;
        }
    } else if (s->magic != MAGIC) {
        say(b, fmi2Error, "fmi2GetFMUstate: the state pointer given is not one of Blower's");
        return fmi2Error;
    }
    *s = b->s;
    *out = s;
    return fmi2OK;
}

EXPORT fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate st) {
    Blower *b = c;
    if (!b || !st) return fmi2Error;
    if (((State *)st)->magic != MAGIC) {
        say(b, fmi2Error, "fmi2SetFMUstate: the state is not one of Blower's");
        return fmi2Error;
    }
    b->s = *(State *)st;
    return fmi2OK;
}

EXPORT fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate *st) {
    if (!c || !st) return fmi2Error;
    if (*st) ((State *)*st)->magic = 0;
    free(*st);
    *st = NULL;
    return fmi2OK;
}

EXPORT fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate st, size_t *size) {
    if (!c || !st || !size) return fmi2Error;
    *size = sizeof(State);
    return fmi2OK;
}

EXPORT fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate st, fmi2Byte out[], size_t size) {
    Blower *b = c;
    if (!b || !st || !out) return fmi2Error;
    if (size < sizeof(State)) {
        say(b, fmi2Error, "fmi2SerializeFMUstate: buffer of %zu bytes, %zu needed", size, sizeof(State));
        return fmi2Error;
    }
    memcpy(out, st, sizeof(State));
    return fmi2OK;
}

EXPORT fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte in[], size_t size, fmi2FMUstate *st) {
    Blower *b = c;
    if (!b || !in || !st) return fmi2Error;
    State tmp;
    if (size != sizeof(State)) {
        say(b, fmi2Error, "fmi2DeSerializeFMUstate: %zu bytes, a Blower state has %zu", size, sizeof(State));
        return fmi2Error;
    }
    memcpy(&tmp, in, sizeof tmp);
    if (tmp.magic != MAGIC || !isfinite(tmp.N) || !isfinite(tmp.I) || !(tmp.V > 0)) {
        say(b, fmi2Error, "fmi2DeSerializeFMUstate: the bytes are not a Blower state");
        return fmi2Error;
    }
    State *s = malloc(sizeof *s);
    if (!s) return fmi2Error;
    *s = tmp;
    *st = s;
    return fmi2OK;
}

/* ---- FMI 3 (Co-Simulation) ----
 * The same model and state behind the FMI 3.0 functions: Float64 variables with the FMI 2
 * value references, `time` (value reference 999) the independent variable; no event mode,
 * no early return, no clocks. Functions of other interfaces (Model Exchange, Scheduled
 * Execution, clocks, intervals) are an error naming themselves. */
#include <stdbool.h>
#include <stdint.h>

typedef void *fmi3Instance;
typedef void *fmi3InstanceEnvironment;
typedef void *fmi3FMUState;
typedef uint32_t fmi3ValueReference;
typedef double fmi3Float64;
typedef bool fmi3Boolean;
typedef const char *fmi3String;
typedef uint8_t fmi3Byte;
typedef enum { fmi3OK, fmi3Warning, fmi3Discard, fmi3Error, fmi3Fatal } fmi3Status;
typedef void (*fmi3LogMessageCallback)(fmi3InstanceEnvironment, fmi3Status, fmi3String, fmi3String);
typedef void (*fmi3IntermediateUpdateCallback)(fmi3InstanceEnvironment, fmi3Float64, fmi3Boolean, fmi3Boolean, fmi3Boolean,
                                               fmi3Boolean, fmi3Boolean *, fmi3Float64 *);

#define VR_TIME 999u

typedef struct {
    Blower b; /* b.cb.logger unused: FMI 3 logs through log3 */
    fmi3LogMessageCallback log3;
    fmi3InstanceEnvironment env;
    int in_init;
} Blower3;

static void say3(Blower3 *b, fmi3Status st, const char *fmt, ...) {
    char msg[512];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(msg, sizeof msg, fmt, ap);
    va_end(ap);
    if (b && b->log3) b->log3(b->env, st, st >= fmi3Error ? "logStatusError" : "logAll", msg);
}

/* The FMI 2 logger's signature, forwarding to FMI 3's (the shared code logs through say). */
static void forward2(fmi2ComponentEnvironment env, fmi2String name, fmi2Status st, fmi2String cat, fmi2String fmt, ...) {
    (void)name;
    (void)cat;
    Blower3 *b = env;
    char msg[512];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(msg, sizeof msg, fmt, ap);
    va_end(ap);
    if (b && b->log3) b->log3(b->env, (fmi3Status)st, st >= fmi2Error ? "logStatusError" : "logAll", msg);
}

EXPORT const char *fmi3GetVersion(void) { return "3.0"; }

EXPORT fmi3Status fmi3SetDebugLogging(fmi3Instance i, fmi3Boolean on, size_t n, const fmi3String cats[]) {
    (void)n;
    (void)cats;
    if (!i) return fmi3Error;
    ((Blower3 *)i)->b.logging = on;
    return fmi3OK;
}

EXPORT fmi3Instance fmi3InstantiateModelExchange(fmi3String name, fmi3String token, fmi3String res, fmi3Boolean vis,
                                                 fmi3Boolean log, fmi3InstanceEnvironment env, fmi3LogMessageCallback cb) {
    (void)name; (void)token; (void)res; (void)vis; (void)log;
    if (cb) cb(env, fmi3Error, "logStatusError", "fmi3InstantiateModelExchange: Blower is a Co-Simulation FMU only");
    return NULL;
}

EXPORT fmi3Instance fmi3InstantiateScheduledExecution(fmi3String name, fmi3String token, fmi3String res, fmi3Boolean vis,
                                                      fmi3Boolean log, fmi3InstanceEnvironment env,
                                                      fmi3LogMessageCallback cb, void *clockUpdate, void *lock, void *unlock) {
    (void)name; (void)token; (void)res; (void)vis; (void)log; (void)clockUpdate; (void)lock; (void)unlock;
    if (cb) cb(env, fmi3Error, "logStatusError", "fmi3InstantiateScheduledExecution: Blower is a Co-Simulation FMU only");
    return NULL;
}

EXPORT fmi3Instance fmi3InstantiateCoSimulation(fmi3String name, fmi3String token, fmi3String res, fmi3Boolean vis,
                                                fmi3Boolean log, fmi3Boolean eventMode, fmi3Boolean earlyReturn,
                                                const fmi3ValueReference req[], size_t nreq, fmi3InstanceEnvironment env,
                                                fmi3LogMessageCallback cb, fmi3IntermediateUpdateCallback upd) {
    (void)res; (void)vis; (void)earlyReturn; (void)req; (void)nreq; (void)upd;
    if (!name) return NULL;
    Blower3 *b = calloc(1, sizeof *b);
    if (!b) return NULL;
    b->log3 = cb;
    b->env = env;
    b->b.cb.logger = forward2;
    b->b.cb.componentEnvironment = b;
    snprintf(b->b.name, sizeof b->b.name, "%s", name);
    b->b.logging = log;
    if (eventMode) {
        say3(b, fmi3Error, "fmi3InstantiateCoSimulation: Blower has no event mode (hasEventMode is false)");
        free(b);
        return NULL;
    }
    if (token && strcmp(token, GUID) != 0) {
        say3(b, fmi3Error, "fmi3InstantiateCoSimulation: instantiation token %s does not match this binary's %s", token, GUID);
        free(b);
        return NULL;
    }
    defaults(&b->b.s);
    return b;
}

EXPORT void fmi3FreeInstance(fmi3Instance i) { free(i); }

EXPORT fmi3Status fmi3EnterInitializationMode(fmi3Instance i, fmi3Boolean tolDef, fmi3Float64 tol, fmi3Float64 t0,
                                              fmi3Boolean stopDef, fmi3Float64 stop) {
    (void)tolDef; (void)tol; (void)stopDef; (void)stop;
    Blower3 *b = i;
    if (!b) return fmi3Error;
    b->b.s.t = t0;
    b->in_init = 1;
    return fmi3OK;
}

EXPORT fmi3Status fmi3ExitInitializationMode(fmi3Instance i) {
    Blower3 *b = i;
    if (!b) return fmi3Error;
    b->in_init = 0;
    return (fmi3Status)fmi2ExitInitializationMode(&b->b);
}

EXPORT fmi3Status fmi3EnterEventMode(fmi3Instance i) {
    say3(i, fmi3Error, "fmi3EnterEventMode: Blower has no event mode");
    return fmi3Error;
}

EXPORT fmi3Status fmi3Terminate(fmi3Instance i) { return i ? fmi3OK : fmi3Error; }

EXPORT fmi3Status fmi3Reset(fmi3Instance i) {
    if (!i) return fmi3Error;
    defaults(&((Blower3 *)i)->b.s);
    return fmi3OK;
}

EXPORT fmi3Status fmi3GetFloat64(fmi3Instance i, const fmi3ValueReference vr[], size_t n, fmi3Float64 v[], size_t nv) {
    Blower3 *b = i;
    if (!b || nv != n) return fmi3Error;
    for (size_t k = 0; k < n; k++) {
        if (vr[k] == VR_TIME) {
            v[k] = b->b.s.t;
            continue;
        }
        fmi3Status st = (fmi3Status)fmi2GetReal(&b->b, &vr[k], 1, &v[k]);
        if (st != fmi3OK) return st;
    }
    return fmi3OK;
}

EXPORT fmi3Status fmi3SetFloat64(fmi3Instance i, const fmi3ValueReference vr[], size_t n, const fmi3Float64 v[], size_t nv) {
    Blower3 *b = i;
    if (!b || nv != n) return fmi3Error;
    for (size_t k = 0; k < n; k++) {
        if (vr[k] == VR_TIME) {
            say3(b, fmi3Error, "fmi3SetFloat64: time (value reference 999) is the independent variable");
            return fmi3Error;
        }
    }
    return (fmi3Status)fmi2SetReal(&b->b, vr, n, v);
}

/* Every other variable type: Blower has none. */
#define NO_TYPE3(name)                                                                                  \
    EXPORT fmi3Status fmi3Get##name(fmi3Instance i, const fmi3ValueReference vr[], size_t n, void *v, size_t nv) { \
        (void)vr; (void)v; (void)nv;                                                                    \
        if (!i) return fmi3Error;                                                                       \
        if (n) say3(i, fmi3Error, "fmi3Get" #name ": Blower has no variables of this type");          \
        return n ? fmi3Error : fmi3OK;                                                                  \
    }                                                                                                   \
    EXPORT fmi3Status fmi3Set##name(fmi3Instance i, const fmi3ValueReference vr[], size_t n, const void *v, size_t nv) { \
        (void)vr; (void)v; (void)nv;                                                                    \
        if (!i) return fmi3Error;                                                                       \
        if (n) say3(i, fmi3Error, "fmi3Set" #name ": Blower has no variables of this type");          \
        return n ? fmi3Error : fmi3OK;                                                                  \
    }
NO_TYPE3(Float32)
NO_TYPE3(Int8)
NO_TYPE3(UInt8)
NO_TYPE3(Int16)
NO_TYPE3(UInt16)
NO_TYPE3(Int32)
NO_TYPE3(UInt32)
NO_TYPE3(Int64)
NO_TYPE3(UInt64)
NO_TYPE3(Boolean)
NO_TYPE3(String)

EXPORT fmi3Status fmi3GetBinary(fmi3Instance i, const fmi3ValueReference vr[], size_t n, size_t sizes[], void *v, size_t nv) {
    (void)vr; (void)sizes; (void)v; (void)nv;
    if (!i) return fmi3Error;
    if (n) say3(i, fmi3Error, "fmi3GetBinary: Blower has no variables of this type");
    return n ? fmi3Error : fmi3OK;
}
EXPORT fmi3Status fmi3SetBinary(fmi3Instance i, const fmi3ValueReference vr[], size_t n, const size_t sizes[], const void *v,
                                size_t nv) {
    (void)vr; (void)sizes; (void)v; (void)nv;
    if (!i) return fmi3Error;
    if (n) say3(i, fmi3Error, "fmi3SetBinary: Blower has no variables of this type");
    return n ? fmi3Error : fmi3OK;
}
EXPORT fmi3Status fmi3GetClock(fmi3Instance i, const fmi3ValueReference vr[], size_t n, void *v) {
    (void)vr; (void)v;
    if (!i) return fmi3Error;
    if (n) say3(i, fmi3Error, "fmi3GetClock: Blower has no clocks");
    return n ? fmi3Error : fmi3OK;
}
EXPORT fmi3Status fmi3SetClock(fmi3Instance i, const fmi3ValueReference vr[], size_t n, const void *v) {
    (void)vr; (void)v;
    if (!i) return fmi3Error;
    if (n) say3(i, fmi3Error, "fmi3SetClock: Blower has no clocks");
    return n ? fmi3Error : fmi3OK;
}

/* The outputs p, N, u, Q_fan, Q_valve depend on V and p_set (modelDescription.xml). */
static int is_output(fmi3ValueReference vr) { return vr >= VR_P && vr <= VR_QVALVE; }

EXPORT fmi3Status fmi3GetNumberOfVariableDependencies(fmi3Instance i, fmi3ValueReference vr, size_t *n) {
    if (!i || !n) return fmi3Error;
    *n = is_output(vr) ? 2 : 0;
    return fmi3OK;
}

EXPORT fmi3Status fmi3GetVariableDependencies(fmi3Instance i, fmi3ValueReference dep, size_t eDep[], fmi3ValueReference ind[],
                                              size_t eInd[], int kinds[], size_t n) {
    if (!i) return fmi3Error;
    if (!is_output(dep)) return n ? fmi3Error : fmi3OK;
    if (n < 2) return fmi3Error;
    for (size_t k = 0; k < 2; k++) {
        eDep[k] = 0;
        ind[k] = k == 0 ? VR_V : VR_PSET;
        eInd[k] = 0;
        kinds[k] = 4; /* fmi3Dependent */
    }
    return fmi3OK;
}

EXPORT fmi3Status fmi3GetFMUState(fmi3Instance i, fmi3FMUState *s) { return i ? (fmi3Status)fmi2GetFMUstate(&((Blower3 *)i)->b, s) : fmi3Error; }
EXPORT fmi3Status fmi3SetFMUState(fmi3Instance i, fmi3FMUState s) { return i ? (fmi3Status)fmi2SetFMUstate(&((Blower3 *)i)->b, s) : fmi3Error; }
EXPORT fmi3Status fmi3FreeFMUState(fmi3Instance i, fmi3FMUState *s) { return i ? (fmi3Status)fmi2FreeFMUstate(&((Blower3 *)i)->b, s) : fmi3Error; }
EXPORT fmi3Status fmi3SerializedFMUStateSize(fmi3Instance i, fmi3FMUState s, size_t *n) {
    return i ? (fmi3Status)fmi2SerializedFMUstateSize(&((Blower3 *)i)->b, s, n) : fmi3Error;
}
EXPORT fmi3Status fmi3SerializeFMUState(fmi3Instance i, fmi3FMUState s, fmi3Byte out[], size_t n) {
    return i ? (fmi3Status)fmi2SerializeFMUstate(&((Blower3 *)i)->b, s, (fmi2Byte *)out, n) : fmi3Error;
}
EXPORT fmi3Status fmi3DeserializeFMUState(fmi3Instance i, const fmi3Byte in[], size_t n, fmi3FMUState *s) {
    return i ? (fmi3Status)fmi2DeSerializeFMUstate(&((Blower3 *)i)->b, (const fmi2Byte *)in, n, s) : fmi3Error;
}

EXPORT fmi3Status fmi3GetDirectionalDerivative(fmi3Instance i, const fmi3ValueReference unk[], size_t nu,
                                               const fmi3ValueReference kn[], size_t nk, const fmi3Float64 seed[], size_t ns,
                                               fmi3Float64 sens[], size_t nsens) {
    if (!i || ns != nk || nsens != nu) return fmi3Error;
    return (fmi3Status)fmi2GetDirectionalDerivative(&((Blower3 *)i)->b, unk, nu, kn, nk, seed, sens);
}

/* vᵀ J: one directional derivative per known (J is at most 6 x 2). */
EXPORT fmi3Status fmi3GetAdjointDerivative(fmi3Instance i, const fmi3ValueReference unk[], size_t nu,
                                           const fmi3ValueReference kn[], size_t nk, const fmi3Float64 seed[], size_t ns,
                                           fmi3Float64 sens[], size_t nsens) {
    if (!i || ns != nu || nsens != nk) return fmi3Error;
    double col[8];
    if (nu > 8) return fmi3Error;
    for (size_t j = 0; j < nk; j++) {
        double one = 1.0;
        fmi3Status st = (fmi3Status)fmi2GetDirectionalDerivative(&((Blower3 *)i)->b, unk, nu, &kn[j], 1, &one, col);
        if (st != fmi3OK) return st;
        double acc = 0.0;
        for (size_t k = 0; k < nu; k++) acc += seed[k] * col[k];
        sens[j] = acc;
    }
    return fmi3OK;
}

EXPORT fmi3Status fmi3DoStep(fmi3Instance i, fmi3Float64 t, fmi3Float64 h, fmi3Boolean noPrior, fmi3Boolean *eventNeeded,
                             fmi3Boolean *terminate, fmi3Boolean *early, fmi3Float64 *last) {
    (void)noPrior;
    Blower3 *b = i;
    if (!b) return fmi3Error;
    fmi3Status st = (fmi3Status)fmi2DoStep(&b->b, t, h, 0);
    if (eventNeeded) *eventNeeded = false;
    if (terminate) *terminate = false;
    if (early) *early = false;
    if (last) *last = b->b.s.t;
    return st;
}

EXPORT fmi3Status fmi3EnterStepMode(fmi3Instance i) { return i ? fmi3OK : fmi3Error; }

EXPORT fmi3Status fmi3GetOutputDerivatives(fmi3Instance i, const fmi3ValueReference vr[], size_t n, const int32_t o[],
                                           fmi3Float64 v[], size_t nv) {
    (void)vr; (void)o; (void)v; (void)nv;
    if (!i) return fmi3Error;
    if (n) say3(i, fmi3Error, "fmi3GetOutputDerivatives: not provided (maxOutputDerivativeOrder is 0)");
    return n ? fmi3Error : fmi3OK;
}

/* The interfaces Blower does not implement: an error naming the function. */
#define UNSUPPORTED3(name)                                                   \
    EXPORT fmi3Status fmi3##name(fmi3Instance i) {                           \
        say3(i, fmi3Error, "fmi3" #name ": not supported by Blower (Co-Simulation without events or clocks)"); \
        return fmi3Error;                                                    \
    }
UNSUPPORTED3(EnterConfigurationMode)
UNSUPPORTED3(ExitConfigurationMode)
UNSUPPORTED3(GetIntervalDecimal)
UNSUPPORTED3(GetIntervalFraction)
UNSUPPORTED3(GetShiftDecimal)
UNSUPPORTED3(GetShiftFraction)
UNSUPPORTED3(SetIntervalDecimal)
UNSUPPORTED3(SetIntervalFraction)
UNSUPPORTED3(SetShiftDecimal)
UNSUPPORTED3(SetShiftFraction)
UNSUPPORTED3(EvaluateDiscreteStates)
UNSUPPORTED3(UpdateDiscreteStates)
UNSUPPORTED3(EnterContinuousTimeMode)
UNSUPPORTED3(CompletedIntegratorStep)
UNSUPPORTED3(SetTime)
UNSUPPORTED3(SetContinuousStates)
UNSUPPORTED3(GetContinuousStateDerivatives)
UNSUPPORTED3(GetEventIndicators)
UNSUPPORTED3(GetContinuousStates)
UNSUPPORTED3(GetNominalsOfContinuousStates)
UNSUPPORTED3(GetNumberOfEventIndicators)
UNSUPPORTED3(GetNumberOfContinuousStates)
UNSUPPORTED3(ActivateModelPartition)
