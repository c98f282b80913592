"""``surfhap study``: perception studies of the papers, from design to analysis.

::

    surfhap study templates
    surfhap study new DESIGN --out STUDY/ [--seed N] [--participants N]
    surfhap study run STUDY --participant P01 [--gain G] [--comfort-voltage V] [--port 8780]
    surfhap study run STUDY --participant P01 --simulate SEED     (dry run, no page)
    surfhap study comfort STUDY --participant P01 [--method quest|questplus] [--output sim]  (comfort voltage)
    surfhap study status STUDY
    surfhap study analyze STUDY --report DIR
    surfhap study export LOG --format csv|bids --out PATH           (LOG: a log or a study folder)

DESIGN is a design file (JSON, ``surfhap-study-design``) or a built-in template name.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Optional

import typer

from surfhap.cli._common import check_out, print_table, status_line, stderr, stdout
from surfhap.cli._display_options import resolve_display
from surfhap.cli._options import ConfigOption, DisplayOption, JsonOption, OverwriteOption
from surfhap.cli._output import parse_output
from surfhap.cli._signals import StopSignals
from surfhap.errors import ConfigError

__all__ = ["register"]

study_app = typer.Typer(no_args_is_help=True, add_completion=False, pretty_exceptions_enable=False,
                        help="Perception studies: generate a counterbalanced design, run participants on a touch "
                             "page with a loss-free log, analyse the results as in the papers.")


@study_app.command("templates")
def templates() -> None:
    """List the built-in study designs (one per paper)."""
    from surfhap.lab.designs import TEMPLATES

    for name, d in TEMPLATES.items():
        stdout().print(f"{name:26s} {d['kind']:18s} {d['participants']:3d} participants  {d['name']}")


@study_app.command("new")
def new(
    design: str = typer.Argument(..., help="Design file (JSON) or built-in template name (see 'study templates')."),
    out: Path = typer.Option(..., "--out", help="Study folder to create (must not hold a study yet)."),
    seed: Optional[int] = typer.Option(None, "--seed", help="Random seed (overrides the design's)."),
    participants: Optional[int] = typer.Option(None, "--participants", help="Number of participants (overrides)."),
) -> None:
    """Generate every participant's trial list into STUDY/study.json."""
    from surfhap.errors import StudyFormatError
    from surfhap.lab.designs import TEMPLATES, build_study, template
    from surfhap.lab.schema import load_design

    if Path(design).is_file() or design.endswith(".json"):
        spec = load_design(design)
        upd = {k: v for k, v in (("seed", seed), ("participants", participants)) if v is not None}
        spec = spec.model_validate({**spec.model_dump(), **upd})
    elif design in TEMPLATES:
        spec = template(design, seed=seed or 0, participants=participants)
    else:
        raise StudyFormatError(f"neither a file nor a template ({', '.join(TEMPLATES)})", source=design, field="design")
    try:
        study = build_study(spec)
    except StudyFormatError as exc:  # name the design file in the one-line message
        raise StudyFormatError(exc.message, source=exc.source or design, field=exc.field) from None
    target = out / "study.json"
    if target.exists():
        raise StudyFormatError("already holds a study (choose another --out)", source=str(out), field="study.json")
    out.mkdir(parents=True, exist_ok=True)
    target.write_text(json.dumps(study.model_dump(mode="json"), indent=1) + "\n", encoding="utf-8")
    (out / "logs").mkdir(exist_ok=True)
    n = len(study.participants[0].trials)
    stdout().print(f"{spec.name}: {len(study.participants)} participants x {n} trials, seed {spec.seed}")
    stdout().print(f"wrote {target}")


def _simulate(runner, seed: int, p_correct: float, pace: float, guard: StopSignals, ff=None) -> None:
    import sys

    import numpy as np

    rng = np.random.default_rng(seed)
    while not runner.finished and not guard.stopped:
        st = runner.state()
        if st["status"] == "rest":
            runner.resume()
            continue
        if st["status"] == "info":  # the form: the first offered answer, the lower bound, "simulated"
            runner.info({f["id"]: f["choices"][0] if f["kind"] == "choice" else
                         ("simulated" if f["kind"] == "text" else f["min"] or 0.0) for f in st["info"]})
            continue
        t = runner.current()
        for i, stim in enumerate(t.stimuli if ff is not None else ()):  # each stimulus stroked on the device
            runner.stimulus(t.id, i)
            ff.select(stim.render)
            ff.explore(4.0 if ff.limit_s is None else ff.limit_s + 0.5, stim.label)
        ids = [c.id for c in t.choices]
        if t.training:  # answered right, drawing nothing: the experiment's answers stay those without training
            ans = t.correct
        elif t.response == "text":
            ans = f"simulated description {rng.integers(1000)}"
        elif t.response == "toggles":
            want = dict(x.split("=") for x in t.correct.split(",")) if t.correct else {}
            ans = ",".join(f"{q}={want[q] if want and rng.random() < p_correct else ids[rng.integers(len(ids))]}"
                           for q in t.toggles)
        elif t.correct is not None and rng.random() < p_correct:
            ans = t.correct
        else:
            ans = ids[int(rng.integers(len(ids)))]
        runner.answer(t.id, ans, rt_client_s=None if t.training else float(rng.gamma(4.0, 0.5)))
        sys.stdout.write(f"logged {t.id}\n")
        sys.stdout.flush()
        if pace > 0:
            guard.wait(pace)


@study_app.command("run")
def run(
    study: Path = typer.Argument(..., help="Study folder (made by 'study new')."),
    participant: str = typer.Option(..., "--participant", "-p", help="Participant id, e.g. P01."),
    gain: Optional[float] = typer.Option(None, "--gain", help="This participant's multiplier of the drive gain "
                                                              "alpha (0-4]; the safety limit still clamps."),
    comfort_voltage: Optional[float] = typer.Option(None, "--comfort-voltage",
                                                    help="This participant's comfort threshold (V, <= 250): "
                                                         "the session's safety limit."),
    host: str = typer.Option("127.0.0.1", "--host", help="Address the page binds (loopback by default)."),
    port: int = typer.Option(8780, "--port", help="Port of the page (0: any free port)."),
    simulate: Optional[int] = typer.Option(None, "--simulate", help="Dry run without a page: a simulated "
                                                                    "participant with this seed answers."),
    p_correct: float = typer.Option(0.8, "--p-correct", help="With --simulate: chance of a correct answer."),
    pace: float = typer.Option(0.0, "--pace", help="With --simulate: seconds between answers."),
    output: Optional[str] = typer.Option(None, "--output", help="Render the stimuli live under the finger on the "
                                                                "page's touch pad: sim | sound[:DEVICE] | "
                                                                "file:PATH.wav|.npz (as 'surfhap serve'). "
                                                                "Default: answers only."),
    amp_gain: float = typer.Option(250.0, "--amp-gain", help="With a sound output: amplifier volts per unit "
                                                             "of sound-card full scale (as 'surfhap serve')."),
    lsl: bool = typer.Option(False, "--lsl", help="Push Lab Streaming Layer markers (stimulus on/off, touch, "
                                                  "answer); needs the 'lsl' extra (pylsl)."),
    ff_device: Optional[str] = typer.Option(None, "--ff-device", help="Play force-feedback stimuli ({\"effect\": "
                                            "...}, 004) on this device: sim (the simulated one; with --simulate the "
                                            "simulated participant strokes each stimulus on it) | haply://HOST:PORT "
                                            "(a Haply Inverse3, as 'ff run --device')."),
    allow_same_day: bool = typer.Option(False, "--allow-same-day", help="Start the participant's next session "
                                        "on the day the previous one ran (refused by default: sessions on "
                                        "different days)."),
    display: DisplayOption = None,
    config: ConfigOption = None,
) -> None:
    """Run (or resume) one participant: the page shows the trials, the terminal the progress.

    Ctrl-C or SIGTERM pauses: the live output ramps to zero, every answered trial is in the
    log, exit 130; run again to resume."""
    from surfhap.lab.comfort import required_comfort_voltage
    from surfhap.lab.session import SessionRunner

    if ff_device not in (None, "sim") and not (ff_device.startswith("haply://") and simulate is None):
        raise ConfigError("expected sim or haply://HOST:PORT (with --simulate: sim)", source="--ff-device")
    if ff_device is not None and output is not None:
        raise ConfigError("give either --ff-device (force feedback) or --output (electrostatic)", source="--ff-device")
    disp = None if display is None and config is None else resolve_display(display, config)
    measured = None
    if comfort_voltage is None:
        from surfhap.lab.schema import load_study

        pid = load_study(study).participant(participant).id
        # a staircase without a threshold (or unfinished) stops here: one line, exit 2
        comfort_voltage = measured = required_comfort_voltage(study, pid)
        if measured is None:
            if output is not None and parse_output(output).reaches_amplifier:
                raise ConfigError(f"no comfort voltage for {pid}: run 'study comfort' first or give --comfort-voltage "
                                  "(a session on a real display never starts at the 250 V safety limit by default)",
                                  source="--output")
            stderr().print(f"no comfort voltage measured for {pid} ('study comfort'): session limit is the safety "
                           "limit")
    runner = SessionRunner(study, participant, gain=gain, comfort_voltage=comfort_voltage,
                           mode="simulated" if simulate is not None else "page", display=disp,
                           allow_same_day=allow_same_day,
                           extra_config={"comfort_voltage_from": "study comfort" if measured is not None else
                                         ("--comfort-voltage" if comfort_voltage is not None else None)})
    try:
        if measured is not None:
            stderr().print(f"comfort voltage {measured:.1f} V (from 'study comfort'): session limit {runner.v_max:.1f} V")
        if runner.n_done:
            stderr().print(f"resuming {runner.plan.id}: {runner.n_done}/{runner.total} trials already logged")
        with StopSignals() as guard:
            if simulate is not None and ff_device is not None:
                from surfhap.lab.stimuli import FFStimulusPlayer, FFStudySession

                ff = FFStimulusPlayer(FFStudySession(simulated=True), limit_s=runner.limit_s)
                ff.session.start()
                try:
                    _simulate(runner, simulate, p_correct, pace, guard, ff)
                finally:
                    ff.session.stop()
            elif simulate is not None:
                _simulate(runner, simulate, p_correct, pace, guard)
            else:
                _run_page(runner, host, port, output, amp_gain, guard, lsl, ff_device)
        stderr().print(f"{runner.plan.id}: {runner.n_done}/{runner.total} trials logged in {runner.log.path}")
        if runner.finished and runner.later:
            stdout().print(f"{runner.plan.id}: session {runner.study_session} done; session {runner.study_session + 1} "
                           "on another day ('study run' again)")
    finally:
        runner.close()
    guard.finish("paused; every answered trial is in the log (run again to resume)")


def _run_page(runner, host: str, port: int, output: str | None, amp_gain: float, guard: StopSignals,
              lsl: bool = False, ff_device: str | None = None) -> None:
    """Serve the page until the runner is finished or ``guard`` caught SIGINT/SIGTERM; then
    the live output ramps to zero (the recording is flushed) before the page stops."""
    from rich.live import Live
    from rich.table import Table

    from surfhap.lab.markers import open_markers
    from surfhap.live.config import ServerConfig
    from surfhap.web import create_app
    from surfhap.web.server import ServerThread
    from surfhap.web.study import StudyPage, start_player

    markers = open_markers(lsl, runner.plan.id)
    if markers.enabled:
        stderr().print(f"LSL markers: stream 'surfhap-{runner.plan.id}' (type Markers)")
    haply = None
    if ff_device is not None and ff_device.startswith("haply://"):
        from surfhap.live.ff_haply import HaplyDevice
        from surfhap.live.netaddr import parse_url

        haply = HaplyDevice(*parse_url(ff_device, "--ff-device", "haply"))
    player = start_player(runner, None if output is None else parse_output(output), amp_gain,  # no Haply service: exit 2
                          ff=ff_device is not None, ff_backend=haply)
    session = None if player is None else player.session
    ff_loop = session.loop if ff_device is not None else None  # a failed force loop ends the page
    try:
        page = StudyPage(runner, player, markers)
        server = ServerThread(create_app(ServerConfig(host=host, port=port), study=page), host, port).start()
    except BaseException:
        if session is not None:
            session.stop()
        raise
    stderr().print(f"participant page: [bold]{server.url}[/]  (Ctrl-C pauses; run again to resume)")
    stderr().print(f"experimenter page (keep this address to yourself): {server.url}/experimenter?token="
                   f"{page.experimenter_token}", soft_wrap=True)

    def table() -> Table:
        tb = Table(show_header=False, box=None)
        st = runner.state()
        tb.add_row("participant", runner.plan.id + (f" ({runner.plan.group})" if runner.plan.group else ""))
        tb.add_row("progress", f"{runner.n_done}/{runner.total}")
        blind = runner.study.design.session.blind_experimenter  # block labels and choice ids may name conditions
        tb.add_row("status", st["status"] + ("" if blind else f" - {st.get('block_label') or st.get('next_block') or ''}"))
        last = runner.last_record
        if last:
            ok = "" if last["is_correct"] is None else (" correct" if last["is_correct"] else " wrong")
            rt = "" if last["rt_s"] is None else f", {last['rt_s']:.2f} s"
            tb.add_row("last answer", f"{last['trial_id']}:{'' if blind else ' ' + str(last['answer'])}{ok}{rt}")
        return tb

    try:
        with Live(table(), console=stderr(), refresh_per_second=4, transient=False) as live:
            while not runner.finished and not guard.wait(0.25) and not (ff_loop is not None and ff_loop.done.is_set()):
                live.update(table())
            live.update(table())
        if not stderr().is_terminal:  # a redirected Live table ends without a newline: the next line starts its own
            stderr().line()
        if not guard.stopped:
            guard.wait(1.0)  # let the page fetch the "done" screen
    finally:  # the output first: its stop ramp runs on the live drive
        if session is not None:
            session.stop()
        server.stop()
    if ff_loop is not None and ff_loop.error is not None:  # the force loop failed (e.g. a silent device): exit 3
        from surfhap.cli.ff import _exit_if_failed

        _exit_if_failed(ff_loop.error)


@study_app.command("comfort")
def comfort(
    study: Path = typer.Argument(..., help="Study folder."),
    participant: str = typer.Option(..., "--participant", "-p", help="Participant id, e.g. P01."),
    start: float = typer.Option(60.0, "--start", help="First amplitude (V)."),
    method: Optional[str] = typer.Option(None, "--method", help="Adaptive method: staircase | quest | questplus "
                                                                "(default: the design's 'adaptive', else staircase)."),
    material: Optional[str] = typer.Option(None, "--material", help="Material of the square wave (default: the "
                                                                    "study's first)."),
    host: str = typer.Option("127.0.0.1", "--host", help="Address the page binds."),
    port: int = typer.Option(8780, "--port", help="Port of the page (0: any free port)."),
    output: Optional[str] = typer.Option(None, "--output", help="Live output for the square wave: sim | "
                                                                "sound[:DEVICE] | file:PATH (as 'surfhap serve')."),
    amp_gain: float = typer.Option(250.0, "--amp-gain", help="With a sound output: volts per unit full scale."),
    simulate: Optional[int] = typer.Option(None, "--simulate", help="Dry run: a simulated participant (seed)."),
    simulated_threshold: float = typer.Option(120.0, "--simulated-threshold",
                                              help="With --simulate: the simulated participant's threshold (V)."),
) -> None:
    """Measure a participant's comfort voltage with a staircase (Zhao et al.); 'study run' then
    uses it as the session's safety limit."""
    import numpy as np

    from surfhap.lab.comfort import ComfortOptions, ComfortRunner, comfort_ceiling

    runner = ComfortRunner(study, participant, material=material, options=ComfortOptions(method=method, start=start))
    try:
        if simulate is not None:
            rng = np.random.default_rng(simulate)
            while not runner.finished:
                st = runner.state()
                v = runner.stair.level
                p_no = 1.0 / (1.0 + np.exp(-(v - simulated_threshold) / (0.1 * simulated_threshold)))
                runner.answer(st["trial"]["id"], "no" if rng.random() < p_no else "yes", float(rng.gamma(4, 0.4)))
        else:
            with StopSignals() as guard:
                _run_page(runner, host, port, output, amp_gain, guard)
            if guard.stopped:
                stdout().print(f"{runner.plan.id}: {runner.result().levels.size} staircase trials logged; run again to continue")
                guard.finish("paused; every answered trial is in the log")
        res = runner.result()
        if runner.finished:
            v = comfort_ceiling(res.threshold, runner.params)
            thr = ("none (no reversal): 'study run' will not start" if v is None else
                   f"{v:.1f} V (one {runner.params.steps[-1]:g} dB step below the {runner.adaptive.method} estimate "
                   f"{res.threshold:.1f} V)")
            stdout().print(f"{runner.plan.id}: comfort voltage {thr} after {res.levels.size} trials "
                           f"({res.stopped_by})")
        else:
            stdout().print(f"{runner.plan.id}: {res.levels.size} staircase trials logged; run again to continue")
    finally:
        runner.close()


@study_app.command("status")
def status(study: Path = typer.Argument(..., help="Study folder.")) -> None:
    """Progress of every participant: trials logged, sessions, comfort voltage."""
    from surfhap.lab.comfort import comfort_voltage_of
    from surfhap.lab.schema import load_study
    from surfhap.lab.triallog import read_log

    st = load_study(study)
    folder = study if study.is_dir() else study.parent
    rows = []
    for plan in st.participants:
        log = read_log(folder / "logs" / f"{plan.id}.jsonl")
        v = comfort_voltage_of(folder, plan.id)
        rows.append((plan.id, plan.group or "", f"{len(log.trials)}/{len(plan.trials)}", str(len(log.sessions)),
                     "-" if v is None else f"{v:.1f}"))
    print_table(("participant", "group", "trials", "sessions", "comfort V"), rows, title=st.design.name)


@study_app.command("analyze")
def analyze(
    study: Path = typer.Argument(..., help="Study folder."),
    report: Path = typer.Option(..., "--report", help="Folder for the HTML report and its figures."),
    as_json: JsonOption = False,
) -> None:
    """Analyse every participant's log as in the paper of the design; write an HTML report and
    results.json (every test) beside it."""
    from surfhap.cli._common import report as print_result
    from surfhap.lab.analyze_study import analyze_study
    from surfhap.report.lab_report import write_study_report

    result = analyze_study(study)
    with status_line("writing the report and its figures"):
        path = write_study_report(result, report)
    (Path(path).parent / "results.json").write_text(json.dumps(result.results(), indent=1, allow_nan=False))
    print_result({**result.results(), "report": str(path)}, [*result.summary_lines(), f"wrote {path}"], as_json)


@study_app.command("export")
def export(
    log: Path = typer.Argument(..., help="A participant's log (STUDY/logs/P01.jsonl) or a study folder (every "
                                         "participant's log)."),
    fmt: str = typer.Option("csv", "--format", help="csv (one tidy table, one row per trial) | bids (a BIDS 'beh' "
                                                    "dataset: *_beh.tsv + JSON sidecar per participant and task)."),
    out: Path = typer.Option(..., "--out", help="The CSV file, or the folder of the BIDS dataset."),
    overwrite: OverwriteOption = False,
) -> None:
    """Export the trials for analysis elsewhere (pandas, R, BIDS tools)."""
    from surfhap.lab.export import export_logs

    check_out(out, "--out", overwrite)
    written = export_logs(log, fmt, out)
    stdout().print(f"wrote {written[0]}" if fmt == "csv" else f"wrote {len(written)} files into {out}")


def register(app: typer.Typer) -> None:
    app.add_typer(study_app, name="study")
