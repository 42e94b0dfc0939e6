/* A minimal FMI 3.0 co-simulation master in C (no Python in the process), for tests/test_fmu_pythonfmu.py: it
 * dlopens an FMU binary, instantiates it with debug logging on, initializes it at START_S, runs STEPS fmi3DoStep of
 * STEP_S seconds and frees it.
 *
 * usage: _fmi3_master BINARY RESOURCE_PATH INSTANTIATION_TOKEN VR STEPS STEP_S START_S
 * prints every log message as "LOG <status> <category>: <message>" and, at the end, "VALUE <getFloat64 of VR>";
 * exit status 0 when every call returned fmi3OK, else 1 (with the failing call on stderr). */
#include <dlfcn.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmi3Functions.h"

static void logger(fmi3InstanceEnvironment env, fmi3Status status, fmi3String category, fmi3String message) {
    (void)env;
    printf("LOG %d %s: %s\n", (int)status, category ? category : "", message ? message : "");
    fflush(stdout);
}

#define LOAD(name)                                                                   \
    name##TYPE *name = (name##TYPE *)dlsym(lib, #name);                              \
    if (!name) { fprintf(stderr, "missing symbol %s\n", #name); return 1; }
#define CHECK(call)                                                                  \
    if ((call) != fmi3OK) { fprintf(stderr, "%s failed\n", #call); return 1; }

int main(int argc, char **argv) {
    if (argc != 8) {
        fprintf(stderr, "usage: %s BINARY RESOURCE_PATH INSTANTIATION_TOKEN VR STEPS STEP_S START_S\n", argv[0]);
        return 2;
    }
    void *lib = dlopen(argv[1], RTLD_NOW | RTLD_LOCAL);
    if (!lib) { fprintf(stderr, "dlopen failed: %s\n", dlerror()); return 1; }
    LOAD(fmi3InstantiateCoSimulation) LOAD(fmi3EnterInitializationMode) LOAD(fmi3ExitInitializationMode)
    LOAD(fmi3DoStep) LOAD(fmi3GetFloat64) LOAD(fmi3Terminate) LOAD(fmi3FreeInstance)
    fmi3Instance c = fmi3InstantiateCoSimulation("master", argv[3], argv[2], fmi3False, fmi3True, fmi3False,
                                                 fmi3False, NULL, 0, NULL, logger, NULL);
    if (!c) { fprintf(stderr, "fmi3InstantiateCoSimulation returned NULL\n"); return 1; }
    fmi3ValueReference vr = (fmi3ValueReference)strtoul(argv[4], NULL, 10);
    int steps = atoi(argv[5]);
    double h = atof(argv[6]), t = atof(argv[7]), value = 0.0, last = 0.0;
    fmi3Boolean event = fmi3False, terminate = fmi3False, early = fmi3False;
    CHECK(fmi3EnterInitializationMode(c, fmi3False, 0.0, t, fmi3False, 0.0))
    CHECK(fmi3ExitInitializationMode(c))
    for (int i = 0; i < steps; i++, t += h) CHECK(fmi3DoStep(c, t, h, fmi3True, &event, &terminate, &early, &last))
    CHECK(fmi3GetFloat64(c, &vr, 1, &value, 1))
    CHECK(fmi3Terminate(c))
    fmi3FreeInstance(c);
    printf("VALUE %.17g\n", value);
    return 0;
}
