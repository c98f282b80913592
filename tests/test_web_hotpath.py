"""The per-event path of the touch page (issue 20, 50 clients x 120 Hz): what runs for every
pointer message is written with comparisons instead of min/max calls. These tests hold it to
the rules written out independently here (numpy's clip, the clock's stated law), so the speed
work changes no result."""

from __future__ import annotations

from unittest import mock

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from surfhap.live.sources import RateLimiter, TouchSpace
from surfhap.web import touch
from surfhap.web.messages import CSS_PX_M, Move, page_to_surface

fraction = st.floats(-0.05, 1.05)


@settings(max_examples=200, deadline=None)
@given(x=fraction, y=fraction, p=st.floats(0.0, 1.0), w=st.floats(10.0, 20000.0), h=st.floats(10.0, 20000.0),
       surface=st.booleans())
def test_page_to_surface_is_the_clipped_linear_map(x, y, p, w, h, surface):
    space = TouchSpace(width=0.2, height=0.15, max_load=1.5)
    msg = Move(type="move", seq=0, t=0.0, x=x, y=y, p=p)
    cx, cy = (float(v) for v in np.clip([x, y], 0.0, 1.0))
    want = (cx * space.width, cy * space.height) if surface else (cx * w * CSS_PX_M, cy * h * CSS_PX_M)
    load = (p if p > 0 else 0.5) * space.max_load
    assert page_to_surface(msg, w, h, space, surface) == (*want, load)


@settings(max_examples=100, deadline=None)
@given(steps=st.lists(st.tuples(st.floats(0.0, 5.0), st.one_of(st.none(), st.floats(-20.0, 40.0))), min_size=1,
                      max_size=30), page_start=st.floats(0.0, 1e6))
def test_the_client_clock_follows_its_law(steps, page_start):
    """The client's clock: the page's stamps relative to its first one, at most CATCH_UP_S ahead
    of the server's time since connect, never backwards; server time for a message without a
    stamp."""
    server = [100.0]
    client = touch.Client(1, "test", RateLimiter(1.0, 1.0, t=0.0), server0=100.0)
    page0, elapsed = None, 0.0  # the clock starts at 0 at connect
    for dt, offset in steps:
        server[0] += dt
        since = server[0] - 100.0
        t_page = None if offset is None else page_start + since + offset
        if t_page is None:
            want = since
        else:
            page0 = t_page - since if page0 is None else page0
            want = min(t_page - page0, since + touch.CATCH_UP_S)
        elapsed = max(elapsed, want)
        with mock.patch.object(touch, "now", lambda: server[0]):
            assert client.clock(t_page) == elapsed
