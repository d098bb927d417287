# The compiled form's declarations of sequence.py (Cython's augmenting .pxd): the sequence manager as a
# typed class, so that the slaves' per-step master check (step_kernel.command_slaves) is a C call that
# reads its station and the protocol's timeouts by C reads.

from petswarm_env.middleware.station cimport Station


cdef class SequenceManager:
    cdef public Station node
    cdef set _acks
    cdef public object last_master
    cdef public list master_lost_at
    cdef public object successor
    cdef public object ring_heard
    cdef object _cfg  # the station's config the two timeouts below were read from
    cdef double _organize_timeout_s
    cdef double _status_timeout_s

    cpdef bint master_lost(self, double now_s)
    cdef void _timeouts(self)
