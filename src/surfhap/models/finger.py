"""What a human finger on a touch panel can physically do: the one set of plausibility bounds.

Every touch input is held to these: trajectory files and ``--scan``
(:func:`surfhap.models.trajectory.implausible`, ``render``, ``play``, ``shape``, ``ff
simulate``) and the live force-feedback engine's touch samples
(:class:`surfhap.ff.engine.FFEngine`: beyond them a sample is rejected, or the prediction
filter restarts). A value beyond them is a unit mistake or a sensor glitch far more often
than a real finger. CHOICE values, each with its reason:

* ``MAX_SPEED`` 3 m/s: ordinary swipes stay below ~1 m/s and the fastest flicks on a touch
  panel reach 2-3 m/s (the paper's strokes, 004 Sec. 5.2, are ~0.1 m/s); faster is a jump.
* ``MAX_ACCELERATION`` 100 m/s^2 (~10 g), measured over ``ACCELERATION_WINDOW`` (20 ms, hand
  motion lies below a few Hz): back-and-forth strokes at 1 m/s reverse at 2 v / window.
* ``MAX_LOAD`` 50 N: the strongest voluntary press of an index finger is ~40-50 N; touch
  loads are 0.1-5 N (003: 0.26-0.96 N on average). A load in grams (x 100) of a 1 N press
  is still caught.
"""

from __future__ import annotations

__all__ = ["MAX_SPEED", "MAX_ACCELERATION", "MAX_LOAD", "ACCELERATION_WINDOW"]

MAX_SPEED = 3.0  # m/s
MAX_ACCELERATION = 100.0  # m/s^2, over ACCELERATION_WINDOW
ACCELERATION_WINDOW = 0.02  # s, time base of velocities and accelerations
MAX_LOAD = 50.0  # N
