"""HTML report of a study analysis (:class:`surfhap.lab.analyze_study.StudyAnalysis`)."""

from __future__ import annotations

from pathlib import Path

from matplotlib.figure import Figure

from surfhap.report.axes import figure_axes
from surfhap.report.html import start_page

__all__ = ["write_study_report", "plot_study"]


def plot_study(result, ax=None) -> Figure:
    """Every figure of the analysis's sections in one panel each (up to 3 columns)."""
    figures = [(obj, kw) for sec in result.sections for _, obj, kw in sec.figures]
    cols = max(1, min(len(figures), 3))
    rows = max(1, -(-len(figures) // cols))
    fig, axs = figure_axes(ax, len(figures), (4.5 * cols, 3.6 * rows), nrows=rows, ncols=cols)
    for a in axs[len(figures):]:
        a.set_axis_off()
    for (obj, kw), a in zip(figures, axs):
        obj.plot(a, **kw)
    return fig


def write_study_report(result, folder: str | Path) -> Path:
    """Write ``index.html`` and one PNG per figure into ``folder``; returns the HTML path."""
    out, page = start_page(folder, f"surfhap study: {result.name}")
    page.paragraph(f"{result.kind} study, {len(result.participants)} participants "
                   f"({', '.join(result.participants)}), {result.n_trials} trials logged.")
    if result.incomplete:
        page.paragraph(f"Incomplete sessions: {', '.join(result.incomplete)}.", cls="bad")
    for w in result.warnings:
        page.paragraph(f"Warning: {w}", cls="bad")
    for sec in result.sections:
        page.heading(sec.title)
        for t in sec.text:
            page.paragraph(t)
        for header, rows in sec.tables:
            page.table(header, rows)
        for name, obj, kw in sec.figures:
            safe = "".join(ch if ch.isalnum() or ch in "-_" else "_" for ch in name)
            page.figure(obj.plot(**kw), out, f"{safe}.png", name)
    return page.write(out / "index.html")
