/* Working-space colours to 8-bit file values in one pass (runtime/color.py decides the
 * mapping and sends it as the 255 working values where the level steps up).
 *
 * Why compiled: the numpy pipeline (clip, power, scale, round, cast) allocates five or six
 * image-sized temporaries, and in a small virtual machine their first-touch page faults
 * cost more than the arithmetic (0.03 to 0.13 s for a 1280x960 image). Here each value is
 * looked up: its float32 bits, shifted, index a table of the level at the bucket's start,
 * and the few thresholds inside the bucket are compared. The result is the level whose
 * interval [threshold(k-1), threshold(k)) holds the value: the exact rounding of the exact
 * encoding, the boundaries being computed in float64 by color.py.
 */
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#define LEVELS 256
#define SHIFT 13 /* 2^10 buckets per octave: a bucket spans at most a few levels */
#define ONE_BITS 0x3F800000u

static inline uint32_t bits_of(float v) {
    uint32_t u;
    memcpy(&u, &v, sizeof u);
    return u;
}

static inline float clamp01(float v) {
    /* NaN and negatives to 0 (a NaN fails every comparison, as in the numpy path) */
    if (!(v > 0.0f)) return 0.0f;
    return v < 1.0f ? v : 1.0f;
}

static PyObject *quantise8(PyObject *self, PyObject *args) {
    PyObject *src_o, *thr_o, *out_o;
    if (!PyArg_ParseTuple(args, "OOO", &src_o, &thr_o, &out_o)) return NULL;
    Py_buffer sb, tb, ob;
    if (PyObject_GetBuffer(src_o, &sb, PyBUF_C_CONTIGUOUS)) return NULL;
    if (PyObject_GetBuffer(thr_o, &tb, PyBUF_C_CONTIGUOUS)) {
        PyBuffer_Release(&sb);
        return NULL;
    }
    if (PyObject_GetBuffer(out_o, &ob, PyBUF_C_CONTIGUOUS | PyBUF_WRITABLE)) {
        PyBuffer_Release(&tb);
        PyBuffer_Release(&sb);
        return NULL;
    }
    PyObject *result = NULL;
    Py_ssize_t n = sb.len / 4;
    if (sb.itemsize != 4 || tb.itemsize != 8 || tb.len != 8 * (LEVELS - 1) || ob.itemsize != 1 ||
        ob.len != n) {
        PyErr_SetString(PyExc_ValueError,
                        "quantise8(float32 values, 255 float64 thresholds, uint8 out of the "
                        "same length)");
        goto done;
    }
    const double *thr = tb.buf;
    for (int k = 1; k < LEVELS - 1; k++)
        if (!(thr[k] >= thr[k - 1])) {
            PyErr_SetString(PyExc_ValueError, "quantise8: thresholds must ascend");
            goto done;
        }
    size_t buckets = (ONE_BITS >> SHIFT) + 1;
    uint8_t *table = malloc(buckets);
    if (!table) {
        PyErr_NoMemory();
        goto done;
    }
    const float *src = sb.buf;
    uint8_t *out = ob.buf;
    Py_BEGIN_ALLOW_THREADS
    /* the level at each bucket's smallest value */
    int level = 0;
    for (size_t b = 0; b < buckets; b++) {
        uint32_t u = (uint32_t)(b << SHIFT);
        float lo;
        memcpy(&lo, &u, sizeof lo);
        while (level < LEVELS - 1 && (double)lo >= thr[level]) level++;
        table[b] = (uint8_t)level;
    }
    for (Py_ssize_t i = 0; i < n; i++) {
        float v = clamp01(src[i]);
        int k = table[bits_of(v) >> SHIFT];
        while (k < LEVELS - 1 && (double)v >= thr[k]) k++;
        out[i] = (uint8_t)k;
    }
    Py_END_ALLOW_THREADS
    free(table);
    result = Py_None;
    Py_INCREF(result);
done:
    PyBuffer_Release(&ob);
    PyBuffer_Release(&tb);
    PyBuffer_Release(&sb);
    return result;
}

static PyMethodDef methods[] = {
    {"quantise8", quantise8, METH_VARARGS,
     "quantise8(values, thresholds, out): float32 working values to uint8 levels; level k "
     "holds the values in [thresholds[k-1], thresholds[k])."},
    {NULL, NULL, 0, NULL}};

static struct PyModuleDef module = {PyModuleDef_HEAD_INIT, "_pixels",
                                    "8-bit file values in one pass (see runtime/color.py).", -1,
                                    methods};

PyMODINIT_FUNC PyInit__pixels(void) { return PyModule_Create(&module); }
