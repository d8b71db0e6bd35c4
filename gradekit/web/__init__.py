"""The online page, `gradekit serve`: students answer and are graded at once (see docs/serve.md)."""
