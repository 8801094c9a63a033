/* A lidar's fan of beams against faces and circles, in C: the optional kernel of
 * labsim.backends.pymunk.lidar_fan (docs/decisions.md §60).
 *
 * LidarFan.cast calls cast() once a tick with the faces and circles near the lidar (world
 * metres, as lidar_fan's _Near holds them) and the beams' table; it returns every beam's range
 * (inf beyond range_m), what the numpy fan's _faces, _circles and threshold give, to rounding.
 * The point test, the choice of faces and the beams in a wall's band stay in Python. A face is
 * tried only by the beams within its angular extent and a circle only by those within its own,
 * found by bisection in the beams sorted by direction, so a tick costs about one test per beam
 * that meets something rather than one per beam and face. Built by setuptools when a C
 * compiler is there (pyproject.toml, ext-modules, optional); without it the numpy fan runs.
 * Python's C API only, no other library.
 */
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <math.h>

#define PI 3.14159265358979323846
#define TAU (2.0 * PI)
/* as lidar_fan.ANGLE_MARGIN_RAD: far beyond the rounding of the angles, so that no beam that
 * meets a face or circle is left out; the exact test sorts the others out */
#define ANGLE_MARGIN_RAD 1e-9

/* Every beam that sees nothing reads this one inf: a float made per beam cost more than the
 * geometry (a room's lidar misses most of its beams). */
static PyObject *miss = NULL;

/* The beams' table, B of each: cos, sin (robot frame), direction in [0, 2 pi) sorted, and the
 * beam (its place in cast's output) of each sorted direction. */
typedef struct {
    Py_ssize_t beams;
    const double *cos_u, *sin_u, *by_angle, *order;
} Table;

static Py_ssize_t bisect_left(const double *a, Py_ssize_t n, double x) {
    Py_ssize_t lo = 0, hi = n;
    while (lo < hi) {
        Py_ssize_t mid = (lo + hi) / 2;
        if (a[mid] < x) lo = mid + 1; else hi = mid;
    }
    return lo;
}

static Py_ssize_t bisect_right(const double *a, Py_ssize_t n, double x) {
    Py_ssize_t lo = 0, hi = n;
    while (lo < hi) {
        Py_ssize_t mid = (lo + hi) / 2;
        if (x < a[mid]) hi = mid; else lo = mid + 1;
    }
    return lo;
}

/* x modulo 2 pi in [0, 2 pi), as Python's x % TAU */
static double wrap(double x) {
    double r = fmod(x, TAU);
    return r < 0.0 ? r + TAU : r;
}

/* The directions [lo, hi] (lo in [-pi, 2 pi)) as at most two ranges of sorted beams
 * [first, last): lidar_fan._arcs with the bisections. Returns how many. */
static int arcs(const Table *t, double lo, double hi, Py_ssize_t out[2][2]) {
    double ranges[2][2];
    int n = 1;
    if (hi - lo >= TAU) {
        ranges[0][0] = 0.0; ranges[0][1] = TAU;
    } else if (lo < 0.0) {
        ranges[0][0] = 0.0; ranges[0][1] = hi;
        ranges[1][0] = lo + TAU; ranges[1][1] = TAU;
        n = 2;
    } else if (hi >= TAU) {
        ranges[0][0] = lo; ranges[0][1] = TAU;
        ranges[1][0] = 0.0; ranges[1][1] = hi - TAU;
        n = 2;
    } else {
        ranges[0][0] = lo; ranges[0][1] = hi;
    }
    for (int i = 0; i < n; i++) {
        out[i][0] = bisect_left(t->by_angle, t->beams, ranges[i][0]);
        out[i][1] = bisect_right(t->by_angle, t->beams, ranges[i][1]);
    }
    return n;
}

/* A tuple of n numbers into out; -1 with the error set when it is not one. */
static int numbers(PyObject *item, Py_ssize_t n, double *out) {
    if (!PyTuple_Check(item) || PyTuple_GET_SIZE(item) != n) {
        PyErr_Format(PyExc_TypeError, "expected a tuple of %zd numbers", n);
        return -1;
    }
    for (Py_ssize_t i = 0; i < n; i++) {
        out[i] = PyFloat_AsDouble(PyTuple_GET_ITEM(item, i));
        if (out[i] == -1.0 && PyErr_Occurred()) return -1;
    }
    return 0;
}

/* 1 / t of the nearest face each beam crosses into inv (lidar_fan.LidarFan._faces): a beam u
 * crosses the face p1 -> p2, seen counter-clockwise, where cross(p1, u) and cross(u, p2) are
 * both >= 0, at 1 / t = cross(p1 - p2, u) / cross(p1, p2). */
static int faces(const Table *t, double ox, double oy, double c, double s, PyObject *list, double *inv) {
    Py_ssize_t n = PyList_GET_SIZE(list);
    for (Py_ssize_t f = 0; f < n; f++) {
        double p[4];
        if (numbers(PyList_GET_ITEM(list, f), 4, p) < 0) return -1;
        double ax = p[0] - ox, ay = p[1] - oy, bx = p[2] - ox, by = p[3] - oy;
        double num = ax * by - ay * bx;
        if (!(num > 0.0)) continue; /* seen from behind or edge-on: reads nothing */
        double k = 1.0 / num;
        double q1x = (c * ax + s * ay) * k, q1y = (c * ay - s * ax) * k;
        double q2x = (c * bx + s * by) * k, q2y = (c * by - s * bx) * k;
        double ex = q1x - q2x, ey = q1y - q2y;
        /* the face spans the directions from p1's counter-clockwise to p2's (less than pi) */
        double at1 = atan2(q1y, q1x), first = wrap(at1);
        double width = atan2(q2y, q2x) - at1;
        if (width < 0.0) width += TAU;
        Py_ssize_t spans[2][2];
        int count = arcs(t, first - ANGLE_MARGIN_RAD, first + width + ANGLE_MARGIN_RAD, spans);
        for (int i = 0; i < count; i++) {
            for (Py_ssize_t j = spans[i][0]; j < spans[i][1]; j++) {
                Py_ssize_t b = (Py_ssize_t)t->order[j];
                double sn = t->sin_u[b], mc = -t->cos_u[b];
                /* the rows of the numpy fan's product: (x, y) . (sin u, -cos u) */
                double along1 = q1x * sn + q1y * mc;
                double along2 = (-q2x) * sn + (-q2y) * mc;
                double least = along2 < along1 ? along2 : along1;
                if (signbit(least) || least != least) continue;
                double v = fabs(ex * sn + ey * mc); /* copysign(E, least), least >= +0 */
                if (v > inv[b]) inv[b] = v;
            }
        }
    }
    return 0;
}

/* 1 / t of the circles' nearest points into inv (lidar_fan.LidarFan._circles): with
 * h = |q|^2 - r^2 and p = q . u, a beam meets the circle first at t = h / (p + sqrt(p^2 - h)). */
static int circles(const Table *t, double ox, double oy, double c, double s, PyObject *list, double *inv) {
    Py_ssize_t n = PyList_GET_SIZE(list);
    for (Py_ssize_t i = 0; i < n; i++) {
        double q[3];
        if (numbers(PyList_GET_ITEM(list, i), 3, q) < 0) return -1;
        double dx = q[0] - ox, dy = q[1] - oy, r2 = q[2];
        double qx = c * dx + s * dy, qy = c * dy - s * dx;
        double h = qx * qx + qy * qy - r2;
        if (h <= 0.0) continue; /* the lidar touches it: the point test said so already */
        double ratio = sqrt(r2 / (h + r2));
        double half = asin(ratio < 1.0 ? ratio : 1.0) + ANGLE_MARGIN_RAD;
        double mid = wrap(atan2(qy, qx));
        Py_ssize_t spans[2][2];
        int count = arcs(t, mid - half, mid + half, spans);
        for (int a = 0; a < count; a++) {
            for (Py_ssize_t j = spans[a][0]; j < spans[a][1]; j++) {
                Py_ssize_t b = (Py_ssize_t)t->order[j];
                double p = qx * t->cos_u[b] + qy * t->sin_u[b];
                double d = p * p - h;
                if (p > 0.0 && d >= 0.0) {
                    double v = (p + sqrt(d)) / h;
                    if (v > inv[b]) inv[b] = v;
                }
            }
        }
    }
    return 0;
}

static PyObject *cast(PyObject *self, PyObject *args) {
    double ox, oy, c, s, inv_range;
    PyObject *face_list, *circle_list;
    Py_buffer table;
    (void)self;
    if (!PyArg_ParseTuple(args, "ddddO!O!y*d", &ox, &oy, &c, &s, &PyList_Type, &face_list, &PyList_Type,
                          &circle_list, &table, &inv_range))
        return NULL;
    Py_ssize_t beams = table.len / (Py_ssize_t)(4 * sizeof(double));
    if (table.len != beams * (Py_ssize_t)(4 * sizeof(double))) {
        PyBuffer_Release(&table);
        return PyErr_Format(PyExc_ValueError, "the beams' table holds 4 doubles a beam");
    }
    const double *d = (const double *)table.buf;
    Table t = {beams, d, d + beams, d + 2 * beams, d + 3 * beams};
    double *inv = PyMem_Calloc(beams ? (size_t)beams : 1, sizeof(double)); /* 1 / t, 0 where nothing is seen */
    PyObject *out = NULL;
    if (inv == NULL) {
        PyErr_NoMemory();
    } else if (faces(&t, ox, oy, c, s, face_list, inv) == 0 && circles(&t, ox, oy, c, s, circle_list, inv) == 0) {
        out = PyList_New(beams);
        for (Py_ssize_t b = 0; out != NULL && b < beams; b++) {
            PyObject *range;
            if (inv[b] >= inv_range) {
                range = PyFloat_FromDouble(1.0 / inv[b]);
            } else {
                range = miss;
                Py_INCREF(range);
            }
            if (range == NULL) {
                Py_CLEAR(out);
                break;
            }
            PyList_SET_ITEM(out, b, range);
        }
    }
    PyMem_Free(inv);
    PyBuffer_Release(&table);
    return out;
}

static PyMethodDef methods[] = {
    {"cast", cast, METH_VARARGS,
     "cast(ox, oy, c, s, faces, circles, table, inv_range) -> every beam's range in metres (inf beyond "
     "range_m): faces a list of (p1x, p1y, p2x, p2y), circles of (x, y, r squared), world metres; table "
     "the beams' cos, sin, sorted directions and their beams, 4 x B doubles (LidarFan builds it)."},
    {NULL, NULL, 0, NULL},
};

static struct PyModuleDef module = {
    PyModuleDef_HEAD_INIT, "_fan", "A lidar's fan of beams against faces and circles, in C.", -1, methods,
    NULL, NULL, NULL, NULL,
};

PyMODINIT_FUNC PyInit__fan(void) {
    if (miss == NULL && (miss = PyFloat_FromDouble(HUGE_VAL)) == NULL) return NULL;
    return PyModule_Create(&module);
}
