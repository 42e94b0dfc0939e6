/* hacgear FMU binary, FMI 3.0 co-simulation: the FMI 3.0 functions over the Python bridge (bridge.h).
 * Compiled by hacgear_core.fmu.build when an FMU is built (gcc, Python's stable ABI, FMI 3.0 headers).
 * Variables: Float64 (Real), Int32 (Integer), Enumeration (through the Int64 functions), Boolean; scalars only.
 * No Event Mode, no intermediate update, no clocks, no Model Exchange or Scheduled Execution. */
#include "bridge.h"
#include "fmi3Functions.h"

typedef struct {
    HgInstance h; /* first member: an fmi3Instance is an HgInstance */
    fmi3InstanceEnvironment env;
    fmi3LogMessageCallback logMessage;
} Fmi3Instance;

static void emit3(HgInstance *h, int status, const char *category, const char *message) {
    const Fmi3Instance *c = (const Fmi3Instance *)h;
    if (c->logMessage) c->logMessage(c->env, (fmi3Status)status, category, message);
}

#define ENTER(c)                                    \
    if (!(c)) return fmi3Error;                     \
    Fmi3Instance *I = (Fmi3Instance *)(c);          \
    HgInstance *H = &I->h;                          \
    PyGILState_STATE gil = PyGILState_Ensure();     \
    int st = HG_ERROR;
#define LEAVE()                                     \
    PyGILState_Release(gil);                        \
    return (fmi3Status)st;

/* A function this FMU does not provide (its capability flags say so): Error, the instance in its error state. */
static fmi3Status unsupported(fmi3Instance c, const char *what) {
    if (c) {
        char buf[256];
        snprintf(buf, sizeof buf, "%s is not supported by this FMU", what);
        PyGILState_STATE gil = PyGILState_Ensure();
        hg_fail(&((Fmi3Instance *)c)->h, buf);
        PyGILState_Release(gil);
    }
    return fmi3Error;
}

const char *fmi3GetVersion(void) { return fmi3Version; }

fmi3Status fmi3SetDebugLogging(fmi3Instance c, fmi3Boolean loggingOn, size_t nCategories,
                               const fmi3String categories[]) {
    (void)nCategories; (void)categories;
    ENTER(c)
    H->logging_on = loggingOn ? 1 : 0;
    PyObject *b = PyBool_FromLong(H->logging_on);
    st = (b && PyObject_SetAttrString(H->inst, "logging_on", b) == 0) ? HG_OK : HG_ERROR;
    Py_XDECREF(b);
    PyErr_Clear();
    LEAVE()
}

fmi3Instance fmi3InstantiateModelExchange(fmi3String instanceName, fmi3String instantiationToken,
                                          fmi3String resourcePath, fmi3Boolean visible, fmi3Boolean loggingOn,
                                          fmi3InstanceEnvironment instanceEnvironment,
                                          fmi3LogMessageCallback logMessage) {
    (void)instantiationToken; (void)resourcePath; (void)visible; (void)loggingOn;
    if (logMessage) logMessage(instanceEnvironment, fmi3Error, "logStatusError",
                               "this FMU supports co-simulation only");
    (void)instanceName;
    return NULL;
}

fmi3Instance fmi3InstantiateScheduledExecution(fmi3String instanceName, fmi3String instantiationToken,
                                               fmi3String resourcePath, fmi3Boolean visible, fmi3Boolean loggingOn,
                                               fmi3InstanceEnvironment instanceEnvironment,
                                               fmi3LogMessageCallback logMessage,
                                               fmi3ClockUpdateCallback clockUpdate,
                                               fmi3LockPreemptionCallback lockPreemption,
                                               fmi3UnlockPreemptionCallback unlockPreemption) {
    (void)instanceName; (void)instantiationToken; (void)resourcePath; (void)visible; (void)loggingOn;
    (void)clockUpdate; (void)lockPreemption; (void)unlockPreemption;
    if (logMessage) logMessage(instanceEnvironment, fmi3Error, "logStatusError",
                               "this FMU supports co-simulation only");
    return NULL;
}

fmi3Instance fmi3InstantiateCoSimulation(fmi3String instanceName, fmi3String instantiationToken,
                                         fmi3String resourcePath, fmi3Boolean visible, fmi3Boolean loggingOn,
                                         fmi3Boolean eventModeUsed, fmi3Boolean earlyReturnAllowed,
                                         const fmi3ValueReference requiredIntermediateVariables[],
                                         size_t nRequiredIntermediateVariables,
                                         fmi3InstanceEnvironment instanceEnvironment,
                                         fmi3LogMessageCallback logMessage,
                                         fmi3IntermediateUpdateCallback intermediateUpdate) {
    (void)visible; (void)earlyReturnAllowed; (void)requiredIntermediateVariables;
    (void)nRequiredIntermediateVariables; (void)intermediateUpdate;
    Fmi3Instance *I = (Fmi3Instance *)calloc(1, sizeof(Fmi3Instance));
    if (!I) return NULL;
    I->env = instanceEnvironment;
    I->logMessage = logMessage;
    I->h.name = hg_strdup(instanceName ? instanceName : "");
    I->h.emit = emit3;
    I->h.logging_on = loggingOn ? 1 : 0;
    const char *problem = NULL;
    if (!resourcePath) problem = "resourcePath is NULL";
    else if (eventModeUsed) problem = "this FMU has no Event Mode (hasEventMode = false): eventModeUsed must be false";
    if (problem) {
        emit3(&I->h, HG_ERROR, "logStatusError", problem);
        fprintf(stderr, "hacgear FMU '%s': %s\n", I->h.name, problem);
        free(I->h.name);
        free(I);
        return NULL;
    }
    char *error = NULL;
    PyGILState_STATE gil = PyGILState_UNLOCKED;
    int gil_held = 0;
    PyObject *inst = hg_instantiate(&I->h, instanceName, resourcePath, instantiationToken, loggingOn ? 1 : 0, 3, &error, &gil, &gil_held);
    if (!inst) {
        const char *e = error ? error : "unknown error";
        char *msg = (char *)malloc(strlen(e) + 64);
        if (msg) {
            sprintf(msg, "instantiation failed: %s", e);
            emit3(&I->h, HG_ERROR, "logStatusError", msg);
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
    return (fmi3Instance)I;
}

void fmi3FreeInstance(fmi3Instance c) {
    if (!c) return;
    Fmi3Instance *I = (Fmi3Instance *)c;
    PyGILState_STATE gil = PyGILState_Ensure();
    hg_detach(&I->h);
    PyGILState_Release(gil);
    free(I->h.name);
    free(I);
}

fmi3Status fmi3EnterInitializationMode(fmi3Instance c, fmi3Boolean toleranceDefined, fmi3Float64 tolerance,
                                       fmi3Float64 startTime, fmi3Boolean stopTimeDefined, fmi3Float64 stopTime) {
    ENTER(c)
    PyObject *stop = stopTimeDefined ? PyFloat_FromDouble(stopTime) : (Py_INCREF(Py_None), Py_None);
    PyObject *tol = toleranceDefined ? PyFloat_FromDouble(tolerance) : (Py_INCREF(Py_None), Py_None);
    st = hg_call(H, "enter_initialization_mode", "fmi3EnterInitializationMode", "(dOO)", startTime, stop, tol);
    Py_XDECREF(stop);
    Py_XDECREF(tol);
    LEAVE()
}

fmi3Status fmi3ExitInitializationMode(fmi3Instance c) {
    ENTER(c)
    st = hg_call(H, "exit_initialization_mode", "fmi3ExitInitializationMode", NULL);
    LEAVE()
}

fmi3Status fmi3EnterEventMode(fmi3Instance c) { return unsupported(c, "fmi3EnterEventMode (hasEventMode = false)"); }

fmi3Status fmi3Terminate(fmi3Instance c) {
    ENTER(c)
    st = hg_call(H, "terminate", "fmi3Terminate", NULL);
    LEAVE()
}

fmi3Status fmi3Reset(fmi3Instance c) {
    ENTER(c)
    st = hg_call(H, "reset", "fmi3Reset", NULL);
    LEAVE()
}

/* ---------------------------------------------------------------- getters and setters */
static int conv_i32(PyObject *o, void *dst, size_t i) {
    long v = PyLong_AsLong(o);
    if (v == -1 && PyErr_Occurred()) return 0;
    ((fmi3Int32 *)dst)[i] = (fmi3Int32)v;
    return 1;
}

static int conv_i64(PyObject *o, void *dst, size_t i) {
    long long v = PyLong_AsLongLong(o);
    if (v == -1 && PyErr_Occurred()) return 0;
    ((fmi3Int64 *)dst)[i] = (fmi3Int64)v;
    return 1;
}

static int conv_bool3(PyObject *o, void *dst, size_t i) {
    int v = PyObject_IsTrue(o);
    if (v < 0) return 0;
    ((fmi3Boolean *)dst)[i] = v ? fmi3True : fmi3False;
    return 1;
}

static int conv_none(PyObject *o, void *dst, size_t i) { (void)o; (void)dst; (void)i; return 0; }

/* scalars only: nValues must equal nValueReferences */
#define CHECK_N(fn)                                                                                       \
    if (nValues != nValueReferences) {                                                                    \
        st = hg_fail(H, fn ": nValues must equal nValueReferences (no array variables)");                   \
        LEAVE()                                                                                           \
    }

fmi3Status fmi3GetFloat64(fmi3Instance c, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                          fmi3Float64 values[], size_t nValues) {
    ENTER(c)
    CHECK_N("fmi3GetFloat64")
    st = hg_get(H, H->get_real, "real", "fmi3GetFloat64", valueReferences, nValueReferences, values, hg_conv_double);
    LEAVE()
}

fmi3Status fmi3GetInt32(fmi3Instance c, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                        fmi3Int32 values[], size_t nValues) {
    ENTER(c)
    CHECK_N("fmi3GetInt32")
    st = hg_get(H, NULL, "integer", "fmi3GetInt32", valueReferences, nValueReferences, values, conv_i32);
    LEAVE()
}

fmi3Status fmi3GetInt64(fmi3Instance c, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                        fmi3Int64 values[], size_t nValues) {
    ENTER(c)
    CHECK_N("fmi3GetInt64")
    st = hg_get(H, NULL, "int64", "fmi3GetInt64", valueReferences, nValueReferences, values, conv_i64);
    LEAVE()
}

fmi3Status fmi3GetBoolean(fmi3Instance c, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                          fmi3Boolean values[], size_t nValues) {
    ENTER(c)
    CHECK_N("fmi3GetBoolean")
    st = hg_get(H, NULL, "boolean", "fmi3GetBoolean", valueReferences, nValueReferences, values, conv_bool3);
    LEAVE()
}

/* types without variables in this FMU: an empty call is OK, any value reference an Error from the instance */
#define GET_NONE(NAME, CTYPE, KIND)                                                                         \
    fmi3Status NAME(fmi3Instance c, const fmi3ValueReference valueReferences[], size_t nValueReferences,    \
                    CTYPE values[], size_t nValues) {                                                       \
        ENTER(c)                                                                                            \
        CHECK_N(#NAME)                                                                                      \
        st = hg_get(H, NULL, KIND, #NAME, valueReferences, nValueReferences, (void *)values, conv_none);   \
        LEAVE()                                                                                             \
    }
GET_NONE(fmi3GetFloat32, fmi3Float32, "float32")
GET_NONE(fmi3GetInt8, fmi3Int8, "int8")
GET_NONE(fmi3GetUInt8, fmi3UInt8, "uint8")
GET_NONE(fmi3GetInt16, fmi3Int16, "int16")
GET_NONE(fmi3GetUInt16, fmi3UInt16, "uint16")
GET_NONE(fmi3GetUInt32, fmi3UInt32, "uint32")
GET_NONE(fmi3GetUInt64, fmi3UInt64, "uint64")
GET_NONE(fmi3GetString, fmi3String, "string")

fmi3Status fmi3GetBinary(fmi3Instance c, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                         size_t valueSizes[], fmi3Binary values[], size_t nValues) {
    (void)valueSizes;
    ENTER(c)
    CHECK_N("fmi3GetBinary")
    st = hg_get(H, NULL, "binary", "fmi3GetBinary", valueReferences, nValueReferences, (void *)values, conv_none);
    LEAVE()
}

fmi3Status fmi3GetClock(fmi3Instance c, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                        fmi3Clock values[]) {
    (void)valueReferences; (void)values;
    if (nValueReferences == 0) return c ? fmi3OK : fmi3Error;
    return unsupported(c, "fmi3GetClock (no clocks)");
}

static PyObject *tuple_f64(const double *v, size_t n) {
    if (n && !v) return PyTuple_New(0);
    PyObject *t = PyTuple_New((Py_ssize_t)n);
    for (size_t i = 0; t && i < n; i++) PyTuple_SetItem(t, (Py_ssize_t)i, PyFloat_FromDouble(v[i]));
    return t;
}

fmi3Status fmi3SetFloat64(fmi3Instance c, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                          const fmi3Float64 values[], size_t nValues) {
    ENTER(c)
    CHECK_N("fmi3SetFloat64")
    st = hg_set(H, H->set_real, "real", "fmi3SetFloat64", valueReferences, nValueReferences,
                tuple_f64(values, nValueReferences));
    LEAVE()
}

fmi3Status fmi3SetInt32(fmi3Instance c, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                        const fmi3Int32 values[], size_t nValues) {
    ENTER(c)
    CHECK_N("fmi3SetInt32")
    PyObject *t = PyTuple_New((Py_ssize_t)nValueReferences);
    for (size_t i = 0; t && values && i < nValueReferences; i++)
        PyTuple_SetItem(t, (Py_ssize_t)i, PyLong_FromLong(values[i]));
    st = hg_set(H, NULL, "integer", "fmi3SetInt32", valueReferences, nValueReferences, t);
    LEAVE()
}

fmi3Status fmi3SetInt64(fmi3Instance c, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                        const fmi3Int64 values[], size_t nValues) {
    ENTER(c)
    CHECK_N("fmi3SetInt64")
    PyObject *t = PyTuple_New((Py_ssize_t)nValueReferences);
    for (size_t i = 0; t && values && i < nValueReferences; i++)
        PyTuple_SetItem(t, (Py_ssize_t)i, PyLong_FromLongLong(values[i]));
    st = hg_set(H, NULL, "int64", "fmi3SetInt64", valueReferences, nValueReferences, t);
    LEAVE()
}

fmi3Status fmi3SetBoolean(fmi3Instance c, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                          const fmi3Boolean values[], size_t nValues) {
    ENTER(c)
    CHECK_N("fmi3SetBoolean")
    PyObject *t = PyTuple_New((Py_ssize_t)nValueReferences);
    for (size_t i = 0; t && values && i < nValueReferences; i++)
        PyTuple_SetItem(t, (Py_ssize_t)i, PyBool_FromLong(values[i]));
    st = hg_set(H, NULL, "boolean", "fmi3SetBoolean", valueReferences, nValueReferences, t);
    LEAVE()
}

/* types without variables: the value is irrelevant, the instance answers Error for any value reference */
#define SET_NONE(NAME, CTYPE, KIND)                                                                          \
    fmi3Status NAME(fmi3Instance c, const fmi3ValueReference valueReferences[], size_t nValueReferences,     \
                    const CTYPE values[], size_t nValues) {                                                  \
        (void)values;                                                                                        \
        ENTER(c)                                                                                             \
        CHECK_N(#NAME)                                                                                       \
        PyObject *t = PyTuple_New((Py_ssize_t)nValueReferences);                                             \
        for (size_t i = 0; t && i < nValueReferences; i++) {                                                 \
            Py_INCREF(Py_None);                                                                              \
            PyTuple_SetItem(t, (Py_ssize_t)i, Py_None);                                                      \
        }                                                                                                    \
        st = hg_set(H, NULL, KIND, #NAME, valueReferences, nValueReferences, t);                            \
        LEAVE()                                                                                              \
    }
SET_NONE(fmi3SetFloat32, fmi3Float32, "float32")
SET_NONE(fmi3SetInt8, fmi3Int8, "int8")
SET_NONE(fmi3SetUInt8, fmi3UInt8, "uint8")
SET_NONE(fmi3SetInt16, fmi3Int16, "int16")
SET_NONE(fmi3SetUInt16, fmi3UInt16, "uint16")
SET_NONE(fmi3SetUInt32, fmi3UInt32, "uint32")
SET_NONE(fmi3SetUInt64, fmi3UInt64, "uint64")
SET_NONE(fmi3SetString, fmi3String, "string")

fmi3Status fmi3SetBinary(fmi3Instance c, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                         const size_t valueSizes[], const fmi3Binary values[], size_t nValues) {
    (void)valueSizes; (void)values;
    ENTER(c)
    CHECK_N("fmi3SetBinary")
    PyObject *t = PyTuple_New((Py_ssize_t)nValueReferences);
    for (size_t i = 0; t && i < nValueReferences; i++) {
        Py_INCREF(Py_None);
        PyTuple_SetItem(t, (Py_ssize_t)i, Py_None);
    }
    st = hg_set(H, NULL, "binary", "fmi3SetBinary", valueReferences, nValueReferences, t);
    LEAVE()
}

fmi3Status fmi3SetClock(fmi3Instance c, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                        const fmi3Clock values[]) {
    (void)valueReferences; (void)values;
    if (nValueReferences == 0) return c ? fmi3OK : fmi3Error;
    return unsupported(c, "fmi3SetClock (no clocks)");
}

/* ---------------------------------------------------------------- dependencies, derivatives, clocks, ME */
fmi3Status fmi3GetNumberOfVariableDependencies(fmi3Instance c, fmi3ValueReference valueReference,
                                               size_t *nDependencies) {
    (void)valueReference; (void)nDependencies;
    return unsupported(c, "fmi3GetNumberOfVariableDependencies (providesPerElementDependencies = false)");
}

fmi3Status fmi3GetVariableDependencies(fmi3Instance c, fmi3ValueReference dependent, size_t elementIndicesOfDependent[],
                                       fmi3ValueReference independents[], size_t elementIndicesOfIndependents[],
                                       fmi3DependencyKind dependencyKinds[], size_t nDependencies) {
    (void)dependent; (void)elementIndicesOfDependent; (void)independents; (void)elementIndicesOfIndependents;
    (void)dependencyKinds; (void)nDependencies;
    return unsupported(c, "fmi3GetVariableDependencies (providesPerElementDependencies = false)");
}

fmi3Status fmi3GetDirectionalDerivative(fmi3Instance c, const fmi3ValueReference unknowns[], size_t nUnknowns,
                                        const fmi3ValueReference knowns[], size_t nKnowns, const fmi3Float64 seed[],
                                        size_t nSeed, fmi3Float64 sensitivity[], size_t nSensitivity) {
    (void)unknowns; (void)nUnknowns; (void)knowns; (void)nKnowns; (void)seed; (void)nSeed; (void)sensitivity;
    (void)nSensitivity;
    return unsupported(c, "fmi3GetDirectionalDerivative (providesDirectionalDerivatives = false)");
}

fmi3Status fmi3GetAdjointDerivative(fmi3Instance c, const fmi3ValueReference unknowns[], size_t nUnknowns,
                                    const fmi3ValueReference knowns[], size_t nKnowns, const fmi3Float64 seed[],
                                    size_t nSeed, fmi3Float64 sensitivity[], size_t nSensitivity) {
    (void)unknowns; (void)nUnknowns; (void)knowns; (void)nKnowns; (void)seed; (void)nSeed; (void)sensitivity;
    (void)nSensitivity;
    return unsupported(c, "fmi3GetAdjointDerivative (providesAdjointDerivatives = false)");
}

fmi3Status fmi3EnterConfigurationMode(fmi3Instance c) {
    return unsupported(c, "fmi3EnterConfigurationMode (no structural parameters)");
}
fmi3Status fmi3ExitConfigurationMode(fmi3Instance c) {
    return unsupported(c, "fmi3ExitConfigurationMode (no structural parameters)");
}

fmi3Status fmi3GetIntervalDecimal(fmi3Instance c, const fmi3ValueReference valueReferences[], size_t n,
                                  fmi3Float64 intervals[], fmi3IntervalQualifier qualifiers[]) {
    (void)valueReferences; (void)n; (void)intervals; (void)qualifiers;
    return unsupported(c, "fmi3GetIntervalDecimal (no clocks)");
}
fmi3Status fmi3GetIntervalFraction(fmi3Instance c, const fmi3ValueReference valueReferences[], size_t n,
                                   fmi3UInt64 counters[], fmi3UInt64 resolutions[],
                                   fmi3IntervalQualifier qualifiers[]) {
    (void)valueReferences; (void)n; (void)counters; (void)resolutions; (void)qualifiers;
    return unsupported(c, "fmi3GetIntervalFraction (no clocks)");
}
fmi3Status fmi3GetShiftDecimal(fmi3Instance c, const fmi3ValueReference valueReferences[], size_t n,
                               fmi3Float64 shifts[]) {
    (void)valueReferences; (void)n; (void)shifts;
    return unsupported(c, "fmi3GetShiftDecimal (no clocks)");
}
fmi3Status fmi3GetShiftFraction(fmi3Instance c, const fmi3ValueReference valueReferences[], size_t n,
                                fmi3UInt64 counters[], fmi3UInt64 resolutions[]) {
    (void)valueReferences; (void)n; (void)counters; (void)resolutions;
    return unsupported(c, "fmi3GetShiftFraction (no clocks)");
}
fmi3Status fmi3SetIntervalDecimal(fmi3Instance c, const fmi3ValueReference valueReferences[], size_t n,
                                  const fmi3Float64 intervals[]) {
    (void)valueReferences; (void)n; (void)intervals;
    return unsupported(c, "fmi3SetIntervalDecimal (no clocks)");
}
fmi3Status fmi3SetIntervalFraction(fmi3Instance c, const fmi3ValueReference valueReferences[], size_t n,
                                   const fmi3UInt64 counters[], const fmi3UInt64 resolutions[]) {
    (void)valueReferences; (void)n; (void)counters; (void)resolutions;
    return unsupported(c, "fmi3SetIntervalFraction (no clocks)");
}
fmi3Status fmi3SetShiftDecimal(fmi3Instance c, const fmi3ValueReference valueReferences[], size_t n,
                               const fmi3Float64 shifts[]) {
    (void)valueReferences; (void)n; (void)shifts;
    return unsupported(c, "fmi3SetShiftDecimal (no clocks)");
}
fmi3Status fmi3SetShiftFraction(fmi3Instance c, const fmi3ValueReference valueReferences[], size_t n,
                                const fmi3UInt64 counters[], const fmi3UInt64 resolutions[]) {
    (void)valueReferences; (void)n; (void)counters; (void)resolutions;
    return unsupported(c, "fmi3SetShiftFraction (no clocks)");
}
fmi3Status fmi3EvaluateDiscreteStates(fmi3Instance c) {
    return unsupported(c, "fmi3EvaluateDiscreteStates (providesEvaluateDiscreteStates = false)");
}
fmi3Status fmi3UpdateDiscreteStates(fmi3Instance c, fmi3Boolean *discreteStatesNeedUpdate,
                                    fmi3Boolean *terminateSimulation, fmi3Boolean *nominalsOfContinuousStatesChanged,
                                    fmi3Boolean *valuesOfContinuousStatesChanged, fmi3Boolean *nextEventTimeDefined,
                                    fmi3Float64 *nextEventTime) {
    (void)discreteStatesNeedUpdate; (void)terminateSimulation; (void)nominalsOfContinuousStatesChanged;
    (void)valuesOfContinuousStatesChanged; (void)nextEventTimeDefined; (void)nextEventTime;
    return unsupported(c, "fmi3UpdateDiscreteStates (no Event Mode)");
}
fmi3Status fmi3EnterContinuousTimeMode(fmi3Instance c) { return unsupported(c, "Model Exchange"); }
fmi3Status fmi3CompletedIntegratorStep(fmi3Instance c, fmi3Boolean noSetFMUStatePriorToCurrentPoint,
                                       fmi3Boolean *enterEventMode, fmi3Boolean *terminateSimulation) {
    (void)noSetFMUStatePriorToCurrentPoint; (void)enterEventMode; (void)terminateSimulation;
    return unsupported(c, "Model Exchange");
}
fmi3Status fmi3SetTime(fmi3Instance c, fmi3Float64 time) { (void)time; return unsupported(c, "Model Exchange"); }
fmi3Status fmi3SetContinuousStates(fmi3Instance c, const fmi3Float64 continuousStates[], size_t n) {
    (void)continuousStates; (void)n;
    return unsupported(c, "Model Exchange");
}
fmi3Status fmi3GetContinuousStateDerivatives(fmi3Instance c, fmi3Float64 derivatives[], size_t n) {
    (void)derivatives; (void)n;
    return unsupported(c, "Model Exchange");
}
fmi3Status fmi3GetEventIndicators(fmi3Instance c, fmi3Float64 eventIndicators[], size_t n) {
    (void)eventIndicators; (void)n;
    return unsupported(c, "Model Exchange");
}
fmi3Status fmi3GetContinuousStates(fmi3Instance c, fmi3Float64 continuousStates[], size_t n) {
    (void)continuousStates; (void)n;
    return unsupported(c, "Model Exchange");
}
fmi3Status fmi3GetNominalsOfContinuousStates(fmi3Instance c, fmi3Float64 nominals[], size_t n) {
    (void)nominals; (void)n;
    return unsupported(c, "Model Exchange");
}
fmi3Status fmi3GetNumberOfEventIndicators(fmi3Instance c, size_t *n) { (void)n; return unsupported(c, "Model Exchange"); }
fmi3Status fmi3GetNumberOfContinuousStates(fmi3Instance c, size_t *n) {
    (void)n;
    return unsupported(c, "Model Exchange");
}
fmi3Status fmi3EnterStepMode(fmi3Instance c) {
    return unsupported(c, "fmi3EnterStepMode (no Event Mode: the FMU is in Step Mode after initialization)");
}
fmi3Status fmi3GetOutputDerivatives(fmi3Instance c, const fmi3ValueReference valueReferences[], size_t n,
                                    const fmi3Int32 orders[], fmi3Float64 values[], size_t nValues) {
    (void)valueReferences; (void)n; (void)orders; (void)values; (void)nValues;
    return unsupported(c, "fmi3GetOutputDerivatives (maxOutputDerivativeOrder = 0)");
}
fmi3Status fmi3ActivateModelPartition(fmi3Instance c, fmi3ValueReference clockReference,
                                      fmi3Float64 activationTime) {
    (void)clockReference; (void)activationTime;
    return unsupported(c, "Scheduled Execution");
}

/* ---------------------------------------------------------------- FMU states */
fmi3Status fmi3GetFMUState(fmi3Instance c, fmi3FMUState *FMUState) {
    ENTER(c)
    st = hg_state_get(H, (void **)FMUState, "fmi3GetFMUState");
    LEAVE()
}

fmi3Status fmi3SetFMUState(fmi3Instance c, fmi3FMUState FMUState) {
    ENTER(c)
    st = hg_state_set(H, FMUState, "fmi3SetFMUState");
    LEAVE()
}

fmi3Status fmi3FreeFMUState(fmi3Instance c, fmi3FMUState *FMUState) {
    ENTER(c)
    st = hg_state_free(H, (void **)FMUState, "fmi3FreeFMUState");
    LEAVE()
}

fmi3Status fmi3SerializedFMUStateSize(fmi3Instance c, fmi3FMUState FMUState, size_t *size) {
    ENTER(c)
    st = hg_state_size(H, FMUState, size, "fmi3SerializedFMUStateSize");
    LEAVE()
}

fmi3Status fmi3SerializeFMUState(fmi3Instance c, fmi3FMUState FMUState, fmi3Byte serializedState[], size_t size) {
    ENTER(c)
    st = hg_state_serialize(H, FMUState, serializedState, size, "fmi3SerializeFMUState",
                            "fmi3SerializedFMUStateSize");
    LEAVE()
}

fmi3Status fmi3DeserializeFMUState(fmi3Instance c, const fmi3Byte serializedState[], size_t size,
                                   fmi3FMUState *FMUState) {
    ENTER(c)
    st = hg_state_deserialize(H, serializedState, size, (void **)FMUState, "fmi3DeserializeFMUState");
    LEAVE()
}

/* ---------------------------------------------------------------- stepping */
fmi3Status fmi3DoStep(fmi3Instance c, fmi3Float64 currentCommunicationPoint, fmi3Float64 communicationStepSize,
                      fmi3Boolean noSetFMUStatePriorToCurrentPoint, fmi3Boolean *eventHandlingNeeded,
                      fmi3Boolean *terminateSimulation, fmi3Boolean *earlyReturn, fmi3Float64 *lastSuccessfulTime) {
    (void)noSetFMUStatePriorToCurrentPoint;
    ENTER(c)
    PyObject *args = PyTuple_New(2);
    if (args) {
        PyTuple_SetItem(args, 0, PyFloat_FromDouble(currentCommunicationPoint));
        PyTuple_SetItem(args, 1, PyFloat_FromDouble(communicationStepSize));
        st = hg_status(H, PyObject_Call(H->do_step, args, NULL), "fmi3DoStep");
        Py_DECREF(args);
    } else {
        st = hg_status(H, NULL, "fmi3DoStep");
    }
    if (eventHandlingNeeded) *eventHandlingNeeded = fmi3False;
    if (terminateSimulation) *terminateSimulation = fmi3False;
    if (earlyReturn) *earlyReturn = fmi3False;
    if (lastSuccessfulTime)
        *lastSuccessfulTime = st == HG_OK ? currentCommunicationPoint + communicationStepSize : currentCommunicationPoint;
    LEAVE()
}
