"""The project's evaluations of the INS/GPS filter, apart from the runtime packages.

:mod:`metrics` (error RMS, outage drift, NEES/NIS, one run), :mod:`paper_sim` (the simulated
paper drive, :mod:`imu_sim`), :mod:`claims` (WMRA on/off x Allan-derived noise model, through
:mod:`wmra_filter` and :mod:`imu_calib`), :mod:`datasets` (Katwijk, Canada, the balzer car),
:mod:`bad_input` (the filter on damaged input), :mod:`cli` (``ins-gps-kf evaluate``).
Depends on every runtime package and on :mod:`imu_sim`; no runtime package depends on it.
"""
