"""surfhap.live: the real-time engine (:mod:`surfhap.live.engine`), its backends and touch
sources (the pages that feed it are the web app of :mod:`surfhap.web`).

Importing this package is cheap: each part is imported from its own module, and the backends'
optional dependencies (sounddevice, python-osc, nidaqmx) only when that backend is used.
"""
