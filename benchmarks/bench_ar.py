"""AR order selection up to p = 100 on 60 s at 2 kHz vs statsmodels ar_select_order(maxlag=60).

Target: >= 100x faster, with the coefficients at the chosen order equal to statsmodels
``yule_walker(method="mle")`` within 1e-8.
"""

import warnings

import numpy as np
from _common import best_time, report, run
from scipy.signal import lfilter
from statsmodels.regression.linear_model import yule_walker as sm_yule_walker
from statsmodels.tsa.ar_model import ar_select_order

from surfhap.signal.ar import select_order


def main():
    rng = np.random.default_rng(0)
    fs, seconds = 2000, 60
    # a textured-CoF-like signal: AR(6) driven by white noise
    a = np.poly(np.r_[0.95 * np.exp(1j * np.r_[0.2, -0.2, 0.9, -0.9]), 0.8, -0.5]).real
    x = lfilter([1.0], a, rng.standard_normal(fs * seconds))
    ours = best_time(lambda: select_order(x, max_order=100), repeat=5)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        theirs = best_time(lambda: ar_select_order(x, maxlag=60, ic="aic"), repeat=1)
        sel = select_order(x, max_order=100)
        rho, _ = sm_yule_walker(x, sel.order, method="mle")
    diff = float(np.max(np.abs(rho - sel.coefficients)))
    speedup = theirs / ours
    report("ar_order_selection", {"samples": x.size, "ours_s": round(ours, 5), "statsmodels_s": round(theirs, 3),
                                  "speedup": round(speedup, 1), "chosen_order": sel.order, "max_coef_diff": diff},
           speedup / 100.0, "speedup >= 100 and coefficients within 1e-8 (ratio = speedup / 100 >= 1)",
           speedup >= 100 and diff <= 1e-8)


if __name__ == "__main__":
    run(main)
