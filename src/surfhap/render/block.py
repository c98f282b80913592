"""What every block renderer returns: :class:`RenderBlock` (the protocol it belongs to is
:class:`surfhap.runtime.protocols.Renderer`).

The texture chain (:class:`surfhap.render.chain.TextureChain`) and the shape chain
(:class:`surfhap.render.shape_chain.ShapeChain`) both return it, so the runtime
(:func:`surfhap.runtime.loop.run`) drives either one the same way. Block contract:
the engine hands ``n`` finger samples at ``control_rate`` and receives the drive samples that
became available (``n * drive_rate / control_rate`` on average), already through the
renderer's own safety stage; the engine's output safety pass still comes after.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

__all__ = ["RenderBlock"]


class RenderBlock(NamedTuple):
    """Output of one block of a renderer.

    drive      : (m,) float V at ``drive_rate``, after the renderer's safety stage.
    load_drive : (m,) float N, the finger load held at ``drive_rate`` (what the safety stage saw).
    target     : (n,) float N, the friction the renderer asks the display to add, one value per
                 control-rate input sample.
    detail     : renderer-specific extras (the texture chain: texture samples and its
                 :class:`~surfhap.render.drive.DriveBlock`; see ``TextureChain``), or None.
    friction   : (k,) float N, the simulated display's friction for this block's drive when the
                 renderer was given one (``process(..., display=...)``), else None.
    """

    drive: np.ndarray
    load_drive: np.ndarray
    target: np.ndarray
    detail: object = None
    friction: np.ndarray | None = None
