/* Buffer arguments of the compiled modules (whitted.c, boxtree.c). */
#ifndef STRALA_BUFFER_H
#define STRALA_BUFFER_H

#define PY_SSIZE_T_CLEAN
#include <Python.h>

/* `obj` as a C-contiguous buffer of at least `items` elements of `size` bytes each,
 * writable when asked; -1 with a ValueError naming `name` when it is not. */
static int checked_buffer(PyObject *obj, Py_buffer *view, Py_ssize_t items, Py_ssize_t size,
                          int writable, const char *name) {
    if (PyObject_GetBuffer(obj, view, PyBUF_C_CONTIGUOUS | (writable ? PyBUF_WRITABLE : 0)))
        return -1;
    if (view->itemsize != size || view->len < items * size) {
        PyErr_Format(PyExc_ValueError, "%s: expected %zd values of %zd bytes", name, items,
                     size);
        PyBuffer_Release(view);
        return -1;
    }
    return 0;
}

#endif
