/* transgen FMU: the FMI 2.0 interface (Model Exchange and Co-Simulation) over tg_model.c.
 * Written for transgen (MIT licence); the FMI 2.0 headers come from FMPy at build time. */
#include "fmi2Functions.h"
#include "tg_model.c"

typedef struct {
    TG m;
    fmi2CallbackFunctions cb;
    fmi2String name;
    int logging;
    int initialized;
    int terminated;
} Instance;

static void tg_log(Instance *c, fmi2Status status, const char *message) {
    if (c->cb.logger) c->cb.logger(c->cb.componentEnvironment, c->name, status, "logError", "%s", message);
}

static fmi2Status tg_fail(Instance *c) {
    tg_log(c, fmi2Error, c->m.msg);
    return fmi2Error;
}

const char *fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }
const char *fmi2GetVersion(void) { return fmi2Version; }

fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean loggingOn, size_t n, const fmi2String categories[]) {
    (void)n; (void)categories;
    ((Instance *)c)->logging = loggingOn;
    return fmi2OK;
}

fmi2Component fmi2Instantiate(fmi2String name, fmi2Type type, fmi2String guid, fmi2String location,
                              const fmi2CallbackFunctions *functions, fmi2Boolean visible, fmi2Boolean loggingOn) {
    (void)type; (void)location; (void)visible;
    if (!functions || !guid || strcmp(guid, TG_GUID) != 0) {
        if (functions && functions->logger)
            functions->logger(functions->componentEnvironment, name, fmi2Error, "logError",
                              "the GUID %s does not match this FMU's %s", guid ? guid : "(none)", TG_GUID);
        return NULL;
    }
    Instance *c = (Instance *)calloc(1, sizeof(Instance));
    if (!c) return NULL;
    c->cb = *functions;
    c->name = name;
    c->logging = loggingOn;
    tg_reset(&c->m);
    return c;
}

void fmi2FreeInstance(fmi2Component c) { free(c); }

fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean toleranceDefined, fmi2Real tolerance,
                               fmi2Real startTime, fmi2Boolean stopTimeDefined, fmi2Real stopTime) {
    (void)toleranceDefined; (void)tolerance; (void)stopTimeDefined; (void)stopTime;
    ((Instance *)c)->m.t = startTime;
    return fmi2OK;
}

fmi2Status fmi2EnterInitializationMode(fmi2Component c) { (void)c; return fmi2OK; }

fmi2Status fmi2ExitInitializationMode(fmi2Component c) {
    Instance *x = (Instance *)c;
    x->initialized = 1;
    return tg_start(&x->m) ? tg_fail(x) : fmi2OK;
}

fmi2Status fmi2Terminate(fmi2Component c) { ((Instance *)c)->terminated = 1; return fmi2OK; }

fmi2Status fmi2Reset(fmi2Component c) {
    Instance *x = (Instance *)c;
    tg_reset(&x->m);
    x->initialized = x->terminated = 0;
    return fmi2OK;
}

fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Real value[]) {
    Instance *x = (Instance *)c;
    for (size_t i = 0; i < nvr; i++)
        if (tg_get_real(&x->m, vr[i], &value[i])) return tg_fail(x);
    return fmi2OK;
}

fmi2Status fmi2GetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Integer value[]) {
    Instance *x = (Instance *)c;
    for (size_t i = 0; i < nvr; i++)
        if (tg_get_integer(&x->m, vr[i], &value[i])) return tg_fail(x);
    return fmi2OK;
}

fmi2Status fmi2GetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Boolean value[]) {
    Instance *x = (Instance *)c;
    for (size_t i = 0; i < nvr; i++) {
        int v;
        if (tg_get_boolean(&x->m, vr[i], &v)) return tg_fail(x);
        value[i] = v ? fmi2True : fmi2False;
    }
    return fmi2OK;
}

fmi2Status fmi2GetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2String value[]) {
    (void)vr; (void)value;
    if (nvr == 0) return fmi2OK;
    snprintf(((Instance *)c)->m.msg, sizeof ((Instance *)c)->m.msg, "this FMU has no string variables");
    return tg_fail((Instance *)c);
}

fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2Real value[]) {
    Instance *x = (Instance *)c;
    for (size_t i = 0; i < nvr; i++)
        if (tg_set_real(&x->m, vr[i], value[i])) return tg_fail(x);
    return fmi2OK;
}

static fmi2Status tg_no_set(fmi2Component c, size_t nvr) {
    if (nvr == 0) return fmi2OK;
    snprintf(((Instance *)c)->m.msg, sizeof ((Instance *)c)->m.msg, "no integer, boolean or string variable can be set");
    return tg_fail((Instance *)c);
}

fmi2Status fmi2SetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2Integer value[]) {
    (void)vr; (void)value;
    return tg_no_set(c, nvr);
}

fmi2Status fmi2SetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2Boolean value[]) {
    (void)vr; (void)value;
    return tg_no_set(c, nvr);
}

fmi2Status fmi2SetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2String value[]) {
    (void)vr; (void)value;
    return tg_no_set(c, nvr);
}

/* the state of an instance is the plain struct TG: saved, restored and serialized as bytes */
fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate *state) {
    *state = tg_state_save(&((Instance *)c)->m, *state);
    return *state ? fmi2OK : fmi2Error;
}

fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate state) {
    if (!state) return fmi2Error;
    ((Instance *)c)->m = *(TG *)state;
    return fmi2OK;
}

fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate *state) {
    (void)c;
    free(*state);
    *state = NULL;
    return fmi2OK;
}

fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate state, size_t *size) {
    (void)c; (void)state;
    *size = sizeof(TG);
    return fmi2OK;
}

fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate state, fmi2Byte bytes[], size_t size) {
    (void)c;
    if (size < sizeof(TG) || !state) return fmi2Error;
    memcpy(bytes, state, sizeof(TG));
    return fmi2OK;
}

fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte bytes[], size_t size, fmi2FMUstate *state) {
    (void)c;
    *state = tg_state_from_bytes(bytes, size);
    return *state ? fmi2OK : fmi2Error;
}

fmi2Status fmi2GetDirectionalDerivative(fmi2Component c, const fmi2ValueReference vUnknown[], size_t nUnknown,
                                        const fmi2ValueReference vKnown[], size_t nKnown, const fmi2Real dvKnown[],
                                        fmi2Real dvUnknown[]) {
    (void)vUnknown; (void)nUnknown; (void)vKnown; (void)nKnown; (void)dvKnown; (void)dvUnknown;
    snprintf(((Instance *)c)->m.msg, sizeof ((Instance *)c)->m.msg, "directional derivatives are not provided");
    return tg_fail((Instance *)c);
}

/* ----------------------------------------------------------------------- Model Exchange */

fmi2Status fmi2EnterEventMode(fmi2Component c) { (void)c; return fmi2OK; }

fmi2Status fmi2NewDiscreteStates(fmi2Component c, fmi2EventInfo *info) {
    Instance *x = (Instance *)c;
    memset(info, 0, sizeof *info);
    if (!x->m.fresh && tg_event(&x->m)) return tg_fail(x);
    x->m.fresh = 1;
    info->newDiscreteStatesNeeded = fmi2False;
    info->terminateSimulation = fmi2False;
    info->nominalsOfContinuousStatesChanged = fmi2False;
    info->valuesOfContinuousStatesChanged = fmi2True;
    info->nextEventTimeDefined = isfinite(x->m.t_stop) ? fmi2True : fmi2False;
    info->nextEventTime = isfinite(x->m.t_stop) ? x->m.t_stop : 0.0;
    return fmi2OK;
}

fmi2Status fmi2EnterContinuousTimeMode(fmi2Component c) { ((Instance *)c)->m.fresh = 0; return fmi2OK; }

fmi2Status fmi2CompletedIntegratorStep(fmi2Component c, fmi2Boolean noSetFMUStatePriorToCurrentPoint,
                                       fmi2Boolean *enterEventMode, fmi2Boolean *terminateSimulation) {
    (void)c; (void)noSetFMUStatePriorToCurrentPoint;
    *enterEventMode = fmi2False;
    *terminateSimulation = fmi2False;
    return fmi2OK;
}

fmi2Status fmi2SetTime(fmi2Component c, fmi2Real time) {
    Instance *x = (Instance *)c;
    if (time != x->m.t) x->m.fresh = 0;
    x->m.t = time;
    return fmi2OK;
}

fmi2Status fmi2SetContinuousStates(fmi2Component c, const fmi2Real states[], size_t nx) {
    Instance *x = (Instance *)c;
    for (size_t k = 0; k < nx && k < TG_NX; k++) {
        if (x->m.w[k] != states[k]) x->m.fresh = 0;
        x->m.w[k] = states[k];
    }
    return fmi2OK;
}

fmi2Status fmi2GetDerivatives(fmi2Component c, fmi2Real derivatives[], size_t nx) {
    Instance *x = (Instance *)c;
    double dw[TG_NX + 1];
    if (tg_start(&x->m)) return tg_fail(x);
    tg_derivatives(&x->m, x->m.t, x->m.w, dw);
    for (size_t k = 0; k < nx && k < TG_NX; k++) derivatives[k] = dw[k];
    return fmi2OK;
}

fmi2Status fmi2GetEventIndicators(fmi2Component c, fmi2Real indicators[], size_t ni) {
    Instance *x = (Instance *)c;
    double z[TG_NZ + 1];
    if (tg_start(&x->m)) return tg_fail(x);
    tg_indicators(&x->m, x->m.t, x->m.w, z);
    for (size_t k = 0; k < ni && k < TG_NZ; k++) indicators[k] = z[k];
    return fmi2OK;
}

fmi2Status fmi2GetContinuousStates(fmi2Component c, fmi2Real states[], size_t nx) {
    Instance *x = (Instance *)c;
    for (size_t k = 0; k < nx && k < TG_NX; k++) states[k] = x->m.w[k];
    return fmi2OK;
}

fmi2Status fmi2GetNominalsOfContinuousStates(fmi2Component c, fmi2Real nominals[], size_t nx) {
    (void)c;
    for (size_t k = 0; k < nx; k++) nominals[k] = 1.0;
    return fmi2OK;
}

/* ----------------------------------------------------------------------- Co-Simulation */

fmi2Status fmi2SetRealInputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                       const fmi2Integer order[], const fmi2Real value[]) {
    (void)vr; (void)order; (void)value;
    if (nvr == 0) return fmi2OK;
    snprintf(((Instance *)c)->m.msg, sizeof ((Instance *)c)->m.msg, "input derivatives are not used");
    return tg_fail((Instance *)c);
}

fmi2Status fmi2GetRealOutputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                        const fmi2Integer order[], fmi2Real value[]) {
    (void)vr; (void)order; (void)value;
    if (nvr == 0) return fmi2OK;
    snprintf(((Instance *)c)->m.msg, sizeof ((Instance *)c)->m.msg, "output derivatives are not provided");
    return tg_fail((Instance *)c);
}

fmi2Status fmi2DoStep(fmi2Component c, fmi2Real currentCommunicationPoint, fmi2Real communicationStepSize,
                      fmi2Boolean noSetFMUStatePriorToCurrentPoint) {
    Instance *x = (Instance *)c;
    (void)noSetFMUStatePriorToCurrentPoint;
    if (!(communicationStepSize > 0.0)) {
        snprintf(x->m.msg, sizeof x->m.msg, "communication step size %g must be positive", communicationStepSize);
        return tg_fail(x);
    }
    x->m.t = currentCommunicationPoint;
    return tg_cs_step(&x->m, currentCommunicationPoint + communicationStepSize) ? tg_fail(x) : fmi2OK;
}

fmi2Status fmi2CancelStep(fmi2Component c) { (void)c; return fmi2Error; }

fmi2Status fmi2GetStatus(fmi2Component c, const fmi2StatusKind s, fmi2Status *value) {
    (void)c; (void)s;
    *value = fmi2OK;
    return fmi2OK;
}

fmi2Status fmi2GetRealStatus(fmi2Component c, const fmi2StatusKind s, fmi2Real *value) {
    if (s == fmi2LastSuccessfulTime) {
        *value = ((Instance *)c)->m.t;
        return fmi2OK;
    }
    return fmi2Discard;
}

fmi2Status fmi2GetIntegerStatus(fmi2Component c, const fmi2StatusKind s, fmi2Integer *value) {
    (void)c; (void)s; (void)value;
    return fmi2Discard;
}

fmi2Status fmi2GetBooleanStatus(fmi2Component c, const fmi2StatusKind s, fmi2Boolean *value) {
    (void)c;
    if (s == fmi2Terminated) {
        *value = fmi2False;
        return fmi2OK;
    }
    return fmi2Discard;
}

fmi2Status fmi2GetStringStatus(fmi2Component c, const fmi2StatusKind s, fmi2String *value) {
    (void)c; (void)s; (void)value;
    return fmi2Discard;
}
