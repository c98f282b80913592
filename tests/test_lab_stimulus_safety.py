"""Per-participant gain and comfort voltage on the study page: whatever the gain, every drive
sample a study stimulus produces stays within the session's limit (hypothesis)."""

import numpy as np
from hypothesis import HealthCheck, given, settings, strategies as st

from surfhap.lab.stimuli import StimulusPlayer
from surfhap.runtime.commands import SetGain


class _Engine:
    drive_rate = 8000

    def __init__(self):
        self.sent = []

    def send(self, cmd):
        self.sent.append(cmd)
        return True

    def push_touch(self, source, x, y, load, t_event=float("nan")):
        self.sent.append(("touch", t_event, load))


class _Session:
    def __init__(self):
        from surfhap.live.sources import TouchSpace

        self.engine = _Engine()
        self.space = TouchSpace()


RENDERS = [{"material": "leather", "method": "otake2022"}, {"material": "cork", "method": "friction-only"},
           {"material": "denim", "method": "zhao"},
           {"material": "wood", "method": "square", "square_frequency": 30.0, "square_amplitude": 250.0}]


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(gain=st.floats(0.01, 4.0), v_max=st.floats(5.0, 250.0), which=st.integers(0, len(RENDERS) - 1),
       seed=st.integers(0, 2 ** 16), load_scale=st.floats(0.0, 30.0))
def test_stimulus_drive_never_exceeds_the_session_limit(gain, v_max, which, seed, load_scale):
    player = StimulusPlayer(_Session(), gain=gain, v_max=v_max, seed=seed)
    assert player.select(RENDERS[which]) != "muted"
    chain = player.current
    assert chain.safety.limits.v_max == v_max  # the engine adopts the renderer's limit on the swap
    rng = np.random.default_rng(seed)
    n = 400
    t = np.arange(n) / chain.control_rate
    for _ in range(3):
        speed = rng.uniform(-3.0, 3.0, n)
        load = rng.uniform(0.0, 1.0, n) * load_scale
        drive = chain.process(speed, load, t).drive
        t = t + n / chain.control_rate
        assert np.all(np.abs(drive) <= v_max + 1e-9)


def test_real_samples_and_visual_only_scenes_mute():
    s = _Session()
    player = StimulusPlayer(s)
    assert player.select({"real": "cork"}) == "muted"
    assert player.select({"scene": "gaussian-1B3H-spot", "haptic": False}) == "muted"
    assert player.select({"effect": "follow"}) == "muted"
    assert SetGain(0.0) in s.engine.sent


def test_scene_stimulus_renders_the_scene_shape_and_picture():
    from surfhap.lab.stimuli import scene_picture

    player = StimulusPlayer(_Session(), gain=1.0, v_max=200.0)
    assert player.select({"scene": "frustum-2B2H-directional", "haptic": True}) != "muted"
    assert player.positions == "surface" and player.current.safety.limits.v_max == 200.0
    png = scene_picture("frustum-2B2H-directional", (0.217, 0.136))
    assert png[:8] == b"\x89PNG\r\n\x1a\n"
    # the two lights of a scene give different pictures (Kim et al.: the light changes the view)
    assert scene_picture("gaussian-1B3H-spot", (0.217, 0.136)) != scene_picture("gaussian-1B3H-directional",
                                                                                (0.217, 0.136))


def test_formative_profiles_follow_the_ip_mappings():
    from surfhap.shape.profiles import ip_intensity, profile_force

    player = StimulusPlayer(_Session(), v_max=250.0)
    xs = np.linspace(-0.02, 0.02, 9)
    for shape in ("bump", "hole", "flat"):
        for mapping, offset in (("IP0.5", 0.5), ("IP0.7", 0.7)):
            player.select({"profile1d": shape, "mapping": mapping, "grain": "edge-soft"})
            r = player.current
            got = np.array([r.touch_point(x, 0.0)[0] for x in xs])
            force = np.zeros_like(xs) if shape == "flat" else profile_force(xs, hole=shape == "hole")
            assert np.allclose(got, ip_intensity(force, offset))
            assert r.touch_point(0.04, 0.0) == (0.0, 0.0)  # off the 5 cm track
    # IP0.5 and IP0.7 differ: the study's two conditions feel different
    player.select({"profile1d": "bump", "mapping": "IP0.5"})
    a = player.current.touch_point(-0.005, 0.0)[0]
    player.select({"profile1d": "bump", "mapping": "IP0.7"})
    assert player.current.touch_point(-0.005, 0.0)[0] != a


@settings(max_examples=15, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(gain=st.floats(0.01, 4.0), v_max=st.floats(5.0, 250.0), seed=st.integers(0, 2 ** 16),
       which=st.sampled_from([{"profile1d": "hole", "mapping": "IP0.7", "grain": "area-grainy"},
                              {"profile1d": "flat", "mapping": "IP0.5", "grain": "edge-soft"},
                              {"scene": "gaussian-2B2H-spot", "haptic": True}]))
def test_shape_stimuli_never_exceed_the_session_limit(gain, v_max, seed, which):
    player = StimulusPlayer(_Session(), gain=gain, v_max=v_max, seed=seed)
    player.select(which)
    r = player.current
    rng = np.random.default_rng(seed)
    for k in range(40):  # one touch sample per model block, random positions over the surface
        x = rng.uniform(-0.01, 0.23, 1)
        y = rng.uniform(-0.01, 0.15, 1)
        load = rng.uniform(0.0, 3.0, 1)
        drive = r.process(np.zeros(1), load, np.array([k / r.control_rate]), x, y).drive
        assert np.all(np.abs(drive) <= v_max + 1e-9)


def test_gain_scales_the_laws_own_alpha():
    base = StimulusPlayer(_Session(), gain=1.0)
    base.select({"material": "denim", "method": "zhao"})
    double = StimulusPlayer(_Session(), gain=2.0)
    double.select({"material": "denim", "method": "zhao"})
    assert double.current.params.alpha == 2.0 * base.current.params.alpha


def test_mesh_file_stimulus_respects_the_session_limit(tmp_path):
    from surfhap.shape.scenes import gaussian_bump

    v, f = gaussian_bump(0.002)
    path = tmp_path / "bump.obj"
    path.write_text("".join(f"v {a} {b} {c}\n" for a, b, c in v) + "".join(f"f {a + 1} {b + 1} {c + 1}\n" for a, b, c in f))
    player = StimulusPlayer(_Session(), v_max=60.0)
    player.select({"mesh": str(path)})
    assert player.current.safety.limits.v_max == 60.0


def test_a_stimulus_stops_its_time_limit_after_the_first_touch():
    """004 Sec. 5.2: a stimulus lasts 3.5 s from the first touch; later samples reach the
    engine as a lifted finger and the output is muted, until the next stimulus is selected."""
    s = _Session()
    player = StimulusPlayer(s, limit_s=3.5)
    render = RENDERS[0]
    player.select(render)
    for t_ms in (1000.0, 2000.0, 4499.0, 4501.0, 6000.0):
        player.touch(0, 0.5, 0.5, 0.5, t_ms, 800.0, 400.0)
    touches = [(t, load > 0) for kind, t, load in (c for c in s.engine.sent if isinstance(c, tuple))]
    assert touches == [(1.0, True), (2.0, True), (4.499, True), (4.501, False), (6.0, False)]
    assert s.engine.sent[-3] == SetGain(0.0)  # muted once, at the first sample past the limit
    player.select(render)  # the next stimulus: its own 3.5 s from its first touch
    player.touch(0, 0.5, 0.5, 0.5, 9000.0, 800.0, 400.0)
    assert s.engine.sent[-1][0] == "touch" and s.engine.sent[-1][2] > 0
