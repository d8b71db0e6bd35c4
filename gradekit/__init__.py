"""gradekit: individual-value force-analysis assignments, worked keys and grading."""

__version__ = "0.1.0"
