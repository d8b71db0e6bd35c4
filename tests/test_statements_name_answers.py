"""Every quantity the answer table asks for is named in the statement a student reads.

The answer table (and the answers.csv template the student fills) lists each answer by its key;
the statement must name that quantity with the same symbol, so no student has to guess which
of the statement's words a row of the table means. A key is named by itself (``F12``, ``aG3_dir``)
or by its printed symbol, a leading Greek name written as the letter (``alpha2`` as α2, ``tau1``
as τ1), as a whole word of the statement rendered with one variant's values.
"""

from __future__ import annotations

import re

import pytest
from quick import bank_params

import gradekit
from gradekit.bank.registry import load_bank
from gradekit.statement import render_statement

BANK = load_bank()
GREEK = {"alpha": "α", "omega": "ω", "theta": "θ", "tau": "τ", "phi": "φ"}


def printed(key: str) -> set[str]:
    """The ways the sheet may write *key*: the key itself, and with its Greek name as a letter."""
    names = {key}
    for word, letter in GREEK.items():
        if re.fullmatch(rf"{word}(\d\w*)?", key):
            names.add(letter + key[len(word):])
    return names


def named(symbol: str, text: str) -> bool:
    """Whether *symbol* stands in *text* as a word of its own (F23 is not named by F23_I or F234)."""
    return re.search(rf"(?<![\w]){re.escape(symbol)}(?![\w])", text) is not None


def test_printed_symbols():
    assert printed("alpha2") == {"alpha2", "α2"}
    assert printed("tau") == {"tau", "τ"}
    assert printed("Fi2") == {"Fi2"}
    assert not named("F23", "the pin force F23_I at C and F234")
    assert named("F23", "the pin force F23 at C")


@pytest.mark.parametrize("pid", bank_params(sorted(BANK)))
def test_statement_names_every_answer(pid):
    p = BANK[pid]
    text = render_statement(p, gradekit.solve(gradekit.sample(pid, seed=1)).values)
    missing = [a.key for a in p.answers if not any(named(s, text) for s in printed(a.key))]
    assert not missing, f"{pid}: the statement does not name {missing}:\n{text}"
