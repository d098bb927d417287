"""The one clock (sim/clock.py): its first-of waits and bare callbacks run as SimPy would run them."""

import pytest
import simpy


def _trace_of_waits(clock):
    """Processes that wait on "an event or a timeout", as the token ring does; (time, label) trace."""
    trace = []

    def waiter(name, ev, timeout):
        got = yield clock.any_of([ev, clock.timeout(timeout)])
        trace.append((clock.now, name, ev in got))

    evs = [clock.event() for _ in range(4)]
    for k, ev in enumerate(evs):
        clock.process(waiter(f"w{k}", ev, 0.05 + 0.01 * k))
    clock.later(0.02, evs[0].succeed)  # before its timeout
    clock.later(0.08, evs[1].succeed)  # after its timeout: too late
    evs[2].succeed()  # already triggered when the condition is built? (processed at t=0)
    clock.later(0.03, lambda: trace.append((clock.now, "tick", None)))
    clock.run_until(0.2)
    return trace


def test_first_of_resumes_like_simpy_any_of():
    from petswarm_env.sim.clock import Clock

    class SimpyClock(Clock):
        def any_of(self, events):
            return simpy.AnyOf(self, events)

    fast, ref = _trace_of_waits(Clock()), _trace_of_waits(SimpyClock())
    assert fast == ref
    assert [t[1] for t in fast] == ["w2", "w0", "tick", "w1", "w3"]


def _later_as_simpy_timeouts(clock):
    """The oracle of ``Clock.later``: ``later(delay, fn, *args)`` is a SimPy timeout of ``delay``
    with one callback that calls ``fn(*args)`` (same queue key, so the same order)."""

    def later(delay, fn, *args):
        clock.timeout(delay).callbacks.append(lambda _event: fn(*args))

    return later


@pytest.mark.parametrize("loop", ["run_until", "run"])
def test_bare_callbacks_run_in_clock_order(loop):
    """``Clock.later`` runs its callbacks at the times and in the order of SimPy timeouts with a
    callback (a plain SimPy environment, the oracle), among a process's own timeouts, with
    ``run_until`` and with SimPy's ``run``; ``clock.now`` follows the time."""
    import simpy

    from petswarm_env.sim.clock import Clock

    def trace(clock, later):
        out = []
        for k, delay in enumerate([0.3, 0.1, 0.2, 0.1, 0.0]):
            later(delay, lambda k=k: out.append((round(clock.now, 9), k)))

        def proc():
            yield clock.timeout(0.15)
            out.append((round(clock.now, 9), "proc"))
            later(0.0, lambda: out.append((round(clock.now, 9), "from proc")))

        clock.process(proc())
        if loop == "run_until" and isinstance(clock, Clock):
            clock.run_until(1.0)
        else:
            clock.run(until=1.0)
        assert clock.now == 1.0
        return out

    want = trace(ref := simpy.Environment(), _later_as_simpy_timeouts(ref))
    assert want == [(0.0, 4), (0.1, 1), (0.1, 3), (0.15, "proc"), (0.15, "from proc"), (0.2, 2), (0.3, 0)]
    clock = Clock()
    assert trace(clock, clock.later) == want


def test_start_and_soon_run_where_a_process_start_and_an_event_success_run():
    """``clock.start(fn)`` is keyed as SimPy keys a process started now (its first step before the
    events due now), ``clock.soon(fn)`` as an event that succeeds now (after them): the same trace
    as a plain SimPy environment with processes and events, the oracle."""
    from petswarm_env.sim.clock import Clock

    def trace(clock, start, soon):
        out = []
        for k in range(3):
            clock.timeout(0.1).callbacks.append(lambda _e, k=k: out.append(("due", k)))

        def at_0_1():
            out.append(("now", round(clock.now, 9)))
            soon(lambda: out.append("soon a"))
            start(lambda: out.append("start"))
            soon(lambda: out.append("soon b"))

        clock.timeout(0.1).callbacks.append(lambda _e: at_0_1())
        clock.timeout(0.1).callbacks.append(lambda _e: out.append(("due", 3)))
        clock.run(until=1.0)
        return out

    def simpy_start(clock):
        def start(fn):
            def proc():
                fn()
                yield clock.timeout(0)
            clock.process(proc())
        return start

    def simpy_soon(clock):
        def soon(fn):
            ev = clock.event()
            ev.callbacks.append(lambda _e: fn())
            ev.succeed()
        return soon

    ref = simpy.Environment()
    want = trace(ref, simpy_start(ref), simpy_soon(ref))
    assert want == [("due", 0), ("due", 1), ("due", 2), ("now", 0.1), "start", ("due", 3), "soon a", "soon b"]
    clock = Clock()
    assert trace(clock, clock.start, clock.soon) == want
