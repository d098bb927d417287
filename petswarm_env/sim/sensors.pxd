# The compiled form's declarations of sensors.py (Cython's augmenting .pxd): the wheel odometry as a
# C call for the observation (observe.py cimports it), which reads it for every slave at every step.

from petswarm_env.sim.body cimport DrivenBody

cdef (double, double, double) wheel_odometry(DrivenBody robot, double ex, double ey, double ew) noexcept
