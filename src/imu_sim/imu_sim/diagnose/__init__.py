"""Sim-versus-real diagnosis: locate a mismatch, name the missing physics, model it, show the fit improve.

Modules: :mod:`case` (inputs, deterministic simulation, residual), :mod:`spectral`
(GLS by frequency-domain whitening with the model's noise PSD), :mod:`regressors`
(one regressor set per deterministic effect), :mod:`noise_tests` (vibration line,
quantization lattice, Gauss-Markov and random-walk bias), :mod:`local_level` (exact
likelihood of block means under white noise, a walk and a Gauss-Markov bias, by Kalman filter),
:mod:`metrics` (held-out fit, change points, Allan band), :mod:`candidate` (the candidate type, thresholds,
calibration loading; a leaf), :mod:`effect_tests` (the registry of per-effect tests, one context object each),
:mod:`noise_candidates` (Gauss-Markov and random-walk candidates), :mod:`ranking` (slow-wander rivals),
:mod:`heldout` (held-out metrics), :mod:`engine` (the iterate-until-nothing-significant loop), :mod:`report` (JSON, HTML, PNG), :mod:`suite` (concealed-effect
Monte Carlo), :mod:`calibrate` (threshold factors from the null cases, ``calibration.yaml``),
:mod:`gnss_tests` / :mod:`gnss_candidates` (GNSS-side effects from the fix residual),
:mod:`real` (real recordings to CSV + scenario).

The package imports none of its modules (so importing one never runs the engine): use
``from imu_sim.diagnose.engine import diagnose``.
"""
