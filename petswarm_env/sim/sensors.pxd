# The compiled form's declarations of sensors.py (Cython's augmenting .pxd): the wheel odometry as a
# C call for the observation (observe.py cimports it), which reads it for every slave at every step; what a
# robot's software gets of its readings, as C calls (middleware/station.py's OwnClock implements it); the AHRS,
# whose reading the station and the observation take by a C call.

from petswarm_env.sim.body cimport Body, DrivenBody
from petswarm_env.sim.health cimport FaultState

cdef (double, double, double) wheel_odometry(DrivenBody robot, double ex, double ey, double ew) noexcept


cdef class Readings:
    cpdef ring(self, ranges, present, double now_s, bint rang)
    cpdef ahrs(self, double now_s, double yaw)


cdef class AHRS:
    cdef public object body
    cdef public double noise_rad  # σ of the white noise
    cdef public double drift_rad  # σ of the bias walk over one second
    cdef public double bias_rad
    cdef public double power_on_heading_rad  # the heading its readings count from
    cdef public double time_s  # clock time of the last bias step
    cdef public double _last_yaw  # the last reading (a frozen AHRS repeats it)
    cdef public Readings readings  # the robot's software sees every reading (its self-diagnosis)
    cdef object _heading
    cdef Body _body  # the body when it is a Body (its heading a C call), else None
    cdef FaultState _health  # the body's health (its ahrs_ok a C read), or None
    cdef object _normals  # its NormalStream: its noise's normals, in blocks

    cpdef double yaw(self, double now_s)
