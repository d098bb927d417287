# The compiled form's declarations of master.py (Cython's augmenting .pxd): the belt's view, the user
# tracker and the master-role controller as typed classes, so that the user session
# (middleware/user_session.py), which runs them every control period, reads and calls them by C reads
# and C calls.


cdef class BeltView:
    cdef public str activity
    cdef public bint rotating
    cdef public double angular_speed_rps
    cdef public double accumulated_angle_rad
    cdef public double time_s


cdef class UserTracker:
    cdef public double alpha, beta
    cdef public list pose  # own x, y (odometry frame) and AHRS yaw
    cdef public object pos  # [x, y] of the user (odometry frame), None before a fix
    cdef public list vel  # [vx, vy] of the user (odometry frame)
    cdef public double t_fix
    cdef public double last_fix_s

    cpdef reset(self, double yaw_rad=*)
    cpdef move(self, odometry, double yaw, double dt)
    cpdef move_without_ahrs(self, odometry, double dt)
    cpdef fix(self, body_xy, double t, double weight=*)
    cpdef user_body(self, double t)


cdef class MasterController:
    cdef object _cfg
    cdef public double half_angle
    # the configuration's gains as C doubles (a MasterConfig is frozen; set again with ``cfg``)
    cdef double _walk_speed, _blend
    cdef double _band  # the rotate deadband, rad
    cdef double _acc_band, _distance_gain, _speed_gain, _arc_gain, _trail, _sideways_gain, _rotate_gain
    cdef double _settle  # arc_sync_done_deg, rad
    cdef double _sync_gain, _brake
    # state
    cdef double _walk_dir  # ψ: the user's walking direction, body frame
    cdef bint _has_walk_dir  # ψ is set (not before the first command)
    cdef bint _trusted  # ψ steers: tracked, or guessed while the user stood still (not mid-turn)
    cdef double _belt_angle  # the belt's accumulated angle at the last step (current rotation)
    cdef bint _was_rotating
    cdef bint _syncing  # a leading arc of the current rotation runs: its share and the arc done
    cdef double _share, _done
    cdef bint _was_rotating_arc

    cpdef reset(self)
    cpdef tuple user_velocity(self, user_vel, BeltView belt, double own_omega, str mode, double bearing, double dt)
    cdef _arc_in_place(self, BeltView belt, double off, double ux, double uy, own_velocity, double dt)
    cpdef tuple command(self, user_pos, user_vel, BeltView belt, own_velocity, str mode, double target_distance_m,
                        double dt)
    cdef tuple _command(self, double ux, double uy, double r, double nx, double ny, double bearing, double wx,
                        double wy, bint walking, BeltView belt, own_velocity, bint leading, double target_distance_m,
                        double dt)
