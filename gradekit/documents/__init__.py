"""Documents: each student's assignment sheet, answer template and worked key (jinja2 → Typst → PDF)."""

from gradekit.documents.engine import GenerateSummary, generate

__all__ = ["GenerateSummary", "generate"]
