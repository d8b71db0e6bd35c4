"""Speeds of rotation as machinery is specified: rev/min, RPM, r/min and rev/s are read as what they
say, a revolution being 2π rad (they were refused as unreadable, the answer left ungraded)."""

from __future__ import annotations

import math

import pytest

from gradekit import units
from gradekit.errors import GradekitError


@pytest.mark.parametrize("unit, to, expected", [
    ("rev/min", "rad/s", 2 * math.pi / 60), ("RPM", "rad/s", 2 * math.pi / 60), ("r/min", "rad/s", 2 * math.pi / 60),
    ("revs/min", "rad/s", 2 * math.pi / 60), ("rev/s", "rad/s", 2 * math.pi), ("rev/min", "rpm", 1.0),
    ("rpm", "rad/s", 2 * math.pi / 60), ("rev/s**2", "rad/s**2", 2 * math.pi), ("deg/s", "rad/s", math.pi / 180),
])
def test_speeds_of_rotation_as_machinery_gives_them(unit, to, expected):
    assert units.factor(unit, to) == pytest.approx(expected, rel=1e-12)


def test_a_speed_of_rotation_is_still_not_a_force():
    with pytest.raises(GradekitError, match="same kind"):
        units.factor("rev/min", "N")


def test_an_answer_in_rev_per_min_is_graded_against_a_key_in_rad_per_s():
    from gradekit.grading.compare import compare
    from gradekit.grading.reader import Answer
    from gradekit.solving.keys import KeyEntry, Tolerance

    key = KeyEntry("1", "p1", "p1.w3", 10.0, "rad/s", Tolerance(rel=0.001))
    right = 10.0 * 60 / (2 * math.pi)  # 95.493 rev/min
    got = compare(key, Answer("p1.w3", f"{right:.4f}", "rev/min", round(right, 4), "rev/min", 2))
    assert got.correct and got.value == pytest.approx(10.0, rel=1e-5)
    assert not compare(key, Answer("p1.w3", "10", "rev/min", 10.0, "rev/min", 2)).correct


@pytest.mark.parametrize("unit, to", [("Hz", "rad/s"), ("Hz", "rpm"), ("kHz", "rad/s"), ("rad/s", "Hz"),
                                      ("Hz/s", "rad/s**2")])
def test_hertz_for_a_speed_of_turning_is_refused_not_guessed(unit, to):
    # pint takes 1 Hz for 1 rad/s (and 9.55 rpm), while "2 Hz" for a shaft's speed may mean 2 rev/s
    # (4π rad/s) or 2 rad/s: the answer is left for the instructor with a message saying how to write it
    with pytest.raises(GradekitError, match=r"hertz counts cycles: write rev/s"):
        units.factor(unit, to)


@pytest.mark.parametrize("unit, to, expected", [("Hz", "1/s", 1.0), ("kHz", "Hz", 1000.0), ("1/s", "rad/s", 1.0),
                                                ("cycle/s", "rad/s", 2 * math.pi)])
def test_hertz_among_frequencies_and_cycles_a_second_still_convert(unit, to, expected):
    assert units.factor(unit, to) == pytest.approx(expected, rel=1e-12)


def test_an_answer_in_hertz_is_not_graded_and_says_why():
    from gradekit.grading.compare import compare
    from gradekit.grading.reader import Answer
    from gradekit.solving.keys import KeyEntry, Tolerance

    key = KeyEntry("1", "p1", "p1.w3", 4 * math.pi, "rad/s", Tolerance(rel=0.001))
    got = compare(key, Answer("p1.w3", "2", "Hz", 2.0, "Hz", 2))  # 2 rev/s = 4π rad/s, or 2 rad/s?
    assert not got.correct and got.value is None and "hertz counts cycles" in got.message
