# The compiled form's declarations of belt_window.py (Cython's augmenting .pxd): the window statistics
# as a C call for the belt (belt.py cimports them), which runs them for every accelerometer sample.

cpdef tuple window_stats(double[::1] samples, Py_ssize_t start, Py_ssize_t stop, Py_ssize_t w, double deadband)
