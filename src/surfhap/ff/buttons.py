"""Press events of GUI buttons (KinesTouch use case 3, 004 Sec. 6): a button *clicks* when
the finger on it has pushed the screen down past the button's click depth.

The buttons' feel is the scene's stiffness map (an easy button is a soft spring); what a
user also needs is the event: the press that a GUI would act on. :class:`ButtonPresses`
turns the screen's normal displacement under the finger into press / release events with
hysteresis, tick by tick, without allocating:

* depth ``d = -pz`` (m): how far the screen is pushed away from the user below the rest
  position X0 (``pz`` is positive towards the user, :mod:`surfhap.ff.params`);
* a button is *pressed* when the finger (world position) is inside its rectangle, the
  screen is touched, ``d >= click_depth`` and the detector is *armed*;
* it is *released* when ``d < release_depth`` (release_depth < click_depth: the
  hysteresis band keeps a press from chattering on sensor noise or the roughness
  vibration), when the finger lifts or when it slides off the button (a cancelled press);
* a button is armed by a touch that lands on it, by a finger sliding onto it with
  ``d < click_depth`` (the screen then sinks past the click depth: a press), or by
  ``d < release_depth`` while the finger is on it, and disarmed by its press: a finger
  that slides onto a button with the screen already past its click depth does not click
  it, and one push gives one press.
"""

from __future__ import annotations

import math
from typing import Annotated

from pydantic import Field, FiniteFloat, model_validator

from surfhap.checked import checked_dataclass

__all__ = ["Button", "ButtonPresses"]


@checked_dataclass
class Button:
    """One button (also the ``buttons`` entry of a scene file): rectangle ``[x0, x1] x [y0, y1]``
    in content coordinates (m), click and release depths (m, normal displacement of the
    screen; release < click: the hysteresis band)."""

    name: Annotated[str, Field(min_length=1, max_length=64)]
    x0: FiniteFloat
    y0: FiniteFloat
    x1: FiniteFloat
    y1: FiniteFloat
    click_depth_m: Annotated[float, Field(gt=0.0, le=0.05)]
    release_depth_m: Annotated[float, Field(ge=0.0, le=0.05)]

    @model_validator(mode="after")
    def _check(self):
        if not (self.x1 > self.x0 and self.y1 > self.y0):
            raise ValueError("a button needs x1 > x0 and y1 > y0")
        if not self.release_depth_m < self.click_depth_m:
            raise ValueError("release_depth_m must be below click_depth_m (hysteresis)")
        return self

    def contains(self, x: float, y: float) -> bool:
        return self.x0 <= x <= self.x1 and self.y0 <= y <= self.y1


class ButtonPresses:
    """Press / release detection over ``buttons`` (see the module docstring).

    ``update(touched, fx, fy, pz) -> int`` once per tick: the index of the pressed button,
    -1 for none. ``pressed`` is the same index; ``presses`` (list of int) counts the
    presses per button; ``events`` counts all press and release transitions.
    """

    def __init__(self, buttons):
        self.buttons = tuple(buttons)
        self.reset()

    def reset(self) -> None:
        self.pressed = -1
        self.armed = False
        self._cur = -1  # button under the finger on the last touched tick (-1: none / lifted)
        self._touched = False
        self.presses = [0] * len(self.buttons)
        self.events = 0

    def _under(self, x: float, y: float) -> int:
        for i, b in enumerate(self.buttons):
            if b.contains(x, y):
                return i
        return -1

    def update(self, touched: bool, fx: float, fy: float, pz: float) -> int:
        """Advance one tick: finger on the screen, its world position fx, fy (m) and the
        screen's normal position pz (m, relative to X0). Returns the pressed button or -1."""
        if not self.buttons:
            return -1
        depth = -pz if math.isfinite(pz) else 0.0
        i = self._under(fx, fy) if touched else -1
        landed = touched and not self._touched
        self._touched = touched
        if i != self._cur:  # lifted, or moved onto another button / off the buttons
            if self.pressed >= 0:
                self.pressed = -1
                self.events += 1
            self._cur = i
            # a fresh touch arms the button (the screen may already move under the landing
            # finger); sliding onto it arms it only while the screen is above its click depth
            self.armed = i >= 0 and (landed or depth < self.buttons[i].click_depth_m)
            if not (self.armed and depth >= self.buttons[i].click_depth_m):
                return -1
        if i < 0:
            return -1
        b = self.buttons[i]
        if self.pressed >= 0:
            if depth < b.release_depth_m:
                self.pressed = -1
                self.events += 1
                self.armed = True
            return self.pressed
        if depth < b.release_depth_m:
            self.armed = True
        elif self.armed and depth >= b.click_depth_m:
            self.pressed = i
            self.presses[i] += 1
            self.events += 1
            self.armed = False
        return self.pressed

    @property
    def names(self) -> list[str]:
        return [b.name for b in self.buttons]
