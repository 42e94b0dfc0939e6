/* A minimal FMI 2.0 co-simulation master in C (no Python in the process), for tests/test_fmu.py: it dlopens an FMU
 * binary, instantiates it with debug logging on, runs STEPS fmi2DoStep of STEP_S seconds and frees it.
 *
 * usage: _fmi2_master BINARY RESOURCE_URI GUID VR STEPS STEP_S
 * prints every log message as "LOG <status> <category>: <message>" and, at the end, "VALUE <getReal of VR>";
 * exit status 0 when every call returned fmi2OK, else 1 (with the failing call on stderr). */
#include <dlfcn.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmi2Functions.h"

static void logger(fmi2ComponentEnvironment env, fmi2String instance, fmi2Status status, fmi2String category,
                   fmi2String message, ...) {
    (void)env; (void)instance;
    va_list ap;
    va_start(ap, message);
    printf("LOG %d %s: ", (int)status, category ? category : "");
    vprintf(message ? message : "", ap);
    printf("\n");
    va_end(ap);
    fflush(stdout);
}

#define LOAD(name)                                                                   \
    name##TYPE *name = (name##TYPE *)dlsym(lib, #name);                              \
    if (!name) { fprintf(stderr, "missing symbol %s\n", #name); return 1; }
#define CHECK(call)                                                                  \
    if ((call) != fmi2OK) { fprintf(stderr, "%s failed\n", #call); return 1; }

int main(int argc, char **argv) {
    if (argc != 7) {
        fprintf(stderr, "usage: %s BINARY RESOURCE_URI GUID VR STEPS STEP_S\n", argv[0]);
        return 2;
    }
    void *lib = dlopen(argv[1], RTLD_NOW | RTLD_LOCAL);
    if (!lib) { fprintf(stderr, "dlopen failed: %s\n", dlerror()); return 1; }
    LOAD(fmi2Instantiate) LOAD(fmi2SetupExperiment) LOAD(fmi2EnterInitializationMode)
    LOAD(fmi2ExitInitializationMode) LOAD(fmi2DoStep) LOAD(fmi2GetReal) LOAD(fmi2Terminate) LOAD(fmi2FreeInstance)
    fmi2CallbackFunctions cb = {logger, calloc, free, NULL, NULL};
    fmi2Component c = fmi2Instantiate("master", fmi2CoSimulation, argv[3], argv[2], &cb, fmi2False, fmi2True);
    if (!c) { fprintf(stderr, "fmi2Instantiate returned NULL\n"); return 1; }
    fmi2ValueReference vr = (fmi2ValueReference)strtoul(argv[4], NULL, 10);
    int steps = atoi(argv[5]);
    double h = atof(argv[6]), t = 0.0, value = 0.0;
    CHECK(fmi2SetupExperiment(c, fmi2False, 0.0, 0.0, fmi2False, 0.0))
    CHECK(fmi2EnterInitializationMode(c))
    CHECK(fmi2ExitInitializationMode(c))
    for (int i = 0; i < steps; i++, t += h) CHECK(fmi2DoStep(c, t, h, fmi2True))
    CHECK(fmi2GetReal(c, &vr, 1, &value))
    CHECK(fmi2Terminate(c))
    fmi2FreeInstance(c);
    printf("VALUE %.17g\n", value);
    return 0;
}
