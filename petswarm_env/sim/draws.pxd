# The compiled form's declarations of draws.py (Cython's augmenting .pxd): a stream of scalar draws as a
# typed class, its next draw a C call (the radio's and the MCU's draws, for every frame and reception).

cimport cython


@cython.final
cdef class Stream:
    cdef object _draw  # draw(block): the generator's method
    cdef readonly Py_ssize_t block
    cdef object _block  # the current block (float64 array)
    cdef double[::1] _values  # the same, as C doubles
    cdef Py_ssize_t _left  # its draws not handed out yet

    cpdef double next(self)
