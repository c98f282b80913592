"""Pure functions over arrays: AR estimation, filters, resampling kernels, spectra."""

from surfhap.signal.ar import (
    LevinsonResult,
    OrderSelection,
    ar_is_stable,
    ar_psd,
    autocovariance,
    information_criteria,
    levinson_durbin,
    select_order,
    yule_walker,
)

__all__ = [
    "LevinsonResult",
    "OrderSelection",
    "ar_is_stable",
    "ar_psd",
    "autocovariance",
    "information_criteria",
    "levinson_durbin",
    "select_order",
    "yule_walker",
]
