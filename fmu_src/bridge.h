/* hacgear FMU binary, shared part: the Python bridge of the FMI 2.0 (fmi2.c) and FMI 3.0 (fmi3.c) wrappers.
 *
 * Each FMI call takes the GIL, calls one method of the FMU instance (hacgear_core.fmu.slave.FmuInstance, created
 * by resources/hacgear_fmu_boot.py), passes the instance's queued messages to the master's logger (warnings and
 * errors always, debug messages when logging is on) and returns the status the method returned.  No Python
 * exception crosses this layer: one that escapes a method is logged and answered with Error.
 *
 * Built against Python's stable ABI (3.11+) without linking libpython: the binary references no Python symbol, so
 * any master loads it.  The C API functions it calls are function pointers (hg_fn_*), resolved at the first
 * instantiation by hg_ensure_python(): from the process when a Python interpreter is already in it (a Python
 * master: fmpy, libcosimpy), else from the libpython this binary loads itself (dlopen RTLD_GLOBAL, so that the
 * extension modules numpy and numba load find the symbols too) and starts with the chosen interpreter as its
 * program name.  The chosen interpreter is the first that can run the FMU of: the one named by the environment
 * variable HACGEAR_FMU_PYTHON (where set, the only one), the one recorded at build (HG_PYTHON_EXECUTABLE from the
 * generated hg_config.h), a python3, then a python, on PATH (hg_discover).
 */
#ifndef HACGEAR_BRIDGE_H
#define HACGEAR_BRIDGE_H

#ifndef _GNU_SOURCE
#define _GNU_SOURCE 1 /* RTLD_DEFAULT */
#endif
#define PY_SSIZE_T_CLEAN
#define Py_LIMITED_API 0x030B0000
#include <Python.h>
#include <dlfcn.h>
#include <errno.h>
#include <fcntl.h>
#include <poll.h>
#include <pthread.h>
#include <signal.h>
#include <spawn.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

/* HG_PYTHON_EXECUTABLE, HG_PROBE, HG_PYTHON_MINIMUM, HG_REQUIREMENTS, HG_INSTALL (written by the FMU build) */
#include "hg_config.h"

/* ------------------------------------------------------------------ the Python C API, resolved at run time */
/* Every C API symbol the bridge uses (the ones Python.h's macros expand to included). */
#define HG_PY_FUNCTIONS(X)                                                                                        \
    X(PyBool_FromLong) X(PyBytes_AsString) X(PyBytes_FromStringAndSize) X(PyBytes_Size) X(PyDict_GetItemString) \
    X(PyDict_New) X(PyDict_SetItemString) X(PyErr_Clear) X(PyErr_Fetch) X(PyErr_Occurred) X(PyEval_EvalCode)    \
    X(PyEval_GetBuiltins) X(PyEval_SaveThread) X(PyFloat_AsDouble) X(PyFloat_FromDouble) X(PyGILState_Ensure)   \
    X(PyGILState_Release) X(PyList_GetItem) X(PyList_SetSlice) X(PyList_Size) X(PyLong_AsLong)                  \
    X(PyLong_AsLongLong) X(PyLong_FromLong) X(PyLong_FromLongLong) X(PyLong_FromUnsignedLong) X(PyObject_Call)  \
    X(PyObject_CallFunctionObjArgs) X(PyObject_GetAttrString) X(PyObject_IsTrue) X(PyObject_SetAttrString)      \
    X(PyObject_Str) X(PyTuple_GetItem) X(PyTuple_New) X(PyTuple_Pack) X(PyTuple_SetItem) X(PyTuple_Size)        \
    X(PyType_GetFlags) X(PyUnicode_AsUTF8AndSize) X(PyUnicode_FromString) X(Py_CompileString) X(Py_DecRef)      \
    X(Py_DecodeLocale) X(Py_IncRef) X(Py_InitializeEx) X(Py_IsInitialized) X(_PyObject_CallFunction_SizeT)      \
    X(_PyObject_CallMethod_SizeT) X(_Py_VaBuildValue_SizeT)

#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wdeprecated-declarations"
#define HG_DECLARE(name) static __typeof__(&name) hg_fn_##name;
HG_PY_FUNCTIONS(HG_DECLARE)
static __typeof__(&Py_SetProgramName) hg_fn_Py_SetProgramName; /* optional: deprecated since 3.11 */
#pragma GCC diagnostic pop
static PyObject *hg_py_none;                                   /* &_Py_NoneStruct */

#define PyBool_FromLong (*hg_fn_PyBool_FromLong)
#define PyBytes_AsString (*hg_fn_PyBytes_AsString)
#define PyBytes_FromStringAndSize (*hg_fn_PyBytes_FromStringAndSize)
#define PyBytes_Size (*hg_fn_PyBytes_Size)
#define PyDict_GetItemString (*hg_fn_PyDict_GetItemString)
#define PyDict_New (*hg_fn_PyDict_New)
#define PyDict_SetItemString (*hg_fn_PyDict_SetItemString)
#define PyErr_Clear (*hg_fn_PyErr_Clear)
#define PyErr_Fetch (*hg_fn_PyErr_Fetch)
#define PyErr_Occurred (*hg_fn_PyErr_Occurred)
#define PyEval_EvalCode (*hg_fn_PyEval_EvalCode)
#define PyEval_GetBuiltins (*hg_fn_PyEval_GetBuiltins)
#define PyEval_SaveThread (*hg_fn_PyEval_SaveThread)
#define PyFloat_AsDouble (*hg_fn_PyFloat_AsDouble)
#define PyFloat_FromDouble (*hg_fn_PyFloat_FromDouble)
#define PyGILState_Ensure (*hg_fn_PyGILState_Ensure)
#define PyGILState_Release (*hg_fn_PyGILState_Release)
#define PyList_GetItem (*hg_fn_PyList_GetItem)
#define PyList_SetSlice (*hg_fn_PyList_SetSlice)
#define PyList_Size (*hg_fn_PyList_Size)
#define PyLong_AsLong (*hg_fn_PyLong_AsLong)
#define PyLong_AsLongLong (*hg_fn_PyLong_AsLongLong)
#define PyLong_FromLong (*hg_fn_PyLong_FromLong)
#define PyLong_FromLongLong (*hg_fn_PyLong_FromLongLong)
#define PyLong_FromUnsignedLong (*hg_fn_PyLong_FromUnsignedLong)
#define PyObject_Call (*hg_fn_PyObject_Call)
#define PyObject_CallFunctionObjArgs (*hg_fn_PyObject_CallFunctionObjArgs)
#define PyObject_GetAttrString (*hg_fn_PyObject_GetAttrString)
#define PyObject_IsTrue (*hg_fn_PyObject_IsTrue)
#define PyObject_SetAttrString (*hg_fn_PyObject_SetAttrString)
#define PyObject_Str (*hg_fn_PyObject_Str)
#define PyTuple_GetItem (*hg_fn_PyTuple_GetItem)
#define PyTuple_New (*hg_fn_PyTuple_New)
#define PyTuple_Pack (*hg_fn_PyTuple_Pack)
#define PyTuple_SetItem (*hg_fn_PyTuple_SetItem)
#define PyTuple_Size (*hg_fn_PyTuple_Size)
#define PyUnicode_AsUTF8AndSize (*hg_fn_PyUnicode_AsUTF8AndSize)
#define PyUnicode_FromString (*hg_fn_PyUnicode_FromString)
#define Py_CompileString (*hg_fn_Py_CompileString)
#define Py_IsInitialized (*hg_fn_Py_IsInitialized)
#define _PyObject_CallFunction_SizeT (*hg_fn__PyObject_CallFunction_SizeT)
#define _PyObject_CallMethod_SizeT (*hg_fn__PyObject_CallMethod_SizeT)
#define _Py_VaBuildValue_SizeT (*hg_fn__Py_VaBuildValue_SizeT)
#define _Py_NoneStruct (*hg_py_none)
/* Python.h's inline reference counting and type checks reach private symbols (_Py_Dealloc) and PyType_GetFlags:
 * replaced by the resolved functions. */
#undef Py_INCREF
#undef Py_DECREF
#undef Py_XDECREF
#define Py_INCREF(o) hg_fn_Py_IncRef((PyObject *)(o))
#define Py_DECREF(o) hg_fn_Py_DecRef((PyObject *)(o))
#define Py_XDECREF(o) hg_fn_Py_DecRef((PyObject *)(o)) /* Py_DecRef accepts NULL */
#define PyType_HasFeature(t, f) ((hg_fn_PyType_GetFlags(t) & (f)) != 0)

static pthread_mutex_t hg_py_lock = PTHREAD_MUTEX_INITIALIZER;
static int hg_py_ready;
static int hg_py_chosen;         /* the interpreter was chosen and started by this binary (not the master's own) */
static char hg_py_origin[2400];  /* where the interpreter came from, for the log */
static char hg_py_error[12000];  /* why none could be had */

/* Resolve every C API function from ``lib`` (a dlopen handle or RTLD_DEFAULT); 0 and hg_py_error if one lacks. */
static int hg_resolve(void *lib, const char *where) {
#define HG_RESOLVE(name)                                                                                          \
    if (!(*(void **)&hg_fn_##name = dlsym(lib, #name))) {                                                          \
        snprintf(hg_py_error, sizeof hg_py_error, "%s lacks the Python C API function %s (not a Python 3.11+?)",  \
                 where, #name);                                                                                    \
        return 0;                                                                                                  \
    }
    HG_PY_FUNCTIONS(HG_RESOLVE)
#undef HG_RESOLVE
    *(void **)&hg_fn_Py_SetProgramName = dlsym(lib, "Py_SetProgramName");
    hg_py_none = (PyObject *)dlsym(lib, "_Py_NoneStruct");
    if (!hg_py_none) {
        snprintf(hg_py_error, sizeof hg_py_error, "%s lacks _Py_NoneStruct (not a Python 3.11+?)", where);
        return 0;
    }
    return 1;
}

/* ------------------------------------------------------------------ the interpreter to start */
/* In a master that is not a Python program the binary starts one interpreter, the first of the candidates that can
 * run this FMU: HACGEAR_FMU_PYTHON where set (an explicit choice: used alone, never passed over for another), else
 * the interpreter recorded at build (HG_PYTHON_EXECUTABLE) where it exists, else the python3, then the python, found
 * first on PATH.  Each candidate is asked by running HG_PROBE in it (written by the FMU build: its version,
 * sys.executable, shared libpython and the FMU's own loader's requirement check, bootstrap.probe), with the
 * environment the started interpreter will have.  When none can, one error names every candidate, why it cannot,
 * and the command that fixes it. */

/* A candidate interpreter and what its probe said. */
typedef struct {
    char tried[1024];   /* the path (or name) that was run */
    char exe[1024];     /* its sys.executable: the program name it is started with (a pyenv shim names the real one) */
    char lib[1024];     /* its shared libpython */
    char version[64];
    char why[4096];     /* why it cannot run this FMU, a predicate ("is not a Python interpreter ..."); "" if it can */
    char fix[1024];     /* the pip command that installs what it lacks, where that suffices */
} HgCandidate;

/* Append to a string of capacity n (truncated where full). */
static void hg_cat(char *buf, size_t n, const char *fmt, ...) {
    size_t len = strlen(buf);
    if (len + 1 >= n) return;
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(buf + len, n - len, fmt, ap);
    va_end(ap);
}

/* Whether the version "3.11.7" is at least major.minor "3.11". */
static int hg_version_at_least(const char *have, const char *need) {
    int a1 = 0, a2 = 0, b1 = 0, b2 = 0;
    if (sscanf(have, "%d.%d", &a1, &a2) < 1) return 0;
    if (sscanf(need, "%d.%d", &b1, &b2) < 1) return 1;
    return a1 > b1 || (a1 == b1 && a2 >= b2);
}

enum { HG_PROBE_TIMEOUT_S = 120 };

/* Run HG_PROBE in the interpreter ``exe`` (a path, or a name looked up on PATH) for the FMU whose resources are at
 * ``location``; fill c.  Returns 1 when the interpreter can run this FMU. */
static int hg_probe(const char *exe, const char *location, HgCandidate *c) {
    memset(c, 0, sizeof *c);
    snprintf(c->tried, sizeof c->tried, "%s", exe);
    int fd[2];
    if (pipe2(fd, O_CLOEXEC) != 0) {
        snprintf(c->why, sizeof c->why, "could not be asked (pipe: %s)", strerror(errno));
        return 0;
    }
    posix_spawn_file_actions_t fa;
    posix_spawn_file_actions_init(&fa);
    posix_spawn_file_actions_addopen(&fa, 0, "/dev/null", O_RDONLY, 0);
    posix_spawn_file_actions_adddup2(&fa, fd[1], 1); /* the duplicates are not close-on-exec */
    posix_spawn_file_actions_adddup2(&fa, fd[1], 2);
    char *argv[] = {(char *)exe, "-c", (char *)HG_PROBE, (char *)location, NULL};
    extern char **environ;
    pid_t pid;
    int rc = posix_spawnp(&pid, exe, &fa, NULL, argv, environ);
    posix_spawn_file_actions_destroy(&fa);
    close(fd[1]);
    if (rc != 0) {
        close(fd[0]);
        snprintf(c->why, sizeof c->why, "is not a Python interpreter (cannot run it: %s)", strerror(rc));
        return 0;
    }
    static char out[16384];
    size_t len = 0;
    int timed_out = 0;
    time_t deadline = time(NULL) + HG_PROBE_TIMEOUT_S;
    for (;;) {
        long left = (long)(deadline - time(NULL));
        if (left <= 0) {
            kill(pid, SIGKILL);
            timed_out = 1;
            break;
        }
        struct pollfd p = {fd[0], POLLIN, 0};
        int r = poll(&p, 1, (int)(left * 1000));
        if (r < 0 && errno != EINTR) break;
        if (r <= 0) continue;
        char buf[4096];
        ssize_t k = read(fd[0], buf, sizeof buf);
        if (k < 0 && errno == EINTR) continue;
        if (k <= 0) break;
        size_t take = (size_t)k < sizeof out - 1 - len ? (size_t)k : sizeof out - 1 - len;
        memcpy(out + len, buf, take);
        len += take;
    }
    close(fd[0]);
    out[len] = '\0';
    int wst = 0, exit_ok = 1; /* unknown (SIGCHLD ignored by the master): judged by the output */
    pid_t w;
    while ((w = waitpid(pid, &wst, 0)) < 0 && errno == EINTR) {
    }
    if (w == pid) exit_ok = WIFEXITED(wst) && WEXITSTATUS(wst) == 0;
    char need[2048] = "", other[512] = "";
    for (char *line = out, *next; line && *line; line = next) {
        next = strchr(line, '\n');
        if (next) *next++ = '\0';
        size_t n = strlen(line);
        if (n && line[n - 1] == '\r') line[--n] = '\0';
        if (!strncmp(line, "HG-VER ", 7)) snprintf(c->version, sizeof c->version, "%s", line + 7);
        else if (!strncmp(line, "HG-EXE ", 7)) snprintf(c->exe, sizeof c->exe, "%s", line + 7);
        else if (!strncmp(line, "HG-LIB ", 7)) snprintf(c->lib, sizeof c->lib, "%s", line + 7);
        else if (!strncmp(line, "HG-FIX ", 7)) snprintf(c->fix, sizeof c->fix, "%s", line + 7);
        else if (!strncmp(line, "HG-NEED ", 8)) hg_cat(need, sizeof need, "%s%s", need[0] ? "; " : "", line + 8);
        else if (n) snprintf(other, sizeof other, "%s", line); /* the last line of anything else (a traceback's) */
    }
    if (!c->exe[0]) snprintf(c->exe, sizeof c->exe, "%s", exe);
    if (timed_out)
        snprintf(c->why, sizeof c->why, "did not answer within %d s (stopped)", (int)HG_PROBE_TIMEOUT_S);
    else if (!c->version[0])
        snprintf(c->why, sizeof c->why, "is not a Python interpreter (running it failed%s%s)", other[0] ? ": " : "",
                 other);
    else if (!hg_version_at_least(c->version, HG_PYTHON_MINIMUM))
        snprintf(c->why, sizeof c->why, "is Python %s, older than %s", c->version, HG_PYTHON_MINIMUM);
    else if (!c->lib[0])
        snprintf(c->why, sizeof c->why, "is Python %s without a shared libpython (a static build), which a master "
                 "that is not a Python program cannot load", c->version);
    else if (need[0])
        snprintf(c->why, sizeof c->why, "is Python %s, which lacks what the FMU needs: %s", c->version, need);
    else if (!exit_ok)
        snprintf(c->why, sizeof c->why, "is Python %s, but checking the FMU's requirements in it failed%s%s",
                 c->version, other[0] ? ": " : "", other);
    return c->why[0] == '\0';
}

/* The first executable file ``name`` in a directory of PATH (into out); 0 when there is none. */
static int hg_which(const char *name, char *out, size_t n) {
    const char *p = getenv("PATH");
    if (!p || !*p) return 0;
    for (;;) {
        const char *end = strchr(p, ':');
        size_t len = end ? (size_t)(end - p) : strlen(p);
        if (len) snprintf(out, n, "%.*s/%s", (int)len, p, name);
        else snprintf(out, n, "./%s", name);
        struct stat st;
        if (stat(out, &st) == 0 && S_ISREG(st.st_mode) && access(out, X_OK) == 0) return 1;
        if (!end) return 0;
        p = end + 1;
    }
}

/* Whether two paths name the same file. */
static int hg_same_file(const char *a, const char *b) {
    struct stat sa, sb;
    return stat(a, &sa) == 0 && stat(b, &sb) == 0 && sa.st_dev == sb.st_dev && sa.st_ino == sb.st_ino;
}

/* The interpreter to start for the FMU at ``location`` (into *use, *how saying where it came from); 0 and the
 * reason in hg_py_error when no candidate can run the FMU. */
static int hg_discover(const char *location, HgCandidate *use, const char **how) {
    static HgCandidate env_c, rec_c, path_c[2];
    static const char *names[2] = {"python3", "python"};
    const char *env = getenv("HACGEAR_FMU_PYTHON");
    int have_env = env && *env, rec_ok = 0, path_ok[2] = {0, 0}, path_found[2] = {0, 0};
    if (have_env && hg_probe(env, location, &env_c)) {
        *use = env_c;
        *how = "from HACGEAR_FMU_PYTHON";
        return 1;
    }
    /* without HACGEAR_FMU_PYTHON: the first that can run the FMU; with a failing one: every other one is asked too,
     * for the message only */
    memset(&rec_c, 0, sizeof rec_c);
    snprintf(rec_c.tried, sizeof rec_c.tried, "%s", HG_PYTHON_EXECUTABLE);
    if (access(HG_PYTHON_EXECUTABLE, X_OK) != 0)
        snprintf(rec_c.why, sizeof rec_c.why, "does not exist here (%s): the FMU was built on another machine, or in a "
                 "virtual environment since removed", strerror(errno));
    else
        rec_ok = hg_probe(HG_PYTHON_EXECUTABLE, location, &rec_c);
    if (rec_ok && !have_env) {
        *use = rec_c;
        *how = "configured when the FMU was built";
        return 1;
    }
    for (int i = 0; i < 2; i++) {
        char found[1024];
        memset(&path_c[i], 0, sizeof path_c[i]);
        if (!hg_which(names[i], found, sizeof found)) continue;
        path_found[i] = 1;
        if (i == 1 && path_found[0] && hg_same_file(found, path_c[0].tried)) {
            snprintf(path_c[i].tried, sizeof path_c[i].tried, "%s", found);
            snprintf(path_c[i].why, sizeof path_c[i].why, "is the same file as the python3");
            path_ok[i] = path_ok[0];
            continue;
        }
        path_ok[i] = hg_probe(found, location, &path_c[i]);
        if (path_ok[i] && !have_env) {
            *use = path_c[i];
            *how = i == 0 ? "found as python3 on PATH" : "found as python on PATH";
            return 1;
        }
    }
    /* none: one message naming every candidate, why it cannot, and the fix */
    char *e = hg_py_error;
    size_t n = sizeof hg_py_error;
    e[0] = '\0';
    if (have_env)
        hg_cat(e, n, "HACGEAR_FMU_PYTHON='%s' %s. A set HACGEAR_FMU_PYTHON is used alone (an explicit choice wins); "
               "the other candidates would be: ", env, env_c.why);
    else
        hg_cat(e, n, "found no Python that can run this FMU. In a master that is not a Python program the FMU starts "
               "a Python %s+ with a shared libpython and %s, the first that has them of: (1) HACGEAR_FMU_PYTHON: not "
               "set; ", HG_PYTHON_MINIMUM, HG_REQUIREMENTS);
    hg_cat(e, n, "(2) the interpreter recorded when the FMU was built, %s: %s; (3) ", rec_c.tried,
           rec_ok ? "can run it" : rec_c.why);
    for (int i = 0; i < 2; i++) {
        if (i) hg_cat(e, n, "; ");
        if (!path_found[i]) hg_cat(e, n, "%s on PATH: none found", names[i]);
        else hg_cat(e, n, "%s on PATH, %s: %s", names[i], path_c[i].tried, path_ok[i] ? "can run it" : path_c[i].why);
    }
    hg_cat(e, n, ". To fix: ");
    if (have_env) {
        if (env_c.fix[0]) hg_cat(e, n, "install the packages into it: %s; or ", env_c.fix);
        hg_cat(e, n, "export HACGEAR_FMU_PYTHON=/path/to/python (a Python %s+ with a shared libpython and %s)",
               HG_PYTHON_MINIMUM, HG_REQUIREMENTS);
        const char *other = rec_ok ? rec_c.exe : path_ok[0] ? path_c[0].exe : path_ok[1] ? path_c[1].exe : NULL;
        if (other) hg_cat(e, n, "; or unset HACGEAR_FMU_PYTHON to use %s", other);
        return 0;
    }
    const char *fix = NULL, *into = NULL;
    for (int i = 0; i < 2 && !fix; i++)
        if (path_found[i] && path_c[i].fix[0]) fix = path_c[i].fix, into = names[i];
    if (!fix && rec_c.fix[0]) fix = rec_c.fix, into = "recorded interpreter";
    if (fix) hg_cat(e, n, "install the packages into the %s%s: %s", into, into[0] == 'p' ? " on PATH" : "", fix);
    else hg_cat(e, n, "install a Python %s+ with a shared libpython and the packages: %s", HG_PYTHON_MINIMUM,
                HG_INSTALL);
    hg_cat(e, n, "; or name a Python that has them: export HACGEAR_FMU_PYTHON=/path/to/python");
    return 0;
}

/* Make Python available: NULL, or why not (also in hg_py_error).  A Python interpreter already running in the
 * process (a Python master) is used as it is; otherwise the interpreter hg_discover() finds is started: its
 * libpython loaded (unless one is in the process already), and never finalized (numba and numpy do not survive a
 * re-initialization).  ``location``: the FMU's resources (URI or path), for the candidates' requirement check. */
static const char *hg_ensure_python(const char *location) {
    const char *result = NULL;
    pthread_mutex_lock(&hg_py_lock);
    if (hg_py_ready) goto done;
    char lib[1024];
    int in_process = 0;
    if (dlsym(RTLD_DEFAULT, "Py_IsInitialized")) {
        if (!hg_resolve(RTLD_DEFAULT, "the master's process")) { result = hg_py_error; goto done; }
        if (Py_IsInitialized()) {
            snprintf(hg_py_origin, sizeof hg_py_origin, "the master's own Python interpreter");
            hg_py_ready = 1;
            goto done;
        }
        in_process = 1;
    }
    static HgCandidate use;
    const char *how = "";
    if (!hg_discover(location ? location : "", &use, &how)) { result = hg_py_error; goto done; }
    if (in_process) {
        snprintf(lib, sizeof lib, "the libpython already in the master's process");
    } else {
        snprintf(lib, sizeof lib, "%s", use.lib);
        void *h = dlopen(lib, RTLD_NOW | RTLD_GLOBAL);
        if (!h) {
            const char *e = dlerror();
            snprintf(hg_py_error, sizeof hg_py_error,
                     "cannot load libpython %s of the Python %s (%s): %s; set HACGEAR_FMU_PYTHON to a python "
                     "executable (%s+, with a shared libpython and %s)", lib, use.exe, how, e ? e : "unknown error",
                     HG_PYTHON_MINIMUM, HG_REQUIREMENTS);
            result = hg_py_error;
            goto done;
        }
        if (!hg_resolve(h, lib)) { result = hg_py_error; goto done; }
    }
    if (!Py_IsInitialized()) {
        /* the program name is the interpreter's path: Python finds its prefix (standard library) and a venv's
         * site-packages from it */
        if (hg_fn_Py_SetProgramName) {
            wchar_t *w = hg_fn_Py_DecodeLocale(use.exe, NULL); /* kept: Python holds the pointer */
            if (w) hg_fn_Py_SetProgramName(w);
        }
        hg_fn_Py_InitializeEx(0);
        PyEval_SaveThread();
        hg_py_chosen = 1;
        snprintf(hg_py_origin, sizeof hg_py_origin, "started by the FMU binary: program %s, %s (%s)", use.exe, lib,
                 how);
    } else {
        snprintf(hg_py_origin, sizeof hg_py_origin, "the Python interpreter already running in the process");
    }
    hg_py_ready = 1;
done:
    pthread_mutex_unlock(&hg_py_lock);
    return result;
}

enum { HG_OK = 0, HG_WARNING = 1, HG_DISCARD = 2, HG_ERROR = 3, HG_FATAL = 4 };

typedef struct HgInstance HgInstance;
typedef void (*hg_emit_fn)(HgInstance *h, int status, const char *category, const char *message);

struct HgInstance {
    PyObject *inst;      /* the FmuInstance */
    PyObject *messages;  /* its message queue: list of (status, category, message) */
    PyObject *do_step;   /* bound methods of the per-step path */
    PyObject *get_real;
    PyObject *set_real;
    int logging_on;
    char *name;
    hg_emit_fn emit;     /* the master's logger, version-specific */
    const void *env;     /* version-specific logger data */
};

static char *hg_strdup(const char *s) {
    size_t n = s ? strlen(s) : 0;
    char *d = (char *)malloc(n + 1);
    if (d) {
        if (n) memcpy(d, s, n);
        d[n] = '\0';
    }
    return d;
}

/* "Type: message" of the pending Python exception (cleared); the caller frees the result. */
static char *hg_exception_text(void) {
    PyObject *type = NULL, *value = NULL, *tb = NULL;
    char *out = NULL;
    PyErr_Fetch(&type, &value, &tb);
    if (!type) return hg_strdup("unknown error");
    PyObject *tname = PyObject_GetAttrString(type, "__name__");
    PyObject *text = value ? PyObject_Str(value) : NULL;
    const char *a = tname ? PyUnicode_AsUTF8AndSize(tname, NULL) : NULL;
    const char *b = text ? PyUnicode_AsUTF8AndSize(text, NULL) : NULL;
    PyErr_Clear();
    size_t n = (a ? strlen(a) : 9) + (b ? strlen(b) : 0) + 3;
    out = (char *)malloc(n);
    if (out) snprintf(out, n, "%s: %s", a ? a : "Exception", b ? b : "");
    Py_XDECREF(tname);
    Py_XDECREF(text);
    Py_XDECREF(type);
    Py_XDECREF(value);
    Py_XDECREF(tb);
    return out;
}

/* Pass the queued messages to the master's logger. */
static void hg_drain(HgInstance *h) {
    if (!h->messages) return;
    Py_ssize_t n = PyList_Size(h->messages);
    if (n <= 0) {
        if (n < 0) PyErr_Clear();
        return;
    }
    for (Py_ssize_t i = 0; i < n; i++) {
        PyObject *item = PyList_GetItem(h->messages, i); /* borrowed */
        if (!item || !PyTuple_Check(item) || PyTuple_Size(item) != 3) { PyErr_Clear(); continue; }
        long status = PyLong_AsLong(PyTuple_GetItem(item, 0));
        const char *cat = PyUnicode_AsUTF8AndSize(PyTuple_GetItem(item, 1), NULL);
        const char *msg = PyUnicode_AsUTF8AndSize(PyTuple_GetItem(item, 2), NULL);
        if (PyErr_Occurred()) { PyErr_Clear(); continue; }
        if (status != HG_OK || h->logging_on) h->emit(h, (int)status, cat ? cat : "", msg ? msg : "");
    }
    PyList_SetSlice(h->messages, 0, n, NULL);
    PyErr_Clear();
}

/* An Error the binary finds (null pointers, unknown FMU states...): logged and the instance put in its error state
 * by FmuInstance._error, like the errors the instance finds itself. */
static int hg_fail(HgInstance *h, const char *msg) {
    PyObject *r = h->inst ? PyObject_CallMethod(h->inst, "_error", "s", msg) : NULL;
    if (!r) {
        PyErr_Clear();
        h->emit(h, HG_ERROR, "logStatusError", msg);
    } else {
        Py_DECREF(r);
    }
    hg_drain(h);
    return HG_ERROR;
}

/* Status of a method's result (a new reference, consumed); an escaped exception is logged as Error. */
static int hg_status(HgInstance *h, PyObject *res, const char *call) {
    int st = HG_ERROR;
    if (!res) {
        char *t = hg_exception_text();
        char buf[512];
        snprintf(buf, sizeof buf, "%s: internal error: ", call);
        size_t n = strlen(buf) + (t ? strlen(t) : 0) + 1;
        char *m = (char *)malloc(n);
        if (m) {
            snprintf(m, n, "%s%s", buf, t ? t : "");
            h->emit(h, HG_ERROR, "logStatusError", m);
            free(m);
        }
        free(t);
    } else {
        long v = PyLong_AsLong(res);
        if (v == -1 && PyErr_Occurred()) {
            PyErr_Clear();
            h->emit(h, HG_ERROR, "logStatusError", "internal error: a status that is not an integer");
        } else {
            st = (int)v;
        }
        Py_DECREF(res);
    }
    hg_drain(h);
    return st;
}

/* Create the FmuInstance: run resources/hacgear_fmu_boot.py's instantiate(); NULL and *error (malloc'ed) on
 * failure. */
static const char hg_boot_source[] =
    "def _hacgear_boot(name, location, token, logging_on, version, origin, chosen):\n"
    "    import sys\n"
    "    import os, urllib.parse, urllib.request\n"
    "    if location.startswith('file:'):\n"
    "        path = urllib.request.url2pathname(urllib.parse.urlparse(location).path)\n"
    "    else:\n"
    "        path = location\n"
    "    boot = os.path.join(path, 'hacgear_fmu_boot.py')\n"
    "    ns = {'__name__': 'hacgear_fmu_boot', '__file__': boot, '__builtins__': __builtins__}\n"
    "    with open(boot, encoding='utf-8') as f:\n"
    "        exec(compile(f.read(), boot, 'exec'), ns)\n"
    "    inst = ns['instantiate'](name, location, token, bool(logging_on), version, chosen_by_binary=bool(chosen))\n"
    "    inst.log(0, f'hacgear FMU: Python {sys.version.split()[0]} at {sys.executable} ({origin})')\n"
    "    return inst\n";

static PyObject *hg_create(const char *name, const char *location, const char *token, int logging_on,
                           int version, char **error) {
    PyObject *globals = NULL, *code = NULL, *res = NULL, *fn = NULL, *inst = NULL;
    *error = NULL;
    globals = PyDict_New();
    if (!globals) goto fail;
    if (PyDict_SetItemString(globals, "__builtins__", PyEval_GetBuiltins()) < 0) goto fail;
    code = Py_CompileString(hg_boot_source, "<hacgear FMU binary>", Py_file_input);
    if (!code) goto fail;
    res = PyEval_EvalCode(code, globals, globals);
    if (!res) goto fail;
    fn = PyDict_GetItemString(globals, "_hacgear_boot"); /* borrowed */
    if (!fn) goto fail;
    inst = PyObject_CallFunction(fn, "sssiisi", name ? name : "", location ? location : "", token ? token : "",
                                 logging_on, version, hg_py_origin, hg_py_chosen);
    if (!inst) goto fail;
    Py_XDECREF(res);
    Py_XDECREF(code);
    Py_XDECREF(globals);
    return inst;
fail:
    *error = hg_exception_text();
    Py_XDECREF(res);
    Py_XDECREF(code);
    Py_XDECREF(globals);
    return NULL;
}

static int hg_attach(HgInstance *h, PyObject *inst) {
    h->inst = inst;
    h->messages = PyObject_GetAttrString(inst, "messages");
    h->do_step = PyObject_GetAttrString(inst, "do_step");
    h->get_real = PyObject_GetAttrString(inst, "get_real");
    h->set_real = PyObject_GetAttrString(inst, "set_real");
    if (!h->messages || !h->do_step || !h->get_real || !h->set_real) {
        PyErr_Clear();
        return 0;
    }
    return 1;
}

static void hg_detach(HgInstance *h) {
    hg_drain(h);
    Py_XDECREF(h->messages);
    Py_XDECREF(h->do_step);
    Py_XDECREF(h->get_real);
    Py_XDECREF(h->set_real);
    Py_XDECREF(h->inst);
    h->inst = h->messages = h->do_step = h->get_real = h->set_real = NULL;
}

/* Start Python (or join the interpreter running in the process) and create the instance attached to h.  Returns
   the instance with the GIL held; NULL with *error set (malloc'd, NULL for "unknown") otherwise, *gil_held saying
   whether the GIL was taken (release it with *gil). */
static PyObject *hg_instantiate(HgInstance *h, const char *name, const char *location, const char *token,
                                int logging_on, int fmi_version, char **error, PyGILState_STATE *gil,
                                int *gil_held) {
    *error = NULL;
    *gil_held = 0;
    const char *no_python = hg_ensure_python(location);
    if (no_python) {
        *error = hg_strdup(no_python);
        return NULL;
    }
    *gil = PyGILState_Ensure();
    *gil_held = 1;
    PyObject *inst = hg_create(name, location, token, logging_on, fmi_version, error);
    if (inst && !hg_attach(h, inst)) {
        hg_detach(h);
        *error = hg_strdup("internal error: the FMU instance lacks its methods");
        return NULL;
    }
    return inst;
}

/* A tuple of value references. */
static PyObject *hg_vrs(const unsigned int *vr, size_t n) {
    PyObject *t = PyTuple_New((Py_ssize_t)n);
    if (!t) return NULL;
    for (size_t i = 0; i < n; i++) {
        PyObject *v = PyLong_FromUnsignedLong(vr[i]);
        if (!v) { Py_DECREF(t); return NULL; }
        PyTuple_SetItem(t, (Py_ssize_t)i, v);
    }
    return t;
}

/* Call inst.<method>(*args) and return its status. */
static int hg_call(HgInstance *h, const char *method, const char *call, const char *fmt, ...) {
    PyObject *m = PyObject_GetAttrString(h->inst, method);
    PyObject *res = NULL;
    if (m) {
        va_list ap;
        va_start(ap, fmt);
        PyObject *args = fmt ? Py_VaBuildValue(fmt, ap) : PyTuple_New(0);
        va_end(ap);
        if (args && !PyTuple_Check(args)) {
            PyObject *t = PyTuple_Pack(1, args);
            Py_DECREF(args);
            args = t;
        }
        if (args) {
            res = PyObject_Call(m, args, NULL);
            Py_DECREF(args);
        }
        Py_DECREF(m);
    }
    return hg_status(h, res, call);
}

/* Values of a getter into a C array via conv; status. */
typedef int (*hg_conv_fn)(PyObject *item, void *dst, size_t i);

static int hg_get(HgInstance *h, PyObject *method_or_null, const char *kind, const char *call,
                  const unsigned int *vr, size_t nvr, void *values, hg_conv_fn conv) {
    if (nvr == 0) return HG_OK;
    if (!vr || !values) return hg_fail(h, "null pointer for value references or values");
    PyObject *vrs = hg_vrs(vr, nvr);
    PyObject *res = NULL;
    if (vrs) {
        if (method_or_null) {
            res = PyObject_CallFunctionObjArgs(method_or_null, vrs, NULL);
        } else {
            res = PyObject_CallMethod(h->inst, "get_values", "sO", kind, vrs);
        }
        Py_DECREF(vrs);
    }
    if (!res) return hg_status(h, NULL, call);
    int st = HG_OK;
    if (res == Py_None) {
        st = HG_ERROR;
    } else if (!PyList_Check(res) || PyList_Size(res) != (Py_ssize_t)nvr) {
        h->emit(h, HG_ERROR, "logStatusError", "internal error: a getter returned a list of the wrong length");
        st = HG_ERROR;
    } else {
        for (size_t i = 0; i < nvr; i++) {
            if (!conv(PyList_GetItem(res, (Py_ssize_t)i), values, i)) {
                PyErr_Clear();
                st = HG_ERROR;
                h->emit(h, HG_ERROR, "logStatusError", "internal error: a value of the wrong type");
                break;
            }
        }
    }
    Py_DECREF(res);
    hg_drain(h);
    return st;
}

/* Setter: values already converted to a Python tuple (consumed). */
static int hg_set(HgInstance *h, PyObject *method_or_null, const char *kind, const char *call,
                  const unsigned int *vr, size_t nvr, PyObject *vals) {
    if (!vals) return hg_status(h, NULL, call);
    if (nvr == 0) { Py_DECREF(vals); return HG_OK; }
    if (!vr) {
        Py_DECREF(vals);
        return hg_fail(h, "null pointer for value references");
    }
    PyObject *vrs = hg_vrs(vr, nvr);
    PyObject *res = NULL;
    if (vrs) {
        if (method_or_null) {
            res = PyObject_CallFunctionObjArgs(method_or_null, vrs, vals, NULL);
        } else {
            res = PyObject_CallMethod(h->inst, "set_values", "sOO", kind, vrs, vals);
        }
        Py_DECREF(vrs);
    }
    Py_DECREF(vals);
    return hg_status(h, res, call);
}

static int hg_conv_double(PyObject *o, void *dst, size_t i) {
    double v = PyFloat_AsDouble(o);
    if (v == -1.0 && PyErr_Occurred()) return 0;
    ((double *)dst)[i] = v;
    return 1;
}

/* FMU states: Python snapshots held by the binary (new references); the instance records which pointers it
 * issued so that a foreign pointer is refused instead of dereferenced. */
static void *hg_get_state(HgInstance *h, const char *call) {
    PyObject *snap = PyObject_CallMethod(h->inst, "get_state", NULL);
    if (!snap) { hg_status(h, NULL, call); return NULL; }
    if (snap == Py_None) { Py_DECREF(snap); hg_drain(h); return NULL; }
    PyObject *r = PyObject_CallMethod(h->inst, "_issue_state", "On", snap, (Py_ssize_t)(void *)snap);
    if (!r) { Py_DECREF(snap); hg_status(h, NULL, call); return NULL; }
    Py_DECREF(r);
    hg_drain(h);
    return (void *)snap;
}

/* The snapshot behind a state pointer (borrowed) or NULL when this instance did not issue it. */
static PyObject *hg_known_state(HgInstance *h, void *state) {
    if (!state) return NULL;
    PyObject *r = PyObject_CallMethod(h->inst, "_known_state", "n", (Py_ssize_t)state);
    if (!r) { PyErr_Clear(); return NULL; }
    int known = PyObject_IsTrue(r);
    Py_DECREF(r);
    return known == 1 ? (PyObject *)state : NULL;
}

static void hg_release_state(HgInstance *h, void *state) {
    PyObject *snap = hg_known_state(h, state);
    if (!snap) return;
    PyObject *r = PyObject_CallMethod(h->inst, "_forget_state", "n", (Py_ssize_t)state);
    Py_XDECREF(r);
    PyErr_Clear();
    Py_DECREF(snap);
}

/* The FMU-state functions of both FMI versions, called with the GIL held; ``call`` names the FMI function in the
 * log.  Each returns an HG_ status. */
static int hg_state_get(HgInstance *h, void **state, const char *call) {
    char buf[200];
    if (!state) {
        snprintf(buf, sizeof buf, "%s: the state pointer is a null pointer", call);
        return hg_fail(h, buf);
    }
    if (*state) hg_release_state(h, *state); /* a previous state of this instance is reused: replace */
    *state = hg_get_state(h, call);
    return *state ? HG_OK : HG_ERROR;
}

static int hg_state_set(HgInstance *h, void *state, const char *call) {
    char buf[200];
    PyObject *snap = hg_known_state(h, state);
    if (!snap) {
        snprintf(buf, sizeof buf, "%s: not an FMU state of this instance (freed or foreign)", call);
        return hg_fail(h, buf);
    }
    return hg_call(h, "set_state", call, "(O)", snap);
}

static int hg_state_free(HgInstance *h, void **state, const char *call) {
    char buf[200];
    if (!state || !*state) return HG_OK;
    if (!hg_known_state(h, *state)) {
        snprintf(buf, sizeof buf, "%s: not an FMU state of this instance", call);
        return hg_fail(h, buf);
    }
    hg_release_state(h, *state);
    *state = NULL;
    return HG_OK;
}

/* The serialized bytes of a state (new reference) or NULL (logged). */
static PyObject *hg_state_bytes(HgInstance *h, void *state, const char *call) {
    PyObject *snap = hg_known_state(h, state);
    if (!snap) {
        char buf[200];
        snprintf(buf, sizeof buf, "%s: not an FMU state of this instance", call);
        hg_fail(h, buf);
        return NULL;
    }
    PyObject *b = PyObject_CallMethod(h->inst, "serialize_state", "(O)", snap);
    if (!b) { hg_status(h, NULL, call); return NULL; }
    if (!PyBytes_Check(b)) { Py_DECREF(b); hg_drain(h); return NULL; }
    hg_drain(h);
    return b;
}

static int hg_state_size(HgInstance *h, void *state, size_t *size, const char *call) {
    PyObject *b = hg_state_bytes(h, state, call);
    int st = HG_ERROR;
    if (b && size) {
        *size = (size_t)PyBytes_Size(b);
        st = HG_OK;
    }
    Py_XDECREF(b);
    return st;
}

static int hg_state_serialize(HgInstance *h, void *state, void *out, size_t size, const char *call,
                              const char *size_call) {
    PyObject *b = hg_state_bytes(h, state, call);
    int st = HG_ERROR;
    if (b) {
        size_t n = (size_t)PyBytes_Size(b);
        if (!out || size < n) {
            char buf[200];
            snprintf(buf, sizeof buf, "%s: buffer missing or smaller than %s", call, size_call);
            st = hg_fail(h, buf);
        } else {
            memcpy(out, PyBytes_AsString(b), n);
            st = HG_OK;
        }
    }
    Py_XDECREF(b);
    return st;
}

static int hg_state_deserialize(HgInstance *h, const void *in, size_t size, void **state, const char *call) {
    if (!state || (size && !in)) {
        char buf[200];
        snprintf(buf, sizeof buf, "%s: null pointer", call);
        return hg_fail(h, buf);
    }
    int st = HG_ERROR;
    PyObject *b = PyBytes_FromStringAndSize((const char *)in, (Py_ssize_t)size);
    PyObject *snap = b ? PyObject_CallMethod(h->inst, "deserialize_state", "(O)", b) : NULL;
    Py_XDECREF(b);
    if (!snap) {
        hg_status(h, NULL, call);
    } else if (snap == Py_None) {
        Py_DECREF(snap);
        hg_drain(h);
    } else {
        PyObject *r = PyObject_CallMethod(h->inst, "_issue_state", "On", snap, (Py_ssize_t)(void *)snap);
        if (r) {
            Py_DECREF(r);
            *state = (void *)snap;
            st = HG_OK;
        } else {
            Py_DECREF(snap);
            PyErr_Clear();
        }
        hg_drain(h);
    }
    return st;
}

#endif
