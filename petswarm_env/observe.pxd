# The compiled form's declarations of observe.py (Cython's augmenting .pxd): the builder's plan, the
# layout's offsets and scales as C values that _fill reads for every slave at every step.

cdef class _Plan:
    cdef double vmax, wmax, us_max  # the layout's limits (v_max, ω_max) and the ring's range
    cdef double ir_max  # the IR estimator's largest distance (m): a carried fix's bound
    cdef Py_ssize_t link0, link_size, max_links  # link k's fields start at link0 + k·link_size
    # the starts of _BUILDER_FIELDS, in its order
    cdef Py_ssize_t master, activity, rotating, turn_rate, leading, user_xy, master_ir, anchor, odo, yaw, last
    cdef Py_ssize_t offset, us, hierarchy, members, member, flags


cdef class Observer:
    cdef public object layout
    cdef public object nodes
    cdef public object sensors
    cdef public list ahrs
    cdef public object agent_index
    cdef public double master_distance_m
    cdef dict _formation_cache
    cdef _Plan _plan
