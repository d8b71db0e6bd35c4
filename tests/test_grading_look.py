"""Whether a core is free for a helper is seen over the work that leads up to the choice (`parallel.Look`),
counting what this process used meanwhile as free: no sleep when that work took long enough."""

from __future__ import annotations

import time

from gradekit.grading import parallel


class _Clock:
    """Fake counters, clock and CPU time for `parallel`: each read returns the next of its values."""

    def __init__(self, counters, clock, cpu):
        self.counters, self.clock, self.cpu = iter(counters), iter(clock), iter(cpu)


def _fake(monkeypatch, counters, clock, cpu):
    c = _Clock(counters, clock, cpu)
    monkeypatch.setattr(parallel, "_counters", lambda: next(c.counters))
    monkeypatch.setattr(parallel.time, "monotonic", lambda: next(c.clock))
    monkeypatch.setattr(parallel.time, "process_time", lambda: next(c.cpu))
    monkeypatch.setattr(parallel.time, "sleep", lambda s: (_ for _ in ()).throw(AssertionError(f"slept {s}")))
    monkeypatch.setattr(parallel, "cores", lambda: 2)


def test_the_look_counts_this_process_busy_as_a_core_it_would_leave_free(monkeypatch):
    # over 0.2 s, no core sat idle (200 ticks of 200), and this process used 0.2 s of CPU: one core
    # was its own, so the other was busy with other work
    _fake(monkeypatch, [(1000, 5000), (1000, 5200)], [10.0, 10.2, 10.2], [3.0, 3.2])
    look = parallel.Look()
    assert abs(parallel._idle_cores(since=look) - 1.0) < 1e-9  # (the clock: at the look, for what is left, at its end)


def test_the_other_core_idle_while_this_process_works_is_a_spare_core(monkeypatch):
    # half of all ticks idle (one of two cores) while this process kept the other busy
    _fake(monkeypatch, [(1000, 5000), (1100, 5200)], [10.0, 10.2, 10.2], [3.0, 3.2])
    look = parallel.Look()
    assert parallel.spare_core(look)


def test_busy_elsewhere_while_this_process_works_is_no_spare_core(monkeypatch):
    # a tenth of the ticks idle, this process busy half the time: 0.2 + 0.5 cores are free of others
    _fake(monkeypatch, [(1000, 5000), (1020, 5200)], [10.0, 10.2, 10.2], [3.0, 3.1])
    look = parallel.Look()
    assert not parallel.spare_core(look)


def test_a_look_too_short_sleeps_for_the_rest(monkeypatch):
    slept = []
    monkeypatch.setattr(parallel.time, "sleep", slept.append)
    look = parallel.Look()
    look.at = time.monotonic() - 0.07  # began 70 ms ago
    idle = parallel._idle_cores(0.1, since=look)
    assert len(slept) == 1 and 0.0 < slept[0] <= 0.03 + 1e-6
    if idle is not None:
        assert 0.0 <= idle <= parallel.cores()


def test_a_long_look_does_not_sleep(monkeypatch):
    monkeypatch.setattr(parallel.time, "sleep", lambda s: (_ for _ in ()).throw(AssertionError(f"slept {s}")))
    look = parallel.Look()
    look.at -= 0.2
    look.cpu -= 0.2  # this process worked all along
    idle = parallel._idle_cores(0.1, since=look)
    if idle is not None:  # Linux
        assert 0.0 <= idle <= parallel.cores()
