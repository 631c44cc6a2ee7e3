/* transgen FMU: the FMI 3.0 interface (Model Exchange and Co-Simulation) over tg_model.c.
 * Written for transgen (MIT licence); the FMI 3.0 headers come from FMPy at build time. */
#include "fmi3Functions.h"
#include "tg_model.c"

typedef struct {
    TG m;
    fmi3InstanceEnvironment env;
    fmi3LogMessageCallback log;
    int logging;
} Instance;

static fmi3Status tg_fail(Instance *c) {
    if (c->log) c->log(c->env, fmi3Error, "logError", c->m.msg);
    return fmi3Error;
}

static fmi3Status tg_refuse(fmi3Instance c, const char *what) {
    snprintf(((Instance *)c)->m.msg, sizeof ((Instance *)c)->m.msg, "%s", what);
    return tg_fail((Instance *)c);
}

const char *fmi3GetVersion(void) { return fmi3Version; }

fmi3Status fmi3SetDebugLogging(fmi3Instance c, fmi3Boolean loggingOn, size_t n, const fmi3String categories[]) {
    (void)n; (void)categories;
    ((Instance *)c)->logging = loggingOn;
    return fmi3OK;
}

static fmi3Instance tg_instantiate(fmi3String token, fmi3InstanceEnvironment env, fmi3LogMessageCallback log) {
    if (!token || strcmp(token, TG_GUID) != 0) {
        if (log) log(env, fmi3Error, "logError", "the instantiation token does not match this FMU's");
        return NULL;
    }
    Instance *c = (Instance *)calloc(1, sizeof(Instance));
    if (!c) return NULL;
    c->env = env;
    c->log = log;
    tg_reset(&c->m);
    return c;
}

fmi3Instance fmi3InstantiateModelExchange(fmi3String name, fmi3String token, fmi3String resources, fmi3Boolean visible,
                                          fmi3Boolean loggingOn, fmi3InstanceEnvironment env,
                                          fmi3LogMessageCallback log) {
    (void)name; (void)resources; (void)visible; (void)loggingOn;
    return tg_instantiate(token, env, log);
}

fmi3Instance fmi3InstantiateCoSimulation(fmi3String name, fmi3String token, fmi3String resources, fmi3Boolean visible,
                                         fmi3Boolean loggingOn, fmi3Boolean eventModeUsed, fmi3Boolean earlyReturnAllowed,
                                         const fmi3ValueReference required[], size_t nRequired,
                                         fmi3InstanceEnvironment env, fmi3LogMessageCallback log,
                                         fmi3IntermediateUpdateCallback update) {
    (void)name; (void)resources; (void)visible; (void)loggingOn; (void)eventModeUsed; (void)earlyReturnAllowed;
    (void)required; (void)nRequired; (void)update;
    return tg_instantiate(token, env, log);
}

fmi3Instance fmi3InstantiateScheduledExecution(fmi3String name, fmi3String token, fmi3String resources,
                                               fmi3Boolean visible, fmi3Boolean loggingOn, fmi3InstanceEnvironment env,
                                               fmi3LogMessageCallback log, fmi3ClockUpdateCallback clock,
                                               fmi3LockPreemptionCallback lock, fmi3UnlockPreemptionCallback unlock) {
    (void)name; (void)token; (void)resources; (void)visible; (void)loggingOn; (void)clock; (void)lock; (void)unlock;
    if (log) log(env, fmi3Error, "logError", "scheduled execution is not supported");
    return NULL;
}

void fmi3FreeInstance(fmi3Instance c) { free(c); }

fmi3Status fmi3EnterInitializationMode(fmi3Instance c, fmi3Boolean toleranceDefined, fmi3Float64 tolerance,
                                       fmi3Float64 startTime, fmi3Boolean stopTimeDefined, fmi3Float64 stopTime) {
    (void)toleranceDefined; (void)tolerance; (void)stopTimeDefined; (void)stopTime;
    ((Instance *)c)->m.t = startTime;
    return fmi3OK;
}

fmi3Status fmi3ExitInitializationMode(fmi3Instance c) {
    return tg_start(&((Instance *)c)->m) ? tg_fail((Instance *)c) : fmi3OK;
}

fmi3Status fmi3EnterEventMode(fmi3Instance c) { (void)c; return fmi3OK; }
fmi3Status fmi3Terminate(fmi3Instance c) { (void)c; return fmi3OK; }

fmi3Status fmi3Reset(fmi3Instance c) {
    tg_reset(&((Instance *)c)->m);
    return fmi3OK;
}

fmi3Status fmi3GetFloat64(fmi3Instance c, const fmi3ValueReference vr[], size_t nvr, fmi3Float64 values[], size_t nv) {
    Instance *x = (Instance *)c;
    (void)nv;
    for (size_t i = 0; i < nvr; i++)
        if (tg_get_real(&x->m, vr[i], &values[i])) return tg_fail(x);
    return fmi3OK;
}

fmi3Status fmi3SetFloat64(fmi3Instance c, const fmi3ValueReference vr[], size_t nvr, const fmi3Float64 values[],
                          size_t nv) {
    Instance *x = (Instance *)c;
    (void)nv;
    for (size_t i = 0; i < nvr; i++)
        if (tg_set_real(&x->m, vr[i], values[i])) return tg_fail(x);
    return fmi3OK;
}

fmi3Status fmi3GetInt32(fmi3Instance c, const fmi3ValueReference vr[], size_t nvr, fmi3Int32 values[], size_t nv) {
    Instance *x = (Instance *)c;
    (void)nv;
    for (size_t i = 0; i < nvr; i++)
        if (tg_get_integer(&x->m, vr[i], &values[i])) return tg_fail(x);
    return fmi3OK;
}

fmi3Status fmi3GetBoolean(fmi3Instance c, const fmi3ValueReference vr[], size_t nvr, fmi3Boolean values[], size_t nv) {
    Instance *x = (Instance *)c;
    (void)nv;
    for (size_t i = 0; i < nvr; i++) {
        int v;
        if (tg_get_boolean(&x->m, vr[i], &v)) return tg_fail(x);
        values[i] = v ? fmi3True : fmi3False;
    }
    return fmi3OK;
}

/* the types this FMU has no variables of */
#define TG_NO_GET(NAME, T)                                                                                     \
    fmi3Status fmi3Get##NAME(fmi3Instance c, const fmi3ValueReference vr[], size_t nvr, T values[], size_t nv) { \
        (void)vr; (void)values; (void)nv;                                                                      \
        return nvr ? tg_refuse(c, "no variable of type " #NAME) : fmi3OK;                                      \
    }
#define TG_NO_SET(NAME, T)                                                                                           \
    fmi3Status fmi3Set##NAME(fmi3Instance c, const fmi3ValueReference vr[], size_t nvr, const T values[], size_t nv) { \
        (void)vr; (void)values; (void)nv;                                                                            \
        return nvr ? tg_refuse(c, "no settable variable of type " #NAME) : fmi3OK;                                   \
    }
TG_NO_GET(Float32, fmi3Float32)
TG_NO_GET(Int8, fmi3Int8)
TG_NO_GET(UInt8, fmi3UInt8)
TG_NO_GET(Int16, fmi3Int16)
TG_NO_GET(UInt16, fmi3UInt16)
TG_NO_GET(UInt32, fmi3UInt32)
TG_NO_GET(Int64, fmi3Int64)
TG_NO_GET(UInt64, fmi3UInt64)
TG_NO_GET(String, fmi3String)
TG_NO_SET(Float32, fmi3Float32)
TG_NO_SET(Int8, fmi3Int8)
TG_NO_SET(UInt8, fmi3UInt8)
TG_NO_SET(Int16, fmi3Int16)
TG_NO_SET(UInt16, fmi3UInt16)
TG_NO_SET(Int32, fmi3Int32)
TG_NO_SET(UInt32, fmi3UInt32)
TG_NO_SET(Int64, fmi3Int64)
TG_NO_SET(UInt64, fmi3UInt64)
TG_NO_SET(Boolean, fmi3Boolean)
TG_NO_SET(String, fmi3String)

fmi3Status fmi3GetBinary(fmi3Instance c, const fmi3ValueReference vr[], size_t nvr, size_t sizes[], fmi3Binary values[],
                         size_t nv) {
    (void)vr; (void)sizes; (void)values; (void)nv;
    return nvr ? tg_refuse(c, "no binary variables") : fmi3OK;
}

fmi3Status fmi3SetBinary(fmi3Instance c, const fmi3ValueReference vr[], size_t nvr, const size_t sizes[],
                         const fmi3Binary values[], size_t nv) {
    (void)vr; (void)sizes; (void)values; (void)nv;
    return nvr ? tg_refuse(c, "no binary variables") : fmi3OK;
}

fmi3Status fmi3GetClock(fmi3Instance c, const fmi3ValueReference vr[], size_t nvr, fmi3Clock values[]) {
    (void)vr; (void)values;
    return nvr ? tg_refuse(c, "no clocks") : fmi3OK;
}

fmi3Status fmi3SetClock(fmi3Instance c, const fmi3ValueReference vr[], size_t nvr, const fmi3Clock values[]) {
    (void)vr; (void)values;
    return nvr ? tg_refuse(c, "no clocks") : fmi3OK;
}

fmi3Status fmi3GetNumberOfVariableDependencies(fmi3Instance c, fmi3ValueReference vr, size_t *n) {
    (void)vr; (void)n;
    return tg_refuse(c, "variable dependencies are not provided");
}

fmi3Status fmi3GetVariableDependencies(fmi3Instance c, fmi3ValueReference dependent, size_t elementIndices[],
                                       fmi3ValueReference independents[], size_t independentIndices[],
                                       fmi3DependencyKind kinds[], size_t n) {
    (void)dependent; (void)elementIndices; (void)independents; (void)independentIndices; (void)kinds; (void)n;
    return tg_refuse(c, "variable dependencies are not provided");
}

/* the state of an instance is the plain struct TG: saved, restored and serialized as bytes */
fmi3Status fmi3GetFMUState(fmi3Instance c, fmi3FMUState *state) {
    *state = tg_state_save(&((Instance *)c)->m, *state);
    return *state ? fmi3OK : fmi3Error;
}

fmi3Status fmi3SetFMUState(fmi3Instance c, fmi3FMUState state) {
    if (!state) return fmi3Error;
    ((Instance *)c)->m = *(TG *)state;
    return fmi3OK;
}

fmi3Status fmi3FreeFMUState(fmi3Instance c, fmi3FMUState *state) {
    (void)c;
    free(*state);
    *state = NULL;
    return fmi3OK;
}

fmi3Status fmi3SerializedFMUStateSize(fmi3Instance c, fmi3FMUState state, size_t *size) {
    (void)c; (void)state;
    *size = sizeof(TG);
    return fmi3OK;
}

fmi3Status fmi3SerializeFMUState(fmi3Instance c, fmi3FMUState state, fmi3Byte bytes[], size_t size) {
    (void)c;
    if (size < sizeof(TG) || !state) return fmi3Error;
    memcpy(bytes, state, sizeof(TG));
    return fmi3OK;
}

fmi3Status fmi3DeserializeFMUState(fmi3Instance c, const fmi3Byte bytes[], size_t size, fmi3FMUState *state) {
    (void)c;
    *state = tg_state_from_bytes(bytes, size);
    return *state ? fmi3OK : fmi3Error;
}

fmi3Status fmi3GetDirectionalDerivative(fmi3Instance c, const fmi3ValueReference unknowns[], size_t nUnknowns,
                                        const fmi3ValueReference knowns[], size_t nKnowns, const fmi3Float64 seed[],
                                        size_t nSeed, fmi3Float64 sensitivity[], size_t nSensitivity) {
    (void)unknowns; (void)nUnknowns; (void)knowns; (void)nKnowns; (void)seed; (void)nSeed; (void)sensitivity;
    (void)nSensitivity;
    return tg_refuse(c, "directional derivatives are not provided");
}

fmi3Status fmi3GetAdjointDerivative(fmi3Instance c, const fmi3ValueReference unknowns[], size_t nUnknowns,
                                    const fmi3ValueReference knowns[], size_t nKnowns, const fmi3Float64 seed[],
                                    size_t nSeed, fmi3Float64 sensitivity[], size_t nSensitivity) {
    (void)unknowns; (void)nUnknowns; (void)knowns; (void)nKnowns; (void)seed; (void)nSeed; (void)sensitivity;
    (void)nSensitivity;
    return tg_refuse(c, "adjoint derivatives are not provided");
}

fmi3Status fmi3EnterConfigurationMode(fmi3Instance c) { return tg_refuse(c, "no structural parameters"); }
fmi3Status fmi3ExitConfigurationMode(fmi3Instance c) { return tg_refuse(c, "no structural parameters"); }

fmi3Status fmi3GetIntervalDecimal(fmi3Instance c, const fmi3ValueReference vr[], size_t n, fmi3Float64 intervals[],
                                  fmi3IntervalQualifier qualifiers[]) {
    (void)vr; (void)n; (void)intervals; (void)qualifiers;
    return tg_refuse(c, "no clocks");
}

fmi3Status fmi3GetIntervalFraction(fmi3Instance c, const fmi3ValueReference vr[], size_t n, fmi3UInt64 counters[],
                                   fmi3UInt64 resolutions[], fmi3IntervalQualifier qualifiers[]) {
    (void)vr; (void)n; (void)counters; (void)resolutions; (void)qualifiers;
    return tg_refuse(c, "no clocks");
}

fmi3Status fmi3GetShiftDecimal(fmi3Instance c, const fmi3ValueReference vr[], size_t n, fmi3Float64 shifts[]) {
    (void)vr; (void)n; (void)shifts;
    return tg_refuse(c, "no clocks");
}

fmi3Status fmi3GetShiftFraction(fmi3Instance c, const fmi3ValueReference vr[], size_t n, fmi3UInt64 counters[],
                                fmi3UInt64 resolutions[]) {
    (void)vr; (void)n; (void)counters; (void)resolutions;
    return tg_refuse(c, "no clocks");
}

fmi3Status fmi3SetIntervalDecimal(fmi3Instance c, const fmi3ValueReference vr[], size_t n, const fmi3Float64 intervals[]) {
    (void)vr; (void)n; (void)intervals;
    return tg_refuse(c, "no clocks");
}

fmi3Status fmi3SetIntervalFraction(fmi3Instance c, const fmi3ValueReference vr[], size_t n, const fmi3UInt64 counters[],
                                   const fmi3UInt64 resolutions[]) {
    (void)vr; (void)n; (void)counters; (void)resolutions;
    return tg_refuse(c, "no clocks");
}

fmi3Status fmi3SetShiftDecimal(fmi3Instance c, const fmi3ValueReference vr[], size_t n, const fmi3Float64 shifts[]) {
    (void)vr; (void)n; (void)shifts;
    return tg_refuse(c, "no clocks");
}

fmi3Status fmi3SetShiftFraction(fmi3Instance c, const fmi3ValueReference vr[], size_t n, const fmi3UInt64 counters[],
                                const fmi3UInt64 resolutions[]) {
    (void)vr; (void)n; (void)counters; (void)resolutions;
    return tg_refuse(c, "no clocks");
}

fmi3Status fmi3EvaluateDiscreteStates(fmi3Instance c) { (void)c; return fmi3OK; }

fmi3Status fmi3UpdateDiscreteStates(fmi3Instance c, fmi3Boolean *needUpdate, fmi3Boolean *terminate,
                                    fmi3Boolean *nominalsChanged, fmi3Boolean *valuesChanged,
                                    fmi3Boolean *nextEventTimeDefined, fmi3Float64 *nextEventTime) {
    Instance *x = (Instance *)c;
    if (!x->m.fresh && tg_event(&x->m)) return tg_fail(x);
    x->m.fresh = 1;
    *needUpdate = fmi3False;
    *terminate = fmi3False;
    *nominalsChanged = fmi3False;
    *valuesChanged = fmi3True;
    *nextEventTimeDefined = isfinite(x->m.t_stop) ? fmi3True : fmi3False;
    *nextEventTime = isfinite(x->m.t_stop) ? x->m.t_stop : 0.0;
    return fmi3OK;
}

/* ----------------------------------------------------------------------- Model Exchange */

fmi3Status fmi3EnterContinuousTimeMode(fmi3Instance c) { ((Instance *)c)->m.fresh = 0; return fmi3OK; }

fmi3Status fmi3CompletedIntegratorStep(fmi3Instance c, fmi3Boolean noSetPrior, fmi3Boolean *enterEventMode,
                                       fmi3Boolean *terminate) {
    (void)c; (void)noSetPrior;
    *enterEventMode = fmi3False;
    *terminate = fmi3False;
    return fmi3OK;
}

fmi3Status fmi3SetTime(fmi3Instance c, fmi3Float64 time) {
    Instance *x = (Instance *)c;
    if (time != x->m.t) x->m.fresh = 0;
    x->m.t = time;
    return fmi3OK;
}

fmi3Status fmi3SetContinuousStates(fmi3Instance c, const fmi3Float64 states[], size_t nx) {
    Instance *x = (Instance *)c;
    for (size_t k = 0; k < nx && k < TG_NX; k++) {
        if (x->m.w[k] != states[k]) x->m.fresh = 0;
        x->m.w[k] = states[k];
    }
    return fmi3OK;
}

fmi3Status fmi3GetContinuousStateDerivatives(fmi3Instance c, fmi3Float64 derivatives[], size_t nx) {
    Instance *x = (Instance *)c;
    double dw[TG_NX + 1];
    if (tg_start(&x->m)) return tg_fail(x);
    tg_derivatives(&x->m, x->m.t, x->m.w, dw);
    for (size_t k = 0; k < nx && k < TG_NX; k++) derivatives[k] = dw[k];
    return fmi3OK;
}

fmi3Status fmi3GetEventIndicators(fmi3Instance c, fmi3Float64 indicators[], size_t ni) {
    Instance *x = (Instance *)c;
    double z[TG_NZ + 1];
    if (tg_start(&x->m)) return tg_fail(x);
    tg_indicators(&x->m, x->m.t, x->m.w, z);
    for (size_t k = 0; k < ni && k < TG_NZ; k++) indicators[k] = z[k];
    return fmi3OK;
}

fmi3Status fmi3GetContinuousStates(fmi3Instance c, fmi3Float64 states[], size_t nx) {
    Instance *x = (Instance *)c;
    for (size_t k = 0; k < nx && k < TG_NX; k++) states[k] = x->m.w[k];
    return fmi3OK;
}

fmi3Status fmi3GetNominalsOfContinuousStates(fmi3Instance c, fmi3Float64 nominals[], size_t nx) {
    (void)c;
    for (size_t k = 0; k < nx; k++) nominals[k] = 1.0;
    return fmi3OK;
}

fmi3Status fmi3GetNumberOfEventIndicators(fmi3Instance c, size_t *n) {
    (void)c;
    *n = TG_NZ;
    return fmi3OK;
}

fmi3Status fmi3GetNumberOfContinuousStates(fmi3Instance c, size_t *n) {
    (void)c;
    *n = TG_NX;
    return fmi3OK;
}

/* ----------------------------------------------------------------------- Co-Simulation */

fmi3Status fmi3EnterStepMode(fmi3Instance c) { (void)c; return fmi3OK; }

fmi3Status fmi3GetOutputDerivatives(fmi3Instance c, const fmi3ValueReference vr[], size_t nvr, const fmi3Int32 orders[],
                                    fmi3Float64 values[], size_t nv) {
    (void)vr; (void)orders; (void)values; (void)nv;
    return nvr ? tg_refuse(c, "output derivatives are not provided") : fmi3OK;
}

fmi3Status fmi3DoStep(fmi3Instance c, fmi3Float64 t, fmi3Float64 h, fmi3Boolean noSetPrior,
                      fmi3Boolean *eventHandlingNeeded, fmi3Boolean *terminate, fmi3Boolean *earlyReturn,
                      fmi3Float64 *lastSuccessfulTime) {
    Instance *x = (Instance *)c;
    (void)noSetPrior;
    *eventHandlingNeeded = fmi3False;
    *terminate = fmi3False;
    *earlyReturn = fmi3False;
    if (!(h > 0.0)) {
        snprintf(x->m.msg, sizeof x->m.msg, "communication step size %g must be positive", h);
        return tg_fail(x);
    }
    x->m.t = t;
    int failed = tg_cs_step(&x->m, t + h);
    *lastSuccessfulTime = x->m.t;
    return failed ? tg_fail(x) : fmi3OK;
}

fmi3Status fmi3ActivateModelPartition(fmi3Instance c, fmi3ValueReference clock, fmi3Float64 t) {
    (void)clock; (void)t;
    return tg_refuse(c, "scheduled execution is not supported");
}
