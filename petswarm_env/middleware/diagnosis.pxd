# The compiled form's declarations of diagnosis.py (Cython's augmenting .pxd): the diagnosis as a typed class that
# the robot's own clock stamp (middleware/station.py OwnClock) calls by C calls for every ring and AHRS reading.

from petswarm_env.sim.body cimport DrivenBody
from petswarm_env.sim.health cimport FaultState


cdef class Diagnosis:
    cdef public object node_id
    cdef public object cfg
    cdef public object robot
    cdef public object ring
    cdef public set failed
    cdef public list detected
    cdef public object on_detect
    cdef object _know_of
    cdef FaultState _health  # robot.health
    cdef DrivenBody _body  # the robot when it is a DrivenBody (its command by C reads), else None
    cdef double _us_max
    cdef list _us_angles
    cdef list _us_cos
    cdef list _us_sin
    cdef double _radius
    cdef double _us_reach
    cdef int _us_miss
    cdef int _us_silent
    cdef bint _us_by_self_test
    cdef double _us_echo_margin
    cdef double _slot_over_s
    cdef dict _ir_seen
    cdef object _starts_of  # the ring whose slot_starts dict _starts is
    cdef dict _starts
    cdef list _seen_keys  # by place in _starts: its key, and the very start object found evaluated there
    cdef list _seen_marks
    cdef int _ir_miss
    cdef set _ir_missed_from
    cdef double _ir_first_miss_s
    cdef int _ir_far_miss
    cdef set _ir_far_from
    cdef double _ir_far_first_s
    cdef double _own_seen
    cdef bint _ir_off  # "ir" in failed (kept with it by _detect, _clear, _reboot)
    cdef bint _us_off  # "ultrasonic" in failed
    cdef bint _ahrs_off  # "ahrs" in failed
    cdef bint _ahrs_noisy
    cdef bint _yaw_read  # a reading was taken (since power-on)
    cdef double _yaw_last_s  # ... its time
    cdef double _yaw_last  # ... its value
    cdef int _yaw_same
    cdef object _yaw_hist  # deque of (time, AHRS yaw, commanded rotation since start); the noiseless AHRS's check
    cdef double _turned
    cdef bint _ticked  # a ring reading was taken (since power-on)
    cdef double _tick_s  # ... its time

    cpdef on_ring(self, ranges, present, double now_s, bint rang=*)
    cpdef on_ahrs(self, double now_s, double yaw)
    cdef void _check_turn(self, double now_s, double yaw)
    cdef void _check_ir(self, double now_s)
    cdef void _mark_seen(self, Py_ssize_t p, object src, object start)
    cdef void _ir_hit(self)
    cdef void _ir_streak_over(self)
    cdef void _ir_missed(self, double now_s, object src, bint near)
    cdef void _check_ring(self, object ranges, object present, double now_s, bint rang)
    cdef bint _on_ray(self, list present, double now_s)
    cdef void _reboot(self)
    cdef void _detect(self, str part, double now_s)
    cdef void _clear(self, str part)
    cdef void _set_off(self, str part, bint off)
    cdef void _mark(self, str part, bint working)
