# The compiled form's declarations of health.py (Cython's augmenting .pxd): a robot's health flags as typed
# attributes, read by C reads for every frame a station sends or receives and every sensor reading.

cdef class FaultState:
    cdef public set active
    cdef public bint powered
    cdef public bint radio_ok
    cdef public bint ir_ok
    cdef public bint ultrasonic_ok
    cdef public bint ahrs_ok
