"""One truth-RMS helper (nav_eval.metrics.rms) for the evaluations and nav-demo's report: an epoch without a
truth value (NaN) is left out, never turns the figure into NaN, and an all-NaN series is NaN, not 0."""
import math

import numpy as np

from nav_bringup import report
from nav_eval import metrics


def test_rms_leaves_out_epochs_without_truth_and_is_shared_by_the_report():
    assert metrics.rms([3.0, np.nan, 4.0, np.inf]) == math.sqrt(12.5)
    assert math.isnan(metrics.rms([np.nan, np.nan])) and math.isnan(metrics.rms([]))
    assert report.rms is metrics.rms
