# The compiled form's declarations of user_session.py (Cython's augmenting .pxd): the session's state as
# typed attributes, so that what runs every control period, LF burst and belt report reads it by C reads
# and calls the tracker, the controller, the belt and the clocks by C calls. Public: the interpreted
# mixins (pairing.py, successor_side.py), the env, the metrics and the tests read and write them.

from petswarm_env.control.master cimport BeltView, MasterController, UserTracker
from petswarm_env.middleware.station cimport Station
from petswarm_env.sim.body cimport WalkingBody
from petswarm_env.sim.clock cimport Clock, LocalClock
from petswarm_env.wearables.belt cimport SmartBelt


cdef class SessionCore:
    cdef public object cfg, world, swarm, rng_lf, rng_misc, watch, remote
    cdef public Clock clock
    cdef public LocalClock belt_clock
    cdef public WalkingBody user
    cdef public SmartBelt belt
    cdef public MasterController ctrl
    cdef public UserTracker tracker
    cdef public Station tracker_node
    cdef public str state, previous_mode
    cdef public BeltView belt_view
    cdef public object connected_robot, paired_at_s, alert_pause_s
    cdef public double link_since_s, link_ack_s
    cdef public dict events
    cdef public list startup
    cdef public bint _guess_only, _returning, paused, _succeeded
    # its own: plain copies of the config's values that every step reads, the belt's feed, the watch's queue
    cdef double _period_s, _lost_user_s, _distance_m, _report_period_s, _ble_latency_s, _lf_period_s
    cdef object _lf_cfg
    cdef double _fed_s, _fed_heading
    cdef double _emergency_since
    cdef list _gestures
    cdef double _watch_free_s

    cdef void _ble_supervision(self)
    cdef void _pick_up_user_commands(self)
    cdef bint _ready_for(self, str command)
    cdef double _target_m(self)
    cdef void _feed_belt(self, double now)
    cdef void _alert_emergency(self, double now)
    cdef str _end_emergency(self)
    cdef void _walk_back(self)
    cdef bint _in_place_to_resume(self, odometry, double since_s)
    cdef void _check_release(self)
