"""``surfhap materials``: list the built-in materials, or show one with its gain plan;
``surfhap calibrate-texture``: set a texture's strength from a published voltage ratio."""

from __future__ import annotations

from pathlib import Path
from typing import Optional

import typer

from surfhap.cli._common import command_line, print_table, report, stdout
from surfhap.cli._display_options import resolve_display_and_range
from surfhap.cli._options import ConfigOption, DisplayOption, JsonOption, LoadRangeOption, SpeedRangeOption
from surfhap.errors import ConfigError

__all__ = ["register"]


def _show(name: str, display, rng) -> None:
    from rich.text import Text

    from surfhap.exchange.materials import load_material
    from surfhap.render.drive import default_method
    from surfhap.render.gain_plan import plan_gains

    m = load_material(name)
    spec = m.spec
    stdout().print(Text.assemble((m.name, "bold"), f": {spec.description}"))
    fr = spec.friction
    if fr.quasi_static:
        q = fr.quasi_static
        stdout().print(f"  quasi-static mu_p = a fn^b (1 + d v^q)/(1 + c v): a={q.a:g} b={q.b:g} c={q.c:g} d={q.d:g} q={q.q:g}")
        stdout().print(f"    from: {q.provenance.reference}")
    if fr.coulomb:
        stdout().print(f"  Coulomb mu0 = {fr.coulomb.mu0:g}\n    from: {fr.coulomb.provenance.reference}")
    stdout().print(f"  texture: {m.texture_text()}")
    if spec.texture is not None:
        p = spec.texture.provenance
        stdout().print(f"    from: {p.reference or p.recording}" + (f" ({p.note})" if p.note else ""))
        cal = spec.texture_calibration
        if cal is not None:
            stdout().print(f"    strength: r = {cal.target_voltage_ratio:g}, beta = {cal.beta:g}, sd(x) = {cal.reference_std:.4g}, "
                           f"mu_t = {cal.relative_scale:.4g} * mu_low * x")
            stdout().print(f"    from: {cal.provenance.reference}")
            if cal.provenance.note:
                stdout().print(f"    how: {cal.provenance.note}")
    for note in spec.notes:
        stdout().print(f"  note: {note}")
    method = default_method(m)
    plan = plan_gains(m, method, display, rng)
    stdout().print(f"  gain plan ({method}, display: {display.source}; loads {rng.loads[0]:g}-{rng.loads[1]:g} N, "
                   f"speeds {rng.speeds[0]:g}-{rng.speeds[1]:g} m/s):")
    stdout().print(f"    alpha = {plan.alpha:.1f} V/sqrt(N) (calibrated {plan.alpha_calibrated:.1f}; bound by {plan.binding}), "
                   f"rendering gain {plan.rendering_gain:.3f}, headroom {plan.headroom:.3f} ({plan.headroom_db:.2f} dB) "
                   f"at the texture's {plan.percentile:g}th percentile")
    print_table(("load N", "added friction N (over speeds)", f"peak V ({plan.percentile:g} %)"),
                [(f"{plan.loads[i]:.2f}", f"{plan.friction_low_n[i]:.4f} - {plan.friction_high_n[i]:.4f}",
                  f"{plan.peak_voltage[i]:.1f}") for i in range(0, plan.loads.size, max(1, plan.loads.size // 6))])


def _builtin_specs():
    """(name, file contents as JSON) of every built-in material, sorted: the list reads the files
    as written (they are package data, validated by the tests), without the pydantic models and
    numpy that loading a material costs (a quarter of a second of start-up)."""
    import json
    from importlib import resources

    folder = resources.files("surfhap.models") / "builtin"
    return [(p.name[:-5], json.loads(p.read_text(encoding="utf-8")))
            for p in sorted(folder.iterdir(), key=lambda p: p.name[:-5]) if p.name.endswith(".json")]


def _row(name: str, spec: dict) -> tuple[str, str, str, str, str]:
    """One row of the list from a material file's contents; tests/test_cli_startup.py checks each
    built-in's row against the loaded Material (texture_text, default_method, its laws)."""
    friction, texture = spec["friction"], spec.get("texture")
    laws = []
    if (q := friction.get("quasi_static")) is not None:
        laws.append(f"mu_p: a={q['a']:g} b={q['b']:g} c={q['c']:g} d={q['d']:g} q={q['q']:g}")
    if (c := friction.get("coulomb")) is not None:
        laws.append(f"mu0={c['mu0']:g}")
    if texture is None:
        text = "none (friction-only)"
    else:
        models = texture["models"]
        order = max(max(len(m["ar_lsf"]), len(m["ma_lsf"])) if "ar_lsf" in m else len(m["coefficients"]) for m in models)
        text = f"{texture['quantity']}, {len(models)} model(s) of order <= {order} @ {texture['sample_rate']:g} Hz"
        if (cal := texture.get("calibration")) is not None:
            text += f", voltage ratio 10:{10 * cal['target_voltage_ratio']:g} (calibrated)"
    sources = []
    for part in (friction.get("quasi_static"), friction.get("coulomb"), texture):
        if part is not None:
            p = part["provenance"]
            sources.append(p["reference"].split(",")[0].split(" (")[0] if p["source"] == "paper"
                           else f"fit of {p['recording']}")
    method = "otake2022" if friction.get("quasi_static") is not None else "otake2021"
    return name, "\n".join(laws), text, method, "\n".join(dict.fromkeys(sources))


def materials(
    show: Optional[str] = typer.Option(None, "--show", help="Show one material: parameters, provenance and its gain plan."),
    display: DisplayOption = None,
    load_range: LoadRangeOption = None,
    speed_range: SpeedRangeOption = None,
    config: ConfigOption = None,
    as_json: JsonOption = False,
) -> None:
    """List the built-in materials, their friction laws, texture models and sources."""
    if show is not None:
        disp, rng = resolve_display_and_range(display, load_range, speed_range, config)
        _show(show, disp, rng)
        return
    header = ("name", "friction", "texture", "default method", "sources")
    rows = [_row(name, spec) for name, spec in _builtin_specs()]
    if as_json:
        return report({"materials": [dict(zip(header, r)) for r in rows]}, [], True)
    print_table(header, rows, title="built-in materials")
    if stdout().is_terminal:
        stdout().print("Show one with its provenance and gain plan: surfhap materials --show NAME")


def calibrate_texture(
    material_file: Path = typer.Argument(..., help="Material JSON whose texture strength is set (written back)."),
    ratio: float = typer.Option(..., "--ratio", help="Texture:friction voltage ratio r (10:3 -> 0.3); see docs/texture.md."),
    reference: str = typer.Option(..., "--reference", help="Where the ratio comes from (paper file, section, value)."),
    beta: float = typer.Option(1.8, "--beta", help="Textural gain of the drive law the ratio is meant for."),
    cutoff: float = typer.Option(3.5, "--cutoff", help="Band split, Hz: sd(x) is taken above it (003 Sec. II: 3.5)."),
    note: Optional[str] = typer.Option(None, "--note", help="Extra text for the provenance (e.g. why this ratio)."),
    as_json: JsonOption = False,
) -> None:
    """Set the strength of MATERIAL_FILE's texture so its voltage ratio is RATIO at every load and speed.

    For textures recorded in another modality than a textural CoF (e.g. stick acceleration):
    the drive laws then use mu_t = s * mu_low * x with s = ratio^2 / (beta * sd(x)), sd(x) the
    standard deviation of the AR model's output above the band split. The command and numbers
    go into the provenance.
    """
    from surfhap.exchange.material_json import read_material_json, write_material_json
    from surfhap.models.material import Provenance, TextureCalibrationSpec, TextureSpec
    from surfhap.models.texture_calibration import relative_scale, texture_band_std

    if not (0 < ratio <= 2):
        raise ConfigError("must be within (0, 2]", source="--ratio")
    if not (0 <= cutoff < 1000):
        raise ConfigError("must be within [0, 1000) Hz", source="--cutoff")
    if not (0 < beta <= 100):
        raise ConfigError("must be within (0, 100]", source="--beta")
    mat = read_material_json(material_file)
    tex = mat.spec.texture
    if not isinstance(tex, TextureSpec):
        raise ConfigError("has no AR texture bank to calibrate", source=str(material_file), field="texture")
    sds = [texture_band_std(m.coefficients, m.variance, tex.sample_rate, cutoff) for m in tex.models]
    sd = float(sum(s * s for s in sds) / len(sds)) ** 0.5
    scale = relative_scale(ratio, beta, sd)
    how = (f"sd(x) = {sd:.6g} {'m/s^2' if tex.quantity == 'acceleration' else ''} is the standard deviation above {cutoff:g} Hz of "
           f"the AR model{'s (RMS over models)' if len(sds) > 1 else ''}; s = r^2 / (beta sd(x)) = {ratio:g}^2 / "
           f"({beta:g} x {sd:.6g}) = {scale:.6g}")
    command = command_line("calibrate-texture", material_file, ratio=ratio, beta=beta, cutoff=cutoff, reference=reference,
                           note=note or None)
    prov = Provenance(source="paper", reference=reference, command=command, note=how + (f". {note}" if note else ""))
    cal = TextureCalibrationSpec(target_voltage_ratio=ratio, beta=beta, reference_std=sd, relative_scale=scale, provenance=prov)
    spec = mat.spec.model_copy(update={"texture": tex.model_copy(update={"calibration": cal})})
    spec = type(spec).model_validate(spec.model_dump())
    write_material_json(spec, material_file)
    report({"material": mat.name, "ratio": ratio, "beta": beta, "reference_std": sd, "relative_scale": scale,
            "out": str(material_file)}, f"{mat.name}: r = {ratio:g} -> mu_t = {scale:.6g} * mu_low * x -> {material_file}",
           as_json)


def register(app: typer.Typer) -> None:
    app.command("materials")(materials)
    app.command("calibrate-texture")(calibrate_texture)
