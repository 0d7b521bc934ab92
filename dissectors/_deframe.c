/* The deframer's steady state in C (dissectors/deframer.py, Deframer._parse).
 *
 * deframe() walks a buffer from an index and turns what needs no decision into
 * events: whole frames whose checksum holds and that carry no start byte in
 * their payload, and simple response bytes. It stops at the first byte that
 * needs one (noise, a bad or incomplete frame) and returns its index; the
 * Python deframer handles that byte and calls deframe() again. whole() makes the
 * event of a read that is exactly one such token (Deframer._whole: the usual
 * read of a recording or a port) without a buffer. Only buffers with
 * no silence inside come here: no frame can be cut. Timed buffers come with
 * their segments (where each chunk starts, its time, its byte time), and each
 * event's times are worked out as Deframer._time_at does, in the same order of
 * operations, so they are the same floats (built with -ffp-contract=off: a
 * fused multiply-add would round differently).
 *
 * Events are made as copies of a blank Event made by Event's own __init__
 * (configure()), with the wire facts filled in: the defaults stay defined in
 * one place (dissectors/event.py), and no Python frame runs per event. The
 * pure-Python loop in deframer.py is the reference; the tests run on both.
 */

#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <structmember.h>

#define START 0xF8

/* what configure() was given: the Event type, a blank event, the offset of
 * every slot, and the offsets of the slots deframe() fills */
static PyTypeObject *event_type = NULL;
static PyObject *blank = NULL;
static Py_ssize_t *slot_offsets = NULL;
static Py_ssize_t n_slots = 0;
static Py_ssize_t off_line, off_offset, off_kind, off_raw, off_dst, off_src, off_payload, off_checksum_ok;

#define SLOT(obj, off) (*(PyObject **)((char *)(obj) + (off)))

static Py_ssize_t off_t0, off_t1;

/* a chunk of the buffer as Deframer._time_at sees it: from absolute offset
 * start, first byte at time t, byte_time each */
typedef struct {
    Py_ssize_t n;         /* segments */
    Py_ssize_t k;         /* the segment of the last offset asked for */
    PyObject *off, *t, *bt;   /* the deframer's lists (borrowed) */
} Segments;

/* when the byte at absolute offset off starts (after = 1: ends); offsets asked
 * for only grow during one call, so the segment is found by walking on.
 * -1: an error; 1: a time or byte time that is not a float (an int given by
 * hand: Python's arithmetic would keep it an int), for the Python loop. */
static int time_at(Segments *s, Py_ssize_t off, int after, double *out)
{
    /* bisect_right(seg_off, off) - 1, clamped at 0 */
    Py_ssize_t k = s->k;
    while (k + 1 < s->n) {
        Py_ssize_t next = PyLong_AsSsize_t(PyList_GET_ITEM(s->off, k + 1));
        if (next == -1 && PyErr_Occurred())
            return -1;
        if (next > off)
            break;
        k++;
    }
    s->k = k;
    Py_ssize_t start = PyLong_AsSsize_t(PyList_GET_ITEM(s->off, k));
    if (start == -1 && PyErr_Occurred())
        return -1;
    PyObject *tv = PyList_GET_ITEM(s->t, k), *btv = PyList_GET_ITEM(s->bt, k);
    if (!PyFloat_CheckExact(tv) || !PyFloat_CheckExact(btv))
        return 1;
    double t = PyFloat_AS_DOUBLE(tv);
    double bt = PyFloat_AS_DOUBLE(btv);
    double steps = (double)(off - start + after);
    double span = steps * bt;
    *out = t + span;
    return 0;
}

/* when an event's first byte starts and its last ends: 0, or time_at's -1 or 1 */
static int times(Segments *s, Py_ssize_t first, Py_ssize_t last, double *t0, double *t1)
{
    int r = time_at(s, first, 0, t0);
    return r != 0 ? r : time_at(s, last, 1, t1);
}

static int set_times(PyObject *ev, double t0, double t1)
{
    PyObject *a = PyFloat_FromDouble(t0);
    if (a == NULL)
        return -1;
    PyObject *b = PyFloat_FromDouble(t1);
    if (b == NULL) {
        Py_DECREF(a);
        return -1;
    }
    PyObject *old = SLOT(ev, off_t0);
    SLOT(ev, off_t0) = a;
    Py_XDECREF(old);
    old = SLOT(ev, off_t1);
    SLOT(ev, off_t1) = b;
    Py_XDECREF(old);
    return 0;
}

static int slot_offset(PyTypeObject *type, PyObject *name, Py_ssize_t *out)
{
    PyObject *descr = PyDict_GetItemWithError(type->tp_dict, name);   /* borrowed */
    if (descr == NULL) {
        if (!PyErr_Occurred())
            PyErr_Format(PyExc_TypeError, "event type has no slot %R", name);
        return -1;
    }
    if (!Py_IS_TYPE(descr, &PyMemberDescr_Type)) {
        PyErr_Format(PyExc_TypeError, "%R is not a slot of the event type", name);
        return -1;
    }
    PyMemberDef *m = ((PyMemberDescrObject *)descr)->d_member;
    if (m->type != T_OBJECT_EX) {
        PyErr_Format(PyExc_TypeError, "%R is not an object slot", name);
        return -1;
    }
    *out = m->offset;
    return 0;
}

static int named_offset(const char *name, Py_ssize_t *out)
{
    PyObject *s = PyUnicode_FromString(name);
    if (s == NULL)
        return -1;
    int r = slot_offset(event_type, s, out);
    Py_DECREF(s);
    return r;
}

/* configure(blank_event, slot_names): events are made like blank_event */
static PyObject *configure(PyObject *self, PyObject *args)
{
    PyObject *ev, *names;
    if (!PyArg_ParseTuple(args, "OO!:configure", &ev, &PyTuple_Type, &names))
        return NULL;
    PyTypeObject *type = Py_TYPE(ev);
    Py_ssize_t n = PyTuple_GET_SIZE(names);
    Py_ssize_t *offsets = PyMem_New(Py_ssize_t, n > 0 ? n : 1);
    if (offsets == NULL)
        return PyErr_NoMemory();
    PyTypeObject *old_type = event_type;
    event_type = type;
    for (Py_ssize_t k = 0; k < n; k++) {
        PyObject *name = PyTuple_GET_ITEM(names, k);
        if (slot_offset(type, name, &offsets[k]) < 0 || SLOT(ev, offsets[k]) == NULL) {
            if (!PyErr_Occurred())
                PyErr_Format(PyExc_ValueError, "the blank event has no value for %R", name);
            event_type = old_type;
            PyMem_Free(offsets);
            return NULL;
        }
    }
    if (named_offset("line", &off_line) < 0 || named_offset("offset", &off_offset) < 0
            || named_offset("kind", &off_kind) < 0 || named_offset("raw", &off_raw) < 0
            || named_offset("dst", &off_dst) < 0 || named_offset("src", &off_src) < 0
            || named_offset("payload", &off_payload) < 0
            || named_offset("checksum_ok", &off_checksum_ok) < 0
            || named_offset("t", &off_t0) < 0 || named_offset("t_end", &off_t1) < 0) {
        event_type = old_type;
        PyMem_Free(offsets);
        return NULL;
    }
    Py_INCREF(type);
    Py_XDECREF(old_type);
    Py_INCREF(ev);
    Py_XSETREF(blank, ev);
    PyMem_Free(slot_offsets);
    slot_offsets = offsets;
    n_slots = n;
    Py_RETURN_NONE;
}

static inline void set_slot(PyObject *ev, Py_ssize_t off, PyObject *value)   /* steals value */
{
    PyObject *old = SLOT(ev, off);
    SLOT(ev, off) = value;
    Py_XDECREF(old);
}

/* a copy of the blank event with the facts every event has (it takes over the
 * reference to raw, on error too); NULL on error */
static PyObject *new_event(PyObject *line, Py_ssize_t offset, PyObject *kind, PyObject *raw)
{
    PyObject *ev = event_type->tp_alloc(event_type, 0);
    if (ev == NULL) {
        Py_DECREF(raw);
        return NULL;
    }
    for (Py_ssize_t k = 0; k < n_slots; k++) {
        PyObject *v = SLOT(blank, slot_offsets[k]);
        Py_XINCREF(v);
        SLOT(ev, slot_offsets[k]) = v;
    }
    PyObject *off = PyLong_FromSsize_t(offset);
    if (off == NULL) {
        Py_DECREF(raw);
        Py_DECREF(ev);
        return NULL;
    }
    Py_INCREF(line);
    set_slot(ev, off_line, line);
    set_slot(ev, off_offset, off);
    Py_INCREF(kind);
    set_slot(ev, off_kind, kind);
    set_slot(ev, off_raw, raw);   /* steals raw */
    return ev;
}

/* The event of a whole valid frame of n bytes at p (its checksum checked), at
 * absolute offset offset; NULL with an exception set. */
static PyObject *frame_event(const unsigned char *p, Py_ssize_t n, PyObject *line, Py_ssize_t offset,
                             PyObject *frame_kind)
{
    PyObject *raw = PyBytes_FromStringAndSize((const char *)p, n);
    if (raw == NULL)
        return NULL;
    PyObject *ev = new_event(line, offset, frame_kind, raw);
    if (ev == NULL)
        return NULL;
    PyObject *dst = Py_BuildValue("(iii)", p[1], p[2], p[3]);
    PyObject *src = PyLong_FromLong(p[4]);
    PyObject *payload = PyBytes_FromStringAndSize((const char *)p + 6, n - 7);
    if (dst == NULL || src == NULL || payload == NULL) {
        Py_XDECREF(dst);
        Py_XDECREF(src);
        Py_XDECREF(payload);
        Py_DECREF(ev);
        return NULL;
    }
    set_slot(ev, off_dst, dst);
    set_slot(ev, off_src, src);
    set_slot(ev, off_payload, payload);
    Py_INCREF(Py_True);
    set_slot(ev, off_checksum_ok, Py_True);
    return ev;
}

/* The event of the simple response byte at p, of kind kind. */
static PyObject *simple_event(const unsigned char *p, PyObject *line, Py_ssize_t offset, PyObject *kind)
{
    PyObject *raw = PyBytes_FromStringAndSize((const char *)p, 1);
    return raw == NULL ? NULL : new_event(line, offset, kind, raw);
}

/* the length of the whole valid frame at p (n bytes available, p[0] a start
 * byte), or 0: cut short, a checksum that fails, or a start byte inside the
 * payload (deframer._suspect) */
static Py_ssize_t valid_frame(const unsigned char *p, Py_ssize_t n)
{
    if (n < 6)
        return 0;
    Py_ssize_t len = (p[5] ? p[5] : 256) + 7;
    if (len > n)
        return 0;
    unsigned int sum = 0;
    for (Py_ssize_t k = 1; k < len - 1; k++)
        sum += p[k];
    if ((sum & 0xFF) != p[len - 1])
        return 0;
    if (memchr(p + 6, START, (size_t)(len - 7)) != NULL)
        return 0;
    return len;
}

/* deframe(buf, i, kinds, line, frame_kind, base, out[, seg_off, seg_t, seg_bt])
 * -> index of the first byte not turned into an event. kinds: a 256-tuple, the
 * simple response kind of each byte value or None. The segments, for a timed
 * buffer: the deframer's lists of where each chunk starts, its first byte's
 * time and its byte time. */
/* Give a new event its times (a timed buffer) and append it to out; steals ev.
   0, or -1 with an exception set. */
static int emit(PyObject *out, PyObject *ev, int timed, double t0, double t1)
{
    int r = (timed && set_times(ev, t0, t1) < 0) ? -1 : PyList_Append(out, ev);
    Py_DECREF(ev);
    return r;
}

static PyObject *deframe(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    if (nargs != 7 && nargs != 10) {
        PyErr_SetString(PyExc_TypeError, "deframe() takes 7 or 10 arguments");
        return NULL;
    }
    PyObject *bufobj = args[0], *kinds = args[2], *line = args[3], *frame_kind = args[4], *out = args[6];
    if (!PyBytes_Check(bufobj) || !PyTuple_Check(kinds) || PyTuple_GET_SIZE(kinds) != 256 || !PyList_Check(out)) {
        PyErr_SetString(PyExc_TypeError, "deframe(bytes, int, 256-tuple, str, str, int, list[, list, list, list])");
        return NULL;
    }
    Segments seg = {0, 0, NULL, NULL, NULL};
    Segments *timed = NULL;
    if (nargs == 10) {
        if (!PyList_Check(args[7]) || !PyList_Check(args[8]) || !PyList_Check(args[9])) {
            PyErr_SetString(PyExc_TypeError, "deframe(): the segments are lists");
            return NULL;
        }
        seg.off = args[7];
        seg.t = args[8];
        seg.bt = args[9];
        seg.n = PyList_GET_SIZE(seg.off);
        if (PyList_GET_SIZE(seg.t) != seg.n || PyList_GET_SIZE(seg.bt) != seg.n) {
            PyErr_SetString(PyExc_ValueError, "deframe(): segment lists of different lengths");
            return NULL;
        }
        if (seg.n == 0)   /* nothing to time bytes by: the Python loop decides */
            return PyLong_FromSsize_t(PyLong_AsSsize_t(args[1]));
        timed = &seg;
    }
    if (event_type == NULL) {
        PyErr_SetString(PyExc_RuntimeError, "deframe() before configure()");
        return NULL;
    }
    Py_ssize_t i = PyLong_AsSsize_t(args[1]);
    if (i == -1 && PyErr_Occurred())
        return NULL;
    Py_ssize_t base = PyLong_AsSsize_t(args[5]);
    if (base == -1 && PyErr_Occurred())
        return NULL;
    const unsigned char *buf = (const unsigned char *)PyBytes_AS_STRING(bufobj);
    Py_ssize_t n = PyBytes_GET_SIZE(bufobj);
    if (i < 0)
        i = 0;

    while (i < n) {
        unsigned char b = buf[i];
        if (b == START) {
            Py_ssize_t len = valid_frame(buf + i, n - i);
            if (len == 0)
                break;
            Py_ssize_t end = i + len;
            double t0 = 0.0, t1 = 0.0;
            if (timed != NULL) {
                int r = times(timed, base + i, base + end - 1, &t0, &t1);
                if (r < 0)
                    return NULL;
                if (r > 0)
                    break;
            }
            PyObject *ev = frame_event(buf + i, end - i, line, base + i, frame_kind);
            if (ev == NULL)
                return NULL;
            if (emit(out, ev, timed != NULL, t0, t1) < 0)
                return NULL;
            i = end;
            continue;
        }
        PyObject *kind = PyTuple_GET_ITEM(kinds, b);
        if (kind == Py_None)
            break;
        double t0 = 0.0, t1 = 0.0;
        if (timed != NULL) {
            int r = times(timed, base + i, base + i, &t0, &t1);
            if (r < 0)
                return NULL;
            if (r > 0)
                break;
        }
        PyObject *ev = simple_event(buf + i, line, base + i, kind);
        if (ev == NULL)
            return NULL;
        if (emit(out, ev, timed != NULL, t0, t1) < 0)
            return NULL;
        i += 1;
    }
    return PyLong_FromSsize_t(i);
}

/* whole(data, t, bt, base, line, frame_kind, kinds) -> Event or None: the event
 * Deframer._whole makes of a read that is exactly one whole valid frame or one
 * simple response byte, timed from t (None: untimed) at bt a byte; None for
 * anything else, and for times that are not floats (the Python path decides). */
static PyObject *whole(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    if (nargs != 7) {
        PyErr_SetString(PyExc_TypeError, "whole() takes 7 arguments");
        return NULL;
    }
    PyObject *data = args[0], *t = args[1], *bt = args[2], *line = args[4], *frame_kind = args[5];
    PyObject *kinds = args[6];
    if (!PyBytes_Check(data) || !PyTuple_Check(kinds) || PyTuple_GET_SIZE(kinds) != 256) {
        PyErr_SetString(PyExc_TypeError, "whole(bytes, float|None, float, int, str, str, 256-tuple)");
        return NULL;
    }
    if (event_type == NULL) {
        PyErr_SetString(PyExc_RuntimeError, "whole() before configure()");
        return NULL;
    }
    int timed = t != Py_None;
    if (timed && (!PyFloat_CheckExact(t) || !PyFloat_CheckExact(bt)))
        Py_RETURN_NONE;
    Py_ssize_t base = PyLong_AsSsize_t(args[3]);
    if (base == -1 && PyErr_Occurred())
        return NULL;
    const unsigned char *p = (const unsigned char *)PyBytes_AS_STRING(data);
    Py_ssize_t n = PyBytes_GET_SIZE(data);
    PyObject *ev;
    if (n == 1) {
        PyObject *kind = PyTuple_GET_ITEM(kinds, p[0]);
        if (kind == Py_None)
            Py_RETURN_NONE;
        ev = simple_event(p, line, base, kind);
    } else {
        if (n == 0 || p[0] != START || valid_frame(p, n) != n)
            Py_RETURN_NONE;
        ev = frame_event(p, n, line, base, frame_kind);
    }
    if (ev == NULL)
        return NULL;
    if (timed) {
        /* as Deframer._whole: t + n * bt */
        double t0 = PyFloat_AS_DOUBLE(t);
        if (set_times(ev, t0, t0 + (double)n * PyFloat_AS_DOUBLE(bt)) < 0) {
            Py_DECREF(ev);
            return NULL;
        }
    }
    return ev;
}

static PyMethodDef methods[] = {
    {"configure", configure, METH_VARARGS, "configure(blank_event, slot_names): events are made as copies of it"},
    {"deframe", (PyCFunction)(void (*)(void))deframe, METH_FASTCALL,
     "deframe(buf, i, kinds, line, frame_kind, base, out) -> index: whole valid frames and simple responses from i"},
    {"whole", (PyCFunction)(void (*)(void))whole, METH_FASTCALL,
     "whole(data, t, bt, base, line, frame_kind, kinds) -> Event or None: a read that is one whole token"},
    {NULL, NULL, 0, NULL},
};

static struct PyModuleDef module = {
    PyModuleDef_HEAD_INIT, "dissectors._deframe",
    "The deframer's steady state in C (dissectors/deframer.py).", -1, methods,
};

PyMODINIT_FUNC PyInit__deframe(void)
{
    PyObject *m = PyModule_Create(&module);
    /* what deframe() takes and does; deframer.py uses only the version it was written
     * for (a stale build left in a source tree falls back to the pure loop) */
    if (m != NULL && PyModule_AddIntConstant(m, "INTERFACE", 4) < 0) {
        Py_DECREF(m);
        return NULL;
    }
    return m;
}
