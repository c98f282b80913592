"""The result of a study analysis: report sections and every test (``results.json``)."""

from __future__ import annotations

from dataclasses import dataclass, field

from surfhap.lab import analysis as A
from surfhap.results import Result, jsonable

__all__ = ["Section", "StudyAnalysis"]


@dataclass
class Section:
    """One part of the report: paragraphs, tables (header, rows) and figures (name, result
    object with ``.plot()``, keyword arguments of the plot)."""

    title: str
    text: list[str] = field(default_factory=list)
    tables: list[tuple[list[str], list[list]]] = field(default_factory=list)
    figures: list[tuple[str, object, dict]] = field(default_factory=list)
    tests: list[dict] = field(default_factory=list)  # for results.json, see :meth:`add`
    estimates: list[dict] = field(default_factory=list)  # for results.json: name, value, ci, method, n

    def add(self, label: str, t: A.TestResult, groups: list[str], p_adj: float | None = None,
            correction: str = "") -> str:
        """Record test ``t`` (for results.json) and return its line for the text."""
        eff = None if t.estimate is None else {"name": _EFFECT[t.name.split(" ")[0]], "value": t.estimate}
        self.tests.append(jsonable({"name": label, "groups": groups, "statistic": t.statistic, "df": t.df, "p": t.p,
                                    "p_adjusted": p_adj, "alternative": t.alternative, "effect_size": eff,
                                    "method": t.name + (f", {correction}" if correction else "")}))
        df = f", df {t.df:g}" if isinstance(t.df, float) else ""
        return (f"{label}: {t.name}: statistic {t.statistic:.3g}{df}, p = {t.p:.3g}"
                + (f" (Bonferroni {p_adj:.3g})" if p_adj is not None else "") + f" [{t.alternative}]")


_EFFECT = {"binomial": "proportion", "z": "difference of proportions", "t": "difference of means", "r": "r"}


@dataclass
class StudyAnalysis(Result):
    name: str
    kind: str
    participants: list[str]
    n_trials: int
    incomplete: list[str]
    sections: list[Section]
    warnings: list[str] = field(default_factory=list)

    def summary_lines(self) -> list[str]:
        out = [f"{self.name}: {len(self.participants)} participants, {self.n_trials} trials"
               + (f" ({len(self.incomplete)} incomplete: {', '.join(self.incomplete)})" if self.incomplete else "")]
        out += [f"  warning: {w}" for w in self.warnings]
        for s in self.sections:
            out += [f"  {s.title}: {s.text[0]}"] if s.text else []
        return out

    @property
    def panels(self) -> int:
        """One per figure of the sections."""
        return sum(len(s.figures) for s in self.sections)

    def summary(self) -> dict:
        return jsonable({"name": self.name, "kind": self.kind, "participants": self.participants,
                         "n_trials": self.n_trials, "incomplete": self.incomplete, "warnings": self.warnings,
                         "sections": [{"title": s.title, "text": s.text} for s in self.sections]})

    def to_dict(self) -> dict:
        return jsonable({**self.summary(), "sections": [{"title": s.title, "text": s.text, "tables": s.tables}
                                                        for s in self.sections]})  # tables: (header, rows)

    def results(self) -> dict:
        """results.json: every test of every section (name, groups, statistic, df, p, adjusted p,
        alternative, method, effect size) and every estimate (name, value, 95 % CI, method, n)."""
        return jsonable({"name": self.name, "kind": self.kind, "participants": self.participants,
                         "tests": [{"section": s.title, **t} for s in self.sections for t in s.tests],
                         "estimates": [{"section": s.title, **e} for s in self.sections for e in s.estimates]})

    def plot(self, ax=None):
        """Every figure of the sections, one panel each (see :mod:`surfhap.report.lab_report`)."""
        from surfhap.report.lab_report import plot_study

        return plot_study(self, ax)
