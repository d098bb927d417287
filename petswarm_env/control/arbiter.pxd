# The compiled form's declarations of arbiter.py (Cython's augmenting .pxd): the safety stage and the arbiter as
# typed classes, so that the per-step command loops (petswarm_env/step_kernel.py) call decide by a C call.

cdef class SafetyStage:
    cdef public object dirs  # (n, 2): each sensor's direction, body frame
    cdef list _dx  # the same as Python floats
    cdef list _dy
    cdef public double stop
    cdef public double backoff
    cdef public double two_a

    cpdef filter(self, command, ranges)


cdef class ControlArbiter:
    cdef public SafetyStage safety  # None: no ultrasonic stage
    cdef public object counts  # ArbiterCounts: the wins of this episode

    cpdef decide(self, policy_cmd, user_cmd=*, ranges=*, emergency_stop=*)
