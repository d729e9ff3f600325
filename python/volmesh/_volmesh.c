/* SPDX-License-Identifier: BSD-3-Clause */
/* python/volmesh/_volmesh.c — the CPython binding of libvolmesh: volumes and meshes cross as
 * buffers (no copy where the layout allows), every library call runs with the GIL released.
 * The Python API (python/volmesh/__init__.py) is built on these few functions. */
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#ifdef _WIN32
#include <windows.h>
#endif
#include "volmesh/volmesh.h"

static PyObject *error_class; /* volmesh.Error, handed over by __init__.py */

/* ---- Buf: memory from malloc, handed to Python through the buffer protocol ------------ */

/* Owns a malloc'd block; numpy arrays made by np.frombuffer keep it alive as their base. */
typedef struct {
    PyObject_HEAD void *data;
    Py_ssize_t len;
} Buf;

/* Frees the block with the object. */
static void buf_dealloc(Buf *b) {
    free(b->data);
    Py_TYPE(b)->tp_free((PyObject *)b);
}

/* Exposes the block as writable bytes. */
static int buf_getbuffer(Buf *b, Py_buffer *view, int flags) {
    static char empty;
    return PyBuffer_FillInfo(view, (PyObject *)b, b->data ? b->data : &empty, b->len, 0, flags);
}

static PyBufferProcs buf_as_buffer = {(getbufferproc)buf_getbuffer, NULL};

static PyTypeObject BufType = {
    PyVarObject_HEAD_INIT(NULL, 0).tp_name = "volmesh._volmesh.Buffer",
    .tp_basicsize = sizeof(Buf),
    .tp_dealloc = (destructor)buf_dealloc,
    .tp_as_buffer = &buf_as_buffer,
    .tp_flags = Py_TPFLAGS_DEFAULT,
    .tp_doc = "memory owned by volmesh, shared with numpy without a copy",
};

/* Wraps data (taken over: freed with the object, also on failure) as a Buf of len bytes. */
static PyObject *buf_take(void *data, size_t len) {
    Buf *b = PyObject_New(Buf, &BufType);
    if (!b) {
        free(data);
        return NULL;
    }
    b->data = data;
    b->len = (Py_ssize_t)len;
    return (PyObject *)b;
}

/* ---- errors and progress --------------------------------------------------------------- */

/* Raises volmesh.Error with the library's one-line message (MemoryError when out of memory). */
static PyObject *raise_status(vm_status s, const vm_error *err) {
    const char *msg = err->message[0] ? err->message : vm_status_string(s);
    if (s == VM_ERR_NOMEM) return PyErr_Format(PyExc_MemoryError, "%s", msg);
    PyErr_SetString(error_class ? error_class : PyExc_RuntimeError, msg);
    return NULL;
}

/* What the library's progress hook needs: the Python callable (or NULL), the first
 * exception raised while the GIL was released (by the callable, or KeyboardInterrupt and
 * the like from a signal handler), the thread that released the GIL, and the clock. */
typedef struct {
    PyObject *callback;
    PyObject *exc_type, *exc_value, *exc_tb;
    unsigned long thread; /* PyThread_get_thread_ident() of the caller */
    double next;          /* monotonic seconds: no look at Python before then */
    const char *stage;    /* of the last call handed to the callable */
} progress_ctx;

/* At most this often (seconds) the hook takes the GIL to run signal handlers and the
 * callable: Ctrl-C stops a run within about this plus the library's own check interval. */
#define PROGRESS_EVERY 0.1

static double monotonic_seconds(void) {
#ifdef _WIN32
    return (double)GetTickCount64() * 1e-3;
#else
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
#endif
}

/* A context for a call made from this thread (the GIL held). */
static void progress_init(progress_ctx *p, PyObject *callback) {
    memset(p, 0, sizeof *p);
    p->callback = callback && callback != Py_None ? callback : NULL;
    p->thread = PyThread_get_thread_ident();
    p->next = monotonic_seconds() + PROGRESS_EVERY;
}

/* The library's progress hook (always installed, so that Ctrl-C works without a callable).
 * Only on the thread that released the GIL, at most every PROGRESS_EVERY seconds (and at a
 * stage's first and last call), it takes the GIL, runs the pending signal handlers
 * (PyErr_CheckSignals: KeyboardInterrupt on SIGINT) and the callable(stage, done, total).
 * An exception from either is kept and cancels the run (nonzero); it is raised when the
 * library returns (progress_finish). */
static int progress_call(const char *stage, double done, double total, void *user) {
    progress_ctx *p = user;
    if (p->exc_type) return 1;
    if (PyThread_get_thread_ident() != p->thread) return 0; /* never Python off the caller */
    double now = monotonic_seconds();
    int edge = stage != p->stage || done >= total;
    if (now < p->next && !(edge && p->callback)) return 0;
    p->next = now + PROGRESS_EVERY;
    PyGILState_STATE g = PyGILState_Ensure();
    if (PyErr_CheckSignals() < 0) {
        PyErr_Fetch(&p->exc_type, &p->exc_value, &p->exc_tb);
    } else if (p->callback) {
        p->stage = stage;
        PyObject *r = PyObject_CallFunction(p->callback, "sdd", stage, done, total);
        if (r)
            Py_DECREF(r);
        else
            PyErr_Fetch(&p->exc_type, &p->exc_value, &p->exc_tb);
    }
    PyGILState_Release(g);
    return p->exc_type != NULL;
}

/* After the library call: re-raises what the hook caught; returns -1 when it did. */
static int progress_finish(progress_ctx *p) {
    if (!p->exc_type) return 0;
    PyErr_Restore(p->exc_type, p->exc_value, p->exc_tb);
    p->exc_type = p->exc_value = p->exc_tb = NULL;
    return -1;
}

/* ---- volumes ----------------------------------------------------------------------------- */

/* Fills v's geometry from Python sequences: spacing (3), origin (3), direction (9, row major). */
static int volume_geometry(vm_volume *v, PyObject *spacing, PyObject *origin, PyObject *dir) {
    for (int a = 0; a < 3; a++) {
        PyObject *s = PySequence_GetItem(spacing, a), *o = PySequence_GetItem(origin, a);
        v->spacing[a] = s ? PyFloat_AsDouble(s) : -1.0;
        v->origin[a] = o ? PyFloat_AsDouble(o) : 0.0;
        Py_XDECREF(s);
        Py_XDECREF(o);
        for (int c = 0; c < 3; c++) {
            PyObject *d = PySequence_GetItem(dir, 3 * a + c);
            v->direction[a][c] = d ? PyFloat_AsDouble(d) : 0.0;
            Py_XDECREF(d);
        }
    }
    return PyErr_Occurred() ? -1 : 0;
}

/* read_volume(path) -> (data Buffer of float32, (nx, ny, nz), spacing, origin, direction
 * (9, row major), type name, format). */
static PyObject *py_read_volume(PyObject *self, PyObject *args) {
    (void)self;
    PyObject *pathobj;
    if (!PyArg_ParseTuple(args, "O&", PyUnicode_FSConverter, &pathobj)) return NULL;
    vm_volume v;
    vm_error err;
    vm_error_clear(&err);
    memset(&v, 0, sizeof v);
    vm_status s;
    Py_BEGIN_ALLOW_THREADS s = vm_volume_read(PyBytes_AS_STRING(pathobj), &v, &err);
    Py_END_ALLOW_THREADS Py_DECREF(pathobj);
    if (s) return raise_status(s, &err);
    size_t bytes = vm_volume_count(&v) * sizeof(float);
    PyObject *data = buf_take(v.data, bytes);
    v.data = NULL;
    if (!data) return NULL;
    const double(*d)[3] = (const double(*)[3])v.direction;
    return Py_BuildValue("N(LLL)(ddd)(ddd)(ddddddddd)ss", data, (long long)v.dims[0],
                         (long long)v.dims[1], (long long)v.dims[2], v.spacing[0], v.spacing[1],
                         v.spacing[2], v.origin[0], v.origin[1], v.origin[2], d[0][0], d[0][1],
                         d[0][2], d[1][0], d[1][1], d[1][2], d[2][0], d[2][1], d[2][2],
                         vm_scalar_type_name(v.type), v.format);
}

/* ---- meshes ------------------------------------------------------------------------------ */

/* Hands a library mesh to Python, taking its arrays over: (kind, points, cells, region,
 * npoints, ncells, cell fields [(name, ncomp, Buffer)], point fields [...]). Frees m. */
static PyObject *mesh_to_python(vm_mesh *m) {
    size_t nn = (size_t)vm_cell_nodes(m->kind);
    PyObject *pts = buf_take(m->points, m->npoints * 3 * sizeof(double));
    m->points = NULL;
    PyObject *cells = buf_take(m->cells, m->ncells * nn * sizeof(vm_index));
    m->cells = NULL;
    PyObject *reg = buf_take(m->region, m->ncells * sizeof(int32_t));
    m->region = NULL;
    PyObject *fields[2] = {PyList_New(0), PyList_New(0)};
    for (int on_cells = 0; on_cells < 2 && fields[0] && fields[1]; on_cells++) {
        vm_field *f = on_cells ? m->cell_fields : m->point_fields;
        size_t nf = on_cells ? m->ncell_fields : m->npoint_fields;
        size_t n = on_cells ? m->ncells : m->npoints;
        for (size_t i = 0; i < nf; i++) {
            PyObject *b = buf_take(f[i].data, n * (size_t)f[i].ncomp * sizeof(double));
            f[i].data = NULL;
            PyObject *t = b ? Py_BuildValue("siN", f[i].name, f[i].ncomp, b) : NULL;
            if (!t || PyList_Append(fields[on_cells], t)) {
                Py_XDECREF(t);
                Py_CLEAR(fields[on_cells]);
                break;
            }
            Py_DECREF(t);
        }
    }
    size_t np = m->npoints, nc = m->ncells;
    const char *kind = vm_cell_kind_name(m->kind);
    vm_mesh_free(m);
    if (!pts || !cells || !reg || !fields[0] || !fields[1]) {
        Py_XDECREF(pts);
        Py_XDECREF(cells);
        Py_XDECREF(reg);
        Py_XDECREF(fields[0]);
        Py_XDECREF(fields[1]);
        return NULL;
    }
    return Py_BuildValue("sNNNnnNN", kind, pts, cells, reg, (Py_ssize_t)np, (Py_ssize_t)nc,
                         fields[1], fields[0]);
}

/* Kind from its name ("tet4", "hex8", "tri3", "quad4"); 0 when unknown. */
static vm_cell_kind kind_parse(const char *name) {
    static const vm_cell_kind kinds[] = {VM_TET4, VM_HEX8, VM_TRI3, VM_QUAD4};
    for (int i = 0; i < 4; i++)
        if (!strcmp(name, vm_cell_kind_name(kinds[i]))) return kinds[i];
    return (vm_cell_kind)0;
}

/* The buffers of a mesh lent by Python (released by views_release). */
typedef struct {
    Py_buffer pts, cells, reg;
    int held;
} mesh_views;

/* A vm_mesh over Python's arrays, without a copy: points float64 (n, 3), cells of the index
 * type, region int32 (one per cell). The mesh must not be freed, only the views released. */
static int mesh_from_python(PyObject *args_tuple, vm_mesh *m, mesh_views *mv) {
    const char *kind;
    PyObject *pts, *cells, *reg;
    memset(mv, 0, sizeof *mv);
    if (!PyArg_ParseTuple(args_tuple, "sOOO", &kind, &pts, &cells, &reg)) return -1;
    vm_mesh_init(m, kind_parse(kind));
    if (!vm_cell_nodes(m->kind)) {
        PyErr_Format(PyExc_ValueError, "unknown cell kind '%s'", kind);
        return -1;
    }
    int fl = PyBUF_C_CONTIGUOUS;
    if (PyObject_GetBuffer(pts, &mv->pts, fl)) return -1;
    mv->held = 1;
    if (PyObject_GetBuffer(cells, &mv->cells, fl)) return -1;
    mv->held = 2;
    if (PyObject_GetBuffer(reg, &mv->reg, fl)) return -1;
    mv->held = 3;
    size_t nn = (size_t)vm_cell_nodes(m->kind);
    m->npoints = (size_t)mv->pts.len / (3 * sizeof(double));
    m->ncells = (size_t)mv->cells.len / (nn * sizeof(vm_index));
    if ((size_t)mv->pts.len != m->npoints * 3 * sizeof(double) ||
        (size_t)mv->cells.len != m->ncells * nn * sizeof(vm_index) ||
        (size_t)mv->reg.len != m->ncells * sizeof(int32_t)) {
        PyErr_SetString(PyExc_ValueError, "mesh arrays do not fit together");
        return -1;
    }
    m->points = mv->pts.buf;
    m->cells = mv->cells.buf;
    m->region = mv->reg.buf;
    return 0;
}

/* Releases the buffers mesh_from_python took. */
static void views_release(mesh_views *mv) {
    if (mv->held > 2) PyBuffer_Release(&mv->reg);
    if (mv->held > 1) PyBuffer_Release(&mv->cells);
    if (mv->held > 0) PyBuffer_Release(&mv->pts);
    mv->held = 0;
}

/* read_mesh(path) -> the tuple of mesh_to_python. */
static PyObject *py_read_mesh(PyObject *self, PyObject *args) {
    (void)self;
    PyObject *pathobj;
    if (!PyArg_ParseTuple(args, "O&", PyUnicode_FSConverter, &pathobj)) return NULL;
    vm_mesh m;
    vm_error err;
    vm_error_clear(&err);
    vm_status s;
    Py_BEGIN_ALLOW_THREADS s = vm_mesh_read(PyBytes_AS_STRING(pathobj), &m, &err);
    Py_END_ALLOW_THREADS Py_DECREF(pathobj);
    if (s) return raise_status(s, &err);
    return mesh_to_python(&m);
}

/* write_mesh(path, (kind, points, cells, region), format, order, deck, compress, ascii). */
static PyObject *py_write_mesh(PyObject *self, PyObject *args) {
    (void)self;
    PyObject *pathobj, *mt;
    const char *format;
    int order, deck, compress, ascii;
    if (!PyArg_ParseTuple(args, "O&O!siiii", PyUnicode_FSConverter, &pathobj, &PyTuple_Type, &mt,
                          &format, &order, &deck, &compress, &ascii))
        return NULL;
    vm_mesh_write_options wo;
    vm_mesh_write_options_init(&wo);
    if (format[0] && (wo.format = vm_mesh_format_parse(format)) == VM_MESH_AUTO) {
        Py_DECREF(pathobj);
        return PyErr_Format(PyExc_ValueError, "unknown mesh format '%s'", format);
    }
    wo.order = order;
    wo.deck = deck ? VM_DECK_STATIC : VM_DECK_NONE;
    wo.compress = compress;
    wo.ascii = ascii;
    vm_mesh m;
    mesh_views mv;
    if (mesh_from_python(mt, &m, &mv)) {
        views_release(&mv);
        Py_DECREF(pathobj);
        return NULL;
    }
    vm_error err;
    vm_error_clear(&err);
    progress_ctx p; /* no callable: Ctrl-C only */
    progress_init(&p, NULL);
    wo.progress = progress_call;
    wo.progress_user = &p;
    vm_status s;
    Py_BEGIN_ALLOW_THREADS s = vm_mesh_write_as(PyBytes_AS_STRING(pathobj), &m, &wo, &err);
    Py_END_ALLOW_THREADS views_release(&mv);
    Py_DECREF(pathobj);
    if (progress_finish(&p)) return NULL;
    if (s) return raise_status(s, &err);
    Py_RETURN_NONE;
}

/* quality_json((kind, points, cells, region), name) -> the JSON text of volmesh quality. */
static PyObject *py_quality_json(PyObject *self, PyObject *args) {
    (void)self;
    PyObject *mt;
    const char *name;
    if (!PyArg_ParseTuple(args, "O!s", &PyTuple_Type, &mt, &name)) return NULL;
    vm_mesh m;
    mesh_views mv;
    if (mesh_from_python(mt, &m, &mv)) {
        views_release(&mv);
        return NULL;
    }
    vm_quality_summary q;
    vm_error err;
    vm_error_clear(&err);
    vm_status s;
    char *text = NULL;
    size_t len = 0;
    int wrote = -1;
    progress_ctx p; /* no callable: Ctrl-C only */
    progress_init(&p, NULL);
    vm_quality_options qo;
    vm_quality_options_init(&qo);
    qo.progress = progress_call;
    qo.progress_user = &p;
    Py_BEGIN_ALLOW_THREADS s = vm_quality_report_with(&m, &qo, &q, &err);
    if (!s) {
        FILE *f = open_memstream(&text, &len);
        if (f) {
            wrote = vm_quality_write_json(f, name, &q);
            if (fclose(f)) wrote = -1;
        }
    }
    Py_END_ALLOW_THREADS views_release(&mv);
    if (progress_finish(&p)) {
        free(text);
        return NULL;
    }
    if (s) return raise_status(s, &err);
    if (wrote != 0) {
        free(text);
        return PyErr_NoMemory();
    }
    PyObject *r = PyUnicode_FromStringAndSize(text, (Py_ssize_t)len);
    free(text);
    return r;
}

/* ---- meshing ----------------------------------------------------------------------------- */

/* What mesh() was asked for, read from its keywords. */
typedef struct {
    int has_lo, has_hi;
    double lo, hi;
    int labels;                  /* a label volume */
    int32_t *label_list;         /* NULL: every non-zero label */
    size_t nlabels;
    vm_label_edge *edges;        /* label_edge: (label, edge) pairs (owned), nedges of them */
    size_t nedges;
    vm_cell_kind elements;
    int surface_method;          /* -1: a volume mesh */
    int size, adaptive, max_level, improve, smooth;
    double error;
    size_t min_island;
    /* graded sizing (vm_mesh_options); max_edge also sizes label meshes */
    int graded, coarsen;
    double max_edge, min_edge, distance, grading;
    Py_ssize_t tets;
    int min_layers;
    PyObject *size_field; /* (data, (nx, ny, nz), spacing, origin, direction9) or NULL */
    vm_volume sf;         /* its view while meshing */
} mesh_request;

/* label_edge: a sequence of (label, edge) pairs into r->edges; -1 with a Python exception. */
static int request_edges(PyObject *edges, mesh_request *r) {
    PyObject *seq = PySequence_Fast(edges, "label_edge must be pairs (label, edge)");
    if (!seq) return -1;
    Py_ssize_t n = PySequence_Fast_GET_SIZE(seq);
    r->edges = malloc((size_t)(n ? n : 1) * sizeof *r->edges);
    if (!r->edges) {
        Py_DECREF(seq);
        PyErr_NoMemory();
        return -1;
    }
    for (Py_ssize_t i = 0; i < n; i++) {
        long l = 0;
        double e = 0;
        if (!PyArg_ParseTuple(PySequence_Fast_GET_ITEM(seq, i), "ld", &l, &e)) {
            Py_DECREF(seq);
            return -1;
        }
        r->edges[i].label = (int32_t)l;
        r->edges[i].edge = e;
    }
    r->nedges = (size_t)n;
    Py_DECREF(seq);
    return 0;
}

/* Frees what request_parse allocated. */
static void request_free(mesh_request *r) {
    free(r->label_list);
    free(r->edges);
}

/* Reads the keywords of mesh(); -1 with a Python exception on a bad value. */
static int request_parse(PyObject *kw, mesh_request *r) {
    memset(r, 0, sizeof *r);
    PyObject *labels = NULL, *method = NULL, *edges = NULL;
    const char *elements = "tet4";
    static char *names[] = {"has_lo", "lo",       "has_hi",     "hi",      "labels",
                            "elements", "method", "size",       "adaptive", "error",
                            "max_level", "improve", "min_island", "smooth", "label_edge",
                            "graded", "coarsen", "max_edge", "min_edge", "distance",
                            "grading", "tets", "size_field", "min_layers", NULL};
    Py_ssize_t min_island = 1;
    r->size = 1;
    r->error = 0.5;
    r->max_level = 4;
    r->improve = 1;
    r->smooth = 1;
    r->coarsen = 1;
    PyObject *empty = PyTuple_New(0);
    if (!empty) return -1;
    int ok = PyArg_ParseTupleAndKeywords(
        empty, kw, "|pdpdOsOipdipnpOppddddnOi", names, &r->has_lo, &r->lo, &r->has_hi, &r->hi,
        &labels, &elements, &method, &r->size, &r->adaptive, &r->error, &r->max_level,
        &r->improve, &min_island, &r->smooth, &edges, &r->graded, &r->coarsen, &r->max_edge,
        &r->min_edge, &r->distance, &r->grading, &r->tets, &r->size_field, &r->min_layers);
    Py_DECREF(empty);
    if (!ok) return -1;
    r->min_island = (size_t)(min_island < 1 ? 1 : min_island);
    r->elements = kind_parse(elements);
    if (!r->elements) {
        PyErr_Format(PyExc_ValueError, "unknown elements '%s'", elements);
        return -1;
    }
    r->surface_method = -1;
    if (r->elements == VM_TRI3 || r->elements == VM_QUAD4) {
        static const char *methods[] = {"dc", "mc", "asc", "cover"};
        static const vm_surface_method ids[] = {VM_SURFACE_DC, VM_SURFACE_MC, VM_SURFACE_ASC,
                                                VM_SURFACE_COVER};
        const char *m = method && method != Py_None ? PyUnicode_AsUTF8(method) : "dc";
        if (!m) return -1;
        for (int i = 0; i < 4; i++)
            if (!strcmp(m, methods[i])) r->surface_method = (int)ids[i];
        if (r->surface_method < 0) {
            PyErr_Format(PyExc_ValueError, "unknown surface method '%s'", m);
            return -1;
        }
    }
    if (edges && edges != Py_None && request_edges(edges, r)) return -1;
    if (labels && labels != Py_None) {
        r->labels = 1;
        if (PyUnicode_Check(labels)) return 0; /* "all", checked by the caller */
        PyObject *seq = PySequence_Fast(labels, "labels must be 'all' or a list of integers");
        if (!seq) return -1;
        Py_ssize_t n = PySequence_Fast_GET_SIZE(seq);
        r->label_list = malloc((size_t)(n ? n : 1) * sizeof *r->label_list);
        if (!r->label_list) {
            Py_DECREF(seq);
            PyErr_NoMemory();
            return -1;
        }
        for (Py_ssize_t i = 0; i < n; i++) {
            long l = PyLong_AsLong(PySequence_Fast_GET_ITEM(seq, i));
            if (l == -1 && PyErr_Occurred()) {
                Py_DECREF(seq);
                return -1;
            }
            r->label_list[i] = (int32_t)l;
        }
        r->nlabels = (size_t)n;
        Py_DECREF(seq);
    }
    return 0;
}

/* The material bounds and the progress hook, as every option struct of the library has them. */
#define SET_BOUNDS(o, r) ((o).lo = (r)->lo, (o).hi = (r)->hi, (o).has_lo = (r)->has_lo, \
                          (o).has_hi = (r)->has_hi)
#define SET_PROGRESS(o, fn, p) ((o).progress = (fn), (o).progress_user = (p))

/* The meshing pipeline of volmesh mesh (no GIL): labels, surface or volume, then the pass. */
static vm_status run_mesh(const vm_volume *v, const mesh_request *r, progress_ctx *p,
                          vm_mesh *m, vm_error *err) {
    vm_progress_fn fn = progress_call;
    vm_status s;
    if (r->labels) {
        vm_label_options lo;
        vm_label_options_default(&lo);
        lo.labels = r->label_list;
        lo.nlabels = r->nlabels;
        lo.elements = r->elements;
        lo.cell_size = r->size;
        lo.adaptive = r->adaptive;
        lo.max_level = r->max_level;
        lo.min_island = r->min_island;
        lo.smooth = r->smooth;
        lo.edges = r->edges;
        lo.nedges = r->nedges;
        lo.max_edge = r->max_edge;
        SET_PROGRESS(lo, fn, p);
        vm_label_stats st;
        s = vm_mesh_labels(v, &lo, m, &st, err);
        if (s) return s;
        vm_label_stats_free(&st);
        if (!r->improve || m->kind != VM_TET4) return VM_OK;
        vm_improve_options io;
        vm_improve_options_default(&io);
        SET_PROGRESS(io, fn, p);
        io.max_edge = lo.max_edge;
        vm_improve_report ir;
        s = vm_mesh_improve(m, NULL, &io, &ir, err);
        if (s) vm_mesh_free(m);
        return s;
    }
    if (r->surface_method >= 0) {
        vm_surface_options so;
        vm_surface_options_default(&so);
        SET_BOUNDS(so, r);
        so.method = (vm_surface_method)r->surface_method;
        so.elements = r->elements;
        so.cell_size = r->size;
        so.error = r->error;
        so.max_level = r->max_level;
        so.improve = r->improve;
        SET_PROGRESS(so, fn, p);
        return vm_surface_extract(v, &so, m, NULL, err);
    }
    vm_mesh_options o;
    vm_mesh_options_default(&o);
    SET_BOUNDS(o, r);
    o.elements = r->elements;
    o.cell_size = r->size;
    o.adaptive = r->adaptive;
    o.error = r->error;
    o.max_level = r->max_level;
    o.graded = r->graded;
    o.no_coarsen = !r->coarsen;
    o.max_edge = r->max_edge;
    o.min_edge = r->min_edge;
    o.distance = r->distance;
    o.grading = r->grading;
    o.tets = (size_t)r->tets;
    o.min_layers = r->min_layers;
    o.size_field = r->size_field ? &r->sf : NULL;
    SET_PROGRESS(o, fn, p);
    vm_mesh_stats st;
    memset(&st, 0, sizeof st);
    s = vm_mesh_volume(v, &o, m, &st, err);
    if (s || !r->improve) return s;
    if (m->kind == VM_TET4) {
        vm_improve_options io;
        vm_improve_options_default(&io);
        SET_BOUNDS(io, r);
        SET_PROGRESS(io, fn, p);
        io.max_edge = o.max_edge;
        if (o.graded) io.distance = st.distance;
        vm_improve_report ir;
        s = o.graded ? vm_mesh_improve_graded(m, v, &io, &ir, err)
                     : vm_mesh_improve(m, v, &io, &ir, err);
    } else if (m->kind == VM_HEX8) {
        vm_hex_improve_options ho;
        vm_hex_improve_options_default(&ho);
        SET_BOUNDS(ho, r);
        SET_PROGRESS(ho, fn, p);
        vm_hex_improve_report hr;
        s = vm_mesh_improve_hexes(m, v, &ho, &hr, err);
    }
    if (s) vm_mesh_free(m);
    return s;
}

/* mesh(data, (nx, ny, nz), spacing, origin, direction9, progress, **request) -> mesh tuple. */
static PyObject *py_mesh(PyObject *self, PyObject *args, PyObject *kw) {
    (void)self;
    PyObject *data, *spacing, *origin, *dir, *callback;
    long long nx, ny, nz;
    if (!PyArg_ParseTuple(args, "O(LLL)OOOO", &data, &nx, &ny, &nz, &spacing, &origin, &dir,
                          &callback))
        return NULL;
    mesh_request r;
    if (request_parse(kw, &r)) {
        request_free(&r);
        return NULL;
    }
    vm_volume v;
    memset(&v, 0, sizeof v);
    v.dims[0] = nx;
    v.dims[1] = ny;
    v.dims[2] = nz;
    v.type = VM_SCALAR_FLOAT32;
    snprintf(v.format, sizeof v.format, "numpy");
    Py_buffer view;
    if (volume_geometry(&v, spacing, origin, dir) ||
        PyObject_GetBuffer(data, &view, PyBUF_C_CONTIGUOUS)) {
        request_free(&r);
        return NULL;
    }
    if ((unsigned long long)view.len != (unsigned long long)(nx * ny * nz) * sizeof(float)) {
        PyBuffer_Release(&view);
        request_free(&r);
        return PyErr_Format(PyExc_ValueError, "the data holds %zd bytes, not %lld float32 values",
                            view.len, nx * ny * nz);
    }
    v.data = view.buf; /* lent: the library only reads it */
    Py_buffer sfview;
    memset(&sfview, 0, sizeof sfview);
    if (r.size_field) {
        PyObject *sdata, *ssp, *sor, *sdir;
        long long sx, sy, sz;
        if (!PyArg_ParseTuple(r.size_field, "O(LLL)OOO", &sdata, &sx, &sy, &sz, &ssp, &sor,
                              &sdir) ||
            sx < 1 || sy < 1 || sz < 1) {
            if (!PyErr_Occurred())
                PyErr_SetString(PyExc_ValueError, "size_field: dimensions must be >= 1");
            PyBuffer_Release(&view);
            request_free(&r);
            return NULL;
        }
        r.sf.dims[0] = sx;
        r.sf.dims[1] = sy;
        r.sf.dims[2] = sz;
        r.sf.type = VM_SCALAR_FLOAT32;
        snprintf(r.sf.format, sizeof r.sf.format, "numpy");
        if (volume_geometry(&r.sf, ssp, sor, sdir) ||
            PyObject_GetBuffer(sdata, &sfview, PyBUF_C_CONTIGUOUS)) {
            PyBuffer_Release(&view);
            request_free(&r);
            return NULL;
        }
        if ((unsigned long long)sfview.len != (unsigned long long)(sx * sy * sz) * sizeof(float)) {
            PyBuffer_Release(&sfview);
            PyBuffer_Release(&view);
            request_free(&r);
            return PyErr_Format(PyExc_ValueError, "size_field: the data holds %zd bytes, not "
                                "%lld float32 values", sfview.len, sx * sy * sz);
        }
        r.sf.data = sfview.buf;
    }
    progress_ctx p;
    progress_init(&p, callback);
    vm_mesh m;
    vm_mesh_init(&m, r.elements);
    vm_error err;
    vm_error_clear(&err);
    vm_status s;
    Py_BEGIN_ALLOW_THREADS s = run_mesh(&v, &r, &p, &m, &err);
    Py_END_ALLOW_THREADS PyBuffer_Release(&view);
    if (r.size_field) PyBuffer_Release(&sfview);
    request_free(&r);
    if (progress_finish(&p)) {
        if (!s) vm_mesh_free(&m);
        return NULL;
    }
    if (s) return raise_status(s, &err);
    return mesh_to_python(&m);
}

/* ---- the rest ---------------------------------------------------------------------------- */

/* set_threads(n) -> the number before (n <= 0: one per processor). */
static PyObject *py_set_threads(PyObject *self, PyObject *args) {
    (void)self;
    int n;
    if (!PyArg_ParseTuple(args, "i", &n)) return NULL;
    return PyLong_FromLong(vm_set_threads(n));
}

/* threads() -> how many threads the parallel stages use now. */
static PyObject *py_threads(PyObject *self, PyObject *noargs) {
    (void)self;
    (void)noargs;
    return PyLong_FromLong(vm_threads());
}

/* _set_error_class(cls): the exception class raised for library errors. */
static PyObject *py_set_error_class(PyObject *self, PyObject *cls) {
    (void)self;
    Py_XSETREF(error_class, Py_NewRef(cls));
    Py_RETURN_NONE;
}

static PyMethodDef methods[] = {
    {"read_volume", py_read_volume, METH_VARARGS, "read_volume(path) -> volume parts"},
    {"read_mesh", py_read_mesh, METH_VARARGS, "read_mesh(path) -> mesh parts"},
    {"write_mesh", py_write_mesh, METH_VARARGS, "write_mesh(path, mesh parts, options)"},
    {"quality_json", py_quality_json, METH_VARARGS, "quality_json(mesh parts, name) -> str"},
    {"mesh", (PyCFunction)(void (*)(void))py_mesh, METH_VARARGS | METH_KEYWORDS,
     "mesh(data, dims, spacing, origin, direction, progress, **request) -> mesh parts"},
    {"set_threads", py_set_threads, METH_VARARGS, "set_threads(n) -> previous count"},
    {"threads", py_threads, METH_NOARGS, "threads() -> thread count"},
    {"_set_error_class", py_set_error_class, METH_O, "the class of library errors"},
    {NULL, NULL, 0, NULL}};

static struct PyModuleDef module = {PyModuleDef_HEAD_INIT, "_volmesh",
                                    "libvolmesh, the C library behind the volmesh package", -1,
                                    methods, NULL, NULL, NULL, NULL};

PyMODINIT_FUNC PyInit__volmesh(void) {
    if (PyType_Ready(&BufType) < 0) return NULL;
    PyObject *mod = PyModule_Create(&module);
    if (!mod) return NULL;
    if (PyModule_AddStringConstant(mod, "version", VOLMESH_VERSION) ||
        PyModule_AddIntConstant(mod, "index_bytes", (long)sizeof(vm_index)) ||
        PyModule_AddIntConstant(mod, "exodus", vm_exodus_available())) {
        Py_DECREF(mod);
        return NULL;
    }
    return mod;
}
