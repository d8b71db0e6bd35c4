"""Problem files are data, never code: hostile statements, expressions and YAML, through the CLI."""

from __future__ import annotations

import time
from pathlib import Path

import pytest
from click.testing import CliRunner

from gradekit.cli import main

EX51 = Path("problem_bank/ch5_ex5_1_slider_crank_static.yaml")
# the line of `statement:` in EX51 (errors in the statement are reported there)
STATEMENT_LINE = 1 + [ln.startswith("statement:") for ln in EX51.read_text(encoding="utf-8").splitlines()].index(True)


def run(*args: str):
    return CliRunner().invoke(main, list(args))


def variant_of(tmp_path: Path, old: str, new: str, name: str = "hostile.yaml") -> str:
    text = EX51.read_text(encoding="utf-8")
    assert old in text
    f = tmp_path / name
    f.write_text(text.replace(old, new, 1), encoding="utf-8")
    return str(f)


def statement(tmp_path: Path, body: str) -> str:
    return variant_of(tmp_path, "OB = {{ r }}, BC", f"OB = {body}, BC")


def one_line(output: str) -> str:
    lines = [ln for ln in output.splitlines() if ln.strip()]
    assert len(lines) == 1 and "Traceback" not in output, output
    return lines[0].removeprefix("Error: ")


def test_statement_cannot_run_a_shell_command(tmp_path: Path) -> None:
    marker = tmp_path / "pwned"
    f = statement(tmp_path, "{{ lipsum.__globals__['os'].system('touch " + str(marker) + "') }}")
    r = run("bank", "show", f)
    assert r.exit_code == 1
    line = one_line(r.output)
    assert line.startswith(f"{f}:{STATEMENT_LINE}: statement: expected {{{{ parameter }}}}")
    assert line.endswith("got a function call on line 2 of the statement")
    assert not marker.exists()


def test_statement_cannot_reach_python_internals_even_without_a_call(tmp_path: Path) -> None:
    f = statement(tmp_path, "{{ r.__class__.__mro__ }}")
    r = run("bank", "show", f)
    assert r.exit_code == 1
    line = one_line(r.output)
    assert f"{f}:{STATEMENT_LINE}: statement: expected a statement using the problem's parameters" in line
    assert "__class__" in line and "mro" not in r.output.split("__class__")[0]


def test_statement_loops_and_huge_arithmetic_are_refused_fast(tmp_path: Path) -> None:
    looping = statement(tmp_path, "{% for i in range(100000) %}{% for j in range(100000) %}x{% endfor %}{% endfor %}")
    t0 = time.perf_counter()
    r = run("bank", "show", looping)
    assert r.exit_code == 1
    expected = "statement: expected {{ parameter }}, {% if %} and {% set %} only, got a for block on line 2"
    assert expected in one_line(r.output)
    huge = statement(tmp_path, "{{ 'x' * 10**9 }}")
    r = run("bank", "show", huge)
    assert r.exit_code == 1
    assert "statement: expected a statement using the problem's parameters, got an unsafe use" in one_line(r.output)
    power = statement(tmp_path, "{{ 9 ** 99999999 }}")
    r = run("bank", "show", power)
    assert r.exit_code == 1 and "unsafe use: ** gives a result too large" in one_line(r.output)
    assert time.perf_counter() - t0 < 10


def test_plain_statement_still_renders_the_values(tmp_path: Path) -> None:
    f = statement(tmp_path, "{{ r }} ({{ r.value | round(1) }}{% if r.value > 20 %}, long{% endif %})")
    r = run("bank", "show", f)
    assert r.exit_code == 0, r.output
    assert "OB = 30 mm (30.0, long), BC = 70 mm" in r.output


def test_power_tower_is_refused_before_evaluation(tmp_path: Path) -> None:
    f = variant_of(tmp_path, 'expr: "l >= 2.2*r"', 'expr: "l >= 9**9**9**9*r"')
    t0 = time.perf_counter()
    for command in (["solve", f], ["bank", "show", f], ["bank", "check", f, "--variants", "2"]):
        r = run(*command)
        assert r.exit_code == 1, (command, r.output)
        line = one_line(r.output)
        assert line == (
            f"{f}:28: constraints.require[0].expr: expected exponents of at most 1000, "
            "got a power tower in 'l >= 9**9**9**9*r'"
        )
    assert time.perf_counter() - t0 < 10


def test_long_and_deep_expressions_are_field_errors(tmp_path: Path) -> None:
    long = "+".join(["r"] * 60_000)
    f = variant_of(tmp_path, 'expr: "l >= 2.2*r"', f'expr: "l >= {long}"')
    r = run("solve", f)
    assert r.exit_code == 1
    assert one_line(r.output) == (
        f"{f}:28: constraints.require[0].expr: expected an expression of at most 500 characters, got 120,004"
    )
    deep = "-" * 300 + "r"
    f = variant_of(tmp_path, 'expr: "l >= 2.2*r"', f'expr: "l >= {deep}"', "deep.yaml")
    r = run("solve", f)
    assert r.exit_code == 1
    line = one_line(r.output)
    assert line.startswith(f"{f}:28: constraints.require[0].expr: expected an expression nested at most 40 deep")


# libyaml's composer recurses in C once per level: a million levels would overflow the stack (the process
# dies) rather than raise. Some libyaml versions refuse 1,000 levels themselves, before gradekit's bound of
# 60 is read, in their own words; either way one line, naming the file and the line.
NESTING = ("nesting deeper than 60 levels", "exceeded maximum nesting depth")


@pytest.mark.parametrize("levels", [100, 5_000, 990_000])  # the last just under the 2 MB a bank file may have
def test_deeply_nested_yaml_is_a_file_line_error(tmp_path: Path, levels: int) -> None:
    f = tmp_path / "nested.yaml"
    f.write_text("id: x\ntitle: " + "[" * levels + "]" * levels + "\n", encoding="utf-8")
    r = run("solve", str(f))
    assert r.exit_code == 1
    assert one_line(r.output) in {f"{f}:2: expected valid YAML, got {said}" for said in NESTING}
    if levels < 1_000:
        assert one_line(r.output) == f"{f}:2: expected valid YAML, got {NESTING[0]}"


def test_a_deeply_nested_tolerance_table_is_refused_naming_it(tmp_path: Path) -> None:
    from gradekit.bank.measured import measured_tolerances
    from gradekit.errors import ProblemError

    f = tmp_path / "_tolerances.yaml"
    f.write_text("a: " + "[" * 990_000 + "]" * 990_000 + "\n", encoding="utf-8")
    with pytest.raises(ProblemError) as err:
        measured_tolerances(tmp_path)
    assert err.value.format_message() in {f"{f}:1: expected the generated tolerance table, got {said}"
                                          for said in NESTING}


def test_billion_laughs_is_refused_in_well_under_a_second(tmp_path: Path) -> None:
    lines = ['a: &a ["lol", "lol", "lol", "lol", "lol", "lol", "lol", "lol", "lol"]']
    for prev, name in zip("abcdefgh", "bcdefghi", strict=True):
        lines.append(f"{name}: &{name} [" + ", ".join([f"*{prev}"] * 9) + "]")
    f = tmp_path / "laughs.yaml"
    f.write_text("\n".join(lines) + "\n", encoding="utf-8")
    t0 = time.perf_counter()
    r = run("solve", str(f))
    assert time.perf_counter() - t0 < 1.0
    assert r.exit_code == 1
    assert one_line(r.output) == (
        f"{f}:6: expected valid YAML, got more than 200,000 values once its aliases (*name) are expanded"
    )


def test_bank_check_takes_a_path_as_solve_does(tmp_path: Path) -> None:
    f = variant_of(tmp_path, "id: ch5-ex5-1", "id: my-copy")
    r = run("bank", "check", f, "--variants", "3", "--class-size", "5")
    assert r.exit_code == 0, r.output
    assert r.output.splitlines()[0].startswith("my-copy")
    assert " ok " in r.output.splitlines()[0]
    assert r.output.rstrip().endswith("bank check: all problems passed")
    assert "ch5-ex5-3" not in r.output  # only the file given, not the whole bank
    missing = tmp_path / "nope.yaml"
    r = run("bank", "check", str(missing))
    assert r.exit_code == 1
    assert one_line(r.output).startswith(f"{missing}: expected a readable UTF-8 YAML file")
