"""Numbers of the force-feedback side, each with its source.

Device frame (used by every effect, the control law, the safety stage and the backends):
``x`` along the display's width and ``y`` along its height, in the same directions as the
touch coordinates; ``z`` normal to the display, positive towards the user ("up" in the
KinesTouch notation, 004 Sec. 3.1). Positions are metres relative to the workspace centre
``X0`` (so ``X0 = 0``), forces newtons applied to the screen. Mapping these axes onto a
particular device's axes (the Falcon lies on its side in the paper, Sec. 4.1) is the
device bridge's job.

Sources
-------
* 004 = KinesTouch (paper 004_33de855a42b166de): K_max = 1 N/mm (Sec. 3.1), tablet mass
  389 g (Galaxy Tab SM-T810, Sec. 4.1), Falcon force gain about 4.5 through CHAI3D
  (Sec. 4.3), prediction k_pred = 8, alpha = 0.15, velocity smoothing 0.45 and a 60 Hz
  tablet (Sec. 4.2), 1 kHz haptic thread and 60 Hz position thread (Sec. 4.2).
* CHAI3D's Falcon driver (``CFalconDevice.cpp``, ``m_specifications``): largest force
  8.0 N, largest stable stiffness 3000 N/m, largest damping 20 N s/m, workspace radius
  0.04 m (the Falcon's "4 inch cube").
* Choices where both are silent are marked CHOICE with the reason.
"""

from __future__ import annotations

from dataclasses import field
from typing import Annotated

from pydantic import Field

from surfhap.checked import checked_dataclass

__all__ = ["DeviceParams", "FALCON", "K_MAX", "TABLET_MASS", "GRAVITY", "FALCON_GAIN", "SMOOTHING", "VELOCITY_ALPHA",
           "TOUCH_LATENCY"]

K_MAX = 1000.0  # N/m: "1 N/mm in our setup" (004 Sec. 3.1)
TABLET_MASS = 0.389  # kg: Galaxy Tab SM-T810 (004 Sec. 4.1)
GRAVITY = 9.81  # m/s^2
FALCON_GAIN = 4.5  # requested / produced force of a Falcon through CHAI3D (004 Sec. 4.3)
SMOOTHING = 0.15  # position smoothing alpha of eq. 7 (004 Sec. 4.2)
VELOCITY_ALPHA = 0.45  # velocity smoothing per touch sample (004 Sec. 4.2)
TOUCH_LATENCY = 0.040  # s, the tablet's touch latency, "a few dozens of ms" (004 Sec. 4.2)


_FMax = Annotated[float, Field(ge=0.01, le=100.0, allow_inf_nan=False)]  # N per axis
_Half = Annotated[float, Field(ge=1e-3, le=1.0, allow_inf_nan=False)]  # m, workspace half-size per axis


@checked_dataclass
class DeviceParams:
    """One impedance device carrying the screen.

    name          : label.
    gain          : device force units per newton: the backend sends ``gain * F``
                    (Falcon through CHAI3D: 4.5, 004 Sec. 4.3; 1 for a calibrated device).
    f_max         : N, per-axis force limit (x, y, z) that no command may exceed (Falcon: 8 N).
    workspace     : m, half-size of the workspace box per axis around X0 (Falcon: 0.04 m).
    k_max         : N/m, the high stiffness of pseudo position control (004: 1 N/mm).
    damping       : N s/m, damping added on position-controlled axes. CHOICE: eq. 8 has none,
                    but K_max on the 0.389 kg tablet is an undamped 8 Hz oscillator; 10 N s/m
                    (half the Falcon's 20 N s/m maximum) gives a damping ratio of 0.25.
    moving_mass   : kg, mass carried (tablet 0.389 kg, 004 Sec. 4.1; the adapter's mass is not
                    given, add it here), used by the weight compensation m g.
    slew          : N/s, largest change of any force component per second. CHOICE: 8 N in
                    no less than 20 ms (400 N/s), which still passes a 0.2 mm grating at
                    K_max (0.2 N amplitude) unaltered up to ~300 Hz.
    wall_k        : N/m, stiffness of the workspace wall (CHOICE: K_max).
    ref_speed     : m/s, fastest move of the position-control reference on a switch (bumpless
                    transfer, see :mod:`surfhap.ff.engine`). CHOICE: 0.2 m/s, twice the
                    peak speed of the study's 0.5 Hz strokes (Sec. 5.2), so shapes under
                    ordinary strokes are followed unaltered; crossing the Falcon's 8 cm
                    workspace takes 0.4 s.
    device_timeout: s, no device position for this long -> force ramps to zero (10 ms).
    touch_timeout : s, no touch sample for this long -> Idle (100 ms).
    brake_decel   : m/s^2, deceleration a of the wall brake: towards a wall the screen speed is
                    held to ``sqrt(2 a d)`` (d = distance to the wall less ``brake_margin``).
                    CHOICE: 4 m/s^2 (1.6 N on the tablet), leaving of the 8 N the weight
                    (3.8 N) and a finger pushing ~2 N.
    brake_gain    : N s/m, force per m/s of speed above that profile. CHOICE: 100 N s/m
                    (B dt / m = 0.26 at 1 kHz, well inside the discrete stability bound 2).
    brake_margin  : m, the profile reaches zero this far inside the wall. CHOICE: 1 mm.
    wall_damping  : N s/m, damping of the workspace wall (beyond it). CHOICE: 20 N s/m, the
                    Falcon's largest damping (CHAI3D).
    land_time     : s, on stop the weight compensation is lowered to zero over this time while
                    ``land_damping`` brakes the tablet's descent. CHOICE: 1.5 s (>= 1 s).
    land_damping  : N s/m, damping of the landing. CHOICE: 20 N s/m (CHAI3D's Falcon maximum):
                    the tablet sinks at no more than its weight / land_damping (0.19 m/s).
    max_speed     : m/s, device positions implying a faster screen are rejected as garbage.
                    CHOICE: 5 m/s, 3x what 8 N gives the tablet across the workspace.
    """

    name: str = "falcon"
    gain: Annotated[float, Field(ge=0.001, le=1000.0, allow_inf_nan=False)] = FALCON_GAIN
    f_max: tuple[_FMax, _FMax, _FMax] = (8.0, 8.0, 8.0)
    workspace: tuple[_Half, _Half, _Half] = (0.04, 0.04, 0.04)
    k_max: Annotated[float, Field(ge=1.0, le=100000.0, allow_inf_nan=False)] = K_MAX
    damping: Annotated[float, Field(ge=0.0, le=1000.0, allow_inf_nan=False)] = 10.0
    moving_mass: Annotated[float, Field(ge=0.0, le=20.0, allow_inf_nan=False)] = TABLET_MASS
    slew: Annotated[float, Field(ge=1.0, le=1000000.0, allow_inf_nan=False)] = 400.0
    wall_k: Annotated[float, Field(ge=0.0, le=100000.0, allow_inf_nan=False)] = K_MAX
    ref_speed: Annotated[float, Field(ge=0.001, le=10.0, allow_inf_nan=False)] = 0.2
    device_timeout: Annotated[float, Field(ge=0.0001, le=1.0, allow_inf_nan=False)] = 0.010
    touch_timeout: Annotated[float, Field(ge=0.001, le=10.0, allow_inf_nan=False)] = 0.100
    brake_decel: Annotated[float, Field(ge=0.1, le=1000.0, allow_inf_nan=False)] = 4.0
    brake_gain: Annotated[float, Field(ge=0.0, le=10000.0, allow_inf_nan=False)] = 100.0
    brake_margin: Annotated[float, Field(ge=0.0, le=0.1, allow_inf_nan=False)] = 0.001
    wall_damping: Annotated[float, Field(ge=0.0, le=1000.0, allow_inf_nan=False)] = 20.0
    land_time: Annotated[float, Field(ge=0.0, le=60.0, allow_inf_nan=False)] = 1.5
    land_damping: Annotated[float, Field(ge=0.0, le=1000.0, allow_inf_nan=False)] = 20.0
    max_speed: Annotated[float, Field(ge=0.01, le=100.0, allow_inf_nan=False)] = 5.0
    extra: dict = field(default_factory=dict, compare=False)

    @property
    def weight(self) -> float:
        """N, the weight m g that the control law compensates (004 Sec. 4.2 "Transparency")."""
        return self.moving_mass * GRAVITY

    @property
    def position_bound(self) -> tuple[float, float, float]:
        """m per axis: device positions beyond 3x the workspace are rejected as garbage
        (CHOICE: a Falcon's end stops sit at ~1.25x its 4 cm workspace radius)."""
        return tuple(3.0 * w for w in self.workspace)


FALCON = DeviceParams()
