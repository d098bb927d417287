# The compiled form's declarations of clock.py (Cython's augmenting .pxd): the typed attributes of
# its classes and the C methods that the other modules of the compiled core call directly (the
# radio and the station put their callbacks on the queue by a C call, not a Python one).

cimport cython


@cython.final
@cython.freelist(256)
cdef class _Entry:
    cdef double t
    cdef int prio
    cdef long long eid
    cdef object event  # the event, or the callback's function
    cdef tuple args  # the callback's arguments; None for an event
    cdef bint due  # event is a Due: its run() is called


cdef class Due:
    cdef void run(self)


cdef class Clock:
    cdef public double now
    cdef long long _eid
    cdef list _heap
    cdef public object _active_proc  # SimPy's Process sets it while it runs

    cdef void _push(self, double t, int prio, object event, tuple args)
    cdef void _insert(self, _Entry entry)
    cdef _Entry _pop(self)
    cdef void _process(self, event)
    cdef void call_later(self, double delay, object fn, tuple args)
    cdef void call_due(self, double delay, Due due)
    cpdef run_until(self, double t)


@cython.final
cdef class LocalClock:
    cdef readonly double offset_s
    cdef readonly double drift
    cdef double _rate  # local seconds per true second: 1 + drift
    cdef Clock _clock

    cdef void call_later(self, double delay, object fn, tuple args)
    cdef void call_due(self, double delay, Due due)
    cdef void call_start(self, object fn, tuple args)
    cdef void call_soon(self, object fn, tuple args)
    cdef double local_now(self)
    cpdef double local(self, double t_true)
