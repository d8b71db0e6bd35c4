"""The bank problems the README's quick test run checks one by one; every other problem is checked under
the slow marker (`python -m pytest -m slow`; .ci/run runs both)."""

from __future__ import annotations

import pytest

# one of each method (analytical, graphical), analysis (static, dynamic), mechanism kind and route
QUICK = {"ch5-ex5-1", "ch5-ex5-2", "ch5-ex5-3", "ch5-quiz-q2", "s003-slotted-lever", "s004-case-study"}


def bank_params(ids) -> list:
    """*ids* as pytest parameters: those of `QUICK` as they are, the others marked slow."""
    return [pid if pid in QUICK else pytest.param(pid, marks=pytest.mark.slow) for pid in ids]
