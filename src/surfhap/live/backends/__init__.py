"""Output backends of the live engine, each a :class:`surfhap.runtime.protocols.Sink`.

``sim`` (simulated display, default), ``file`` (WAV/NPZ), ``sound`` (PortAudio through
sounddevice), ``osc`` (drive or intensity values to an external renderer) and ``daq`` (an NI
analog output through nidaqmx). :func:`surfhap.live.backends.output.open_backend` turns a typed
output (``SimOutput``, ``FileOutput``, ``SoundOutput``, ``OscOutput``, ``DaqOutput``) and
``OutputOptions`` into a backend.
"""
