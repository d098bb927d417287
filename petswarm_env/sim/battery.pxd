# The compiled form's declarations of battery.py (Cython's augmenting .pxd): the battery's typed
# attributes, and its drain as a C method, which the drive (body.py) calls at every substep.

cdef class Battery:
    cdef public double capacity_mah
    cdef public double remaining_mah
    cdef public bint empty
    cdef public bint actuating
    cdef double _servo
    cdef double _act
    cdef double _sens
    cdef double _inv_v
    cdef double _inv_w

    cpdef bint drain(self, double dt, tuple velocity_body)
    cdef bint drain_at(self, double dt, double speed, double omega)
