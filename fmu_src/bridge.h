/* hacgear FMU binary, shared part: the Python bridge of the FMI 2.0 (fmi2.c) and FMI 3.0 (fmi3.c) wrappers.
 *
 * Each FMI call takes the GIL, calls one method of the FMU instance (hacgear_core.fmu.slave.FmuInstance, created
 * by resources/hacgear_fmu_boot.py), passes the instance's queued messages to the master's logger (warnings and
 * errors always, debug messages when logging is on) and returns the status the method returned.  No Python
 * exception crosses this layer: one that escapes a method is logged and answered with Error.  Built against
 * Python's stable ABI (3.11+); the symbols come from the importer's Python (non-Python masters preload libpython).
 */
#ifndef HACGEAR_BRIDGE_H
#define HACGEAR_BRIDGE_H

#define PY_SSIZE_T_CLEAN
#define Py_LIMITED_API 0x030B0000
#include <Python.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

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

/* Python started by this binary when the master is not a Python program (then never finalized: numba and numpy
 * do not survive a re-initialization). */
static void hg_ensure_python(void) {
    if (!Py_IsInitialized()) {
        Py_InitializeEx(0);
        PyEval_SaveThread();
    }
}

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
    "def _hacgear_boot(name, location, token, logging_on, version):\n"
    "    import os, urllib.parse, urllib.request\n"
    "    if location.startswith('file:'):\n"
    "        path = urllib.request.url2pathname(urllib.parse.urlparse(location).path)\n"
    "    else:\n"
    "        path = location\n"
    "    boot = os.path.join(path, 'hacgear_fmu_boot.py')\n"
    "    ns = {'__name__': 'hacgear_fmu_boot', '__file__': boot, '__builtins__': __builtins__}\n"
    "    with open(boot, encoding='utf-8') as f:\n"
    "        exec(compile(f.read(), boot, 'exec'), ns)\n"
    "    return ns['instantiate'](name, location, token, bool(logging_on), version)\n";

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
    inst = PyObject_CallFunction(fn, "sssii", name ? name : "", location ? location : "", token ? token : "",
                                 logging_on, version);
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
