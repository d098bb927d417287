# The compiled form's declarations of geometry.py (Cython's augmenting .pxd): the ring's ray cast as
# a C call for the ultrasonic ring (sensors.py cimports it), which runs it for every robot's ring at
# every step.

cpdef double wrap_float(double angle_rad)  # wrap_angle of one float

cpdef ring_cast(const double[:, ::1] origins, Py_ssize_t n, const double[::1] headings, const double[::1] angles,
                const double[:, ::1] centers, const double[::1] radii, const double[::1] walls, double max_range,
                double[:, ::1] out, double[:, ::1] dirs)
