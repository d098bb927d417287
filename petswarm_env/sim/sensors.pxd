# The compiled form's declarations of sensors.py (Cython's augmenting .pxd): the wheel odometry as a
# C call for the observation (observe.py cimports it), which reads it for every slave at every step; what a
# robot's software gets of its readings, as C calls (middleware/station.py's OwnClock implements it).

from petswarm_env.sim.body cimport DrivenBody

cdef (double, double, double) wheel_odometry(DrivenBody robot, double ex, double ey, double ew) noexcept


cdef class Readings:
    cpdef ring(self, ranges, present, double now_s, bint rang)
    cpdef ahrs(self, double now_s, double yaw)
