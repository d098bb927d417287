# The compiled form's declarations of radio.py (Cython's augmenting .pxd): a frame's fields, so that the
# middleware that handles every received frame (middleware/station.py, token_ring.py, node.py) reads them
# by C reads.

cimport cython


cdef class Frame:
    cdef public str kind
    cdef public long src
    cdef public object dst
    cdef public object pan
    cdef public dict payload
    cdef public long size_bytes
    cdef public double rx_distance_est_m
