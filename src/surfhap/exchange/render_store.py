"""Render time series on disk: HDF5 (``render.h5``) or NumPy (``render.npz``), written as a
render streams and read back through one function, :func:`read_render`.

Both formats hold one array per channel (see :data:`RENDER_CHANNELS`) with its
rate (Hz) and unit, and the render's attributes (material, method, rates, latency, ...):

- ``render.h5``: one chunked, resizable, uncompressed dataset per channel at the root, with
  attributes ``rate_hz`` and ``unit``; file attributes hold the rest, and ``complete`` is set
  only when the writer closed normally (``interrupted`` says whether the render was stopped).
  Blocks are appended as they come: memory stays constant whatever the duration.
- ``render.npz``: the same arrays (uncompressed ``np.savez``) and a ``_meta`` JSON string with
  the rates, units and attributes. It is assembled in memory and written once at the end (to a
  temporary name, then renamed): meant for short renders.

Model-rate channels are stored as float32 (7 significant digits: far finer than the models, the
sensors and the simulated display); ``drive`` stays float64, the exact samples the safety stage
passed. Times are not stored: :class:`RenderData` gives ``t`` and ``t_drive`` from the rates.
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import numpy as np

from surfhap.errors import ConfigError, writing
from surfhap.exchange.files import load_npz

RENDER_CHANNELS = {  # channel -> (rate: "model" or "drive", unit)
    "speed": ("model", "m/s"), "load": ("model", "N"), "texture": ("model", "texture"),
    "mu_low": ("model", "1"), "mu_tex": ("model", "1"), "target": ("model", "N"),
    "voltage": ("model", "V"), "friction_sim": ("model", "N"), "drive": ("drive", "V"),
}


__all__ = ["RENDER_CHANNELS", "RenderData", "read_render", "open_render_writer", "READERS", "WRITERS", "store_dtype"]

FORMAT = "surfhap-render"
VERSION = 1


def store_dtype(channel: str) -> type:
    """float64 for the drive (V, exact), float32 for the control-rate channels."""
    return np.float64 if channel == "drive" else np.float32


@dataclass
class RenderData:
    """A render read back: ``data[name]`` is a channel (n,) array; ``t`` and ``t_drive`` (s) are
    built from the rates, ``acc`` is ``texture`` when the texture is an acceleration.

    rates: channel -> Hz; units: channel -> unit; attrs: file attributes (JSON-ready values).
    """

    channels: dict[str, np.ndarray]
    rates: dict[str, float] = field(default_factory=dict)
    units: dict[str, str] = field(default_factory=dict)
    attrs: dict = field(default_factory=dict)

    def _derived(self) -> dict[str, Callable[[], np.ndarray]]:
        out = {}
        if "voltage" in self.channels and "voltage" in self.rates:
            out["t"] = lambda: np.arange(self.channels["voltage"].size) / self.rates["voltage"]
        if "drive" in self.channels and "drive" in self.rates:
            out["t_drive"] = lambda: np.arange(self.channels["drive"].size) / self.rates["drive"]
        if "texture" in self.channels and self.attrs.get("texture_quantity") == "acceleration":
            out["acc"] = lambda: self.channels["texture"]
        if "latency_s" in self.attrs:
            out["latency"] = lambda: np.array(self.attrs["latency_s"])
        return out

    def __getitem__(self, name: str) -> np.ndarray:
        if name in self.channels:
            return self.channels[name]
        derived = self._derived()
        if name in derived:
            return derived[name]()
        raise KeyError(name)

    def __contains__(self, name: str) -> bool:
        return name in self.channels or name in self._derived()


class H5Writer:
    """``render.h5``: chunked datasets grown one whole chunk at a time from a fixed buffer per
    channel (constant memory, few HDF5 calls). As :class:`NpzWriter`: ``writer(channel, block)``
    appends a block, ``close(attrs)`` finishes the file, ``abort()`` closes and removes it;
    ``spec``: channel -> (rate Hz, unit)."""

    CHUNK = 1 << 16  # samples per chunk and per write

    def __init__(self, path, spec):
        import h5py

        self.path, self.spec = Path(path), spec
        with writing(self.path):
            self._f = h5py.File(self.path, "w", rdcc_nbytes=0)  # whole chunks are written: no cache (it grew with the file)
        self._f.attrs["format"] = FORMAT
        self._f.attrs["version"] = VERSION
        self._f.attrs["complete"] = False
        self._sets, self._buf, self._fill = {}, {}, {}
        for name, (rate, unit) in spec.items():
            ds = self._f.create_dataset(name, shape=(0,), maxshape=(None,), chunks=(self.CHUNK,), dtype=store_dtype(name))
            ds.attrs["rate_hz"] = float(rate)
            ds.attrs["unit"] = unit
            self._sets[name] = ds
            self._buf[name] = np.empty(self.CHUNK, dtype=store_dtype(name))
            self._fill[name] = 0

    def __call__(self, channel, block):
        buf = self._buf[channel]
        pos = 0
        while pos < block.shape[0]:
            fill = self._fill[channel]
            k = min(self.CHUNK - fill, block.shape[0] - pos)
            buf[fill:fill + k] = block[pos:pos + k]
            self._fill[channel] = fill + k
            pos += k
            if self._fill[channel] == self.CHUNK:
                self._flush(channel)

    def _flush(self, channel):
        ds, n0, k = self._sets[channel], self._sets[channel].shape[0], self._fill[channel]
        if k:
            with writing(self.path):
                ds.resize((n0 + k,))
                ds[n0:n0 + k] = self._buf[channel][:k]
                self._fill[channel] = 0
                if channel == "drive":  # every ~3 s at 20 kHz: metadata on disk, so even a hard kill
                    self._f.flush()     # leaves a file readable up to here ("complete" stays false)

    def close(self, attrs):
        for name in self._sets:
            self._flush(name)
        for key, value in attrs.items():
            if isinstance(value, (dict, list, tuple)) or value is None:
                self._f.attrs[key + "_json"] = json.dumps(value, default=float)
            else:
                self._f.attrs[key] = value
        self._f.attrs["complete"] = True
        with writing(self.path):
            self._f.close()

    def abort(self):
        self._f.close()
        self.path.unlink(missing_ok=True)


class NpzWriter:
    """``render.npz``: blocks kept in memory, written once (uncompressed) at ``close``."""

    def __init__(self, path, spec):
        self.path, self.spec = Path(path), spec
        self._blocks = {name: [] for name in spec}

    def __call__(self, channel, block):
        self._blocks[channel].append(np.asarray(block, dtype=store_dtype(channel)))

    def close(self, attrs):
        arrays = {name: np.concatenate(b) if b else np.zeros(0, store_dtype(name)) for name, b in self._blocks.items()}
        meta = {"format": FORMAT, "version": VERSION, "rates": {k: v[0] for k, v in self.spec.items()},
                "units": {k: v[1] for k, v in self.spec.items()}, "attrs": attrs | {"complete": True}}
        tmp = self.path.with_name(self.path.name + ".part.npz")
        try:
            with writing(self.path):
                np.savez(tmp, _meta=np.array(json.dumps(meta, default=float)), **arrays)
                os.replace(tmp, self.path)
        finally:
            tmp.unlink(missing_ok=True)
        self._blocks = {}

    def abort(self):
        self._blocks = {}


WRITERS: dict[str, type[H5Writer | NpzWriter]] = {"h5": H5Writer, "npz": NpzWriter}  # format -> writer of render.<format>


def open_render_writer(out_dir: str | Path, fmt: str, spec: dict[str, tuple[float, str]]) -> H5Writer | NpzWriter:
    """A writer of ``render.<suffix>`` in ``out_dir`` for format ``fmt`` ("h5" or "npz")."""
    if fmt not in WRITERS:
        raise ConfigError(f"unknown format {fmt!r} (known: {', '.join(WRITERS)})", source="--format")
    return WRITERS[fmt](Path(out_dir) / f"render.{fmt}", spec)


def _attrs(attrs) -> dict:
    """HDF5 attributes (h5py's ``.attrs``) as Python values; ``NAME_json`` attributes decoded into ``NAME``."""
    out = {}
    for key, value in attrs.items():
        value = value.decode() if isinstance(value, bytes) else value.item() if isinstance(value, np.generic) else value
        out[key.removesuffix("_json")] = json.loads(value) if key.endswith("_json") else value
    return out


def _read_h5(path: Path) -> RenderData:
    import h5py

    try:
        f = h5py.File(path, "r")
    except OSError as exc:
        raise ConfigError(f"not a readable HDF5 file ({exc})", source=str(path)) from None
    with f:
        if f.attrs.get("format") != FORMAT:
            raise ConfigError("not a surfhap render (attribute 'format' missing)", source=str(path), field="format")
        channels, rates, units = {}, {}, {}
        for name, ds in f.items():
            channels[name] = ds[()]
            rates[name] = float(ds.attrs["rate_hz"])
            units[name] = str(_attrs(ds.attrs)["unit"])
        attrs = _attrs(f.attrs)
    return RenderData(channels, rates, units, attrs)


def _read_npz(path: Path) -> RenderData:
    data = load_npz(path, ConfigError)
    arrays = {k: v for k, v in data.items() if k != "_meta"}
    if "_meta" not in data:  # written before the format had metadata: t and t_drive stored
        rates = {}
        for key, tkey in (("voltage", "t"), ("drive", "t_drive")):
            t = arrays.get(tkey)
            if t is not None and t.size > 1:
                rates[key] = float(round(1.0 / (t[1] - t[0])))
        latency = arrays.pop("latency", None)
        return RenderData(arrays, rates, {}, {} if latency is None else {"latency_s": float(latency)})
    meta = json.loads(str(data["_meta"]))
    return RenderData(arrays, {k: float(v) for k, v in meta["rates"].items()}, meta["units"], meta["attrs"])


READERS: dict[str, Callable[[Path], RenderData]] = {".h5": _read_h5, ".hdf5": _read_h5, ".npz": _read_npz}


def read_render(path: str | Path) -> RenderData:
    """Read a render file (``render.h5`` or ``render.npz``, by suffix), or the render file of
    a render folder."""
    p = Path(path)
    if p.is_dir():
        found = [p / f"render.{fmt}" for fmt in WRITERS if (p / f"render.{fmt}").is_file()]
        if not found:
            raise ConfigError("no render.h5 or render.npz in this folder", source=str(p))
        p = found[0]
    reader = READERS.get(p.suffix.lower())
    if reader is None:
        raise ConfigError(f"unknown render file type {p.suffix!r} (known: {', '.join(READERS)})", source=str(p))
    if not p.is_file():
        raise ConfigError("no such file", source=str(p))
    return reader(p)

