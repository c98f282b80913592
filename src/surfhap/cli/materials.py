"""``surfhap materials``: list the built-in materials."""

from __future__ import annotations

import typer
from rich.table import Table

from surfhap.cli._common import stdout

__all__ = ["register"]


def materials() -> None:
    """List the built-in materials, their friction laws, texture models and sources."""
    from surfhap.exchange.materials import builtin_names, load_material
    from surfhap.render.drive import default_method

    table = Table(title="built-in materials", show_lines=False)
    for col in ("name", "friction", "texture", "default method", "sources"):
        table.add_column(col)
    for name in builtin_names():
        m = load_material(name)
        fr = []
        if m.quasi_static:
            q = m.quasi_static
            fr.append(f"mu_p: a={q.a:g} b={q.b:g} c={q.c:g} d={q.d:g} q={q.q:g}")
        if m.coulomb:
            fr.append(f"mu0={m.coulomb.mu0:g}")
        if m.texture is None:
            tex = "none (friction-only)"
        else:
            orders = ",".join(str(x.order) for x in m.texture.models)
            tex = f"{m.texture.quantity} AR({orders}) @ {m.texture.sample_rate:g} Hz"
        srcs = []
        spec = m.spec
        for part in (spec.friction.quasi_static, spec.friction.coulomb, spec.texture):
            if part is not None:
                p = part.provenance
                srcs.append(p.reference.split(",")[0].split(" (")[0] if p.source == "paper" else f"fit of {p.recording}")
        table.add_row(name, "\n".join(fr), tex, default_method(m), "\n".join(dict.fromkeys(srcs)))
    stdout.print(table)


def register(app: typer.Typer) -> None:
    app.command("materials")(materials)
