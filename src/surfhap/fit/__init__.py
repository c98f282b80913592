"""Fitting material models from recordings.

* :func:`surfhap.fit.material_fit.fit_friction` — friction recordings of a finger (Otake
  route): Coulomb mu0, the quasi-static law and AR textures per reference velocity.
* :func:`surfhap.fit.accel.fit_accel` — acceleration recordings of a tool (HaTT / Zhao
  route): segmentation, AR per segment, LSF-interpolated bank over (speed, force).
* :func:`surfhap.fit.imu.fit_imu_texture` — one IMU recording of a tool (DFT321, band
  split, AR by Yule-Walker): a single-model acceleration texture.

Submodules are imported on demand, so ``import surfhap.fit`` does no work.
"""

__all__ = ["fit_friction", "fit_accel", "FrictionFit", "AccelFit"]


def __getattr__(name):
    if name in ("fit_friction", "FrictionFit"):
        from surfhap.fit import material_fit

        return getattr(material_fit, name)
    if name in ("fit_accel", "AccelFit"):
        from surfhap.fit import accel

        return getattr(accel, name)
    raise AttributeError(name)
