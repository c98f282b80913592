"""One control law for all active effects: KinesTouch eq. 8, merged per axis.

Eq. 8 (004 Sec. 4.3) sums the effects' terms under one stabilisation matrix K:

    F = (m g + delta sin(phi)) e_z + alpha f_dot - nu f_dot ^ e_z + K (X0 + h e_z - X_t)

with K from Table 2 for the effect in use. Fixed here as the physics means it (see
:mod:`surfhap.ff.effects` for the roughness phase and the sliding terms):

* several effects may be active together (the picture use case combines stiffness,
  friction and roughness maps): each axis takes the *most compliant* stiffness any active
  effect asks for (Table 2 matrices only relax axes of K_max I3: Stiffness relaxes z to
  k_mat, Sliding frees x and y), the normal offsets h add (shape + grating), and the
  feed-forward forces add;
* the grating is an offset of the normal reference of depth delta (not a force);
* a damping ``-D v`` acts on the position-controlled axes, ``D = damping sqrt(K / K_max)``
  (a constant damping ratio as K changes): eq. 8 has none, but without it K_max on the
  tablet's mass rings at 8 Hz (see :class:`surfhap.ff.params.DeviceParams`);
* the weight compensation ``m g e_z`` (Sec. 4.2 "Transparency") is always applied;
* the reference height is kept inside the workspace;
* bumpless switching: the reference position ``X0 + h e_z`` is not applied at once but
  approached at no more than ``ref_speed`` (m/s) per axis, and on an axis left free
  (K = 0, Sliding) the reference follows the screen. Otherwise a switch (lift-off on a high
  floor, leaving a Sliding region far from X0) asks K_max x (a few cm) = tens of N, which the
  force limit clips and the tablet overshoots into the workspace walls. The grating's
  offset (Roughness, ``vibration = True``) is added after the rate limit, unaltered.

Not touched (or a stale touch stream): Idle (eq. 5) only. Force jumps at switches are
bounded by the safety stage's slew limit, which is the last stage before the device.

The effects' terms are merged here (:meth:`ControlLaw.merge`, Python: effects read maps); the
arithmetic after them is compiled (:func:`surfhap.ff.tick_kernel.law`), and the engine runs it
together with the safety stage in one call (:meth:`surfhap.ff.safety.ForceSafety.law_limit`).
"""

from __future__ import annotations

import numpy as np

from surfhap.ff import tick_kernel as kernel
from surfhap.ff.effects import Effect, TickState
from surfhap.ff.params import DeviceParams

__all__ = ["ControlLaw"]


class ControlLaw:
    """``compute(s) -> (3,) float N`` for the effects of a scene on one device.

    effects : the scene's effects, in order (bit i of ``mask`` = effect i active).
    device  : :class:`DeviceParams` (K_max, damping, weight, workspace, ref_speed).
    rate    : Hz, tick rate (for the reference rate limit).
    """

    def __init__(self, effects: list[Effect], device: DeviceParams, rate: float = 1000.0):
        self.effects = list(effects)
        if len(self.effects) > 30:
            raise ValueError("at most 30 effects per scene")
        self.device = device
        self.k_max = float(device.k_max)
        self.out = np.zeros(3)
        self.mask = 0
        self._calls = [(e.terms, e.vibration) for e in self.effects]
        # kernel parameters: k_max, damping, weight, h_lim, ref_step; reference: rx, ry, rz, fresh
        self.params = np.array([device.k_max, device.damping, device.weight, device.workspace[2],
                                device.ref_speed / rate])
        self.ref = np.array([0.0, 0.0, 0.0, 1.0])
        self.reset()

    def reset(self) -> None:
        for e in self.effects:
            e.reset()
        self.mask = 0
        self.out[:] = 0.0
        self.ref[:] = (0.0, 0.0, 0.0, 1.0)  # the reference starts at the screen on the next tick

    def compute(self, s: TickState) -> np.ndarray:
        """The merged force (3,) N, device frame (a view of ``self.out``)."""
        kx, ky, kz, h, hv, fx, fy, fz = self.merge(s)
        kernel.law(self.ref, self.params, s.px, s.py, s.pz, s.vx, s.vy, s.vz, kx, ky, kz, h, hv, fx, fy, fz,
                   self.out)
        return self.out

    def merge(self, s: TickState) -> tuple[float, float, float, float, float, float, float, float]:
        """The active effects' terms merged (sets ``mask``): ``(kx, ky, kz, h, hv, fx, fy, fz)``
        -- per axis the most compliant stiffness, the summed normal offsets (``hv`` the
        vibrations') and the summed feed-forward forces."""
        kx = ky = kz = self.k_max
        h = hv = fx = fy = fz = 0.0
        mask = 0
        if s.touched:
            bit = 1
            for call, vib in self._calls:
                r = call(s)
                if r is not None:
                    mask |= bit
                    a, b, c, hh, p, q, w = r
                    if a < kx:
                        kx = a
                    if b < ky:
                        ky = b
                    if c < kz:
                        kz = c
                    if vib:
                        hv += hh
                    else:
                        h += hh
                    fx += p
                    fy += q
                    fz += w
                bit <<= 1
        self.mask = mask
        return float(kx), float(ky), float(kz), float(h), float(hv), float(fx), float(fy), float(fz)
