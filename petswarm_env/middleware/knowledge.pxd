# The compiled form's declarations of knowledge.py (Cython's augmenting .pxd): what a robot knows as
# typed attributes, so that the observation (observe.py), a station and the token ring, which read or
# write them for every slave at every step and for every IR slot, do so by C reads and writes.

cimport cython


@cython.final
cdef class IRMeasurement:
    cdef public double distance_m, bearing_rad, time_s, own_yaw_rad, own_x_m, own_y_m


@cython.final
cdef class HeadingEstimate:
    cdef public double relative_rad, time_s, own_yaw_rad


@cython.final
cdef class MasterStatus:
    cdef public object velocity, activity, mode, user_position_m
    cdef public double user_turn_rate_rps, time_s
    cdef public bint user_rotating


cdef MasterStatus new_status(object velocity, object activity, object mode, double user_turn_rate_rps,
                             object user_position_m, double time_s, bint user_rotating)


cdef class Knowledge:
    cdef public long member, total_members
    cdef public dict members  # member number -> node id (its lookups C calls for the ring's frames)
    cdef public dict ir  # node id -> latest IR measurement
    cdef public dict heading  # node id -> relative heading estimate
    cdef public object mode, lf_members, odometry_xy
    cdef public MasterStatus status
    cdef public double odometry_s

    cpdef void dead_reckon(self, double now_s, double vx, double vy, double yaw_rad)
    cpdef double formation_offset(self, double now_s, double yaw_rad, double fresh_s)
    cpdef object number_of(self, object node_id)
