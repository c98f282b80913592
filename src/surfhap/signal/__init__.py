"""Pure functions over arrays: AR estimation (:mod:`~surfhap.signal.ar`, :mod:`~surfhap.signal.burg`),
LSFs, the band split, resampling, segmentation, spectra, splicing and tribometer measures."""
