"""What a worked key's Typst compile spends its work on: the same real keys compiled as they are and
with one thing changed (tables left out, math as text, PDF tags off, figures as empty boxes, ...).

The bodies are the ones `generate` writes for examples/hw5.yaml (captured from a class of 6, with
their figures). Each variant compiles one sheet and one key as they are to warm the compiler (fonts), then
three more keys with the change; the figure is the work of those three keys a key. With ``--callgrind`` each
variant runs under valgrind and the work is counted in instructions, which do not depend on how
fast the machine is at the moment (about 1 minute a variant); without it, CPU time (noisy when the
machine is shared).

Run: ``python benchmarks/typst_costs.py [--callgrind] [VARIANT ...]`` (no variant: all).
Its table is pasted into RESULTS ("Typst: where a worked key's compile goes").
"""

from __future__ import annotations

import argparse
import re
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
KEYS = (3, 5, 7)  # the measured keys: sources 1, 3, 5, ... are keys, 0, 2, ... sheets


# a formula as `typeset.formula` writes it: the equation with its spoken alt text, then the math
FORMULA = re.compile(r'#math\.equation\(alt: ("(?:[^"\\]|\\.)*"), block: false, \$((?:[^$\\]|\\.)*)\$\.body\);')


def _as_text(formula: re.Match) -> str:
    return '#"' + formula.group(2).replace('"', "").replace("\\", "") + '";'


VARIANTS = {
    "as-is": lambda s: s,
    "no-tables": lambda s: re.sub(r"#table\(", "#let _t = table(", s),
    "math-as-text": lambda s: FORMULA.sub(_as_text, s),
    "pdf-tags-off": lambda s: s,  # the compile option, below
    "no-header-footer": lambda s: re.sub(r"header: context \{.*?\} \},\n", "", s, flags=re.S).replace(
        "footer: context { set text(8pt, fill: luma(90)); h(1fr); [Page #counter(page).display()]; h(1fr) })", ")"),
    "boxed-math": lambda s: FORMULA.sub(
        lambda m: f"#box(math.equation(alt: {m.group(1)}, block: false, ${m.group(2)}$.body));", s),
    "figures-as-boxes": lambda s: re.sub(r'fitted\("[^"]*", "(?:[^"\\]|\\.)*"\)', "box(width: 12cm, height: 6cm)", s),
    "no-matrix": lambda s: re.sub(r"#text\([0-9.]+pt\)\[#table\(", "#text(7.5pt)[#let _t = table(", s),
    "fr-columns": lambda s: re.sub(r"#table\(columns: \(([^)]*)\)",
                                   lambda m: "#table(columns: (" + m.group(1).replace("auto", "1fr") + ")", s),
}


def capture(folder: Path) -> None:
    """The Typst bodies of a class of 6 (sheet, key, sheet, key, ...) as src<i>.typ, and their root."""
    sys.path.insert(0, str(ROOT / "benchmarks"))
    import bench_generate

    from gradekit.documents import engine, typeset

    compile_pdf = typeset.Compiler.pdf

    def keep(self, source: str, **options) -> bytes:
        n = len(list(folder.glob("src*.typ")))
        (folder / f"src{n}.typ").write_text(source, encoding="utf-8")
        shutil.copytree(self.root, folder / "root", dirs_exist_ok=True)
        return compile_pdf(self, source, **options)

    typeset.Compiler.pdf = keep
    try:
        roster = bench_generate.roster(folder / "roster.csv", 6)
        engine.generate(bench_generate.ASSIGNMENT, roster, folder / "out", jobs=1, keys=True, progress=False)
    finally:
        typeset.Compiler.pdf = compile_pdf


def compile_variant(folder: Path, name: str, keys: tuple[int, ...] = KEYS) -> float:
    """Compile the warm-up pair and the *keys* with *name*'s change; the CPU s of the *keys*."""
    import typst

    change = VARIANTS[name]
    options = {"pdf_tags": False} if name == "pdf-tags-off" else {}
    sources = [(folder / f"src{i}.typ").read_text(encoding="utf-8") for i in range(max(keys, default=1) + 1)]
    compiler = typst.Compiler(root=str(folder / "root"))
    for i in (0, 1):  # as they are, so that every variant starts from the same warm compiler
        compiler.compile(input=sources[i].encode(), format="pdf", **options)
    t = time.process_time()
    for i in keys:
        compiler.compile(input=change(sources[i]).encode(), format="pdf", **options)
    return time.process_time() - t


def instructions(folder: Path, name: str, warm_only: bool = False) -> int:
    """Instructions of a run of `compile_variant` under callgrind (all threads)."""
    args = [sys.executable, __file__, "--compile", str(folder), name] + (["--warm-only"] if warm_only else [])
    out = subprocess.run(
        ["valgrind", "--tool=callgrind", "--callgrind-out-file=/dev/null", *args],
        capture_output=True, text=True, env={"RAYON_NUM_THREADS": "1", "PATH": "/usr/bin:/bin"}, check=True,
    )
    found = re.search(r"I\s+refs:\s+([\d,]+)", out.stderr)
    if not found:
        raise RuntimeError(f"expected callgrind's instruction count, got:\n{out.stderr[-2000:]}")
    return int(found.group(1).replace(",", ""))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("variants", nargs="*", help=f"some of: {', '.join(VARIANTS)}")
    ap.add_argument("--callgrind", action="store_true", help="count instructions under valgrind")
    ap.add_argument("--compile", nargs=2, metavar=("FOLDER", "VARIANT"), help=argparse.SUPPRESS)
    ap.add_argument("--warm-only", action="store_true", help=argparse.SUPPRESS)
    a = ap.parse_args()
    if a.compile:  # the child run under valgrind
        compile_variant(Path(a.compile[0]), a.compile[1], () if a.warm_only else KEYS)
        return
    names = a.variants or list(VARIANTS)
    unknown = [n for n in names if n not in VARIANTS]
    if unknown:
        ap.error(f"expected variants among {', '.join(VARIANTS)}, got {', '.join(unknown)}")
    if "as-is" not in names:
        names.insert(0, "as-is")
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        capture(folder)
        if a.callgrind:
            base = instructions(folder, "as-is", warm_only=True)
            per_key = {n: (instructions(folder, n) - base) / len(KEYS) for n in names}
            unit = "instructions a key"
        else:
            per_key = {n: sorted(compile_variant(folder, n) for _ in range(3))[1] / len(KEYS) for n in names}
            unit = "CPU s a key (median of 3)"
    ref = per_key["as-is"]
    print(f"| variant | {unit} | against as-is |\n|---|---|---|")
    for n in names:
        value = f"{per_key[n]:,.0f}" if a.callgrind else f"{per_key[n]:.4f}"
        print(f"| {n} | {value} | {100 * (per_key[n] / ref - 1):+.1f} % |")


if __name__ == "__main__":
    main()
