"""Allow `python -m gradekit`."""

from gradekit.cli import run

if __name__ == "__main__":  # pragma: no cover
    run()
