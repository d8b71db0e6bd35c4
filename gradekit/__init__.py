"""gradekit: individual-value force-analysis assignments, worked keys and grading.

The Python API (`gradekit.api`) is exported here: ``load_problem``, ``sample``, ``sample_many``,
``solve``, ``solve_many``, ``figure``, ``figure_names``, ``generate`` and ``grade``. Importing the
package loads none of numpy, matplotlib, typst or click; each function imports what it needs.
"""

__version__ = "0.1.0"

from gradekit.api import (  # noqa: E402
    figure,
    figure_names,
    generate,
    grade,
    load_problem,
    sample,
    sample_many,
    solve,
    solve_many,
)

__all__ = [
    "__version__",
    "figure",
    "figure_names",
    "generate",
    "grade",
    "load_problem",
    "sample",
    "sample_many",
    "solve",
    "solve_many",
]
