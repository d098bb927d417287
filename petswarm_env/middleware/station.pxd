# The compiled form's declarations of station.py (Cython's augmenting .pxd): the typed attributes of
# its classes, so that the token ring (middleware/token_ring.py), which every ring frame runs, reads a
# station's state (its id, its knowledge, its configuration) by a C read, not a Python one.

cimport cython

from petswarm_env.middleware.diagnosis cimport Diagnosis
from petswarm_env.sim.clock cimport Clock, LocalClock
from petswarm_env.sim.draws cimport Stream
from petswarm_env.sim.health cimport FaultState
from petswarm_env.sim.sensors cimport AHRS, Readings


@cython.final
cdef class OwnClock(Readings):
    cdef LocalClock _clock  # the MCU's clock (its ``local`` a C call)
    cdef Diagnosis _diagnosis  # the robot's self-diagnosis (its ``on_ring`` and ``on_ahrs`` C calls)


cdef class Station:
    # read for every frame sent, received or handled
    cdef public long node_id
    cdef public frozenset pans  # PAN IDs its MAC accepts
    cdef public object swarm_pan
    cdef public dict handlers
    cdef long _frames_handled
    cdef long _foreign_pan_frames_processed
    cdef public FaultState health  # the robot's (sim/health.pxd): its radio_ok a C read
    cdef public object cfg  # may be replaced (tests): read, never cached
    cdef public object state  # the sequence manager's state
    cdef public object know  # read by every manager, the observation and the metrics
    cdef public object formation
    cdef public object later
    cdef public object recovery  # its RecoveryManager (middleware/recovery.py; the node sets it): read every step
    cdef public double joined_s  # when it last entered a swarm (a slave's status timeout counts from here)
    cdef public object radio
    cdef LocalClock _mcu  # ``clock``, typed
    cdef Clock _true_clock  # the true clock (the body's sensors run on it)
    cdef AHRS _ahrs  # the robot's AHRS (its yaw a C call)
    cdef Stream _uniform  # the MCU's jitter draws (a C call)
    cdef double _processing_s
    cdef double _jitter_s

    cdef void _handle_frame(self, object handler, object frame)
    cdef double _own_yaw(self)
