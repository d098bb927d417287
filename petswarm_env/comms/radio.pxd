# The compiled form's declarations of radio.py (Cython's augmenting .pxd): a frame's fields, so that the
# middleware that handles every received frame (middleware/station.py, token_ring.py, node.py) reads them
# by C reads; the medium and what it schedules, so that a station sends a frame by a C call (transmit).

cimport cython

from petswarm_env.sim.body cimport Body
from petswarm_env.sim.clock cimport Clock, Due
from petswarm_env.sim.draws cimport Stream


cdef class Frame:
    cdef public str kind
    cdef public long src
    cdef public object dst  # BROADCAST or a node id (None: a node id not known, which no station is)
    cdef public object pan  # None: a robot's "own swarm" when it is in none (no MAC accepts it)
    cdef public dict payload
    cdef public long size_bytes
    cdef public double rx_distance_est_m  # filled per reception


cdef class RadioStats:
    cdef public long frames_sent
    cdef public long frames_dropped_busy  # CSMA gave up
    cdef public long receptions
    cdef public long frames_lost  # random loss at a receiver
    cdef public long frames_collided  # receptions destroyed by overlap
    cdef public long foreign_pan_dropped  # filtered by the MAC


@cython.final
cdef class _Tx(Due):
    cdef Frame frame
    cdef double start
    cdef double end
    cdef double x
    cdef double y
    cdef object medium  # the RadioMedium that carries it
    cdef object sender  # the sender's _Port


@cython.final
cdef class _Cca(Due):
    cdef object medium  # the RadioMedium
    cdef object port  # the sender's _Port
    cdef Frame frame
    cdef int nb  # busy assessments so far
    cdef int be  # the backoff exponent


@cython.final
cdef class _Port:
    cdef long node_id
    cdef object station
    cdef object position
    cdef Body body  # the body whose own reader ``position`` is (read from Chipmunk by a C call), else None
    cdef list queue

    cdef (double, double) xy(self)


cdef class RadioMedium:
    cdef public object clock
    cdef public object cfg
    cdef public object rng
    cdef public dict stations
    cdef public RadioStats stats
    cdef public object drop_filter  # fault injection (tests)
    cdef public object trace  # the experimenter's trace hook (module docstring)
    cdef Clock _clock  # the same clock, typed
    cdef Stream _mac_uniform
    cdef Stream _rx_uniform
    cdef Stream _rx_normal
    cdef dict _ports  # node id -> _Port
    cdef list _port_list  # the _Ports in the order they attached (= stations' order)
    cdef list _air  # transmissions that may still overlap something
    cdef double _range2
    cdef double _shadow_k
    cdef double _overhead_bytes
    cdef double _bitrate_bps
    cdef double _latency_s
    cdef double _turnaround_s
    cdef double _backoff_slot_s
    cdef double _loss_prob
    cdef int _min_be
    cdef int _max_be
    cdef int _max_backoffs

    cpdef double airtime_s(self, Frame frame)
    cpdef transmit(self, str kind, long src, object dst, object pan, dict payload, long size)
    cdef void _enqueue(self, _Port port, Frame frame)
    cdef void _start(self, _Port port, Frame frame)
    cdef void _done(self, _Port port)
    cdef double _backoff(self, int be)
    cdef void _cca(self, _Cca cca)
    cdef void _deliver(self, _Tx tx, _Port sender)
