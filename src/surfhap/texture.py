"""``sh.texture``: render materials on an electrostatic display (the texture pipeline).

::

    import surfhap as sh
    cork = sh.load_material("cork")
    result = sh.texture.render(cork, sh.constant_scan(speed=0.1, load=0.5, duration=5.0))
    result.plot()

Names: :func:`render` (in memory), :func:`stream_render` (block by block into a sink), their
:class:`RenderResult`, :class:`TextureChain`
and :class:`ChainConfig` (block by block), the drive laws (:class:`DriveParams`,
:data:`METHODS`, :data:`LAWS`), gain planning (:func:`plan_gains`), fidelity metrics, the
display (:class:`DisplayModel`, :class:`SimulatedDisplay`), the safety stage and
:func:`compare_materials`. Loaded on first use.
"""

from surfhap._lazy import lazy_names

_MODULES = {
    "surfhap.runtime.offline": ("render", "stream_render"),
    "surfhap.render.offline": ("RenderResult",),
    "surfhap.render.chain": ("ChainConfig", "TextureChain"),
    "surfhap.render.drive": ("DriveParams", "METHODS", "LAWS", "make_drive_law", "rendering_gain"),
    "surfhap.render.fidelity": ("FidelityMetrics", "fidelity_metrics"),
    "surfhap.render.gain_plan": ("GainPlan", "OperatingRange", "plan_gains"),
    "surfhap.render.safety": ("SafetyLimits", "SafetyStage"),
    "surfhap.models.panel": ("DisplayModel", "SimulatedDisplay"),
    "surfhap.models.device_curve": ("DeviceCurve",),
    "surfhap.models.material": ("Material",),
    "surfhap.models.trajectory": ("constant_scan", "strokes", "Trajectory"),
    "surfhap.lab.compare": ("compare_materials",),
}
__all__ = sorted(name for names in _MODULES.values() for name in names)
__getattr__, __dir__ = lazy_names(__name__, _MODULES, globals())
