"""A single self-contained HTML report: model, paper reproduction, comparison, diagnosis."""

from .build import ReportData, build_report, render_html, write_report

__all__ = ["ReportData", "build_report", "render_html", "write_report"]
