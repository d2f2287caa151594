"""Detector thresholds from Monte Carlo on the sensor model's own noise, for a stated false-alarm rate.

The model's noise (:mod:`sensor_health.noise_sim`) is cut into windows and run through the same window
statistics and the same CUSUM recursions as the monitor. Per detector and channel the false-alarm budget is
``false_alarms_per_10h / (number of monitored detector-channels)``:

* the noise-level CUSUM: run lengths are *measured* on the simulated series at a grid of low thresholds (restart
  after each alarm), log(mean run length) is fitted linear in h (the CUSUM's run length grows exponentially with
  its threshold) and solved for the budget's run length;
* the bias CUSUMs: alarms *counted* on ``bias_hours`` of simulated window means through the same filter, the tail
  beyond the counts split (:mod:`sensor_health.bias_tail`: the slow wander's tail, which 8000 windows do not show);
* the line gate (one window, chi-square(2) max over the searched bins): an exponential tail fitted to the
  upper 2 % of the simulated maxima, solved for the budget's per-window probability.
* the clip test (samples of the last 10 windows exactly at their extreme): two more than the most simulated;
* the stuck-output run length is exact: the probability that quantized noise repeats a value.
"""
from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np
from scipy import stats

from nav_core.sensor_model import SensorModel
from sensor_health import bias_tail, noise_sim
from sensor_health.window_stats import WindowGrid, sample_sigma, span_ties, window_stats

SECONDS_PER_10H = 36000.0
NOISE_IGNORED_RATIO = 3.0
"""Variance ratios up to this (sd x1.73) make the noise CUSUM drift down (k = ln of it, in sd of log level): a
vehicle's own high-frequency level moves with road and speed; a failing sensor's noise x3 (variance x9) climbs at
~3.5 sd per window."""
BIAS_DESIGN_STEP = 10.0
"""The bias CUSUM is tuned to a step of this many times the model's bias sd (its drift k is half that step in sd
of a window mean, kept within BIAS_K_RANGE: a larger k also ignores the slow specific-force changes of driving,
such as the Eotvos effect on az)."""
BIAS_K_RANGE = (0.5, 1.5)
FAST_BASELINE_S = 5.0
"""Baseline time constant, s, of a channel whose design step is large (k at its cap): such a step shows within a
window or two, and a short baseline follows the slow specific-force changes of driving (Eotvos: 2 Omega v_E
cos(lat), some mm/s^2 with a period of a lap)."""


BIAS_WARMUP_S = 60.0
"""The bias baseline starts as the mean of this long a stretch (a shorter one leaves an offset the CUSUM climbs)."""


def bias_warmup_windows(window_s: float) -> int:
    """Windows averaged into the first bias baseline."""
    return max(2, int(round(BIAS_WARMUP_S / window_s)))


def baseline_times(bias_k: np.ndarray, baseline_s: float) -> np.ndarray:
    """Per-channel baseline time constant, s: FAST_BASELINE_S where k is at its cap, else ``baseline_s``."""
    return np.where(bias_k >= BIAS_K_RANGE[1], FAST_BASELINE_S, baseline_s)


def bias_walk_variance(model: SensorModel, sd_mean: np.ndarray, tau_s: np.ndarray, window_s: float) -> np.ndarray:
    """The bias filter's random-walk variance per window (6,), channel units squared: the model's rate random walk
    (K^2 window_s), or the baseline's (sd_mean / tau in windows, squared) where that is faster.

    Sized at the baseline alone (sqrt 2.5e-6 rad/s per 1-s window on the benchmark's gyro), the filter lagged the
    unit's own wander (Allan K 1.2e-5 rad/s/sqrt(s)): the innovations' 60-s means had sd 0.155 on the healthy drives
    against 0.129 for white ones, and that slow excess, which the 8000-window Monte Carlo's extrapolated run length
    does not carry, is what gave the false gx and gy events. At the model's K they have 0.130."""
    rrw = np.concatenate([model.gyro.rate_random_walk, model.accel.rate_random_walk])
    return np.maximum((sd_mean * window_s / tau_s) ** 2, rrw**2 * window_s)
BIAS_CHANNELS = (0, 1, 5)
"""gx, gy, az: on a land vehicle their means stay near constant (roll and pitch rates average out, az near g);
gz, ax, ay carry the vehicle's turns and accelerations, so a bias step there is not seen in the raw signal."""


N_TESTS = 6 + 6 + 6 + len(BIAS_CHANNELS) + 3
"""Statistical tests sharing the false-alarm budget: noise, line and clip on every channel, bias on BIAS_CHANNELS,
the gz scale factor against the GNSS course, the ax and gz biases against the GNSS track."""


@dataclass
class Thresholds:
    """Everything the monitor needs from the Monte Carlo; SI units, windows of ``window_s`` s."""

    window_s: float
    noise_mu: np.ndarray
    """(6,) median of log(level) under the model."""
    noise_sd: np.ndarray
    """(6,) robust sd of log(level)."""
    noise_k: float
    noise_h: float
    bias_sd: np.ndarray
    """(6,) sd of a window mean of the model's white and quantization noise (the bias filter's measurement noise,
    scaled by max(1, level) in use)."""
    bias_k: np.ndarray
    """(6,) drift per channel, sd."""
    bias_h: np.ndarray
    """(6,) threshold per channel (inf where not monitored)."""
    bias_tau_s: np.ndarray
    """(6,) time constant of the slow baseline the window means are compared with, s."""
    bias_q: np.ndarray
    """(6,) the bias filter's random-walk variance per window (:func:`bias_walk_variance`), channel units squared."""
    line_h: float
    """chi-square(2) gate of the line statistic."""
    stuck_run: np.ndarray
    """(6,) samples repeating one value that make a stuck output."""
    clip_ties: np.ndarray
    """(6,) samples of one window exactly at its extreme (a run's look-back in the sample checks): 2 more than the
    most the Monte Carlo saw."""
    clip_span_ties: np.ndarray
    """(6,) samples of the last CLIP_SPAN_WINDOWS windows exactly at their extreme that make a clip
    (:func:`clip_threshold`)."""
    sample_sigma: np.ndarray
    """(6,) per-sample sd of the model's white and quantization noise."""
    budget_per_10h: float
    mc_windows: int
    gyro_bias_per_10h: float
    """False events per 10 h allowed to each of the gx and gy bias CUSUMs (beyond ``budget_per_10h``)."""
    bias_tail_hours: float
    """Hours of simulated window means the bias thresholds were counted on."""
    bias_h_how: list
    """(6,) per bias channel how h was read (``bias_tail.BiasTail.how``: 'measured', 'split' or 'extended')."""
    clip_per_10h: float
    """False events per 10 h allowed to the flat-top clip count of each channel (beyond ``budget_per_10h``)."""

    def clip_p_window(self) -> float:
        """The clip count's false-event probability per window and channel."""
        return self.clip_per_10h * self.window_s / SECONDS_PER_10H

    def to_dict(self) -> dict:
        """Plain types (health.json ``thresholds``)."""
        return {k: (v.tolist() if isinstance(v, np.ndarray) else v) for k, v in asdict(self).items()}


def cusum_alarms(y: np.ndarray, k: float, hs: np.ndarray) -> np.ndarray:
    """Alarms of the one-sided CUSUM max(0, S + y - k) > h, restarted at 0 after each, for each h of ``hs``:
    y (nw, c) -> counts (len(hs),) summed over the columns."""
    s = np.zeros((len(hs), y.shape[1]))
    count = np.zeros(len(hs))
    for row in y:
        s = np.maximum(0.0, s + row - k)
        hit = s > hs[:, None]
        count += hit.sum(axis=1)
        s[hit] = 0.0
    return count


def cusum_threshold(y: np.ndarray, k: float, target_windows: float) -> float:
    """h whose mean run length on y (nw, c) extrapolates to ``target_windows`` (log-linear in h); where k leaves too
    few alarms to measure, the gate k + h on one increment from the increments' exponential tail."""
    hs = np.linspace(0.25, 8.0, 32)
    counts = cusum_alarms(y, k, hs)
    arl = y.size / np.maximum(counts, 1)
    ok = counts >= 30
    if ok.sum() < 3:
        # k so large that an alarm takes one increment over k + h (a gate): the tail of the increments
        return max(exp_tail_threshold(y.ravel(), 1.0 / target_windows) - k, 0.0)
    slope, icpt = np.polyfit(hs[ok], np.log(arl[ok]), 1)
    return float((np.log(target_windows) - icpt) / slope)


def excursion_maxima(z: np.ndarray, floor: float) -> np.ndarray:
    """Maxima of the runs of z (1-D) above ``floor``: one alarm per run at any gate above it (for tests that restart
    after an event)."""
    above = np.r_[False, z > floor, False]
    edges = np.flatnonzero(np.diff(above.astype(int)))
    return np.maximum.reduceat(z, edges[::2])[: len(edges) // 2] if len(edges) else np.zeros(0)


def exp_tail_threshold(x: np.ndarray, p: float, top: float = 0.02) -> float:
    """x's quantile 1 - p from an exponential tail fitted to its upper ``top`` fraction."""
    u = np.quantile(x, 1 - top)
    excess = x[x > u] - u
    return float(u + excess.mean() * np.log(top / p))


def model_lattice(model: SensorModel, dt: float) -> np.ndarray:
    """The output lattice step (6,) of the model's increment quantization Q (lsb = Q sqrt(12) / dt), rad/s, m/s^2."""
    return np.concatenate([model.gyro.quantization, model.accel.quantization]) * np.sqrt(12.0) / dt


def stuck_run_length(model: SensorModel, dt: float, budget_per_channel: float, max_run: int) -> np.ndarray:
    """Samples of one repeated value (6,) that quantized model noise reaches less than ``budget_per_channel``
    times per 10 h: P(repeat) = P(|difference| < lsb / 2) for a per-sample lattice step lsb."""
    q = np.concatenate([model.gyro.quantization, model.accel.quantization])
    step = q * np.sqrt(12.0) / dt
    sd_diff = np.sqrt(2.0) * sample_sigma(model, dt)
    p = np.where(step > 0, 2 * stats.norm.cdf(0.5 * step / np.maximum(sd_diff, 1e-300)) - 1, 0.0)
    n_samples = SECONDS_PER_10H / dt
    with np.errstate(divide="ignore"):
        runs = 1 + np.ceil(np.log(budget_per_channel / n_samples) / np.log(np.clip(p, 1e-300, 0.999)))
    return np.clip(runs, 3, max_run).astype(int)


COARSE_LATTICE = 0.25
"""A lattice step above this many per-sample sd makes the noise itself sit at a span's extreme for tens of samples
(ADIS16405 accelerometers: 0.0327 m/s^2 steps on 0.028 m/s^2 of noise, 40-77 samples in 10 s as the bias wanders
across the lattice): there the flat-top count cannot tell a clip and is off (CLIP_OFF); the range and the
repeat checks still run."""
CLIP_OFF = 2**31 - 1


def clip_threshold(sigma: np.ndarray, lattice: np.ndarray, n: int, p_window: float, windows: int = 4000,
                   seed: int = 0) -> np.ndarray:
    """Clip threshold (6,) for white noise of per-sample sd ``sigma`` (6,) on a lattice of step ``lattice`` (6,)
    (0: none), exceeded with probability ``p_window`` per window: an exponential tail fitted to the upper 2 % of
    the simulated span ties (the spans overlap, so their maximum says little about a 10-h budget), and at least
    2 more than the most simulated (and 3)."""
    rng = np.random.default_rng(seed)
    x = rng.normal(0.0, 1.0, (windows, n, 6)) * sigma
    step = np.where(lattice > 0, lattice, 1.0)
    x = np.where(lattice > 0, np.round(x / step + rng.uniform(size=6)) * step, x)
    ties = span_ties(x)
    tail = np.array([exp_tail_threshold(ties[:, c].astype(float) + rng.uniform(0, 1, len(ties)), p_window)
                     for c in range(6)])  # jittered: a continuous tail through the integer counts
    out = np.maximum.reduce([np.full(6, 3), ties.max(axis=0) + 2, np.ceil(tail).astype(int)]).astype(int)
    return np.where(lattice > COARSE_LATTICE * sigma, CLIP_OFF, out)


def observed_lattice(x: np.ndarray, floor: np.ndarray) -> np.ndarray:
    """The smallest difference above ``floor`` (6,) between distinct finite values of each channel of x (m, 6): the
    output's lattice step as recorded (float rounding of counts x lsb gives differences below it); 0 if none."""
    out = np.zeros(6)
    for c in range(6):
        d = np.diff(np.unique(x[np.isfinite(x[:, c]), c]))
        d = d[d > floor[c]]
        out[c] = d.min() if len(d) else 0.0
    return out


def monte_carlo(model: SensorModel, grid: WindowGrid, window_s: float, budget_per_10h: float,
                baseline_s: float, mc_windows: int = 20000, seed: int = 0,
                gyro_bias_per_10h: float = 0.0, clip_per_10h: float = 0.0, bias_hours: float = 1000.0) -> Thresholds:
    """Thresholds for ``model`` from ``mc_windows`` simulated windows and ``bias_hours`` of simulated window means
    for the bias CUSUMs (seeded: the same model gives the same thresholds in the CLI and the node).
    ``gyro_bias_per_10h`` > 0: the gx and gy bias CUSUMs each get that share instead of an equal one of
    ``budget_per_10h``; ``clip_per_10h`` > 0 likewise each channel's clip count."""
    rng = np.random.default_rng(seed)
    x = noise_sim.model_noise(model, mc_windows * grid.n, grid.dt, rng).reshape(mc_windows, grid.n, 6)
    ws = window_stats(grid, x)
    per_test = budget_per_10h / N_TESTS
    target = SECONDS_PER_10H / window_s / per_test
    log_level = np.log(ws.level)
    mu = np.median(log_level, axis=0)
    sd = stats.iqr(log_level, axis=0) / 1.349
    noise_k = np.log(NOISE_IGNORED_RATIO) / float(np.median(sd))
    noise_h = cusum_threshold((log_level - mu) / sd, noise_k, target)
    b = np.concatenate([model.gyro.bias_instability, model.accel.bias_instability])
    white_sd = np.std(ws.mean[1:] - ws.mean[:-1], axis=0) / np.sqrt(2)
    bias_k = np.clip(0.5 * BIAS_DESIGN_STEP * b / white_sd, *BIAS_K_RANGE)
    # az carries the vertical specific force of driving (Eotvos, road grade changes): always the large k and the
    # short baseline, which follow it; a smaller accelerometer step than 3 sd per window is not claimed
    bias_k[3:] = BIAS_K_RANGE[1]
    tau = baseline_times(bias_k, baseline_s)
    bias_q = bias_walk_variance(model, white_sd, tau, window_s)
    bias_h, how = np.full(6, np.inf), [""] * 6
    for c in BIAS_CHANNELS:
        share = gyro_bias_per_10h if c < 2 and gyro_bias_per_10h > 0 else per_test
        tail = bias_tail.bias_tail(model, c, window_s, white_sd[c], ws.level[:, c], bias_q[c], bias_k[c], share,
                                   bias_hours, bias_warmup_windows(window_s), seed)
        bias_h[c], how[c] = tail.h, tail.how
    line_h = exp_tail_threshold(ws.line.ravel(), per_test * window_s / SECONDS_PER_10H)
    stuck = stuck_run_length(model, grid.dt, per_test, max_run=max(3, grid.n))
    clip_ties = np.maximum(3, ws.ties.max(axis=0) + 2)
    clip_per_10h = clip_per_10h if clip_per_10h > 0 else per_test
    clip_span = clip_threshold(sample_sigma(model, grid.dt), model_lattice(model, grid.dt), grid.n,
                               clip_per_10h * window_s / SECONDS_PER_10H, seed=seed)
    return Thresholds(window_s, mu, sd, noise_k, noise_h, white_sd, bias_k, bias_h, tau, bias_q, line_h, stuck, clip_ties,
                      clip_span, sample_sigma(model, grid.dt), budget_per_10h, mc_windows,
                      gyro_bias_per_10h, bias_hours, how, clip_per_10h)
