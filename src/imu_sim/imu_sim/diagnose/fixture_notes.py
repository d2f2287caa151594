"""The notes a fixture's nuisance test writes into ``tested`` for a candidate it does not rank (text only)."""
from __future__ import annotations

import numpy as np

NOT_SEPARABLE = "not separable from the reference on this record"


def tilt_note(case, cand, lr_alone: float, given: float, top: float) -> str:
    """Why a tilt-sensitive candidate is not ranked on a fixture's holds: below threshold there given the holds' bias
    offsets, or only given the fixture's tilts within attitude_tolerance_deg (not separable from the reference)."""
    if lr_alone < cand.threshold:
        # the tilts took nothing: the holds' own evidence is below threshold once each hold's bias offset and the
        # unit's stated wander are allowed for, so calling it inseparable from the reference would blame the fixture
        return (f"not significant on the holds: given each hold's bias offset and the unit's stated wander its "
                f"likelihood ratio there is {lr_alone:.3g} ({given:.3g} given a tilt of each static segment's fixture "
                f"too), below the threshold {cand.threshold:.3g}; not ranked")
    return (f"{NOT_SEPARABLE}: on the holds, given a tilt of each static segment's fixture (at most "
            f"{np.degrees(top):.3g} deg, tolerance {case.scenario.attitude_tolerance_deg:g} deg: "
            f"attitude_tolerance_deg) its likelihood ratio falls from {lr_alone:.3g} to {given:.3g}, below the "
            f"threshold {cand.threshold:.3g}; not ranked")


def free_note(case, cand, given: float, free: float) -> str:
    """Why an accelerometer misalignment on a fixture of still holds is not ranked: a free tilt of each hold makes the
    same readings."""
    return (f"{NOT_SEPARABLE}: on a fixture of still holds each hold's attitude is its own, and a tilt of each hold "
            "makes the same level accelerometer readings as an accelerometer misalignment (the gyros see only the "
            f"Earth rate, 7.3e-5 rad/s, to tell them apart); with each hold's attitude free its likelihood ratio is "
            f"{free:.3g} (within attitude_tolerance_deg {case.scenario.attitude_tolerance_deg:g} deg: {given:.3g}), "
            f"below the threshold {cand.threshold:.3g}; not ranked")


def floor_note(cand, got) -> None:
    """Append to a g-sensitivity not significant on a fixture the coefficient it could have been found at: per axis
    the value whose likelihood ratio on the holds, given the tilts and each hold's bias wander, reaches the threshold
    alone (sqrt(threshold) standard errors of the joint fit; ``got`` is its (.., theta, cov) or None). A tactical
    unit's 0.6-1e-6 rad/s per m/s^2 reached 10.6 against 15.9 on the blind's fixture, with no floor said."""
    if not isinstance(got, tuple) or len(got[3]) != 3:
        return
    floor = np.sqrt(cand.threshold * np.clip(np.diag(got[4]), 0.0, None))
    cand.reason = "; ".join(filter(None, [cand.reason, (
        "not detectable on this record below " + ", ".join(f"{v:.2g} ({a})" for a, v in zip("xyz", floor))
        + " rad/s per m/s^2 (the coefficient whose likelihood ratio on the holds, given the fixture's tilts and each "
        "hold's bias wander, reaches the threshold alone)")]))


def wander_note(cand, given: float) -> str:
    """Why a hold-keyed effect (g-sensitivity, scale factor, misalignment) significant given the fixture's tilts is not
    ranked: below threshold once a significant noise term's bias wander from hold to hold is allowed for."""
    noise = " or ".join(k for k in ("gauss_markov_bias", "bias_random_walk") if k in cand.given_rivals)
    return (f"not significant given the bias wander from hold to hold that {noise} makes: on the holds, given each "
            f"hold's fixture tilt and that wander, its likelihood ratio is {given:.3g}, below the threshold "
            f"{cand.threshold:.3g}; not ranked in this pass")
