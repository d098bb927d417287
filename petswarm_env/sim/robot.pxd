# The compiled form's declarations of robot.py (Cython's augmenting .pxd): a robot's command through its MOVE
# module as a C function, which the per-step command loops (petswarm_env/step_kernel.py) call directly.

from petswarm_env.sim.body cimport DrivenBody

cdef void drive_command(DrivenBody body, double vx, double vy, double omega)
