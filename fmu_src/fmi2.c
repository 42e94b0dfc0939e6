/* hacgear FMU binary, FMI 2.0 co-simulation: the FMI 2.0 functions over the Python bridge (bridge.h).
 * Compiled by hacgear_core.fmu.build when an FMU is built (gcc, Python's stable ABI, FMI 2.0 headers). */
#include "bridge.h"
#include "fmi2Functions.h"

typedef struct {
    HgInstance h; /* first member: an fmi2Component is an HgInstance */
    fmi2CallbackFunctions cb;
} Fmi2Instance;

static void emit2(HgInstance *h, int status, const char *category, const char *message) {
    const Fmi2Instance *c = (const Fmi2Instance *)h;
    if (c->cb.logger) c->cb.logger(c->cb.componentEnvironment, h->name, (fmi2Status)status, category, message);
}

/* enter/leave: NULL component -> Error; the GIL around the call */
#define ENTER(c)                                    \
    if (!(c)) return fmi2Error;                     \
    Fmi2Instance *I = (Fmi2Instance *)(c);          \
    HgInstance *H = &I->h;                          \
    PyGILState_STATE gil = PyGILState_Ensure();     \
    int st = HG_ERROR;
#define LEAVE()                                     \
    PyGILState_Release(gil);                        \
    return (fmi2Status)st;

/* A function this FMU does not provide (its capability flag says so): Error, the instance in its error state. */
static void unsupported(fmi2Component c, const char *what) {
    if (!c) return;
    Fmi2Instance *I = (Fmi2Instance *)c;
    char buf[256];
    snprintf(buf, sizeof buf, "%s is not supported by this FMU", what);
    PyGILState_STATE gil = PyGILState_Ensure();
    hg_fail(&I->h, buf);
    PyGILState_Release(gil);
}

/* A status inquiry without an answer: Discard, logged, no change of state. */
static void not_available(fmi2Component c, const char *what) {
    if (!c) return;
    char buf[256];
    snprintf(buf, sizeof buf, "%s is not available from this FMU", what);
    emit2(&((Fmi2Instance *)c)->h, HG_DISCARD, "logStatusDiscard", buf);
}

const char *fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }
const char *fmi2GetVersion(void) { return fmi2Version; }

fmi2Component fmi2Instantiate(fmi2String instanceName, fmi2Type fmuType, fmi2String fmuGUID,
                              fmi2String fmuResourceLocation, const fmi2CallbackFunctions *functions,
                              fmi2Boolean visible, fmi2Boolean loggingOn) {
    (void)visible;
    Fmi2Instance *I = (Fmi2Instance *)calloc(1, sizeof(Fmi2Instance));
    if (!I) return NULL;
    if (functions) I->cb = *functions;
    I->h.name = hg_strdup(instanceName ? instanceName : "");
    I->h.emit = emit2;
    I->h.logging_on = loggingOn ? 1 : 0;
    const char *problem = NULL;
    if (fmuType != fmi2CoSimulation) problem = "this FMU supports co-simulation only (fmuType = fmi2CoSimulation)";
    else if (!fmuResourceLocation) problem = "fmuResourceLocation is NULL";
    if (problem) {
        emit2(&I->h, HG_ERROR, "logStatusError", problem);
        fprintf(stderr, "hacgear FMU '%s': %s\n", I->h.name, problem);
        free(I->h.name);
        free(I);
        return NULL;
    }
    char *error = NULL;
    PyGILState_STATE gil = PyGILState_UNLOCKED;
    int gil_held = 0;
    PyObject *inst = hg_instantiate(&I->h, instanceName, fmuResourceLocation, fmuGUID, loggingOn ? 1 : 0, 2, &error, &gil, &gil_held);
    if (!inst) {
        const char *e = error ? error : "unknown error";
        /* the reason reaches the user without debug logging: the logger (status Error) and stderr */
        /* FMI 2.0 loggers take a printf format (masters written in Python do not format): '%' doubled */
        char *msg = (char *)malloc(2 * strlen(e) + 64);
        if (msg) {
            char *o = msg + sprintf(msg, "instantiation failed: ");
            for (const char *p = e; *p; p++) {
                if (*p == '%') *o++ = '%';
                *o++ = *p;
            }
            *o = '\0';
            if (I->cb.logger) I->cb.logger(I->cb.componentEnvironment, I->h.name, fmi2Error, "logStatusError", msg);
            free(msg);
        }
        fprintf(stderr, "hacgear FMU '%s': instantiation failed: %s\n", I->h.name, e);
        free(error);
        if (gil_held) PyGILState_Release(gil);
        free(I->h.name);
        free(I);
        return NULL;
    }
    hg_drain(&I->h);
    PyGILState_Release(gil);
    return (fmi2Component)I;
}

void fmi2FreeInstance(fmi2Component c) {
    if (!c) return;
    Fmi2Instance *I = (Fmi2Instance *)c;
    PyGILState_STATE gil = PyGILState_Ensure();
    hg_detach(&I->h);
    PyGILState_Release(gil);
    free(I->h.name);
    free(I);
}

fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean loggingOn, size_t nCategories,
                               const fmi2String categories[]) {
    (void)nCategories; (void)categories;
    ENTER(c)
    H->logging_on = loggingOn ? 1 : 0;
    PyObject *b = PyBool_FromLong(H->logging_on);
    st = (b && PyObject_SetAttrString(H->inst, "logging_on", b) == 0) ? HG_OK : HG_ERROR;
    Py_XDECREF(b);
    PyErr_Clear();
    LEAVE()
}

fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean toleranceDefined, fmi2Real tolerance,
                               fmi2Real startTime, fmi2Boolean stopTimeDefined, fmi2Real stopTime) {
    ENTER(c)
    PyObject *stop = stopTimeDefined ? PyFloat_FromDouble(stopTime) : (Py_INCREF(Py_None), Py_None);
    PyObject *tol = toleranceDefined ? PyFloat_FromDouble(tolerance) : (Py_INCREF(Py_None), Py_None);
    st = hg_call(H, "setup_experiment", "fmi2SetupExperiment", "(dOO)", startTime, stop, tol);
    Py_XDECREF(stop);
    Py_XDECREF(tol);
    LEAVE()
}

fmi2Status fmi2EnterInitializationMode(fmi2Component c) {
    ENTER(c)
    st = hg_call(H, "enter_initialization_mode", "fmi2EnterInitializationMode", NULL);
    LEAVE()
}

fmi2Status fmi2ExitInitializationMode(fmi2Component c) {
    ENTER(c)
    st = hg_call(H, "exit_initialization_mode", "fmi2ExitInitializationMode", NULL);
    LEAVE()
}

fmi2Status fmi2Terminate(fmi2Component c) {
    ENTER(c)
    st = hg_call(H, "terminate", "fmi2Terminate", NULL);
    LEAVE()
}

fmi2Status fmi2Reset(fmi2Component c) {
    ENTER(c)
    st = hg_call(H, "reset", "fmi2Reset", NULL);
    LEAVE()
}

/* ---------------------------------------------------------------- getters and setters */
static int conv_int(PyObject *o, void *dst, size_t i) {
    long v = PyLong_AsLong(o);
    if (v == -1 && PyErr_Occurred()) return 0;
    ((fmi2Integer *)dst)[i] = (fmi2Integer)v;
    return 1;
}

static int conv_bool(PyObject *o, void *dst, size_t i) {
    int v = PyObject_IsTrue(o);
    if (v < 0) return 0;
    ((fmi2Boolean *)dst)[i] = v ? fmi2True : fmi2False;
    return 1;
}

fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Real value[]) {
    ENTER(c)
    st = hg_get(H, H->get_real, "real", "fmi2GetReal", vr, nvr, value, hg_conv_double);
    LEAVE()
}

fmi2Status fmi2GetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Integer value[]) {
    ENTER(c)
    st = hg_get(H, NULL, "integer", "fmi2GetInteger", vr, nvr, value, conv_int);
    LEAVE()
}

fmi2Status fmi2GetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Boolean value[]) {
    ENTER(c)
    st = hg_get(H, NULL, "boolean", "fmi2GetBoolean", vr, nvr, value, conv_bool);
    LEAVE()
}

fmi2Status fmi2GetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2String value[]) {
    ENTER(c)
    if (nvr == 0) {
        st = HG_OK;
    } else {
        /* no String variables: every value reference is an error, reported by the instance */
        st = hg_get(H, NULL, "string", "fmi2GetString", vr, nvr, (void *)value, conv_int);
    }
    LEAVE()
}

static PyObject *tuple_of_doubles(const double *v, size_t n) {
    if (n && !v) return PyTuple_New(0);
    PyObject *t = PyTuple_New((Py_ssize_t)n);
    if (!t) return NULL;
    for (size_t i = 0; i < n; i++) PyTuple_SetItem(t, (Py_ssize_t)i, PyFloat_FromDouble(v[i]));
    return t;
}

static PyObject *tuple_of_ints(const int *v, size_t n, int as_bool) {
    if (n && !v) return PyTuple_New(0);
    PyObject *t = PyTuple_New((Py_ssize_t)n);
    if (!t) return NULL;
    for (size_t i = 0; i < n; i++)
        PyTuple_SetItem(t, (Py_ssize_t)i, as_bool ? PyBool_FromLong(v[i]) : PyLong_FromLong(v[i]));
    return t;
}

fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2Real value[]) {
    ENTER(c)
    st = hg_set(H, H->set_real, "real", "fmi2SetReal", vr, nvr, tuple_of_doubles(value, nvr));
    LEAVE()
}

fmi2Status fmi2SetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2Integer value[]) {
    ENTER(c)
    st = hg_set(H, NULL, "integer", "fmi2SetInteger", vr, nvr, tuple_of_ints(value, nvr, 0));
    LEAVE()
}

fmi2Status fmi2SetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2Boolean value[]) {
    ENTER(c)
    st = hg_set(H, NULL, "boolean", "fmi2SetBoolean", vr, nvr, tuple_of_ints(value, nvr, 1));
    LEAVE()
}

fmi2Status fmi2SetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2String value[]) {
    ENTER(c)
    PyObject *t = PyTuple_New((Py_ssize_t)nvr);
    for (size_t i = 0; t && i < nvr; i++)
        PyTuple_SetItem(t, (Py_ssize_t)i, PyUnicode_FromString(value && value[i] ? value[i] : ""));
    st = hg_set(H, NULL, "string", "fmi2SetString", vr, nvr, t);
    LEAVE()
}

/* ---------------------------------------------------------------- FMU states */
fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate *FMUstate) {
    ENTER(c)
    st = hg_state_get(H, (void **)FMUstate, "fmi2GetFMUstate");
    LEAVE()
}

fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate FMUstate) {
    ENTER(c)
    st = hg_state_set(H, FMUstate, "fmi2SetFMUstate");
    LEAVE()
}

fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate *FMUstate) {
    ENTER(c)
    st = hg_state_free(H, (void **)FMUstate, "fmi2FreeFMUstate");
    LEAVE()
}

fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate FMUstate, size_t *size) {
    ENTER(c)
    st = hg_state_size(H, FMUstate, size, "fmi2SerializedFMUstateSize");
    LEAVE()
}

fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate FMUstate, fmi2Byte serializedState[], size_t size) {
    ENTER(c)
    st = hg_state_serialize(H, FMUstate, serializedState, size, "fmi2SerializeFMUstate",
                            "fmi2SerializedFMUstateSize");
    LEAVE()
}

fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte serializedState[], size_t size,
                                   fmi2FMUstate *FMUstate) {
    ENTER(c)
    st = hg_state_deserialize(H, serializedState, size, (void **)FMUstate, "fmi2DeSerializeFMUstate");
    LEAVE()
}

/* ---------------------------------------------------------------- stepping */
fmi2Status fmi2DoStep(fmi2Component c, fmi2Real currentCommunicationPoint, fmi2Real communicationStepSize,
                      fmi2Boolean noSetFMUStatePriorToCurrentPoint) {
    (void)noSetFMUStatePriorToCurrentPoint;
    ENTER(c)
    PyObject *args = PyTuple_New(2);
    if (args) {
        PyTuple_SetItem(args, 0, PyFloat_FromDouble(currentCommunicationPoint));
        PyTuple_SetItem(args, 1, PyFloat_FromDouble(communicationStepSize));
        st = hg_status(H, PyObject_Call(H->do_step, args, NULL), "fmi2DoStep");
        Py_DECREF(args);
    } else {
        st = hg_status(H, NULL, "fmi2DoStep");
    }
    LEAVE()
}

fmi2Status fmi2CancelStep(fmi2Component c) {
    unsupported(c, "fmi2CancelStep (doStep is synchronous)");
    return fmi2Error;
}

fmi2Status fmi2GetStatus(fmi2Component c, const fmi2StatusKind s, fmi2Status *value) {
    (void)s; (void)value;
    not_available(c, "fmi2GetStatus (doStep is synchronous)");
    return fmi2Discard;
}

fmi2Status fmi2GetRealStatus(fmi2Component c, const fmi2StatusKind s, fmi2Real *value) {
    if (s != fmi2LastSuccessfulTime || !value) {
        not_available(c, "fmi2GetRealStatus of a kind other than fmi2LastSuccessfulTime");
        return fmi2Discard;
    }
    ENTER(c)
    PyObject *r = PyObject_CallMethod(H->inst, "last_successful_time", NULL);
    if (r) {
        *value = PyFloat_AsDouble(r);
        Py_DECREF(r);
        st = PyErr_Occurred() ? HG_ERROR : HG_OK;
        PyErr_Clear();
    } else {
        st = hg_status(H, NULL, "fmi2GetRealStatus");
    }
    LEAVE()
}

fmi2Status fmi2GetIntegerStatus(fmi2Component c, const fmi2StatusKind s, fmi2Integer *value) {
    (void)s; (void)value;
    not_available(c, "fmi2GetIntegerStatus");
    return fmi2Discard;
}

fmi2Status fmi2GetBooleanStatus(fmi2Component c, const fmi2StatusKind s, fmi2Boolean *value) {
    if (s == fmi2Terminated && value && c) {
        *value = fmi2False; /* the FMU never asks to end the simulation */
        return fmi2OK;
    }
    not_available(c, "fmi2GetBooleanStatus of a kind other than fmi2Terminated");
    return fmi2Discard;
}

fmi2Status fmi2GetStringStatus(fmi2Component c, const fmi2StatusKind s, fmi2String *value) {
    (void)s; (void)value;
    not_available(c, "fmi2GetStringStatus");
    return fmi2Discard;
}

fmi2Status fmi2GetDirectionalDerivative(fmi2Component c, const fmi2ValueReference vUnknown_ref[], size_t nUnknown,
                                        const fmi2ValueReference vKnown_ref[], size_t nKnown,
                                        const fmi2Real dvKnown[], fmi2Real dvUnknown[]) {
    (void)vUnknown_ref; (void)nUnknown; (void)vKnown_ref; (void)nKnown; (void)dvKnown; (void)dvUnknown;
    unsupported(c, "fmi2GetDirectionalDerivative (providesDirectionalDerivative = false)");
    return fmi2Error;
}

fmi2Status fmi2SetRealInputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                       const fmi2Integer order[], const fmi2Real value[]) {
    (void)vr; (void)nvr; (void)order; (void)value;
    unsupported(c, "fmi2SetRealInputDerivatives (canInterpolateInputs = false)");
    return fmi2Error;
}

fmi2Status fmi2GetRealOutputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                        const fmi2Integer order[], fmi2Real value[]) {
    (void)vr; (void)nvr; (void)order; (void)value;
    unsupported(c, "fmi2GetRealOutputDerivatives (maxOutputDerivativeOrder = 0)");
    return fmi2Error;
}
