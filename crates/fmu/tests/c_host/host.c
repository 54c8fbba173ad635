/*
 * A second FMU importer for pneumo's tests (issue 26): a plain C program
 * that loads an unpacked FMI 2.0 Co-Simulation FMU with dlopen, as a C
 * simulation host or a PLC runtime would, and steps it.
 *
 * The few FMI 2.0 types and function signatures it needs are declared here
 * from the FMI 2.0.x standard, section 2.1 (common functions) and 4.2
 * (co-simulation), instead of shipping the standard's header files.
 *
 *     host LIBRARY RESOURCE_URI IDENTIFIER GUID T_END STEP VALUE_REFERENCE
 *
 * prints "t value" after every step (the value of VALUE_REFERENCE as
 * fmi2GetReal returns it) and exits 0; any status other than fmi2OK is
 * printed to stderr with the function's name and exits 1. The FMU's log
 * messages go to stderr.
 */
#include <dlfcn.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>

typedef void *fmi2Component;
typedef void *fmi2ComponentEnvironment;
typedef unsigned int fmi2ValueReference;
typedef double fmi2Real;
typedef int fmi2Boolean;
typedef const char *fmi2String;
typedef int fmi2Status; /* fmi2OK = 0, ..., fmi2Error = 3, fmi2Fatal = 4 */
typedef int fmi2Type;   /* fmi2ModelExchange = 0, fmi2CoSimulation = 1 */

typedef struct {
    void (*logger)(fmi2ComponentEnvironment, fmi2String, fmi2Status, fmi2String, fmi2String, ...);
    void *(*allocateMemory)(size_t, size_t);
    void (*freeMemory)(void *);
    void (*stepFinished)(fmi2ComponentEnvironment, fmi2Status);
    fmi2ComponentEnvironment componentEnvironment;
} fmi2CallbackFunctions;

typedef fmi2Component (*Instantiate)(fmi2String, fmi2Type, fmi2String, fmi2String, const fmi2CallbackFunctions *,
                                     fmi2Boolean, fmi2Boolean);
typedef fmi2Status (*SetupExperiment)(fmi2Component, fmi2Boolean, fmi2Real, fmi2Real, fmi2Boolean, fmi2Real);
typedef fmi2Status (*OneArgument)(fmi2Component);
typedef fmi2Status (*GetReal)(fmi2Component, const fmi2ValueReference *, size_t, fmi2Real *);
typedef fmi2Status (*DoStep)(fmi2Component, fmi2Real, fmi2Real, fmi2Boolean);
typedef void (*FreeInstance)(fmi2Component);

static void logger(fmi2ComponentEnvironment env, fmi2String name, fmi2Status status, fmi2String category,
                   fmi2String message, ...) {
    va_list args;
    (void)env;
    va_start(args, message);
    fprintf(stderr, "[%s] status %d (%s): ", name ? name : "?", status, category ? category : "");
    vfprintf(stderr, message, args);
    fputc('\n', stderr);
    va_end(args);
}

static void *symbol(void *library, const char *name) {
    void *f = dlsym(library, name);
    if (!f) {
        fprintf(stderr, "host: the FMU does not export %s\n", name);
        exit(1);
    }
    return f;
}

static void expect_ok(fmi2Status status, const char *what) {
    if (status != 0) {
        fprintf(stderr, "host: %s returned status %d\n", what, status);
        exit(1);
    }
}

int main(int argc, char **argv) {
    if (argc != 8) {
        fprintf(stderr, "usage: host LIBRARY RESOURCE_URI IDENTIFIER GUID T_END STEP VALUE_REFERENCE\n");
        return 2;
    }
    void *library = dlopen(argv[1], RTLD_NOW | RTLD_LOCAL);
    if (!library) {
        fprintf(stderr, "host: dlopen: %s\n", dlerror());
        return 1;
    }
    double t_end = atof(argv[5]), h = atof(argv[6]);
    fmi2ValueReference vr = (fmi2ValueReference)strtoul(argv[7], NULL, 10);
    fmi2CallbackFunctions callbacks = {logger, calloc, free, NULL, NULL};

    Instantiate instantiate = (Instantiate)symbol(library, "fmi2Instantiate");
    fmi2Component c = instantiate(argv[3], 1, argv[4], argv[2], &callbacks, 0, 0);
    if (!c) {
        fprintf(stderr, "host: fmi2Instantiate returned NULL\n");
        return 1;
    }
    expect_ok(((SetupExperiment)symbol(library, "fmi2SetupExperiment"))(c, 0, 0.0, 0.0, 1, t_end),
              "fmi2SetupExperiment");
    expect_ok(((OneArgument)symbol(library, "fmi2EnterInitializationMode"))(c), "fmi2EnterInitializationMode");
    expect_ok(((OneArgument)symbol(library, "fmi2ExitInitializationMode"))(c), "fmi2ExitInitializationMode");

    GetReal get_real = (GetReal)symbol(library, "fmi2GetReal");
    DoStep do_step = (DoStep)symbol(library, "fmi2DoStep");
    long steps = (long)(t_end / h + 0.5);
    for (long k = 0; k < steps; k++) {
        double t = (double)k * h;
        expect_ok(do_step(c, t, h, 1), "fmi2DoStep");
        fmi2Real value;
        expect_ok(get_real(c, &vr, 1, &value), "fmi2GetReal");
        printf("%.9f %.12g\n", (double)(k + 1) * h, value);
    }
    expect_ok(((OneArgument)symbol(library, "fmi2Terminate"))(c), "fmi2Terminate");
    ((FreeInstance)symbol(library, "fmi2FreeInstance"))(c);
    dlclose(library);
    return 0;
}
