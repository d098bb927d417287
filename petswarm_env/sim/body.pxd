# The compiled form's declarations of body.py (Cython's augmenting .pxd: the typed attributes of its
# classes, and Chipmunk's body accessors called through their C addresses, which pymunk's cffi
# module gives; body.py reads them only when compiled, the interpreter calls them through cffi).

from petswarm_env.sim.battery cimport Battery
from petswarm_env.sim.clock cimport Clock

ctypedef struct cpVect:  # Chipmunk's cpVect (cpFloat is double in pymunk's build)
    double x
    double y

ctypedef cpVect (*_GetVec)(void *) noexcept nogil
ctypedef double (*_GetDbl)(void *) noexcept nogil
ctypedef void (*_SetVec)(void *, cpVect) noexcept nogil
ctypedef void (*_SetDbl)(void *, double) noexcept nogil
ctypedef void (*_SpaceStep)(void *, double) noexcept  # runs pymunk's collision callbacks (cffi reports their errors itself)

cdef _GetVec _cp_get_position
cdef _GetDbl _cp_get_angle
cdef _GetVec _cp_get_velocity
cdef _GetDbl _cp_get_angular_velocity
cdef _SetVec _cp_set_velocity
cdef _SetDbl _cp_set_angular_velocity
cdef _SpaceStep _cp_space_step


cdef class Body:
    cdef public object body
    cdef public object shape
    cdef public object _cbody
    cdef size_t _cp  # the address of the Chipmunk body (alive as long as ``body``)

    cdef double _read_heading(self)


cdef class DrivenBody(Body):
    cdef double _cx, _cy, _cw  # the command (its property: a tuple)
    cdef double _vx, _vy, _vw  # velocity_body
    cdef double _wx, _wy, _ww  # _wheels
    cdef tuple _accel
    cdef double _limits_dt
    cdef readonly double _max_dv  # read by Robot.apply (the wheels follow the command under the same limits)
    cdef readonly double _max_dw
    cdef public Battery battery
    cdef public double wheel_gain  # the wheels' view of the motion over the body's (a robot's 1 / (1 − slip))
    # a robot's MOVE module (sim/robot.py drive_command): a differential body's limits (else None), a mecanum
    # body's wheel limits (ω limit, wheel lever, wheel speed), the body's share of the wheels' motion (1 − slip)
    cdef object _differential
    cdef double _limit, _lever, _max_speed, _keep
    # what a robot's software gets of its ring's readings (a sim/sensors.py Readings, or None) and the robot's own
    # record of its broken sensors: read for every robot at every reading (Sensors.read_rings)
    cdef public object readings
    cdef public set sensors_off

    cdef _drive(self, double dt)
    cdef _apply(self, double dt)


cdef class WalkingBody(Body):
    cdef public object script
    cdef public object segment
    cdef public double script_time_s
    cdef public bint walking
    cdef public list pending_commands
    cdef object _seg_script, _seg
    cdef double _seg_end_s, _seg_speed, _seg_w
    cdef public bint returning
    cdef public double toward_x, toward_y, toward_mps

    cdef _apply(self, double dt)
    cdef _step_toward(self)


cdef class Substeps:
    cdef readonly object space
    cdef Clock _clock  # its run_until by a C call
    # pymunk's containers that its Space.step reads around Chipmunk's step (made once by the space, changed in place)
    cdef object _bodies_to_check, _removed_shapes, _add_later, _remove_later, _post_step_callbacks
    cdef bint _threaded
    cdef readonly list robots
    cdef readonly list users
    cdef readonly double dt
    cdef public long long done
    cdef public long long steps
    cdef size_t _cspace  # the address of the Chipmunk space (alive as long as ``space``)

    cpdef run(self, int n)
    cdef void _step(self, double dt)
