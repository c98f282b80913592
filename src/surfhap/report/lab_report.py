"""HTML report of a study analysis (:class:`surfhap.lab.analyze_study.StudyAnalysis`)."""

from __future__ import annotations

from pathlib import Path

from surfhap.report.html import Page

__all__ = ["write_study_report"]


def write_study_report(result, folder: str | Path) -> Path:
    """Write ``index.html`` and one PNG per figure into ``folder``; returns the HTML path."""
    out = Path(folder)
    out.mkdir(parents=True, exist_ok=True)
    page = Page(f"surfhap study: {result.name}")
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
            fig = obj.plot(**kw)
            fig.savefig(out / f"{safe}.png", dpi=110)
            page.image(f"{safe}.png", name)
    path = out / "index.html"
    path.write_text(page.html(), encoding="utf-8")
    return path
