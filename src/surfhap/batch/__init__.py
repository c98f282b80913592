"""Many renders and fits at once: a job list run over a scheduler (serial, local processes or
a Dask cluster), each job writing its own output folder, plus an index of the jobs.

:mod:`surfhap.batch.schedulers` runs picklable one-job functions and reports each job's
outcome (a failing job never stops the others); :mod:`surfhap.batch.jobs` holds the one-job
functions of ``surfhap render`` and ``surfhap fit imu``; :mod:`surfhap.batch.index` writes the
table of jobs. This package sits at the layer of fit/live: it calls render and fit.
"""
