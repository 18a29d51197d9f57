"""The identification report: a self-contained HTML page and a Markdown summary."""

from simplexspline.aero.report.page import write_report

__all__ = ["write_report"]
