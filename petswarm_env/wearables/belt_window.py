"""The smart belt's window statistics (seed 002 §3.4), typed: each accelerometer window's
periodicity (sign changes) and signal magnitude area, the window mean (gravity) removed first.

Seed 002 §3.4: "The periodicity is defined by checking the number of sign changes of the values
that occur within a valid time period. [...] The SMA accumulates the accelerometer values within
the programmer-defined time." :mod:`.belt` keeps the rules and the choices (the dead band, the
mean as gravity); this module is their arithmetic on every window, which the belt runs for every
accelerometer sample (50 per second).

A module of the compiled core (``petswarm_env/_core.py``): Cython's pure-Python mode, so this file
runs as it is under the interpreter and is compiled to C at install.

Sums are numpy's: ``np.add.reduce`` on float64 adds a row by pairwise summation (its
``pairwise_sum``: up to 128 values in 8 interleaved lanes, then the lanes pairwise and the rest in
order; a longer row halved, at a multiple of 8, and each half summed so; the reduction starts from
0.0). The statistics are, value for value, those of the belt's first form (numpy on the windows,
kept in ``tests/oracles.py``; ``tests/unit/test_belt.py`` holds the two equal, bit for bit).
"""

from __future__ import annotations

import cython

COMPILED = cython.compiled  # True in the compiled form (petswarm_env/_core.py checks it)

_BLOCK = 128  # numpy's PW_BLOCKSIZE: rows up to this long are summed in 8 lanes without halving


@cython.cfunc
@cython.exceptval(check=False)
def _value(a: cython.double[::1], i: cython.Py_ssize_t, mean: cython.double, centred: cython.bint) -> cython.double:
    """``a[i]``, or ``|a[i] − mean|`` (the mean-removed magnitude the SMA accumulates)."""
    if centred:
        return abs(a[i] - mean)
    return a[i]


@cython.cfunc
@cython.exceptval(check=False)
def _pairwise_sum(a: cython.double[::1], lo: cython.Py_ssize_t, n: cython.Py_ssize_t, mean: cython.double,
                  centred: cython.bint) -> cython.double:
    """The sum of ``n ≥ 1`` values from ``a[lo]`` (each :func:`_value`) in numpy's pairwise order."""
    i: cython.Py_ssize_t
    res: cython.double
    if n < 8:  # in order (numpy starts from -0.0, which the first value leaves as that value)
        res = _value(a, lo, mean, centred)
        for i in range(lo + 1, lo + n):
            res += _value(a, i, mean, centred)
        return res
    if n <= _BLOCK:
        r0: cython.double = _value(a, lo, mean, centred)
        r1: cython.double = _value(a, lo + 1, mean, centred)
        r2: cython.double = _value(a, lo + 2, mean, centred)
        r3: cython.double = _value(a, lo + 3, mean, centred)
        r4: cython.double = _value(a, lo + 4, mean, centred)
        r5: cython.double = _value(a, lo + 5, mean, centred)
        r6: cython.double = _value(a, lo + 6, mean, centred)
        r7: cython.double = _value(a, lo + 7, mean, centred)
        end: cython.Py_ssize_t = lo + n - n % 8
        i = lo + 8
        while i < end:
            r0 += _value(a, i, mean, centred)
            r1 += _value(a, i + 1, mean, centred)
            r2 += _value(a, i + 2, mean, centred)
            r3 += _value(a, i + 3, mean, centred)
            r4 += _value(a, i + 4, mean, centred)
            r5 += _value(a, i + 5, mean, centred)
            r6 += _value(a, i + 6, mean, centred)
            r7 += _value(a, i + 7, mean, centred)
            i += 8
        res = ((r0 + r1) + (r2 + r3)) + ((r4 + r5) + (r6 + r7))
        while i < lo + n:
            res += _value(a, i, mean, centred)
            i += 1
        return res
    half: cython.Py_ssize_t = n // 2
    half -= half % 8
    return _pairwise_sum(a, lo, half, mean, centred) + _pairwise_sum(a, lo + half, n - half, mean, centred)


@cython.ccall
def window_stats(samples: cython.double[::1], start: cython.Py_ssize_t, stop: cython.Py_ssize_t,
                 w: cython.Py_ssize_t, deadband: cython.double) -> tuple:
    """The windows ``samples[j : j + w]`` for ``j`` in ``[start, stop)``: their sign changes and
    SMAs (m/s²), as two lists.

    Each window's mean is removed (it holds gravity). A value's sign is + above ``deadband``, −
    below ``-deadband``, none inside the band: a value inside the band keeps the last sign, so
    sensor noise around zero is not counted as motion; a change is a + after a − or a − after a +.
    The SMA is the mean of the mean-removed values' magnitudes."""
    size: cython.Py_ssize_t = len(samples)
    if w < 1 or start < 0 or stop > size - w + 1:
        raise ValueError(f"windows of {w} samples from {start} to {stop} do not fit {size} samples")
    changes: list = []
    smas: list = []
    inv_w: cython.double = 1.0 / w
    j: cython.Py_ssize_t
    i: cython.Py_ssize_t
    sign: cython.int
    last: cython.int
    count: cython.int
    for j in range(start, stop):
        mean: cython.double = (0.0 + _pairwise_sum(samples, j, w, 0.0, False)) * inv_w
        last, count = 0, 0
        for i in range(j, j + w):
            x: cython.double = samples[i] - mean
            sign = 0  # (x > deadband) − (x < −deadband)
            if x > deadband:
                sign = 1
            if x < -deadband:
                sign -= 1
            if sign != 0:
                if last != 0 and sign != last:
                    count += 1
                last = sign
        changes.append(count)
        smas.append((0.0 + _pairwise_sum(samples, j, w, mean, True)) * inv_w)
    return changes, smas
