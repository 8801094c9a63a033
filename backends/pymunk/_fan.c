/* Every ray sensor's cast, in C: the optional kernel of labsim.backends.pymunk.ray_cast, whose
 * RaySet.cast calls rays() once a tick for a robot's whole ray set: its sonars (cones and lone
 * rays), its IR rays and its lidar's fan, in one call.
 *
 * The sonar and IR rays: each cone's rays under one test of the cone's circle, each group's
 * under one of its own, cast through chipmunk's own cpSpaceSegmentQueryFirst and
 * cpSpacePointQueryNearest (pymunk's build of them: bind() is given their addresses once), so
 * the readings are chipmunk's bit for bit, robots and blocks included wherever chipmunk has
 * them. The arithmetic of the rays' ends is the Python fallback's, written in the same order;
 * the build turns off contraction into fused multiply-adds (pyproject.toml), which would round
 * otherwise.
 *
 * The lidar's beams, hundreds of them (chipmunk's segment query costs about 0.6 us a ray even
 * from C), go against the faces and circles near the lidar (world metres, as lidar_fan's _Near
 * holds them, with the moving bodies' where they are now) and the beams' table
 * (docs/decisions.md §60): every beam's range (inf beyond range_m), what the numpy fan's
 * _faces, _circles and threshold give, to rounding; a lidar inside a shape (chipmunk's point
 * query says so) reads 0 on every beam. The choice of faces and the beams in a wall's band
 * stay in Python. A face is tried only by the beams within its
 * angular extent and a circle only by those within its own, found by bisection in the beams
 * sorted by direction, so a tick costs about one test per beam that meets something rather
 * than one per beam and face.
 *
 * Built by setuptools when a C compiler is there (pyproject.toml, ext-modules, optional);
 * without it the numpy fan and the Python rays run. Python's C API only, no other library.
 */
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <math.h>
#include <stddef.h>
#include <stdint.h>

#define PI 3.14159265358979323846
#define TAU (2.0 * PI)
/* as lidar_fan.ANGLE_MARGIN_RAD: far beyond the rounding of the angles, so that no beam that
 * meets a face or circle is left out; the exact test sorts the others out */
#define ANGLE_MARGIN_RAD 1e-9
/* as lidar_fan.TOUCH_M: the smallest positive double, so that the point query finds a shape
 * only where the lidar is inside it (distance <= 0), chipmunk's own test before it casts */
#define TOUCH_M 5e-324

/* Every beam that sees nothing reads this one inf: a float made per beam cost more than the
 * geometry (a room's lidar misses most of its beams). */
static PyObject *miss = NULL;

/* The beams' table, B of each: cos, sin (robot frame), direction in [0, 2 pi) sorted, and the
 * beam (its place among the beams rays() returns) of each sorted direction. */
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

/* Chipmunk's types as pymunk's build has them (bind() checks the sizes and offsets). */
typedef struct { double x, y; } Vect;
typedef struct { uintptr_t group; unsigned int categories, mask; } Filter;
typedef struct { void *shape; Vect point, normal; double alpha; } SegmentInfo;
typedef struct { void *shape; Vect point; double distance; Vect gradient; } PointInfo;
typedef void *(*SegmentQueryFirst)(void *, Vect, Vect, double, Filter, SegmentInfo *);
typedef void *(*PointQueryNearest)(void *, Vect, double, Filter, PointInfo *);
static SegmentQueryFirst segment_query_first = NULL;
static PointQueryNearest point_query_nearest = NULL;

static PyObject *bind(PyObject *self, PyObject *args) {
    unsigned long long segment, point;
    Py_ssize_t filter_size, bitmask_size, mask_at, info_size, normal_at, alpha_at, point_size;
    (void)self;
    if (!PyArg_ParseTuple(args, "KKnnnnnnn", &segment, &point, &filter_size, &bitmask_size, &mask_at, &info_size,
                          &normal_at, &alpha_at, &point_size))
        return NULL;
    if (filter_size != (Py_ssize_t)sizeof(Filter) || bitmask_size != (Py_ssize_t)sizeof(unsigned int)
        || mask_at != (Py_ssize_t)offsetof(Filter, mask) || info_size != (Py_ssize_t)sizeof(SegmentInfo)
        || normal_at != (Py_ssize_t)offsetof(SegmentInfo, normal) || alpha_at != (Py_ssize_t)offsetof(SegmentInfo, alpha)
        || point_size != (Py_ssize_t)sizeof(PointInfo))
        return PyErr_Format(PyExc_ValueError, "chipmunk's structs in this pymunk differ from the kernel's");
    segment_query_first = (SegmentQueryFirst)(uintptr_t)segment;
    point_query_nearest = (PointQueryNearest)(uintptr_t)point;
    Py_RETURN_NONE;
}

/* The table ray_cast.RaySet builds, as doubles: the number of values and of groups, then each
 * group: its circle (x, y, radius in the robot frame; radius < 0: no test) and its number of
 * members, then each member: its value's slot, its kind (0 a ray, 1 a cone), its mount x, y, its
 * range, its cone's circle x, y, radius, whether it has an incidence limit and the limit's
 * threshold, its number of rays, and each ray's end (dx, dy from the mount, robot frame). */
#define GROUP_HEAD 4
#define MEMBER_HEAD 11

/* A double from a Python number into out; -1 with the error set when it is not one. */
static int number(PyObject *item, double *out) {
    *out = PyFloat_AsDouble(item);
    return *out == -1.0 && PyErr_Occurred() ? -1 : 0;
}

/* Called once a tick per robot, so its arguments are read without a format string
 * (METH_FASTCALL): ten, or sixteen with a lidar. */
static PyObject *rays(PyObject *self, PyObject *const *args, Py_ssize_t nargs) {
    double x, y, c, s, inv_range = 0.0, ox = 0.0, oy = 0.0;
    PyObject *face_list = NULL, *circle_list = NULL; /* the lidar's, when the robot has one */
    (void)self;
    if (nargs != 10 && nargs != 16)
        return PyErr_Format(PyExc_TypeError, "rays() takes 10 arguments, or 16 with a lidar (%zd given)", nargs);
    /* args[1] is what keeps the space alive: held by the caller, unused here */
    unsigned long long space_at = PyLong_AsUnsignedLongLongMask(args[0]);
    unsigned long long group = PyLong_AsUnsignedLongLongMask(args[2]);
    unsigned int categories = (unsigned int)PyLong_AsUnsignedLongMask(args[3]);
    unsigned int mask = (unsigned int)PyLong_AsUnsignedLongMask(args[4]);
    if (PyErr_Occurred()) return NULL;
    if (!PyBytes_Check(args[5])) return PyErr_Format(PyExc_TypeError, "the table of rays is bytes");
    if (number(args[6], &x) < 0 || number(args[7], &y) < 0 || number(args[8], &c) < 0 || number(args[9], &s) < 0)
        return NULL;
    PyObject *out = NULL;
    double stack[64], *values = NULL, *inv = NULL;
    const double *d = (const double *)PyBytes_AS_STRING(args[5]);
    Py_ssize_t size = PyBytes_GET_SIZE(args[5]) / (Py_ssize_t)sizeof(double), at = 2, beams = 0;
    Table t = {0, NULL, NULL, NULL, NULL};
    if (nargs == 16) {
        face_list = args[10];
        circle_list = args[11];
        if (!PyList_Check(face_list) || !PyList_Check(circle_list) || !PyBytes_Check(args[12]))
            return PyErr_Format(PyExc_TypeError, "a lidar's faces and circles are lists, its beams' table bytes");
        if (number(args[13], &inv_range) < 0 || number(args[14], &ox) < 0 || number(args[15], &oy) < 0) return NULL;
        Py_ssize_t len = PyBytes_GET_SIZE(args[12]);
        beams = len / (Py_ssize_t)(4 * sizeof(double));
        if (len != beams * (Py_ssize_t)(4 * sizeof(double)))
            return PyErr_Format(PyExc_ValueError, "the beams' table holds 4 doubles a beam");
        const double *b = (const double *)PyBytes_AS_STRING(args[12]);
        t = (Table){beams, b, b + beams, b + 2 * beams, b + 3 * beams};
    }
    if (size < 2) goto bad;
    Py_ssize_t count = (Py_ssize_t)d[0], groups = (Py_ssize_t)d[1];
    if (count < 0 || groups < 0) goto bad;
    if ((groups > 0 || face_list != NULL) && segment_query_first == NULL) {
        PyErr_SetString(PyExc_RuntimeError, "bind() was not called");
        goto done;
    }
    values = count <= 64 ? stack : PyMem_Malloc((size_t)count * sizeof(double));
    if (values == NULL) {
        PyErr_NoMemory();
        goto done;
    }
    for (Py_ssize_t i = 0; i < count; i++) values[i] = HUGE_VAL;
    void *space = (void *)(uintptr_t)space_at;
    Filter filter = {(uintptr_t)group, categories, mask};
    SegmentInfo info;
    PointInfo nearest;
    for (Py_ssize_t g = 0; g < groups; g++) {
        if (at + GROUP_HEAD > size) goto bad;
        const double *h = d + at;
        Py_ssize_t members = (Py_ssize_t)h[3];
        int open = 1;
        at += GROUP_HEAD;
        if (h[2] >= 0.0) {
            Vect p = {x + c * h[0] - s * h[1], y + s * h[0] + c * h[1]};
            open = point_query_nearest(space, p, h[2], filter, &nearest) != NULL;
        }
        for (Py_ssize_t m = 0; m < members; m++) {
            if (at + MEMBER_HEAD > size) goto bad;
            const double *r = d + at;
            Py_ssize_t slot = (Py_ssize_t)r[0], n = (Py_ssize_t)r[10];
            const double *ends = r + MEMBER_HEAD;
            at += MEMBER_HEAD + 2 * n;
            if (slot < 0 || slot >= count || n < 1 || at > size) goto bad;
            if (!open) continue;
            double mx = r[2], my = r[3], range = r[4];
            Vect o = {x + c * mx - s * my, y + s * mx + c * my};
            if (r[1] == 0.0) { /* a lone ray */
                double ex = ends[0], ey = ends[1];
                Vect e = {o.x + c * ex - s * ey, o.y + s * ex + c * ey};
                if (segment_query_first(space, o, e, 0.0, filter, &info) != NULL) values[slot] = info.alpha * range;
                continue;
            }
            double v = HUGE_VAL; /* a cone: its nearest hit met within the limit, under its circle's test */
            Vect p = {x + c * r[5] - s * r[6], y + s * r[5] + c * r[6]};
            if (point_query_nearest(space, p, r[7], filter, &nearest) != NULL) {
                int limited = r[8] != 0.0;
                double threshold = r[9];
                for (Py_ssize_t k = 0; k < n; k++) {
                    double ex = ends[2 * k], ey = ends[2 * k + 1];
                    double wx = c * ex - s * ey;
                    double wy = s * ex + c * ey;
                    Vect e = {o.x + wx, o.y + wy};
                    if (segment_query_first(space, o, e, 0.0, filter, &info) != NULL && info.alpha * range < v
                        && (!limited || info.normal.x * wx + info.normal.y * wy <= threshold))
                        v = info.alpha * range;
                }
            }
            values[slot] = v;
        }
    }
    int touching = 0; /* the lidar inside a shape: every beam reads 0, as chipmunk's casts do */
    if (face_list != NULL) { /* the lidar's fan: 1 / t, 0 where nothing is seen */
        inv = PyMem_Calloc(beams ? (size_t)beams : 1, sizeof(double));
        if (inv == NULL) {
            PyErr_NoMemory();
            goto done;
        }
        touching = point_query_nearest(space, (Vect){ox, oy}, TOUCH_M, filter, &nearest) != NULL;
        if (!touching && (faces(&t, ox, oy, c, s, face_list, inv) < 0 || circles(&t, ox, oy, c, s, circle_list, inv) < 0))
            goto done;
    }
    out = PyList_New(count + beams);
    for (Py_ssize_t i = 0; out != NULL && i < count + beams; i++) {
        PyObject *value;
        double v = i < count ? values[i]
                   : touching ? 0.0
                   : inv[i - count] >= inv_range ? 1.0 / inv[i - count] : HUGE_VAL;
        if (v == HUGE_VAL) {
            value = miss;
            Py_INCREF(value);
        } else if ((value = PyFloat_FromDouble(v)) == NULL) {
            Py_CLEAR(out);
            break;
        }
        PyList_SET_ITEM(out, i, value);
    }
    goto done;
bad:
    PyErr_SetString(PyExc_ValueError, "a malformed table of rays");
done:
    if (values != stack) PyMem_Free(values);
    PyMem_Free(inv);
    return out;
}

static PyMethodDef methods[] = {
    {"bind", bind, METH_VARARGS,
     "bind(segment_query_first, point_query_nearest, sizeof filter, sizeof bitmask, offsetof mask, sizeof "
     "segment info, offsetof normal, offsetof alpha, sizeof point info): chipmunk's two queries for rays(), "
     "by address, once the sizes of its structs are those the kernel was built with."},
    {"rays", (PyCFunction)(void (*)(void))rays, METH_FASTCALL,
     "rays(space, owner, group, categories, mask, table, x, y, c, s[, faces, circles, beams, inv_range, ox, oy]) "
     "-> every ray's reading in metres (inf: nothing): a robot's sonar and IR rays for its body at (x, y) heading "
     "(c, s) = (cos, sin), through chipmunk (space the cpSpace's address, owner what keeps it alive, table as "
     "ray_cast.RaySet builds it), then its lidar's beams from (ox, oy): faces a list of (p1x, p1y, p2x, p2y), "
     "circles of (x, y, r squared), world metres, beams the beams' cos, sin, sorted directions and their beams, "
     "4 x B doubles (lidar_fan.LidarFan builds them)."},
    {NULL, NULL, 0, NULL},
};

static struct PyModuleDef module = {
    PyModuleDef_HEAD_INIT, "_fan", "Every ray sensor's cast, in C: a lidar's fan and a robot's sonar and IR rays.", -1, methods,
    NULL, NULL, NULL, NULL,
};

PyMODINIT_FUNC PyInit__fan(void) {
    if (miss == NULL && (miss = PyFloat_FromDouble(HUGE_VAL)) == NULL) return NULL;
    return PyModule_Create(&module);
}
