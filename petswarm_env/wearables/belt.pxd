# The compiled form's declarations of belt.py (Cython's augmenting .pxd): the smart belt as a typed
# class, so that the user session (middleware/user_session.py) advances it every control period and
# reads it every report period by C calls. (BeltReading, a Cython dataclass, is left out: declared
# here it would lose its generated ``__eq__``.)


cdef class SmartBelt:
    cdef dict __dict__
    cdef public object cfg
    cdef object _normals  # the stream's normals after power-on, in blocks (sim/sensors.NormalStream)
    cdef double _t0, _t, _acc_dt
    cdef Py_ssize_t _w, _n_acc
    cdef object _hist  # array("d")
    cdef public double _gait_phase
    cdef Py_ssize_t _n_gyro
    cdef double _stride_phase, _bias_rps
    cdef list _ma
    cdef double _on_rps, _off_rps, _gyro_noise_rps, _wobble_rad
    cdef tuple _cadence
    cdef int _activity
    cdef double _activity_since
    cdef object _sign_changes
    cdef double _sma
    cdef bint _rotating
    cdef double _rotation_since, _omega_f, _angle
    # the config's numbers read at every control period, read once (a config is frozen)
    cdef double _gyro_dt, _acc_noise, _walk_bounce, _run_bounce, _gait_jitter, _rest_hz, _rest_amp, _rest_jitter
    cdef double _deadband
    cdef int _min_changes
    cdef double _level2, _level3

    cpdef advance(self, double t_end, double speed_mps, double turn_rate_rps, str posture)
    cpdef reading(self)
    cdef double _cadence_hz(self, str posture, double speed_mps)
    cpdef list _synth_accel(self, Py_ssize_t n, double speed_mps, str posture)
    cdef _accel_chunk(self, Py_ssize_t n, double speed_mps, str posture)
    cdef _gyro_samples(self, Py_ssize_t m, double speed_mps, double turn_rate_rps, str posture)
