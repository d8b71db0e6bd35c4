"""Run every benchmark and write benchmarks/RESULTS.md.

``python benchmarks/run.py [--quick] [--only=accuracy,...]``: the solver, accuracy and stability studies of this folder
and the other engineers' ``bench_grade`` / ``bench_figures`` / ``bench_generate`` (each through
its ``run(quick) -> dict``; a missing or failing one is skipped with a note). Speeds are medians
over several runs, ratios are measured within one run.
"""

from __future__ import annotations

import importlib
import json
import os
import platform
import subprocess
import sys
import time
import traceback
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
OTHERS = ("bench_grade", "bench_figures", "bench_generate")


def _machine() -> str:
    import matplotlib

    return (
        f"{platform.platform()}, {os.cpu_count()} CPUs (nproc {len(os.sched_getaffinity(0))}), "
        f"Python {platform.python_version()}, numpy {np.__version__}, matplotlib {matplotlib.__version__}"
    )


def _scalar_table(d: dict) -> str:
    rows = []

    def walk(prefix: str, v) -> None:
        if isinstance(v, dict):
            for k, x in v.items():
                walk(f"{prefix}.{k}" if prefix else str(k), x)
        elif isinstance(v, (list, tuple)) and v and all(isinstance(x, dict) for x in v):
            for i, x in enumerate(v):
                walk(f"{prefix}[{i}]", x)
        elif isinstance(v, (int, float, str, bool)) or v is None:
            text = f"{v:.4g}" if isinstance(v, float) else str(v)
            rows.append(f"| {prefix} | {text.replace('|', '/')} |")

    walk("", d)
    return "\n".join(["| field | value |", "|---|---|", *rows[:80]])


def solver_md(res: dict) -> str:
    return res["markdown"]


def _in_child(module: str, quick: bool, limit: float) -> dict:
    """``module.run(quick)`` in a child process, killed after *limit* seconds."""
    code = (
        f"import json, sys; sys.path.insert(0, {str(HERE)!r}); import {module} as m; "
        f"sys.stdout.write('\\n@@' + json.dumps(m.run({quick}), default=str))"
    )
    try:
        out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=limit, check=False)
    except subprocess.TimeoutExpired:
        raise TimeoutError(f"did not finish within {limit:.0f} s (skipped)") from None
    if out.returncode or "@@" not in out.stdout:
        if "ModuleNotFoundError" in out.stderr and module in out.stderr:
            raise ModuleNotFoundError(f"no module {module}")
        raise RuntimeError(out.stderr.strip().splitlines()[-1] if out.stderr.strip() else "no result")
    return json.loads(out.stdout.rsplit("@@", 1)[1])


def _generate_md(res: dict) -> str:
    """Students per minute of `gradekit generate` (examples/hw5.yaml), one row per configuration, and
    the marginal rate between the two class sizes against the targets."""
    rows = ["| class | jobs | worked keys | run | seconds | students/min |", "|---|---|---|---|---|---|"]
    for r in res.get("results", []):
        rows.append(f"| {r['students']} | {r['jobs']} | {'yes' if r['keys'] else 'no'} | {r.get('run', 1)} | "
                    f"{r['seconds']} | {r['per_minute']} |")
    marginal = res.get("marginal_per_minute", {})
    if marginal:
        rows += ["", "Marginal rate between the two class sizes, (300 − 30) / (t300 − t30), start excluded; with "
                 "keys the median of the runs:", "",
                 "| | students/min | runs | target | met |", "|---|---|---|---|---|"]
        rows += [f"| {k} | {v['per_minute']:g} | {', '.join(f'{x:g}' for x in v.get('runs', [v['per_minute']]))} | "
                 f"≥ {v['target']:g} | {'yes' if v['meets'] else 'NO'} |" for k, v in marginal.items()]
    note = (
        "The whole `generate` (class draws and keys, every sheet, answer template and worked key, key.csv, "
        "keys.json, both combined PDFs, manifest), 2 jobs on this 2-core machine: sheets alone one run of each "
        "class size, with keys three runs of the pair (30 then 300), whose median marginal rate is the figure "
        "(the machine's speed swings 10–15 % from one minute to the next)."
    )
    combine = next((r["combine"] for r in res.get("results", []) if r.get("combine")), None)
    if combine:
        (k1, t1), (k2, t2) = sorted((int(k), v) for k, v in combine.items())
        note += (f"\n\nConcatenating the worked keys into one PDF as keys.pdf is made (`combine_times`, after the "
                 f"{k2}-student run): {k1} keys {t1:g} s, {k2} keys {t2:g} s ({1000 * t1 / k1:.1f} and "
                 f"{1000 * t2 / k2:.1f} ms a key).")
    parts = res.get("breakdown")
    if parts:
        layout = parts["typst_layout_s_per_student"]
        note += (
            f"\n\nWhere a worker's time goes (`breakdown` in the script: CPU seconds a student in one process, "
            f"{parts['students']} students after a warm-up one, worked keys on):\n\n"
            "| part | CPU s a student |\n|---|---|\n"
            + "\n".join(f"| {k} | {v:g} |" for k, v in parts["cpu_s_per_student"].items())
            + f"\n| **total** | **{parts['total_cpu_s_per_student']:g}** |\n\n"
            f"Typst's layout alone (the same bodies compiled without PDF export): sheet {layout['typst sheet']:g} s, "
            f"key {layout['typst key']:g} s; the rest of each is PDF export. Two workers on two cores give at most "
            f"2 × 60 / total students a minute, before the contention of running both at once."
        )
    return "\n".join(rows) + "\n\n" + note


def merged(path: Path, sections: list[tuple[str, str]], keep_order: bool) -> list[tuple[str, str]]:
    """This run's sections with those of the existing RESULTS.md it did not produce (e.g. a section
    another benchmark writes by its own command), kept as they are. With *keep_order* (``--only``)
    the existing order stands and this run's sections replace theirs in place; else this run's
    sections come first."""
    old: list[tuple[str, list[str]]] = []
    if path.is_file():
        for line in path.read_text(encoding="utf-8").splitlines():
            if line.startswith("## "):
                old.append((line[3:].strip(), []))
            elif old:
                old[-1][1].append(line)
    kept = [(t, "\n".join(lines).strip("\n")) for t, lines in old]
    new = dict(sections)
    if not keep_order:
        return sections + [(t, x) for t, x in kept if t not in new]
    out = [(t, new.pop(t, x)) for t, x in kept]
    return out + list(new.items())


def main(argv: list[str]) -> int:
    quick = "--quick" in argv
    only = {x for a in argv if a.startswith("--only=") for x in a[len("--only=") :].split(",")}
    command = "python benchmarks/run.py" + (" --quick" if quick else "")
    t_all = time.perf_counter()
    sections: list[tuple[str, str]] = []

    def attempt(title: str, module: str, render, limit: float | None = None) -> None:
        if only and module not in only:
            return
        t = time.perf_counter()
        try:
            res = _in_child(module, quick, limit) if limit else importlib.import_module(module).run(quick)
        except ModuleNotFoundError as exc:
            sections.append((title, f"(skipped: {exc})"))
            return
        except Exception as exc:  # noqa: BLE001 - one failing benchmark must not lose the others
            sections.append(
                (title, f"(failed: {type(exc).__name__}: {exc})\n\n```\n{traceback.format_exc()[-1500:]}```")
            )
            return
        sections.append((title, render(res) + f"\n\n_{time.perf_counter() - t:.0f} s._"))
        print(f"{module}: {time.perf_counter() - t:.1f} s", file=sys.stderr)

    attempt("Solver throughput", "bench_solver", solver_md)
    attempt(
        "Accuracy and tolerances",
        "accuracy",
        lambda r: r["markdown"] + "\n\n" + "\n".join(f"![{k}](plots/{Path(p).name})" for k, p in r["plots"].items()),
    )
    attempt("Stability at the extremes", "stability", lambda r: r["markdown"])
    titles = {
        "bench_grade": "Grading throughput",
        "bench_figures": "Figure time",
        "bench_generate": "Generate: students per minute",
    }
    renderers = {"bench_generate": _generate_md, "bench_grade": lambda r: r["markdown"]}
    for name in OTHERS:
        # generate at a class of 300 with keys takes minutes on 2 cores: give it room
        limit = (90.0 if quick else 1500.0) if name == "bench_generate" else (45.0 if quick else 300.0)
        attempt(f"{titles.get(name, name)} (`benchmarks/{name}.py`)", name, renderers.get(name, _scalar_table), limit)
    body = [
        "# Benchmark results",
        "",
        f"Produced by `{command}` in {time.perf_counter() - t_all:.0f} s on {time.strftime('%Y-%m-%d %H:%M')}.",
        "",
        f"Machine: {_machine()}.",
        "",
    ]
    if only and (HERE / "RESULTS.md").is_file():  # the other sections' preamble stands, with a note
        pre = (HERE / "RESULTS.md").read_text(encoding="utf-8").split("\n## ", 1)[0].rstrip("\n").splitlines()
        note = f"Re-run by `{command} --only={','.join(sorted(only))}` on {time.strftime('%Y-%m-%d %H:%M')}: "
        body = "\n".join(ln for ln in pre if not ln.startswith("Re-run by ")).rstrip("\n").splitlines()
        body += ["", note + ", ".join(t for t, _ in sections) + ".", ""]
    for title, text in merged(HERE / "RESULTS.md", sections, keep_order=bool(only)):
        body += [f"## {title}", "", text, ""]
    (HERE / "RESULTS.md").write_text("\n".join(body), encoding="utf-8")
    print(f"wrote {HERE / 'RESULTS.md'} in {time.perf_counter() - t_all:.0f} s", file=sys.stderr)
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
