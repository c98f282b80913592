"""What every real-time renderer promises: the :class:`Renderer` protocol and its
:class:`RenderBlock` result.

The texture chain (:class:`surfhap.render.chain.TextureChain`) and the shape chain
(:class:`surfhap.render.shape_chain.ShapeChain`) both implement it, so the live engine
(:class:`surfhap.live.engine.LiveEngine`) drives either one the same way. Block contract:
the engine hands ``n`` finger samples at ``model_rate`` and receives the drive samples that
became available (``n * drive_rate / model_rate`` on average), already through the
renderer's own safety stage; the engine's output safety pass still comes after.
"""

from __future__ import annotations

from typing import NamedTuple, Protocol, runtime_checkable

import numpy as np

__all__ = ["RenderBlock", "Renderer"]


class RenderBlock(NamedTuple):
    """Output of one block of a renderer.

    drive      : (m,) float V at ``drive_rate``, after the renderer's safety stage.
    load_drive : (m,) float N, the finger load held at ``drive_rate`` (what the safety stage saw).
    target     : (n,) float N, the friction the renderer asks the display to add, one value per
                 model-rate input sample.
    detail     : renderer-specific extras (the texture chain: texture samples and its
                 :class:`~surfhap.render.drive.DriveBlock`; see ``TextureChain``), or None.
    """

    drive: np.ndarray
    load_drive: np.ndarray
    target: np.ndarray
    detail: object = None


@runtime_checkable
class Renderer(Protocol):
    """A stateful block renderer for the live engine and offline loops.

    model_rate, drive_rate : int Hz, rates of the inputs and of the drive.
    safety                 : its :class:`~surfhap.render.safety.SafetyStage` (``limits``,
                             ``counters``).
    uses_position          : True when ``x``, ``y`` matter (shapes), False for textures.
    """

    model_rate: int
    drive_rate: int
    uses_position: bool

    @property
    def safety(self): ...

    def reset(self) -> None:
        """Back to silence with no finger; the sample clocks restart at 0."""

    def process(self, speed: np.ndarray, load: np.ndarray, touch_time: np.ndarray,
                x: np.ndarray | None = None, y: np.ndarray | None = None) -> RenderBlock:
        """One block: speed (n,) m/s, load (n,) N, touch_time (n,) s (time stamp of the
        freshest touch sample at each model sample, on the renderer's clock), x, y (n,) m
        finger position (page coordinates of the touch surface; ignored unless
        ``uses_position``)."""
