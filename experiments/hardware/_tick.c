/* The emulated firmware's 10 ms tick, compiled: the steady ticks of Device.step, bit for bit.
 *
 * experiments/hardware/device.py (Device.step) and pad_physics.py (PadPlant.step,
 * FingerSkin.step, FingerScript.force) are the reference: this file is their transcription,
 * kept to the same arithmetic in the same order (IEEE doubles, no contraction into fused
 * multiply-adds: the build passes -ffp-contract=off), so that every double it computes is the
 * one the Python tick computes. The skin's product is numpy's own dot, called as the Python
 * tick calls it. tests/experiments/hardware/test_compiled_tick.py compares the two tick for tick.
 *
 * What is compiled: a tick that changes no state (IDLE with nothing to report, ARMED, PLAYING,
 * RECORDING), raises no event, writes no log and trips no monitor -- the ~900 ticks of a trial
 * but a handful. Any other tick (the watchdog, READY, CONTACT, END, a safety trip, a fault
 * hook, FAULT, a record-mode curve still to compute, a reading whose rounding needs Python's
 * correctly rounded round(v, 3), a telemetry value beyond int16) is handed to Device.step: the
 * compiled tick is computed on a copy of the state and dropped, so Python sees the tick whole
 * (only the skin's boundary cell and its next state vector may already be written: Python's tick
 * writes both again before it reads them). A replaced tick method (a subclass, a test's spy)
 * also ticks in Python; the numbers written here as literals are checked against Python's when
 * the module is configured (compiled_tick.py), and the finger's press curve (FingerScript.force)
 * by the tick-for-tick tests.
 *
 * Entry point: read_ticks(dev, frames, budget), the tick loop of
 * protocol_emulator.Serial.read_frames on a virtual clock with no fault (tick until the device
 * has something to say, at most `budget` ticks, then up to two more while it is not IDLE).
 * NormalStream: the seeded noise block, cycled (pad_physics.normal_stream), whose position the
 * compiled tick can read and advance.
 */
#define PY_SSIZE_T_CLEAN
#include <Python.h>
/* no fused multiply-add, whatever the build flags (GCC: -ffp-contract=off in setup.py) */
#if defined(_MSC_VER)
#pragma fp_contract(off)
#elif defined(__clang__)
#pragma STDC FP_CONTRACT OFF
#endif
#include <math.h>
#include <string.h>

/* device_constants.py, pad_physics.py */
#define TICK_US 10000LL
#define HARD_MIN_C 10.0
#define SETPOINT_MAX_C 44.5
#define HARD_RATE_C_PER_S 100.0
#define WATCHDOG_US (90LL * 1000LL)
#define RATE_WINDOW_TICKS 10
#define RATE_SLACK_C 0.01
#define READY_BAND_C 0.1
#define RELEASE_US (50LL * 1000LL)
#define OVERTEMP_C (45.0 - 0.2)
#define HEATSINK_MAX_C 70.0
#define STUCK_SAMPLES 20
#define CONTACT_AREA_M2 135e-6
#define KELVIN 273.15
#define TEL_SIZE 30
#define MSG_TELEMETRY 0xA0

enum { IDLE = 0, ARMED = 1, PLAYING = 2, RECORDING = 3, FAULT = 4 };
enum { PLAYBACK = 0, RECORD = 1 };
enum { TICK_DONE = 1, TICK_PYTHON = 0, TICK_ERROR = -1 };

/* ------------------------------------------------------------------ NormalStream */
typedef struct {
    PyObject_HEAD
    double *v;
    Py_ssize_t n, pos;
} NormalStream;

static PyTypeObject NormalStreamType;

static int
ns_init(NormalStream *self, PyObject *args, PyObject *kw)
{
    PyObject *seq, *fast;
    if (!PyArg_ParseTuple(args, "O", &seq))
        return -1;
    fast = PySequence_Fast(seq, "NormalStream: expected a sequence of floats");
    if (fast == NULL)
        return -1;
    Py_ssize_t n = PySequence_Fast_GET_SIZE(fast);
    if (n == 0) {
        Py_DECREF(fast);
        PyErr_SetString(PyExc_ValueError, "NormalStream: expected at least one value");
        return -1;
    }
    double *v = PyMem_Malloc(sizeof(double) * n);
    if (v == NULL) {
        Py_DECREF(fast);
        PyErr_NoMemory();
        return -1;
    }
    for (Py_ssize_t i = 0; i < n; i++) {
        v[i] = PyFloat_AsDouble(PySequence_Fast_GET_ITEM(fast, i));
        if (v[i] == -1.0 && PyErr_Occurred()) {
            PyMem_Free(v);
            Py_DECREF(fast);
            return -1;
        }
    }
    Py_DECREF(fast);
    PyMem_Free(self->v);
    self->v = v;
    self->n = n;
    self->pos = 0;
    return 0;
}

static void
ns_dealloc(NormalStream *self)
{
    PyMem_Free(self->v);
    Py_TYPE(self)->tp_free((PyObject *)self);
}

static PyObject *
ns_next(NormalStream *self)
{
    if (self->v == NULL) {
        PyErr_SetString(PyExc_ValueError, "NormalStream: not initialised");
        return NULL;
    }
    double x = self->v[self->pos];
    if (++self->pos == self->n)
        self->pos = 0;
    return PyFloat_FromDouble(x);
}

static PyObject *
ns_get_pos(NormalStream *self, void *closure)
{
    return PyLong_FromSsize_t(self->pos);
}

static PyGetSetDef ns_getset[] = {
    {"pos", (getter)ns_get_pos, NULL, "index of the next value", NULL},
    {NULL}
};

static PyTypeObject NormalStreamType = {
    PyVarObject_HEAD_INIT(NULL, 0)
    .tp_name = "experiments.hardware._tick.NormalStream",
    .tp_basicsize = sizeof(NormalStream),
    .tp_flags = Py_TPFLAGS_DEFAULT,
    .tp_doc = "NormalStream(values): an endless iterator over values, cycled.",
    .tp_new = PyType_GenericNew,
    .tp_init = (initproc)ns_init,
    .tp_dealloc = (destructor)ns_dealloc,
    .tp_iter = PyObject_SelfIter,
    .tp_iternext = (iternextfunc)ns_next,
    .tp_getset = ns_getset,
};

static inline double
draw(const NormalStream *s, Py_ssize_t *pos)
{
    double x = s->v[*pos];
    if (++*pos == s->n)
        *pos = 0;
    return x;
}

/* ------------------------------------------------------------------ configuration */
static PyObject *FrameType = NULL;     /* framing.Frame */
static PyObject *DotFunc = NULL;       /* numpy.dot, as pad_physics calls it */
static PyObject *OutKwnames = NULL;    /* ("out",) */
/* The Python methods this file transcribes (configure()): a device, plant, skin or finger
 * whose class or instance has another one (a subclass, a test's spy) ticks in Python. */
enum { M_DEVICE_STEP, M_DEVICE_SAMPLE, M_PLANT_STEP, M_SKIN_STEP, M_SKIN_SURFACE, M_FINGER_FORCE,
       N_METHODS };
static PyObject *Original[N_METHODS];
static const char *const MethodOf[N_METHODS] = {"step", "_sample_reading", "step", "step",
                                                  "surface_C", "force"};
static PyObject *MethodName[N_METHODS];      /* interned at import */

/* interned attribute names */
#define NAMES(X) \
    X(time_us) X(boot_us) X(state) X(last_rx_us) X(faults) X(stalled) X(finger) X(noise) \
    X(params) X(lim_rate) X(lim_min) X(lim_max) X(tick_s) X(touch_us) X(sp) X(profile) \
    X(contact_us) X(arm_mode) X(neutral) X(_sp_window) X(skin) X(plant) X(enabled) X(threshold) \
    X(fresh) X(ready) X(ready_count) X(release_count) X(max_duration_us) X(counter) X(tx_seq) \
    X(sample) X(curves) X(finger_C) X(ambient_C) X(contact_C) X(forces) X(temperature_C) \
    X(noise_force) X(room) X(noise_ambient) X(noise_sensor) \
    X(start_us) X(press_after_s) X(force_N) X(hold_s) \
    X(_x) X(_x_next) X(_ab) X(_heads) X(_g) X(n) X(surface_node) X(flux) X(conductivity) \
    X(_touch) X(_air) \
    X(_consts) X(pad) X(hs) X(sensor_state) X(_y_prev) X(_q_prev) X(d_hat) X(sensor_override) \
    X(sensor_frozen) X(stuck_current) X(trip_C) X(tripped) X(sensor) X(same_count) X(current) \
    X(step) X(extend) X(maxlen)

#define DECL(name) static PyObject *s_##name;
NAMES(DECL)
#undef DECL

/* ------------------------------------------------------------------ the state */
typedef struct {
    /* device */
    long long time_us, boot_us, last_rx_us, contact_us, max_duration_us, touch_us;
    int has_touch;
    int state, arm_mode, enabled, fresh, ready;
    long long ready_count, release_count, counter;
    int tx_seq;
    double lim_rate, lim_min, lim_max, tick_s, sp, neutral, threshold;
    double f[4], finger_C, ambient_C, contact_C;
    double noise_force, room, noise_ambient, noise_sensor;
    NormalStream *noise;
    Py_ssize_t noise_pos;
    /* finger script */
    int has_fin, fin_started;
    long long fin_start_us;
    double press_after, force_N, hold_s;
    /* profile */
    int has_profile;
    PyObject *vals;                    /* borrowed (a list, held by dev.profile) */
    Py_ssize_t nvals;
    long long dt_us;
    /* rate window: the last RATE_WINDOW_TICKS setpoints, oldest first */
    double win[RATE_WINDOW_TICKS];
    int win_n;
    int win_added;                     /* setpoints appended since the load */
    /* skin (has_skin) */
    int has_skin;
    PyObject *x, *xn, *head_x, *head_xn, *ab_t, *ab_f;     /* borrowed */
    double *xd, *xnd;
    Py_ssize_t n;
    double g_t, g_f, w_t, w_f, surface_node, flux, conductivity;
    /* record mode */
    int has_curves;
    long long curves_touch;
    PyObject *tm, *ts;                 /* borrowed lists */
    double sample_T;
    /* plant */
    double dtc, C, K, a, Re, ch, kh, ah, rh, kp, imax, g_obs, lag, pnoise, g_hs, p_room, C_hs;
    long n_sub;
    NormalStream *pnz;
    Py_ssize_t pnoise_pos;
    double pad, hs, s_state, y_prev, q_prev, d_hat, y, current, trip;
    long long same;
    /* the instance dictionaries written back (borrowed: their objects hold them) */
    PyObject *dev_d, *skin_d, *plant_d;
    /* bookkeeping */
    int ticked;                        /* compiled ticks since the last load */
} St;

/* Attribute helpers. They read and write the objects' instance dictionaries (the attributes
 * are plain instance attributes: no descriptor, no __setattr__ on these classes), which costs
 * half of a getattr; 1 ok, 0 missing or not of the type the compiled tick assumes (a float
 * exactly, an int), -1 error (exception set). */
static int
get_d(PyObject *d, PyObject *name, double *out)
{
    PyObject *v = PyDict_GetItemWithError(d, name);
    if (v == NULL)
        return PyErr_Occurred() ? -1 : 0;
    if (!PyFloat_CheckExact(v))
        return 0;
    *out = PyFloat_AS_DOUBLE(v);
    return 1;
}

static int
as_ll(PyObject *v, long long *out)
{
    if (!PyLong_Check(v))
        return 0;
    int overflow;
    *out = PyLong_AsLongLongAndOverflow(v, &overflow);
    if (*out == -1 && PyErr_Occurred())
        return -1;
    return overflow == 0;
}

static int
get_ll(PyObject *d, PyObject *name, long long *out)
{
    PyObject *v = PyDict_GetItemWithError(d, name);
    if (v == NULL)
        return PyErr_Occurred() ? -1 : 0;
    return as_ll(v, out);
}

static int
get_truth(PyObject *d, PyObject *name, int *out)
{
    PyObject *v = PyDict_GetItemWithError(d, name);
    if (v == NULL)
        return PyErr_Occurred() ? -1 : 0;
    *out = PyObject_IsTrue(v);
    return *out < 0 ? -1 : 1;
}

/* None or an int: has = 0 | 1 */
static int
get_opt_ll(PyObject *d, PyObject *name, int *has, long long *out)
{
    PyObject *v = PyDict_GetItemWithError(d, name);
    if (v == NULL)
        return PyErr_Occurred() ? -1 : 0;
    *has = v != Py_None;
    *out = 0;
    return v == Py_None ? 1 : as_ll(v, out);
}

/* the helpers' 1 goes on; their 0 (not applicable) and -1 (error) are load()'s answer */
#define TRY(expr) do { int r_ = (expr); if (r_ != 1) return r_; } while (0)
/* var = d[name], borrowed (the object holds it); missing: not applicable */
#define BORROW(var, d, name) do { \
        if (((var) = PyDict_GetItemWithError((d), (name))) == NULL) \
            return PyErr_Occurred() ? -1 : 0; } while (0)
/* var = the instance dictionary of obj, borrowed; none (slots): not applicable */
#define DICT(var, obj) do { \
        PyObject *d_ = PyObject_GenericGetDict((obj), NULL); \
        if (d_ == NULL) { PyErr_Clear(); return 0; } \
        Py_DECREF(d_); \
        if (!PyDict_CheckExact(d_)) return 0; \
        (var) = d_; } while (0)

/* 1: obj's class has the original method m and its instance dict d does not shadow it. The
 * answer per class is kept until the class changes (its version tag). */
static struct {
    PyTypeObject *type;
    unsigned int tag;
} method_ok[N_METHODS][4];

static int
original_method(PyObject *obj, PyObject *d, int m)
{
    PyObject *name = MethodName[m];
    PyObject *shadow = PyDict_GetItemWithError(d, name);
    if (shadow != NULL || PyErr_Occurred())
        return shadow != NULL ? 0 : -1;
    PyTypeObject *t = Py_TYPE(obj);
    int tagged = PyType_HasFeature(t, Py_TPFLAGS_VALID_VERSION_TAG);
    for (int i = 0; tagged && i < 4; i++)
        if (method_ok[m][i].type == t && method_ok[m][i].tag == t->tp_version_tag)
            return 1;
    PyObject *f = PyObject_GetAttr((PyObject *)t, name);
    if (f == NULL)
        return -1;
    int same = f == Original[m];
    Py_DECREF(f);
    if (same && PyType_HasFeature(t, Py_TPFLAGS_VALID_VERSION_TAG)) {
        memmove(&method_ok[m][1], &method_ok[m][0], 3 * sizeof(method_ok[m][0]));
        method_ok[m][0].type = t;      /* a class is not freed while an instance is alive */
        method_ok[m][0].tag = t->tp_version_tag;
    }
    return same;
}

static int
set_d(PyObject *d, PyObject *name, double x)
{
    PyObject *v = PyFloat_FromDouble(x);
    if (v == NULL)
        return -1;
    int r = PyDict_SetItem(d, name, v);
    Py_DECREF(v);
    return r;
}

static int
set_ll(PyObject *d, PyObject *name, long long x)
{
    PyObject *v = PyLong_FromLongLong(x);
    if (v == NULL)
        return -1;
    int r = PyDict_SetItem(d, name, v);
    Py_DECREF(v);
    return r;
}

/* a float of a list of floats (the profile, the sample's curves), checked where it is read:
 * 1 and *out, or 0 when it is not a float (the tick is then Python's) */
static inline int
list_float(PyObject *lst, Py_ssize_t i, double *out)
{
    PyObject *v = PyList_GET_ITEM(lst, i);
    if (!PyFloat_CheckExact(v))
        return 0;
    *out = PyFloat_AS_DOUBLE(v);
    return 1;
}

/* a float of a tuple already checked to hold floats */
static inline double
tuple_d(PyObject *tup, Py_ssize_t i)
{
    return PyFloat_AS_DOUBLE(PyTuple_GET_ITEM(tup, i));
}

static PyObject *
dict_item(PyObject *d, PyObject *key)
{
    if (!PyDict_Check(d))
        return NULL;
    return PyDict_GetItemWithError(d, key);   /* borrowed */
}

/* The skin's two state vectors: their data and their head views (FingerSkin._heads), kept
 * from call to call for the last few arrays seen (a buffer export of a numpy array costs more
 * than a tick). The cache holds a reference to each, so an entry's identity stays its own. */
typedef struct {
    PyObject *arr, *head;
    Py_buffer b;
} BufEntry;
#define N_BUF_CACHE 4
static BufEntry buf_cache[N_BUF_CACHE];
static int buf_next;

/* 1 and data/head, 0 not applicable, -1 error */
static int
state_vector(PyObject *arr, PyObject *heads, Py_ssize_t need, double **data, PyObject **head)
{
    for (int i = 0; i < N_BUF_CACHE; i++) {
        BufEntry *e = &buf_cache[i];
        if (e->arr == arr && e->b.len >= (Py_ssize_t)(need * sizeof(double))) {
            *data = (double *)e->b.buf;
            *head = e->head;
            return 1;
        }
    }
    PyObject *key = PyLong_FromVoidPtr(arr), *h;
    if (key == NULL)
        return -1;
    h = dict_item(heads, key);
    Py_DECREF(key);
    if (h == NULL)
        return PyErr_Occurred() ? -1 : 0;
    Py_buffer b;
    if (PyObject_GetBuffer(arr, &b, PyBUF_WRITABLE | PyBUF_C_CONTIGUOUS | PyBUF_FORMAT) < 0) {
        PyErr_Clear();                 /* not a writable contiguous array: Python's tick */
        return 0;
    }
    const char *f = b.format;
    if (f != NULL && (f[0] == '@' || f[0] == '=' || f[0] == '<'))
        f++;
    if (b.itemsize != 8 || f == NULL || strcmp(f, "d") != 0
            || b.len < (Py_ssize_t)(need * sizeof(double))) {
        PyBuffer_Release(&b);
        return 0;
    }
    BufEntry *e = &buf_cache[buf_next];
    buf_next = (buf_next + 1) % N_BUF_CACHE;
    if (e->arr != NULL) {
        PyBuffer_Release(&e->b);
        Py_CLEAR(e->arr);
        Py_CLEAR(e->head);
    }
    e->b = b;                          /* the buffer holds its own reference to arr */
    Py_INCREF(arr);
    e->arr = arr;
    Py_INCREF(h);
    e->head = h;
    *data = (double *)b.buf;
    *head = h;
    return 1;
}

/* Read the device's state. 1: the compiled tick applies; 0: it does not (Python ticks);
 * -1: error. */
static int
load(St *s, PyObject *dev)
{
    PyObject *D, *obj;
    long long v;
    int t;
    memset(s, 0, sizeof(*s));
    DICT(D, dev);
    s->dev_d = D;
    TRY(original_method(dev, D, M_DEVICE_STEP));
    TRY(original_method(dev, D, M_DEVICE_SAMPLE));
    /* a fault spec or a stall: the faults' own code paths live in Python */
    TRY(get_truth(D, s_faults, &t));
    if (t)
        return 0;
    TRY(get_truth(D, s_stalled, &t));
    if (t)
        return 0;
    TRY(get_ll(D, s_state, &v));
    if (v < IDLE || v >= FAULT)
        return 0;
    s->state = (int)v;
    TRY(get_ll(D, s_arm_mode, &v));
    if (v != PLAYBACK && v != RECORD)
        return 0;
    s->arm_mode = (int)v;
    TRY(get_ll(D, s_time_us, &s->time_us));
    TRY(get_ll(D, s_boot_us, &s->boot_us));
    TRY(get_ll(D, s_last_rx_us, &s->last_rx_us));
    TRY(get_ll(D, s_contact_us, &s->contact_us));
    TRY(get_ll(D, s_max_duration_us, &s->max_duration_us));
    TRY(get_opt_ll(D, s_touch_us, &s->has_touch, &s->touch_us));
    TRY(get_truth(D, s_enabled, &s->enabled));
    TRY(get_truth(D, s_fresh, &s->fresh));
    TRY(get_truth(D, s_ready, &s->ready));
    TRY(get_ll(D, s_ready_count, &s->ready_count));
    TRY(get_ll(D, s_release_count, &s->release_count));
    TRY(get_ll(D, s_counter, &s->counter));
    TRY(get_ll(D, s_tx_seq, &v));
    if (v < 0 || v > 0xFF)
        return 0;
    s->tx_seq = (int)v;
    TRY(get_d(D, s_lim_rate, &s->lim_rate));
    TRY(get_d(D, s_lim_min, &s->lim_min));
    TRY(get_d(D, s_lim_max, &s->lim_max));
    TRY(get_d(D, s_tick_s, &s->tick_s));
    TRY(get_d(D, s_sp, &s->sp));
    TRY(get_d(D, s_neutral, &s->neutral));
    TRY(get_d(D, s_threshold, &s->threshold));
    TRY(get_d(D, s_finger_C, &s->finger_C));
    TRY(get_d(D, s_ambient_C, &s->ambient_C));
    TRY(get_d(D, s_contact_C, &s->contact_C));
    /* noise */
    BORROW(obj, D, s_noise);
    if (Py_TYPE(obj) != &NormalStreamType)
        return 0;
    s->noise = (NormalStream *)obj;
    if (s->noise->v == NULL)
        return 0;
    s->noise_pos = s->noise->pos;
    BORROW(obj, D, s_params);
    DICT(obj, obj);
    TRY(get_d(obj, s_noise_force, &s->noise_force));
    TRY(get_d(obj, s_room, &s->room));
    TRY(get_d(obj, s_noise_ambient, &s->noise_ambient));
    TRY(get_d(obj, s_noise_sensor, &s->noise_sensor));
    /* finger script (the class itself: a subclass may move differently) */
    BORROW(obj, D, s_finger);
    if (obj != Py_None) {
        PyObject *fin = obj;
        s->has_fin = 1;
        DICT(obj, fin);
        TRY(original_method(fin, obj, M_FINGER_FORCE));
        TRY(get_opt_ll(obj, s_start_us, &s->fin_started, &s->fin_start_us));
        TRY(get_d(obj, s_press_after_s, &s->press_after));
        TRY(get_d(obj, s_force_N, &s->force_N));
        TRY(get_d(obj, s_hold_s, &s->hold_s));
    }
    /* profile: (values, dt_us) or None */
    BORROW(obj, D, s_profile);
    if (obj != Py_None) {
        if (!PyTuple_Check(obj) || PyTuple_GET_SIZE(obj) != 2 || !PyList_CheckExact(PyTuple_GET_ITEM(obj, 0))
                || !PyLong_CheckExact(PyTuple_GET_ITEM(obj, 1)))
            return 0;
        s->vals = PyTuple_GET_ITEM(obj, 0);
        s->nvals = PyList_GET_SIZE(s->vals);
        int overflow;
        s->dt_us = PyLong_AsLongLongAndOverflow(PyTuple_GET_ITEM(obj, 1), &overflow);
        if (s->dt_us == -1 && PyErr_Occurred())
            return -1;
        if (overflow || s->nvals == 0 || s->dt_us <= 0 || s->dt_us > (1LL << 40))
            return 0;
        s->has_profile = 1;
    }
    if ((s->state == PLAYING || (s->state == ARMED && s->arm_mode == PLAYBACK)) && !s->has_profile)
        return 0;
    /* exact int-to-double conversions below (Python's int / int divides the doubles then) */
    if (s->time_us > (1LL << 52) || s->time_us < 0 || s->contact_us > (1LL << 52) || s->contact_us < 0)
        return 0;
    /* rate window */
    BORROW(obj, D, s__sp_window);
    if (strcmp(Py_TYPE(obj)->tp_name, "collections.deque") != 0)
        return 0;
    {
        PyObject *ml = PyObject_GetAttr(obj, s_maxlen);
        if (ml == NULL)
            return -1;
        long maxlen = (ml == Py_None || !PyLong_Check(ml)) ? -1 : PyLong_AsLong(ml);
        Py_DECREF(ml);
        if (maxlen == -1 && PyErr_Occurred()) {
            PyErr_Clear();             /* beyond a C long: not the firmware's window */
            return 0;
        }
        if (maxlen != RATE_WINDOW_TICKS)
            return 0;
        Py_ssize_t k = PyObject_Length(obj);
        if (k < 1 || k > RATE_WINDOW_TICKS)
            return k < 0 ? -1 : 0;
        PyObject *it = PyObject_GetIter(obj), *item;
        if (it == NULL)
            return -1;
        s->win_n = 0;
        while ((item = PyIter_Next(it)) != NULL) {
            if (!PyFloat_CheckExact(item) || s->win_n >= RATE_WINDOW_TICKS) {
                Py_DECREF(item);
                Py_DECREF(it);
                return 0;
            }
            s->win[s->win_n++] = PyFloat_AS_DOUBLE(item);
            Py_DECREF(item);
        }
        Py_DECREF(it);
        if (PyErr_Occurred())
            return -1;
    }
    /* skin */
    BORROW(obj, D, s_skin);
    if (obj != Py_None) {
        PyObject *skin, *d, *tup;
        DICT(skin, obj);
        s->skin_d = skin;
        TRY(original_method(obj, skin, M_SKIN_STEP));
        TRY(original_method(obj, skin, M_SKIN_SURFACE));
        s->has_skin = 1;
        TRY(get_ll(skin, s_n, &v));
        if (v < 1 || v > 4096)
            return 0;
        s->n = (Py_ssize_t)v;
        TRY(get_d(skin, s_surface_node, &s->surface_node));
        TRY(get_d(skin, s_flux, &s->flux));
        TRY(get_d(skin, s_conductivity, &s->conductivity));
        BORROW(s->x, skin, s__x);
        BORROW(s->xn, skin, s__x_next);
        BORROW(d, skin, s__ab);
        s->ab_t = dict_item(d, Py_True);
        s->ab_f = dict_item(d, Py_False);
        if (s->ab_t == NULL || s->ab_f == NULL)
            return PyErr_Occurred() ? -1 : 0;
        BORROW(d, skin, s__heads);
        TRY(state_vector(s->x, d, s->n + 2, &s->xd, &s->head_x));
        TRY(state_vector(s->xn, d, s->n + 2, &s->xnd, &s->head_xn));
        BORROW(d, skin, s__g);
        PyObject *gt = dict_item(d, Py_True), *gf = dict_item(d, Py_False);
        if (PyErr_Occurred())
            return -1;
        if (gt == NULL || gf == NULL || !PyFloat_CheckExact(gt) || !PyFloat_CheckExact(gf))
            return 0;
        s->g_t = PyFloat_AS_DOUBLE(gt);
        s->g_f = PyFloat_AS_DOUBLE(gf);
        BORROW(tup, skin, s__touch);
        if (!PyTuple_Check(tup) || PyTuple_GET_SIZE(tup) != 5 || !PyFloat_CheckExact(PyTuple_GET_ITEM(tup, 4)))
            return 0;
        s->w_t = PyFloat_AS_DOUBLE(PyTuple_GET_ITEM(tup, 4));
        BORROW(tup, skin, s__air);
        if (!PyTuple_Check(tup) || PyTuple_GET_SIZE(tup) != 5 || !PyFloat_CheckExact(PyTuple_GET_ITEM(tup, 4)))
            return 0;
        s->w_f = PyFloat_AS_DOUBLE(PyTuple_GET_ITEM(tup, 4));
    }
    /* record mode: the passive sample's curves from the first touch */
    if (s->arm_mode == RECORD && (s->state == ARMED || s->state == RECORDING)) {
        BORROW(obj, D, s_sample);
        DICT(obj, obj);
        TRY(get_d(obj, s_temperature_C, &s->sample_T));
        BORROW(obj, D, s_curves);
        if (obj != Py_None) {
            if (!PyTuple_Check(obj) || PyTuple_GET_SIZE(obj) != 3 || !PyLong_CheckExact(PyTuple_GET_ITEM(obj, 0))
                    || !PyList_CheckExact(PyTuple_GET_ITEM(obj, 1)) || !PyList_CheckExact(PyTuple_GET_ITEM(obj, 2)))
                return 0;
            int overflow;
            s->curves_touch = PyLong_AsLongLongAndOverflow(PyTuple_GET_ITEM(obj, 0), &overflow);
            if (s->curves_touch == -1 && PyErr_Occurred())
                return -1;
            s->tm = PyTuple_GET_ITEM(obj, 1);
            s->ts = PyTuple_GET_ITEM(obj, 2);
            if (overflow || PyList_GET_SIZE(s->tm) == 0 || PyList_GET_SIZE(s->ts) != PyList_GET_SIZE(s->tm))
                return 0;
            s->has_curves = 1;
        }
    }
    /* plant */
    BORROW(obj, D, s_plant);
    {
        PyObject *pl, *c, *nz, *ov, *st, *tc;
        DICT(pl, obj);
        s->plant_d = pl;
        TRY(original_method(obj, pl, M_PLANT_STEP));
        BORROW(c, pl, s__consts);
        if (!PyTuple_Check(c) || PyTuple_GET_SIZE(c) != 18 || !PyLong_CheckExact(PyTuple_GET_ITEM(c, 1)))
            return 0;
        for (int i = 0; i < 18; i++)
            if (i != 1 && !PyFloat_CheckExact(PyTuple_GET_ITEM(c, i)))
                return 0;
        s->dtc = tuple_d(c, 0);
        s->n_sub = PyLong_AsLong(PyTuple_GET_ITEM(c, 1));
        if (s->n_sub == -1 && PyErr_Occurred()) {
            PyErr_Clear();
            return 0;
        }
        if (s->n_sub < 1 || s->n_sub > 1000)
            return 0;
        s->C = tuple_d(c, 2); s->K = tuple_d(c, 3); s->a = tuple_d(c, 4); s->Re = tuple_d(c, 5);
        s->ch = tuple_d(c, 6); s->kh = tuple_d(c, 7); s->ah = tuple_d(c, 8); s->rh = tuple_d(c, 9);
        s->kp = tuple_d(c, 10); s->imax = tuple_d(c, 11); s->g_obs = tuple_d(c, 12);
        s->lag = tuple_d(c, 13); s->pnoise = tuple_d(c, 14); s->g_hs = tuple_d(c, 15);
        s->p_room = tuple_d(c, 16); s->C_hs = tuple_d(c, 17);
        BORROW(nz, pl, s_noise);
        if (Py_TYPE(nz) != &NormalStreamType || nz == (PyObject *)s->noise
                || ((NormalStream *)nz)->v == NULL)
            return 0;
        s->pnz = (NormalStream *)nz;
        s->pnoise_pos = s->pnz->pos;
        /* the fault hooks at rest, no latched trip */
        BORROW(ov, pl, s_sensor_override);
        BORROW(st, pl, s_stuck_current);
        if (ov != Py_None || st != Py_None)
            return 0;
        TRY(get_truth(pl, s_sensor_frozen, &t));
        if (t)
            return 0;
        TRY(get_truth(pl, s_tripped, &t));
        if (t)
            return 0;
        BORROW(tc, pl, s_trip_C);
        if (tc == Py_None)
            s->trip = INFINITY;
        else if (PyFloat_CheckExact(tc))
            s->trip = PyFloat_AS_DOUBLE(tc);
        else
            return 0;
        TRY(get_d(pl, s_pad, &s->pad));
        TRY(get_d(pl, s_hs, &s->hs));
        TRY(get_d(pl, s_sensor_state, &s->s_state));
        TRY(get_d(pl, s__y_prev, &s->y_prev));
        TRY(get_d(pl, s__q_prev, &s->q_prev));
        TRY(get_d(pl, s_d_hat, &s->d_hat));
        TRY(get_d(pl, s_sensor, &s->y));
        TRY(get_d(pl, s_current, &s->current));
        TRY(get_ll(pl, s_same_count, &s->same));
    }
    /* forces: (f0, f1, f2, f3) */
    BORROW(obj, D, s_forces);
    if (!PyTuple_Check(obj) || PyTuple_GET_SIZE(obj) != 4)
        return 0;
    for (int i = 0; i < 4; i++) {
        if (!PyFloat_CheckExact(PyTuple_GET_ITEM(obj, i)))
            return 0;
        s->f[i] = PyFloat_AS_DOUBLE(PyTuple_GET_ITEM(obj, i));
    }
    return 1;
}

/* Write back what a compiled tick changes. 0 ok, -1 error. */
static int
store(St *s)
{
    PyObject *D = s->dev_d;
    if (!s->ticked)
        return 0;
    s->ticked = 0;                     /* a failure below is not retried (the window once) */
    PyObject *o;
    s->noise->pos = s->noise_pos;
    s->pnz->pos = s->pnoise_pos;
    if (set_ll(D, s_time_us, s->time_us) < 0 || set_d(D, s_sp, s->sp) < 0
            || set_d(D, s_finger_C, s->finger_C) < 0 || set_d(D, s_ambient_C, s->ambient_C) < 0
            || set_d(D, s_contact_C, s->contact_C) < 0
            || PyDict_SetItem(D, s_fresh, s->fresh ? Py_True : Py_False) < 0
            || set_ll(D, s_ready_count, s->ready_count) < 0
            || set_ll(D, s_release_count, s->release_count) < 0
            || set_ll(D, s_counter, s->counter) < 0 || set_ll(D, s_tx_seq, s->tx_seq) < 0)
        return -1;
    if (s->has_touch) {
        if (set_ll(D, s_touch_us, s->touch_us) < 0)
            return -1;
    }
    o = Py_BuildValue("(dddd)", s->f[0], s->f[1], s->f[2], s->f[3]);
    if (o == NULL || PyDict_SetItem(D, s_forces, o) < 0) {
        Py_XDECREF(o);
        return -1;
    }
    Py_DECREF(o);
    /* the window: the setpoints appended since the load (the deque's maxlen drops the oldest) */
    {
        int k = s->win_added < s->win_n ? s->win_added : s->win_n;
        PyObject *w = PyDict_GetItemWithError(D, s__sp_window), *lst, *r;
        if (w == NULL) {
            if (!PyErr_Occurred())
                PyErr_SetString(PyExc_RuntimeError, "_tick: the device lost its _sp_window");
            return -1;
        }
        Py_INCREF(w);
        lst = PyList_New(k);
        if (lst == NULL) {
            Py_DECREF(w);
            return -1;
        }
        for (int i = 0; i < k; i++) {
            PyObject *v = PyFloat_FromDouble(s->win[s->win_n - k + i]);
            if (v == NULL) {
                Py_DECREF(lst);
                Py_DECREF(w);
                return -1;
            }
            PyList_SET_ITEM(lst, i, v);
        }
        r = PyObject_CallMethodOneArg(w, s_extend, lst);
        Py_DECREF(lst);
        Py_DECREF(w);
        if (r == NULL)
            return -1;
        Py_DECREF(r);
        s->win_added = 0;
    }
    if (s->has_skin) {
        PyObject *skin = s->skin_d;
        if (PyDict_SetItem(skin, s__x, s->x) < 0 || PyDict_SetItem(skin, s__x_next, s->xn) < 0
                || set_d(skin, s_surface_node, s->surface_node) < 0 || set_d(skin, s_flux, s->flux) < 0)
            return -1;
    }
    {
        PyObject *pl = s->plant_d;
        if (set_d(pl, s_pad, s->pad) < 0 || set_d(pl, s_hs, s->hs) < 0
                || set_d(pl, s_sensor_state, s->s_state) < 0 || set_d(pl, s__y_prev, s->y_prev) < 0
                || set_d(pl, s__q_prev, s->q_prev) < 0 || set_d(pl, s_d_hat, s->d_hat) < 0
                || set_d(pl, s_sensor, s->y) < 0 || set_ll(pl, s_same_count, s->same) < 0
                || set_d(pl, s_current, s->current) < 0)
            return -1;
    }
    return 0;
}

/* ------------------------------------------------------------------ the tick */

/* Python's round(x) of a double to an int (half to even), as a double; NaN/inf stay. */
static inline double
round_half_even(double x)
{
    double r = round(x);               /* half away from zero */
    if (fabs(x - r) == 0.5)
        r = 2.0 * round(x / 2.0);
    return r;
}

/* FingerScript.force */
static inline double
finger_force(const St *s, long long t_us)
{
    if (!s->has_fin || !s->fin_started)
        return 0.0;
    double tau = (double)(t_us - s->fin_start_us) * 1e-6 - s->press_after;
    double F = s->force_N;
    if (tau <= 0.0)
        return 0.0;
    if (tau < 0.15)
        return 1.15 * F * tau / 0.15;
    if (tau < s->hold_s)
        return F * (1.0 + 0.15 * exp(-(tau - 0.15) / 0.2));
    if (tau < s->hold_s + 0.1)
        return F * (1.0 - (tau - s->hold_s) / 0.1);
    return 0.0;
}

/* FingerSkin.step: the product by numpy's dot into the other state vector; returns the flux
 * or NAN with an exception set (-> error). */
static int
skin_step(St *s, int touching, double outside_C)
{
    double *x = s->xd;
    Py_ssize_t n = s->n;
    x[n] = outside_C;
    PyObject *args[3] = {touching ? s->ab_t : s->ab_f, s->x, s->head_xn};
    PyObject *r = PyObject_Vectorcall(DotFunc, args, 2, OutKwnames);
    if (r == NULL)
        return -1;
    Py_DECREF(r);
    /* swap: the next state becomes the current one */
    PyObject *t = s->x; s->x = s->xn; s->xn = t;
    t = s->head_x; s->head_x = s->head_xn; s->head_xn = t;
    double *td = s->xd; s->xd = s->xnd; s->xnd = td;
    double s_old = s->surface_node;
    double s_new = s->xd[n - 1];
    s->surface_node = s_new;
    s->flux = (touching ? s->g_t : s->g_f) * (0.5 * (s_old + s_new) - outside_C);
    return 0;
}

static inline double
skin_surface_C(const St *s, int touching)
{
    double w = touching ? s->w_t : s->w_f;
    return s->surface_node - s->flux * w / (2 * s->conductivity);
}

/* PadPlant.step with no fault hook. TICK_DONE, or TICK_PYTHON when a reading needs Python's
 * correctly rounded round(v, 3) or the over-temperature cut acts. */
static inline int
plant_step(St *s, double sp0, double sp1, double load_W, int enabled, double *y_out)
{
    const long n = s->n_sub;
    const double dtc = s->dtc, C = s->C, K = s->K, a = s->a, Re = s->Re, ch = s->ch, kh = s->kh,
                 ah = s->ah, rh = s->rh, kp = s->kp, imax = s->imax, g_obs = s->g_obs,
                 lag = s->lag, noise = s->pnoise, g_hs = s->g_hs, room = s->p_room, C_hs = s->C_hs;
    /* sens: Python's s_state, the sensor's lagged state */
    double pad = s->pad, hs = s->hs, sens = s->s_state, y_prev = s->y_prev, q_prev = s->q_prev,
           d_hat = s->d_hat;
    const double trip = s->trip;
    double dsp = (sp1 - sp0) / n;
    double y = s->y;
    long long same = s->same;
    double i = 0.0;
    for (long k = 0; k < n; k++) {
        sens += lag * (pad - sens);
        double v = sens + noise * draw(s->pnz, &s->pnoise_pos);
        double w = v * 1000.0;
        double kk = round_half_even(w);
        double y_new;
        if (kk != 0.0 && -0.4999 < w - kk && w - kk < 0.4999)
            y_new = kk / 1000.0;
        else
            return TICK_PYTHON;        /* round(v, 3): Python's */
        same = y_new == y ? same + 1 : 0;
        y = y_new;
        double r = sp0 + dsp * k;
        if (enabled && y > trip)
            return TICK_PYTHON;        /* the over-temperature cut: Python trips */
        if (enabled) {
            double d_meas = ch * (y - y_prev) / dtc - q_prev - kh * (hs - y_prev);
            d_hat += g_obs * (d_meas - d_hat);
            double q_des = ch * dsp / dtc + kh * (r - hs) + kp * (r - y) - d_hat;
            double aT = ah * (y + KELVIN);
            double disc = aT * aT + 2.0 * rh * q_des;
            i = disc > 0 ? (-aT + sqrt(disc)) / rh : -aT / rh;
            i = i > imax ? imax : i < -imax ? -imax : i;
            q_prev = ah * (y + KELVIN) * i + 0.5 * rh * i * i;
        } else {
            i = 0.0;
            q_prev = 0.0;
            d_hat = 0.0;
        }
        y_prev = y;
        double joule = 0.5 * Re * i * i;
        double q_pad = a * i * (pad + KELVIN) + joule + K * (hs - pad) + load_W;
        double q_hs = -a * i * (hs + KELVIN) + joule + K * (pad - hs) + g_hs * (room - hs);
        pad += dtc * q_pad / C;
        hs += dtc * q_hs / C_hs;
    }
    s->pad = pad; s->hs = hs; s->s_state = sens; s->y_prev = y_prev; s->q_prev = q_prev;
    s->d_hat = d_hat;
    s->y = y;
    s->same = same;
    s->current = i;
    *y_out = y;
    return TICK_DONE;
}

static inline int
fits_int16(double v)
{
    return v >= -32768.0 && v <= 32767.0;     /* false for NaN */
}

static PyObject *
telemetry_frame(St *s, double sp, double f0, double f1, double f2, double f3, long long t_us)
{
    double v[8] = {round_half_even(sp * 100), round_half_even(s->contact_C * 100),
                   round_half_even(s->ambient_C * 100), round_half_even(s->finger_C * 100),
                   round_half_even(f0 * 100), round_half_even(f1 * 100),
                   round_half_even(f2 * 100), round_half_even(f3 * 100)};
    unsigned char p[TEL_SIZE];
    unsigned long long c = (unsigned long long)s->counter, t = (unsigned long long)(t_us - s->boot_us);
    if (s->counter < 0 || s->counter > 0xFFFFFFFFLL || t_us - s->boot_us < 0)
        return Py_None;                /* struct.error in Python */
    for (int k = 0; k < 8; k++)
        if (!fits_int16(v[k]))
            return Py_None;
    for (int k = 0; k < 4; k++)
        p[k] = (unsigned char)(c >> (8 * k));
    for (int k = 0; k < 8; k++)
        p[4 + k] = (unsigned char)(t >> (8 * k));
    for (int k = 0; k < 8; k++) {
        int q = (int)v[k];
        unsigned short u = (unsigned short)(q & 0xFFFF);
        p[12 + 2 * k] = (unsigned char)(u & 0xFF);
        p[13 + 2 * k] = (unsigned char)(u >> 8);
    }
    p[28] = (unsigned char)s->state;
    p[29] = 0;
    PyObject *payload = PyBytes_FromStringAndSize((const char *)p, TEL_SIZE);
    if (payload == NULL)
        return NULL;
    PyTypeObject *ft = (PyTypeObject *)FrameType;
    PyObject *fr = ft->tp_alloc(ft, 3);
    if (fr == NULL) {
        Py_DECREF(payload);
        return NULL;
    }
    PyTuple_SET_ITEM(fr, 0, PyLong_FromLong(s->tx_seq));
    PyTuple_SET_ITEM(fr, 1, PyLong_FromLong(MSG_TELEMETRY));
    PyTuple_SET_ITEM(fr, 2, payload);
    if (PyTuple_GET_ITEM(fr, 0) == NULL || PyTuple_GET_ITEM(fr, 1) == NULL) {
        Py_DECREF(fr);
        return NULL;
    }
    return fr;
}

/* One tick of Device.step on a copy of the state; committed to *s0 only when whole. */
static int
tick(St *s0, PyObject *frames)
{
    St st = *s0;
    St *s = &st;
    s->time_us += TICK_US;
    const long long t_us = s->time_us;
    const int state = s->state;
    const int active = state == ARMED || state == PLAYING || state == RECORDING;
    if (active && t_us - s->last_rx_us > WATCHDOG_US)
        return TICK_PYTHON;
    /* finger and forces */
    double F = finger_force(s, t_us);
    double nf = s->noise_force;
    double f0 = F * 0.27 + nf * draw(s->noise, &s->noise_pos);
    double f1 = F * 0.24 + nf * draw(s->noise, &s->noise_pos);
    double f2 = F * 0.26 + nf * draw(s->noise, &s->noise_pos);
    double f3 = F * 0.23 + nf * draw(s->noise, &s->noise_pos);
    s->f[0] = f0; s->f[1] = f1; s->f[2] = f2; s->f[3] = f3;
    double Fsum = f0 + f1 + f2 + f3;
    int touching = F > 0.1;
    if (touching && !s->has_touch && active) {
        s->has_touch = 1;
        s->touch_us = t_us;
    }
    /* setpoint */
    double sp_prev = s->sp;
    double max_step = s->lim_rate * s->tick_s;
    double goal;
    if (state == PLAYING) {
        double x = (double)(t_us - s->contact_us) / (double)s->dt_us;
        long long i = (long long)x;
        if (i >= s->nvals - 1) {
            if (!list_float(s->vals, s->nvals - 1, &goal))
                return TICK_PYTHON;
        } else {
            double vi, vj;
            if (i < 0 || !list_float(s->vals, (Py_ssize_t)i, &vi)
                    || !list_float(s->vals, (Py_ssize_t)i + 1, &vj))
                return TICK_PYTHON;
            goal = vi + (x - (double)i) * (vj - vi);
        }
        max_step = HARD_RATE_C_PER_S * s->tick_s;
    } else if (state == ARMED && s->arm_mode == PLAYBACK) {
        if (!list_float(s->vals, 0, &goal))
            return TICK_PYTHON;
    } else
        goal = s->neutral;
    double lo = s->lim_min, hi = s->lim_max;
    if (lo > goal)
        goal = lo;
    if (hi < goal)
        goal = hi;
    double d = goal - sp_prev;
    double sp = (-max_step <= d && d <= max_step) ? goal : sp_prev + copysign(max_step, d);
    double span = s->lim_rate * s->tick_s * RATE_WINDOW_TICKS + RATE_SLACK_C;
    double wmax = s->win[0], wmin = s->win[0];
    for (int k = 1; k < s->win_n; k++) {
        if (s->win[k] > wmax)
            wmax = s->win[k];
        if (s->win[k] < wmin)
            wmin = s->win[k];
    }
    double bound = wmax - span;
    if (bound > sp)
        sp = bound;
    bound = wmin + span;
    if (bound < sp)
        sp = bound;
    if (HARD_MIN_C > sp)
        sp = HARD_MIN_C;
    if (lo > sp)
        sp = lo;
    if (SETPOINT_MAX_C < sp)
        sp = SETPOINT_MAX_C;
    if (hi < sp)
        sp = hi;
    s->sp = sp;
    if (s->win_n == RATE_WINDOW_TICKS) {
        memmove(s->win, s->win + 1, sizeof(double) * (RATE_WINDOW_TICKS - 1));
        s->win[RATE_WINDOW_TICKS - 1] = sp;
    } else
        s->win[s->win_n++] = sp;
    s->win_added++;
    /* physics */
    double load_W = 0.0;
    if (s->has_skin) {
        if (touching && s->arm_mode == PLAYBACK) {
            if (skin_step(s, 1, s->pad) < 0)
                return TICK_ERROR;
            load_W = s->flux * CONTACT_AREA_M2;
            s->finger_C = skin_surface_C(s, 1);
        } else if (!touching) {
            if (skin_step(s, 0, s->room) < 0)
                return TICK_ERROR;
            s->finger_C = skin_surface_C(s, 0);
        }
    } else
        s->finger_C = s->room + s->noise_ambient * draw(s->noise, &s->noise_pos);
    double y;
    int r = plant_step(s, sp_prev, sp, load_W, s->enabled, &y);
    if (r != TICK_DONE)
        return r;
    s->ambient_C = s->room + s->noise_ambient * draw(s->noise, &s->noise_pos);
    if (s->arm_mode == RECORD && (state == ARMED || state == RECORDING)) {
        /* Device._sample_reading */
        if (!s->has_touch || !s->has_fin)
            s->contact_C = s->sample_T;
        else {
            if (!s->has_curves || s->curves_touch != s->touch_us)
                return TICK_PYTHON;    /* the curves are computed in Python */
            if (t_us < s->touch_us)
                return TICK_PYTHON;    /* Python's floor division and negative index */
            long long k = (t_us - s->touch_us) / TICK_US;
            Py_ssize_t len = PyList_GET_SIZE(s->tm);
            if (k >= len)
                k = len - 1;
            double tm_k;
            if ((touching && !list_float(s->ts, k, &s->finger_C)) || !list_float(s->tm, k, &tm_k))
                return TICK_PYTHON;
            s->contact_C = tm_k + s->noise_sensor * draw(s->noise, &s->noise_pos);
        }
    } else
        s->contact_C = y;
    /* safety monitors: any of them acts in Python */
    if (!(-10.0 < y && y < 90.0))
        return TICK_PYTHON;
    if (s->enabled && s->same >= STUCK_SAMPLES)
        return TICK_PYTHON;
    if (y > OVERTEMP_C || s->hs > HEATSINK_MAX_C)
        return TICK_PYTHON;
    /* trial logic: a transition or an event is Python's */
    if (state == ARMED) {
        if (!s->fresh && Fsum < 0.5 * s->threshold)
            s->fresh = 1;
        if (!s->ready) {
            double v0 = 0.0;
            if (s->arm_mode != RECORD && !list_float(s->vals, 0, &v0))
                return TICK_PYTHON;
            int near = s->arm_mode == RECORD || (fabs(y - v0) < READY_BAND_C && sp == goal);
            s->ready_count = near ? s->ready_count + 1 : 0;
            if (s->ready_count >= 10)
                return TICK_PYTHON;
        } else if (Fsum >= s->threshold && s->fresh)
            return TICK_PYTHON;
    } else if (state == PLAYING || state == RECORDING) {
        long long elapsed = t_us - s->contact_us;
        s->release_count = Fsum < 0.5 * s->threshold ? s->release_count + 1 : 0;
        if (s->release_count * TICK_US >= RELEASE_US)
            return TICK_PYTHON;
        if (elapsed >= s->max_duration_us)
            return TICK_PYTHON;
        if (state == PLAYING && elapsed >= (long long)(s->nvals - 1) * s->dt_us)
            return TICK_PYTHON;
    }
    /* telemetry while a trial is on */
    if (state != IDLE) {
        s->counter += 1;
        s->tx_seq = (s->tx_seq + 1) & 0xFF;
        PyObject *fr = telemetry_frame(s, sp, f0, f1, f2, f3, t_us);
        if (fr == NULL)
            return TICK_ERROR;
        if (fr == Py_None)
            return TICK_PYTHON;        /* saturating telemetry: Python's */
        int bad = PyList_Append(frames, fr);
        Py_DECREF(fr);
        if (bad < 0)
            return TICK_ERROR;
    }
    s->ticked = 1;
    *s0 = st;
    return TICK_DONE;
}

/* ------------------------------------------------------------------ the read loop */

#define N_HELD 12
typedef struct {
    St s;
    PyObject *held[N_HELD];            /* the objects the state points into, kept alive */
    int compiled;                      /* load() said the compiled tick applies */
    int python_only;                   /* it did not, after a Python tick: no more loads */
    PyObject *dev, *frames;
    long long ticks_c, ticks_py;
} Loop;

static void
loop_release(Loop *L)
{
    for (int i = 0; i < N_HELD; i++)
        Py_CLEAR(L->held[i]);
}

/* Load the state, and hold what it points into: numpy may release the GIL in its dot, and a
 * signal handler may run, while the state's borrowed pointers are in use. */
static int
loop_load(Loop *L)
{
    loop_release(L);
    int r = load(&L->s, L->dev);
    if (r < 0)
        return -1;
    L->compiled = r;
    if (r) {
        St *s = &L->s;
        PyObject *refs[N_HELD] = {s->dev_d, s->skin_d, s->plant_d, (PyObject *)s->noise,
                                  (PyObject *)s->pnz, s->vals, s->tm, s->ts, s->x, s->xn,
                                  s->ab_t, s->ab_f};
        for (int i = 0; i < N_HELD; i++) {
            Py_XINCREF(refs[i]);
            L->held[i] = refs[i];
        }
    }
    return 0;
}

/* one tick, compiled or Python's; 0 ok, -1 error */
static int
one_tick(Loop *L)
{
    if (L->compiled) {
        int r = tick(&L->s, L->frames);
        if (r == TICK_DONE) {
            L->ticks_c++;
            return 0;
        }
        if (r == TICK_ERROR)
            return -1;
        if (store(&L->s) < 0)
            return -1;
    }
    PyObject *res = PyObject_CallMethodNoArgs(L->dev, s_step);
    if (res == NULL)
        return -1;
    Py_DECREF(res);
    L->ticks_py++;
    if (L->python_only)
        return 0;
    if (loop_load(L) < 0)
        return -1;
    L->python_only = !L->compiled;     /* e.g. FAULT: Python's ticks until this read ends */
    return 0;
}

static int
current_state(Loop *L, long *state)
{
    if (L->compiled) {
        *state = L->s.state;
        return 0;
    }
    PyObject *v = PyObject_GetAttr(L->dev, s_state);
    if (v == NULL)
        return -1;
    *state = PyLong_AsLong(v);
    Py_DECREF(v);
    return (*state == -1 && PyErr_Occurred()) ? -1 : 0;
}

static PyObject *
read_ticks(PyObject *module, PyObject *args)
{
    Loop L;
    long long budget;
    memset(&L, 0, sizeof(L));
    if (!PyArg_ParseTuple(args, "OO!L", &L.dev, &PyList_Type, &L.frames, &budget))
        return NULL;
    if (FrameType == NULL || DotFunc == NULL || Original[0] == NULL) {
        PyErr_SetString(PyExc_RuntimeError, "_tick.configure() was not called");
        return NULL;
    }
    if (loop_load(&L) < 0)
        return NULL;
    long long k;
    for (k = 0; k < budget; k++) {
        if ((k & 1023) == 1023) {      /* a long wait stays interruptible */
            if (L.compiled && store(&L.s) < 0)
                goto fail;
            if (PyErr_CheckSignals() < 0)
                goto fail;
            if (!L.python_only && loop_load(&L) < 0)   /* a handler may have changed the device */
                goto fail;
        }
        if (one_tick(&L) < 0)
            goto fail;
        if (PyList_GET_SIZE(L.frames))
            break;
    }
    if (PyList_GET_SIZE(L.frames)) {
        for (int extra = 0; extra < 2; extra++) {
            long state;
            if (current_state(&L, &state) < 0)
                goto fail;
            if (state == IDLE)
                break;
            if (one_tick(&L) < 0)
                goto fail;
        }
    }
    if (L.compiled && store(&L.s) < 0)
        goto fail;
    loop_release(&L);
    return Py_BuildValue("(LL)", L.ticks_c, L.ticks_py);
fail:
    /* the ticks done so far stay done (their frames are in the list): keep the state with them */
    if (L.compiled && L.s.ticked) {
        PyObject *type, *value, *tb;
        PyErr_Fetch(&type, &value, &tb);
        if (store(&L.s) < 0)
            PyErr_Clear();
        PyErr_Restore(type, value, tb);
    }
    loop_release(&L);
    return NULL;
}

/* The numbers this file writes as literals, against Python's (configure's `constants`). */
static const struct {
    const char *name;
    double value;
} Literal[] = {
    {"TICK_US", (double)TICK_US}, {"HARD_MIN_C", HARD_MIN_C}, {"SETPOINT_MAX_C", SETPOINT_MAX_C},
    {"HARD_RATE_C_PER_S", HARD_RATE_C_PER_S}, {"WATCHDOG_MS", (double)(WATCHDOG_US / 1000)},
    {"RATE_WINDOW_TICKS", RATE_WINDOW_TICKS}, {"RATE_SLACK_C", RATE_SLACK_C},
    {"READY_BAND_C", READY_BAND_C}, {"RELEASE_MS", (double)(RELEASE_US / 1000)},
    {"OVERTEMP_C", OVERTEMP_C}, {"HEATSINK_MAX_C", HEATSINK_MAX_C},
    {"STUCK_SAMPLES", STUCK_SAMPLES}, {"CONTACT_AREA_M2", CONTACT_AREA_M2}, {"KELVIN", KELVIN},
    {"TELEMETRY_SIZE", TEL_SIZE}, {"MSG_TELEMETRY", MSG_TELEMETRY},
    {"SHARE0", 0.27}, {"SHARE1", 0.24}, {"SHARE2", 0.26}, {"SHARE3", 0.23},
    {"IDLE", IDLE}, {"ARMED", ARMED}, {"PLAYING", PLAYING}, {"RECORDING", RECORDING},
    {"FAULT", FAULT}, {"PLAYBACK", PLAYBACK}, {"RECORD", RECORD},
};

static PyObject *
configure(PyObject *module, PyObject *args)
{
    PyObject *frame_type, *dot, *originals, *constants;
    if (!PyArg_ParseTuple(args, "O!OO!O!", &PyType_Type, &frame_type, &dot, &PyTuple_Type,
                          &originals, &PyDict_Type, &constants))
        return NULL;
    if (!PyType_IsSubtype((PyTypeObject *)frame_type, &PyTuple_Type)) {
        PyErr_SetString(PyExc_TypeError, "configure: Frame must be a tuple type");
        return NULL;
    }
    if (PyTuple_GET_SIZE(originals) != N_METHODS) {
        PyErr_Format(PyExc_TypeError, "configure: expected %d original methods", N_METHODS);
        return NULL;
    }
    size_t n = sizeof(Literal) / sizeof(Literal[0]);
    if ((size_t)PyDict_GET_SIZE(constants) != n) {
        PyErr_Format(PyExc_ValueError, "configure: expected %zu constants, got %zd", n,
                     PyDict_GET_SIZE(constants));
        return NULL;
    }
    for (size_t i = 0; i < n; i++) {
        PyObject *v = PyDict_GetItemString(constants, Literal[i].name);
        double x = v == NULL ? NAN : PyFloat_AsDouble(v);
        if (x == -1.0 && PyErr_Occurred())
            return NULL;
        if (!(x == Literal[i].value)) {
            PyObject *lit = PyFloat_FromDouble(Literal[i].value);
            if (lit != NULL)
                PyErr_Format(PyExc_ValueError, "_tick.c's %s is %R, Python's is %R: the "
                             "compiled tick transcribes another firmware (edit _tick.c, rebuild)",
                             Literal[i].name, lit, v == NULL ? Py_None : v);
            Py_XDECREF(lit);
            return NULL;
        }
    }
    for (int m = 0; m < N_METHODS; m++) {
        Py_INCREF(PyTuple_GET_ITEM(originals, m));
        Py_XSETREF(Original[m], PyTuple_GET_ITEM(originals, m));
    }
    Py_INCREF(frame_type);
    Py_XSETREF(FrameType, frame_type);
    Py_INCREF(dot);
    Py_XSETREF(DotFunc, dot);
    Py_RETURN_NONE;
}

static PyMethodDef methods[] = {
    {"read_ticks", read_ticks, METH_VARARGS,
     "read_ticks(device, frames, budget) -> (compiled ticks, Python ticks)\n\n"
     "Serial.read_frames' tick loop on a virtual clock with no fault: tick until `frames` is\n"
     "not empty (at most `budget` ticks), then up to two more while the device is not IDLE."},
    {"configure", configure, METH_VARARGS,
     "configure(Frame, dot, originals, constants): the frame type and numpy's dot as the Python\n"
     "tick uses them, the Python methods transcribed (Device.step, Device._sample_reading,\n"
     "PadPlant.step, FingerSkin.step, FingerSkin.surface_C, FingerScript.force) and the\n"
     "constants written here as literals, checked against Python's (ValueError)."},
    {NULL, NULL, 0, NULL}
};

static struct PyModuleDef module = {
    PyModuleDef_HEAD_INIT, "_tick",
    "The emulated firmware's steady 10 ms ticks, compiled (see _tick.c).", -1, methods
};

PyMODINIT_FUNC
PyInit__tick(void)
{
#define INTERN(name) if ((s_##name = PyUnicode_InternFromString(#name)) == NULL) return NULL;
    NAMES(INTERN)
#undef INTERN
    if ((OutKwnames = Py_BuildValue("(s)", "out")) == NULL)
        return NULL;
    for (int m = 0; m < N_METHODS; m++)
        if ((MethodName[m] = PyUnicode_InternFromString(MethodOf[m])) == NULL)
            return NULL;
    if (PyType_Ready(&NormalStreamType) < 0)
        return NULL;
    PyObject *m = PyModule_Create(&module);
    if (m == NULL)
        return NULL;
    Py_INCREF(&NormalStreamType);
    if (PyModule_AddObject(m, "NormalStream", (PyObject *)&NormalStreamType) < 0) {
        Py_DECREF(&NormalStreamType);
        Py_DECREF(m);
        return NULL;
    }
    return m;
}
