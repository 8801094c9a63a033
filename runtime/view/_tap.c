/* The live view's tick hook, in C: the optional twin of labsim.runtime.view.record's generated
 * after_act (fast_after_act) and of its PathThinner, which stay the specification and the
 * fallback where no C compiler built this module.
 *
 * A live run calls the recorder's hook after every robot acts, on every tick: at "as fast as it
 * goes" the wall lab runs a tick in about 7 us, and the hook, written out in Python, cost a
 * microsecond of it (the chart's values packed, the path's point, the checks for anything
 * unusual). Tap does the same in one C call, in the same order and with the same arithmetic:
 *
 *   - when anything is to be noted (a state entered, an event, a slider moved or a change by
 *     hand, a collision begun or ended, a breakpoint set, a value that is no number) it calls
 *     the general hook (TickRecorder.after_act) and does nothing itself;
 *   - else it keeps the rule and the readings, adds the position to the robot's Path and packs
 *     the chart's values as doubles onto the robot's Kept.data, thinning it (Kept.thin) past
 *     the limit.
 *
 * Path is PathThinner: a path as the points where it bends, its state in C doubles. The build
 * turns off contraction into fused multiply-adds (pyproject.toml), so that every comparison
 * rounds as Python's does; the direction's length is sqrt(dx*dx + dy*dy), in both.
 *
 * Built by setuptools when a C compiler is there (pyproject.toml, ext-modules, optional).
 * Python's C API only, no other library.
 */
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <structmember.h>
#include <math.h>
#include <stdint.h>
#include <string.h>

/* ------------------------------------------------------------------------------------ Path */

typedef struct {
    PyObject_HEAD
    double tol;
    Py_ssize_t most;        /* points kept at most between two takes: the oldest go */
    PyObject *points;       /* list of (x, y): kept since the last take */
    double ax, ay;          /* the last kept point (nan: none yet) */
    int on;                 /* whether a direction is set */
    double ux, uy, along;   /* the unit vector from the last kept point, the furthest along it */
    int seen;               /* whether a point was seen since the last kept one */
    double lx, ly;          /* that point */
} Path;

static PyTypeObject PathType;

static int path_keep(Path *p, double x, double y) {
    PyObject *point = Py_BuildValue("(dd)", x, y);
    if (point == NULL) return -1;
    int failed = PyList_Append(p->points, point);
    Py_DECREF(point);
    if (failed) return -1;
    Py_ssize_t n = PyList_GET_SIZE(p->points);
    if (n > p->most && PyList_SetSlice(p->points, 0, n - p->most, NULL) < 0) return -1;
    p->ax = x;
    p->ay = y;
    p->on = 0;
    p->along = 0.0;
    p->seen = 0;
    return 0;
}

static int path_add(Path *p, double x, double y);

/* PathThinner._add: anything but a point on the line set out on */
static int path_add_rest(Path *p, double x, double y) {
    if (!(isfinite(x) && isfinite(y))) return 0;
    if (p->ax != p->ax) return path_keep(p, x, y);  /* no point kept yet */
    double dx = x - p->ax, dy = y - p->ay;
    if (!p->on) {  /* still within the tolerance of the anchor: no direction yet */
        double dist = sqrt(dx * dx + dy * dy);
        if (dist >= p->tol) {
            p->on = 1;
            p->ux = dx / dist;
            p->uy = dy / dist;
            p->along = dist;
        }
        p->seen = 1;
        p->lx = x;
        p->ly = y;
        return 0;
    }
    double along = dx * p->ux + dy * p->uy;
    if (fabs(dx * p->uy - dy * p->ux) > p->tol || along < p->along - p->tol) {
        if (path_keep(p, p->lx, p->ly) < 0) return -1;  /* a direction is set by a point: the last seen */
        return path_add(p, x, y);  /* again, from the point just kept */
    }
    if (along > p->along) p->along = along;
    p->seen = 1;
    p->lx = x;
    p->ly = y;
    return 0;
}

/* PathThinner.add */
static int path_add(Path *p, double x, double y) {
    if (p->on) {  /* the common case, on every tick: still on the line (nan is not) */
        double dx = x - p->ax, dy = y - p->ay, tol = p->tol;
        double off = dx * p->uy - dy * p->ux;
        if (-tol <= off && off <= tol) {
            double along = dx * p->ux + dy * p->uy;
            if (along >= p->along - tol) {
                if (along > p->along) p->along = along;
                p->lx = x;
                p->ly = y;
                return 0;
            }
        }
    }
    return path_add_rest(p, x, y);
}

static int path_init(Path *p, PyObject *args, PyObject *kwds) {
    static char *names[] = {"tolerance_m", "most", NULL};
    double tol = 0.005;
    Py_ssize_t most = PY_SSIZE_T_MAX;
    if (!PyArg_ParseTupleAndKeywords(args, kwds, "|dn", names, &tol, &most)) return -1;
    PyObject *points = PyList_New(0);
    if (points == NULL) return -1;
    Py_XSETREF(p->points, points);
    p->tol = tol;
    p->most = most < 1 ? 1 : most;
    p->ax = p->ay = Py_NAN;
    p->on = p->seen = 0;
    p->ux = p->uy = p->along = p->lx = p->ly = 0.0;
    return 0;
}

static PyObject *path_new(PyTypeObject *type, PyObject *args, PyObject *kwds) {
    Path *p = (Path *)PyType_GenericNew(type, args, kwds);
    if (p == NULL) return NULL;
    if ((p->points = PyList_New(0)) == NULL) {  /* usable before __init__ too */
        Py_DECREF(p);
        return NULL;
    }
    p->tol = 0.005;
    p->most = PY_SSIZE_T_MAX;
    p->ax = p->ay = Py_NAN;
    return (PyObject *)p;
}

static int path_traverse(Path *p, visitproc visit, void *arg) {
    Py_VISIT(p->points);
    return 0;
}

static int path_clear(Path *p) {
    Py_CLEAR(p->points);
    return 0;
}

static void path_dealloc(Path *p) {
    PyObject_GC_UnTrack(p);
    path_clear(p);
    Py_TYPE(p)->tp_free((PyObject *)p);
}

static int two_doubles(PyObject *const *args, Py_ssize_t n, double *x, double *y) {
    if (n != 2) {
        PyErr_Format(PyExc_TypeError, "expected 2 arguments (x, y), got %zd", n);
        return -1;
    }
    *x = PyFloat_AsDouble(args[0]);
    if (*x == -1.0 && PyErr_Occurred()) return -1;
    *y = PyFloat_AsDouble(args[1]);
    if (*y == -1.0 && PyErr_Occurred()) return -1;
    return 0;
}

static PyObject *path_add_method(Path *p, PyObject *const *args, Py_ssize_t n) {
    double x, y;
    if (two_doubles(args, n, &x, &y) < 0 || path_add(p, x, y) < 0) return NULL;
    Py_RETURN_NONE;
}

static PyObject *path_jump(Path *p, PyObject *const *args, Py_ssize_t n) {
    double x, y;
    if (two_doubles(args, n, &x, &y) < 0) return NULL;
    p->ax = p->ay = Py_NAN;
    p->on = p->seen = 0;
    PyObject *gap = Py_BuildValue("(dd)", Py_NAN, Py_NAN);
    if (gap == NULL) return NULL;
    int failed = PyList_Append(p->points, gap);
    Py_DECREF(gap);
    if (failed || path_add(p, x, y) < 0) return NULL;
    Py_RETURN_NONE;
}

static PyObject *path_pending(Path *p, PyObject *unused) {
    if (!p->seen) Py_RETURN_NONE;
    return Py_BuildValue("(dd)", p->lx, p->ly);
}

static PyObject *path_take(Path *p, PyObject *unused) {
    PyObject *fresh = PyList_New(0);
    if (fresh == NULL) return NULL;
    PyObject *out = p->points;
    p->points = fresh;
    return out;
}

static PyMethodDef path_methods[] = {
    {"add", (PyCFunction)(void (*)(void))path_add_method, METH_FASTCALL, "add(x, y): the next point of the path."},
    {"jump", (PyCFunction)(void (*)(void))path_jump, METH_FASTCALL,
     "jump(x, y): the robot was put somewhere else: the path starts again there (no line across)."},
    {"pending", (PyCFunction)path_pending, METH_NOARGS,
     "The last point seen and not kept (a path drawn now ends there), if any."},
    {"take", (PyCFunction)path_take, METH_NOARGS, "The points kept since the last take."},
    {NULL, NULL, 0, NULL},
};

static PyObject *path_get_points(Path *p, void *unused) {
    Py_INCREF(p->points);
    return p->points;
}

static int path_set_points(Path *p, PyObject *value, void *unused) {
    if (value == NULL || !PyList_Check(value)) {
        PyErr_SetString(PyExc_TypeError, "points is a list");
        return -1;
    }
    Py_INCREF(value);
    Py_SETREF(p->points, value);
    return 0;
}

static PyGetSetDef path_getset[] = {
    {"points", (getter)path_get_points, (setter)path_set_points, "The points kept since the last take.", NULL},
    {NULL, NULL, NULL, NULL, NULL},
};

static PyMemberDef path_members[] = {
    {"tol", T_DOUBLE, offsetof(Path, tol), READONLY, "The tolerance, m."},
    {NULL, 0, 0, 0, NULL},
};

static PyTypeObject PathType = {
    PyVarObject_HEAD_INIT(NULL, 0)
    .tp_name = "labsim.runtime.view._tap.Path",
    .tp_basicsize = sizeof(Path),
    .tp_flags = Py_TPFLAGS_DEFAULT | Py_TPFLAGS_HAVE_GC,
    .tp_doc = "Path(tolerance_m=0.005, most=...): a path as the points where it bends (record.PathThinner).",
    .tp_new = path_new,
    .tp_init = (initproc)path_init,
    .tp_dealloc = (destructor)path_dealloc,
    .tp_traverse = (traverseproc)path_traverse,
    .tp_clear = (inquiry)path_clear,
    .tp_methods = path_methods,
    .tp_getset = path_getset,
    .tp_members = path_members,
};

/* ------------------------------------------------------------------------------------- Tap */

typedef struct {
    PyObject_HEAD
    vectorcallfunc vectorcall;
    PyObject *general;      /* TickRecorder.after_act, bound */
    PyObject *slow;         /* slow(kept, row): a row with a value that is no number, packed */
    PyObject *states, *touching, *last_rule, *last, *paths, *samples, *breaks;  /* the recorder's lists */
    PyObject *inputs;       /* the run's inputs (Inputs), or None */
    PyObject *slots, *events;  /* one robot's (None: several, read from each) */
    Py_ssize_t state, x, y, hit;  /* STATE's slot; x, y and collided in the readings (-1: none) */
    Py_ssize_t limit;       /* Kept.data's bytes past which it is thinned */
    Py_ssize_t nchan, nslot, width;
    Py_ssize_t *columns;    /* width of them: the channels read, then the slots */
    double *row;            /* width of them: the tick's values, before they are packed */
    /* per robot, the Kept last packed onto and its data (Kept.data is one bytearray for the Kept's
     * life): an attribute read a tick less */
    Py_ssize_t robots;
    PyObject **kept_at, **data_at;
} Tap;

static PyObject *s_index, *s_program, *s_slots, *s_events, *s_applied, *s_data, *s_thin;

static PyObject *tap_general(Tap *t, PyObject *const *args) {
    return PyObject_Vectorcall(t->general, args, 3, NULL);
}

/* a != b, both held while compared (a comparison may run Python code that changes the lists) */
static int differ(PyObject *a, PyObject *b) {
    if (PyFloat_CheckExact(a) && PyFloat_CheckExact(b)) return PyFloat_AS_DOUBLE(a) != PyFloat_AS_DOUBLE(b);
    Py_INCREF(a);
    Py_INCREF(b);
    int r = PyObject_RichCompareBool(a, b, Py_NE);
    Py_DECREF(a);
    Py_DECREF(b);
    return r;
}

/* 1: something to note (the general hook does the tick), 0: nothing, -1: an error */
static int tap_unusual(Tap *t, Py_ssize_t i, PyObject *s, PyObject *events, PyObject *values) {
    if (i < 0 || i >= PyList_GET_SIZE(t->states) || t->state >= PyList_GET_SIZE(s)) return 1;
    int r = differ(PyList_GET_ITEM(s, t->state), PyList_GET_ITEM(t->states, i));
    if (r != 0) return r;
    if ((r = PyObject_IsTrue(events)) != 0 || (r = PyObject_IsTrue(t->breaks)) != 0) return r;
    if (t->inputs != Py_None && (t->slots != Py_None || i == 0)) {
        PyObject *applied = PyObject_GetAttr(t->inputs, s_applied);
        if (applied == NULL) return -1;
        r = PyObject_IsTrue(applied);
        Py_DECREF(applied);
        if (r != 0) return r;
    }
    if (t->hit >= 0) {
        if (t->hit >= PyList_GET_SIZE(values) || i >= PyList_GET_SIZE(t->touching)) return 1;
        r = differ(PyList_GET_ITEM(values, t->hit), PyList_GET_ITEM(t->touching, i));
        if (r != 0) return r;
    }
    return 0;
}

/* the tick's chart values as doubles; 1 when one is no number (the Python way packs the row) */
static int tap_row(Tap *t, PyObject *values, PyObject *s, double *row) {
    for (Py_ssize_t k = 0; k < t->width; k++) {
        PyObject *list = k < t->nchan ? values : s;
        Py_ssize_t at = t->columns[k];
        if (at >= PyList_GET_SIZE(list)) return 1;
        PyObject *v = PyList_GET_ITEM(list, at);
        if (PyFloat_CheckExact(v)) {
            row[k] = PyFloat_AS_DOUBLE(v);
            continue;
        }
        row[k] = PyFloat_AsDouble(v);
        if (row[k] == -1.0 && PyErr_Occurred()) {
            PyErr_Clear();
            return 1;
        }
    }
    return 0;
}

static PyObject *tap_packed_slowly(Tap *t, PyObject *kept, PyObject *values, PyObject *s) {
    PyObject *row = PyTuple_New(t->width);
    if (row == NULL) return NULL;
    for (Py_ssize_t k = 0; k < t->width; k++) {
        PyObject *list = k < t->nchan ? values : s;
        PyObject *v = t->columns[k] < PyList_GET_SIZE(list) ? PyList_GET_ITEM(list, t->columns[k]) : Py_None;
        Py_INCREF(v);  /* a place beyond the list: None, a gap */
        PyTuple_SET_ITEM(row, k, v);
    }
    PyObject *out = PyObject_CallFunctionObjArgs(t->slow, kept, row, NULL);
    Py_DECREF(row);
    return out;
}

/* room for `need` bytes in a bytearray: doubled when it grows (bytearray's own growth is an
 * eighth, which copies a frame's worth of rows over and over) */
static int tap_room(PyObject *data, Py_ssize_t need) {
    PyByteArrayObject *b = (PyByteArrayObject *)data;
    Py_ssize_t room = b->ob_alloc - (b->ob_start - b->ob_bytes);  /* bytes from the start, its NUL included */
    if (need + 1 <= room && need >= Py_SIZE(b) && b->ob_exports == 0) {  /* PyByteArray_Resize's own quick way */
        Py_SET_SIZE(b, need);
        b->ob_start[need] = '\0';
        return 0;
    }
    if (need + 1 > room && PyByteArray_Resize(data, 2 * need - 1) < 0)
        return -1;  /* an upsize that large is made exact: 2 * need allocated */
    return PyByteArray_Resize(data, need);  /* within the allocation: its size only */
}

/* the chart's values packed onto Kept.data (thinned past the limit) */
static int tap_chart(Tap *t, Py_ssize_t i, PyObject *values, PyObject *s) {
    if (i >= PyList_GET_SIZE(t->samples) || i >= t->robots) return 0;
    PyObject *kept = PyList_GET_ITEM(t->samples, i);
    double *row = t->row;  /* filled and packed before any call into Python */
    if (kept != t->kept_at[i]) {  /* a frame took the last one: a new Kept */
        PyObject *data = PyObject_GetAttr(kept, s_data);
        if (data == NULL) return -1;
        Py_INCREF(kept);
        Py_XSETREF(t->kept_at[i], kept);
        Py_XSETREF(t->data_at[i], data);
    }
    /* both held while Python code may run (a value's __float__, thin()) */
    PyObject *data = t->data_at[i];
    Py_INCREF(kept);
    Py_INCREF(data);
    int failed = -1;
    if (!PyByteArray_CheckExact(data) || tap_row(t, values, s, row)) {
        PyObject *done = tap_packed_slowly(t, kept, values, s);
        if (done != NULL) {
            Py_DECREF(done);
            failed = 0;
        }
        goto out;
    }
    Py_ssize_t n = PyByteArray_GET_SIZE(data), bytes = t->width * (Py_ssize_t)sizeof(double);
    if (tap_room(data, n + bytes) < 0) goto out;
    memcpy(PyByteArray_AS_STRING(data) + n, row, bytes);
    if (n + bytes > t->limit) {
        PyObject *thinned = PyObject_CallMethodNoArgs(kept, s_thin);
        if (thinned == NULL) goto out;
        Py_DECREF(thinned);
    }
    failed = 0;
out:
    Py_DECREF(data);
    Py_DECREF(kept);
    return failed;
}

static int tap_path(Tap *t, Py_ssize_t i, PyObject *values) {
    if (i >= PyList_GET_SIZE(t->paths) || t->x >= PyList_GET_SIZE(values) || t->y >= PyList_GET_SIZE(values))
        return 0;
    PyObject *p = PyList_GET_ITEM(t->paths, i), *x = PyList_GET_ITEM(values, t->x),
             *y = PyList_GET_ITEM(values, t->y);
    if (Py_IS_TYPE(p, &PathType) && PyFloat_CheckExact(x) && PyFloat_CheckExact(y))
        return path_add((Path *)p, PyFloat_AS_DOUBLE(x), PyFloat_AS_DOUBLE(y));
    PyObject *out = PyObject_CallMethod(p, "add", "OO", x, y);  /* a PathThinner, or no float */
    if (out == NULL) return -1;
    Py_DECREF(out);
    return 0;
}

static PyObject *tap_call(Tap *t, PyObject *const *args, size_t nargsf, PyObject *kwnames) {
    if (PyVectorcall_NARGS(nargsf) != 3 || kwnames != NULL) {
        PyErr_SetString(PyExc_TypeError, "a tap is called with (robot, rule, values)");
        return NULL;
    }
    if (t->general == NULL) {
        PyErr_SetString(PyExc_TypeError, "a tap is made with Tap(...) before it is called");
        return NULL;
    }
    PyObject *r = args[0], *rule = args[1], *values = args[2];
    if (!PyList_CheckExact(values)) return tap_general(t, args);
    PyObject *s = t->slots, *events = t->events, *program = NULL, *out = NULL;
    Py_ssize_t i = 0;
    if (s == Py_None) {  /* several robots: this one's index, slots and events */
        PyObject *index = PyObject_GetAttr(r, s_index);
        if (index == NULL) return NULL;
        i = PyLong_AsSsize_t(index);
        Py_DECREF(index);
        if (i == -1 && PyErr_Occurred()) return NULL;
        if ((program = PyObject_GetAttr(r, s_program)) == NULL) return NULL;
        s = PyObject_GetAttr(program, s_slots);
        events = s == NULL ? NULL : PyObject_GetAttr(program, s_events);
        if (events == NULL) goto done;
    } else {
        Py_INCREF(s);
        Py_INCREF(events);
    }
    if (!PyList_Check(s)) {  /* the program's Slots, a list of its own name */
        out = tap_general(t, args);
        goto done;
    }
    int unusual = tap_unusual(t, i, s, events, values);
    if (unusual < 0) goto done;
    if (unusual || i >= PyList_GET_SIZE(t->last_rule) || i >= PyList_GET_SIZE(t->last)) {
        out = tap_general(t, args);
        goto done;
    }
    Py_INCREF(rule);
    PyList_SetItem(t->last_rule, i, rule);
    Py_INCREF(values);
    PyList_SetItem(t->last, i, values);
    if ((t->x >= 0 && tap_path(t, i, values) < 0) || (t->width && tap_chart(t, i, values, s) < 0)) goto done;
    out = Py_None;
    Py_INCREF(out);
done:
    Py_XDECREF(program);
    Py_XDECREF(s);
    Py_XDECREF(events);
    return out;
}

/* the per-robot Kept and data let go */
static void tap_forget(Tap *t) {
    for (Py_ssize_t k = 0; k < t->robots; k++) {
        Py_CLEAR(t->kept_at[k]);
        Py_CLEAR(t->data_at[k]);
    }
    PyMem_Free(t->kept_at);
    PyMem_Free(t->data_at);
    t->kept_at = t->data_at = NULL;
    t->robots = 0;
}

/* the column places of `seq` (ints >= 0) into a new array; its length in *n */
static Py_ssize_t *columns_of(PyObject *seq, Py_ssize_t *n) {
    PyObject *fast = PySequence_Fast(seq, "the columns are a sequence of int");
    if (fast == NULL) return NULL;
    *n = PySequence_Fast_GET_SIZE(fast);
    Py_ssize_t *out = PyMem_Malloc((*n ? *n : 1) * sizeof(Py_ssize_t));
    if (out == NULL) {
        Py_DECREF(fast);
        PyErr_NoMemory();
        return NULL;
    }
    for (Py_ssize_t k = 0; k < *n; k++) {
        out[k] = PyLong_AsSsize_t(PySequence_Fast_GET_ITEM(fast, k));
        if (out[k] < 0) {
            if (!PyErr_Occurred()) PyErr_SetString(PyExc_ValueError, "a column is an index >= 0");
            Py_DECREF(fast);
            PyMem_Free(out);
            return NULL;
        }
    }
    Py_DECREF(fast);
    return out;
}

static int tap_init(Tap *t, PyObject *args, PyObject *kwds) {
    static char *names[] = {"general", "slow", "states", "touching", "last_rule", "last", "paths", "samples",
                            "breaks", "inputs", "slots", "events", "state", "x", "y", "hit", "limit",
                            "channels", "columns", NULL};
    PyObject *general, *slow, *states, *touching, *last_rule, *last, *paths, *samples, *breaks, *inputs, *slots,
        *events, *channels, *kept_slots;
    Py_ssize_t state, x, y, hit, limit;
    if (!PyArg_ParseTupleAndKeywords(args, kwds, "OOO!O!O!O!O!O!O!OOOnnnnnOO", names, &general, &slow,
                                     &PyList_Type, &states, &PyList_Type, &touching, &PyList_Type, &last_rule,
                                     &PyList_Type, &last, &PyList_Type, &paths, &PyList_Type, &samples,
                                     &PyList_Type, &breaks, &inputs, &slots, &events, &state, &x, &y, &hit,
                                     &limit, &channels, &kept_slots))
        return -1;
    if (t->general != NULL) {  /* its lists and columns may be in use by a call under way */
        PyErr_SetString(PyExc_TypeError, "a tap is made once");
        return -1;
    }
    if (state < 0 || x < -1 || y < -1 || hit < -1 || (x < 0) != (y < 0)) {
        PyErr_SetString(PyExc_ValueError, "a tap's state slot is >= 0, and x, y and hit places >= 0 (-1: none)");
        return -1;
    }
    Py_ssize_t nchan, nslot;
    Py_ssize_t *chan = columns_of(channels, &nchan), *slot = chan == NULL ? NULL : columns_of(kept_slots, &nslot);
    Py_ssize_t *columns = slot == NULL ? NULL : PyMem_Malloc((nchan + nslot ? nchan + nslot : 1) * sizeof(Py_ssize_t));
    double *row = columns == NULL ? NULL : PyMem_Malloc((nchan + nslot ? nchan + nslot : 1) * sizeof(double));
    if (row == NULL) {
        if (slot != NULL && !PyErr_Occurred()) PyErr_NoMemory();
        PyMem_Free(chan);
        PyMem_Free(slot);
        PyMem_Free(columns);
        return -1;
    }
    memcpy(columns, chan, nchan * sizeof(Py_ssize_t));
    memcpy(columns + nchan, slot, nslot * sizeof(Py_ssize_t));
    PyMem_Free(chan);
    PyMem_Free(slot);
    PyMem_Free(t->columns);
    PyMem_Free(t->row);
    t->columns = columns;
    t->row = row;
    t->nchan = nchan;
    t->nslot = nslot;
    t->width = nchan + nslot;
    PyObject **fields[] = {&t->general, &t->slow, &t->states, &t->touching, &t->last_rule, &t->last, &t->paths,
                           &t->samples, &t->breaks, &t->inputs, &t->slots, &t->events};
    PyObject *given[] = {general, slow, states, touching, last_rule, last, paths, samples, breaks, inputs, slots,
                         events};
    for (size_t k = 0; k < sizeof given / sizeof given[0]; k++) {
        Py_INCREF(given[k]);
        Py_XSETREF(*fields[k], given[k]);
    }
    Py_ssize_t robots = PyList_GET_SIZE(samples);
    PyObject **kept_at = PyMem_Calloc(robots ? robots : 1, sizeof(PyObject *)),
             **data_at = PyMem_Calloc(robots ? robots : 1, sizeof(PyObject *));
    if (kept_at == NULL || data_at == NULL) {
        PyMem_Free(kept_at);
        PyMem_Free(data_at);
        PyErr_NoMemory();
        return -1;
    }
    tap_forget(t);
    t->robots = robots;
    t->kept_at = kept_at;
    t->data_at = data_at;
    t->state = state;
    t->x = x;
    t->y = y;
    t->hit = hit;
    t->limit = limit;
    t->vectorcall = (vectorcallfunc)tap_call;
    return 0;
}

static int tap_traverse(Tap *t, visitproc visit, void *arg) {
    Py_VISIT(t->general);
    Py_VISIT(t->slow);
    Py_VISIT(t->states);
    Py_VISIT(t->touching);
    Py_VISIT(t->last_rule);
    Py_VISIT(t->last);
    Py_VISIT(t->paths);
    Py_VISIT(t->samples);
    Py_VISIT(t->breaks);
    Py_VISIT(t->inputs);
    Py_VISIT(t->slots);
    Py_VISIT(t->events);
    for (Py_ssize_t k = 0; k < t->robots; k++) {
        Py_VISIT(t->kept_at[k]);
        Py_VISIT(t->data_at[k]);
    }
    return 0;
}

static int tap_clear(Tap *t) {
    Py_CLEAR(t->general);
    Py_CLEAR(t->slow);
    Py_CLEAR(t->states);
    Py_CLEAR(t->touching);
    Py_CLEAR(t->last_rule);
    Py_CLEAR(t->last);
    Py_CLEAR(t->paths);
    Py_CLEAR(t->samples);
    Py_CLEAR(t->breaks);
    Py_CLEAR(t->inputs);
    Py_CLEAR(t->slots);
    Py_CLEAR(t->events);
    tap_forget(t);
    return 0;
}

static void tap_dealloc(Tap *t) {
    PyObject_GC_UnTrack(t);
    tap_clear(t);
    PyMem_Free(t->columns);
    PyMem_Free(t->row);
    Py_TYPE(t)->tp_free((PyObject *)t);
}

static PyObject *tap_new(PyTypeObject *type, PyObject *args, PyObject *kwds) {
    Tap *t = (Tap *)PyType_GenericNew(type, args, kwds);
    if (t != NULL) {
        t->vectorcall = (vectorcallfunc)tap_call;
        t->x = t->y = t->hit = -1;
    }
    return (PyObject *)t;
}

static PyTypeObject TapType = {
    PyVarObject_HEAD_INIT(NULL, 0)
    .tp_name = "labsim.runtime.view._tap.Tap",
    .tp_basicsize = sizeof(Tap),
    .tp_flags = Py_TPFLAGS_DEFAULT | Py_TPFLAGS_HAVE_GC | Py_TPFLAGS_HAVE_VECTORCALL,
    .tp_doc = "Tap(general, slow, states, touching, last_rule, last, paths, samples, breaks, inputs, slots, "
              "events, state, x, y, hit, limit, channels, columns): the recorder's tick hook "
              "(record.fast_after_act), called as tap(robot, rule, values).",
    .tp_new = tap_new,
    .tp_init = (initproc)tap_init,
    .tp_dealloc = (destructor)tap_dealloc,
    .tp_traverse = (traverseproc)tap_traverse,
    .tp_clear = (inquiry)tap_clear,
    .tp_call = PyVectorcall_Call,
    .tp_vectorcall_offset = offsetof(Tap, vectorcall),
};

/* -------------------------------------------------------------------------------- envelope */

/* envelope(data, width, columns, starts, rows) -> (low, high, fell, rose): a frame's chart
 * envelope (labsim.runtime.view.peaks.pairs) straight from Kept.data, rows of `width` doubles
 * one after the other, without numpy's temporaries (a frame of 6,000 ticks made four copies of
 * them, each touching fresh memory). `columns` (bytes of Py_ssize_t) picks each chart column's
 * place in a row (-1: none, nan), `starts` (bytes of Py_ssize_t, rising, the first 0) begins
 * each group of consecutive rows. Per group and column, group after group: the least and the
 * greatest finite value, nan and inf passed over (doubles, in `low` and `high`; nan: none); and
 * whether a step between two finite values of consecutive rows of the group fell or rose (bytes
 * of 0 and 1; the step into the next group's first row not counted). */
static PyObject *envelope(PyObject *module, PyObject *const *args, Py_ssize_t nargs) {
    if (nargs != 5) {
        PyErr_SetString(PyExc_TypeError, "envelope(data, width, columns, starts, rows)");
        return NULL;
    }
    Py_buffer data, cols, starts;
    if (PyObject_GetBuffer(args[0], &data, PyBUF_SIMPLE) < 0) return NULL;
    if (PyObject_GetBuffer(args[2], &cols, PyBUF_SIMPLE) < 0) {
        PyBuffer_Release(&data);
        return NULL;
    }
    if (PyObject_GetBuffer(args[3], &starts, PyBUF_SIMPLE) < 0) {
        PyBuffer_Release(&data);
        PyBuffer_Release(&cols);
        return NULL;
    }
    PyObject *out = NULL, *low = NULL, *high = NULL, *fell = NULL, *rose = NULL;
    double *prev = NULL;
    Py_ssize_t width = PyLong_AsSsize_t(args[1]), rows = PyLong_AsSsize_t(args[4]);
    Py_ssize_t k = cols.len / (Py_ssize_t)sizeof(Py_ssize_t), groups = starts.len / (Py_ssize_t)sizeof(Py_ssize_t);
    const Py_ssize_t *col = cols.buf, *start = starts.buf;
    const double *m = data.buf;
    if (PyErr_Occurred()) goto done;
    if (((uintptr_t)data.buf % sizeof(double)) || ((uintptr_t)cols.buf % sizeof(Py_ssize_t))
        || ((uintptr_t)starts.buf % sizeof(Py_ssize_t))) {
        PyErr_SetString(PyExc_ValueError, "envelope: a buffer not aligned for its numbers");
        goto done;
    }
    if (width <= 0 || rows < 0 || rows > data.len / width / (Py_ssize_t)sizeof(double)
        || (groups && start[0] != 0)) {
        PyErr_SetString(PyExc_ValueError, "envelope: rows, width and data disagree");
        goto done;
    }
    for (Py_ssize_t j = 0; j < k; j++)
        if (col[j] >= width) {
            PyErr_SetString(PyExc_ValueError, "envelope: a column beyond the row");
            goto done;
        }
    for (Py_ssize_t g = 0; g < groups; g++)
        if (start[g] < 0 || start[g] >= rows || (g && start[g] <= start[g - 1])) {
            PyErr_SetString(PyExc_ValueError, "envelope: the groups' starts are not rising within the rows");
            goto done;
        }
    low = PyBytes_FromStringAndSize(NULL, groups * k * (Py_ssize_t)sizeof(double));
    high = PyBytes_FromStringAndSize(NULL, groups * k * (Py_ssize_t)sizeof(double));
    fell = PyBytes_FromStringAndSize(NULL, groups * k);
    rose = PyBytes_FromStringAndSize(NULL, groups * k);
    prev = PyMem_Malloc((k ? k : 1) * sizeof(double));
    if (low == NULL || high == NULL || fell == NULL || rose == NULL || prev == NULL) {
        if (prev == NULL) PyErr_NoMemory();
        goto done;
    }
    double *lo = (double *)PyBytes_AS_STRING(low), *hi = (double *)PyBytes_AS_STRING(high);
    char *down = PyBytes_AS_STRING(fell), *up = PyBytes_AS_STRING(rose);
    for (Py_ssize_t g = 0; g < groups; g++) {
        Py_ssize_t first = start[g], end = g + 1 < groups ? start[g + 1] : rows;
        double *l = lo + g * k, *h = hi + g * k;
        char *f = down + g * k, *r = up + g * k;
        for (Py_ssize_t j = 0; j < k; j++) {
            l[j] = h[j] = Py_NAN;
            f[j] = r[j] = 0;
        }
        for (Py_ssize_t t = first; t < end; t++) {
            const double *row = m + t * width;
            for (Py_ssize_t j = 0; j < k; j++) {
                if (col[j] < 0) continue;
                double v = row[col[j]];
                if (isfinite(v)) {  /* numpy's fmin and fmax: a nan is passed over, and so is an inf */
                    if (!(l[j] <= v)) l[j] = v;  /* a nan so far, or greater */
                    if (!(h[j] >= v)) h[j] = v;
                    if (t > first && isfinite(prev[j])) {  /* a step between two finite values */
                        double d = v - prev[j];
                        if (d < 0) f[j] = 1;
                        else if (d > 0) r[j] = 1;
                    }
                }
                prev[j] = v;
            }
        }
    }
    out = PyTuple_Pack(4, low, high, fell, rose);
done:
    PyMem_Free(prev);
    Py_XDECREF(low);
    Py_XDECREF(high);
    Py_XDECREF(fell);
    Py_XDECREF(rose);
    PyBuffer_Release(&data);
    PyBuffer_Release(&cols);
    PyBuffer_Release(&starts);
    return out;
}

static PyMethodDef functions[] = {
    {"envelope", (PyCFunction)(void (*)(void))envelope, METH_FASTCALL,
     "envelope(data, width, columns, starts, rows) -> (low, high, fell, rose): per group of rows and chart "
     "column, the least and greatest value (nan passed over) and whether a step fell or rose (peaks.pairs)."},
    {NULL, NULL, 0, NULL},
};

static struct PyModuleDef module = {
    PyModuleDef_HEAD_INIT, "_tap", "The live view's tick hook, path thinner and chart envelope, in C "
    "(labsim.runtime.view.record, labsim.runtime.view.peaks).",
    -1, functions, NULL, NULL, NULL, NULL,
};

PyMODINIT_FUNC PyInit__tap(void) {
    const char *text[] = {"index", "program", "slots", "events", "applied", "data", "thin"};
    PyObject **interned[] = {&s_index, &s_program, &s_slots, &s_events, &s_applied, &s_data, &s_thin};
    for (size_t k = 0; k < sizeof text / sizeof text[0]; k++)
        if (*interned[k] == NULL && (*interned[k] = PyUnicode_InternFromString(text[k])) == NULL) return NULL;
    if (PyType_Ready(&PathType) < 0 || PyType_Ready(&TapType) < 0) return NULL;
    PyObject *m = PyModule_Create(&module);
    if (m == NULL) return NULL;
    Py_INCREF(&PathType);
    Py_INCREF(&TapType);
    if (PyModule_AddObject(m, "Path", (PyObject *)&PathType) < 0 || PyModule_AddObject(m, "Tap", (PyObject *)&TapType) < 0) {
        Py_DECREF(m);
        return NULL;
    }
    return m;
}
