"""Fixed-interval Rauch-Tung-Striebel smoother for the closed-loop error-state filter (issue 25).

The forward filter feeds every update back into the nominal state and resets its error state to zero,
so a textbook RTS pass over its (always zero) error states smooths nothing. Here the smoother
estimates the error of the *stored forward trajectory itself*. With ``e = estimate - truth`` and
``x+ = x- (-) dx`` at each epoch (``dx`` the sum of the epoch's fed-back corrections), the error of the
a-priori nominal at epoch k+1 is ``e-(k+1) = e+(k+1) + dx(k+1)``, and the forward prediction of it from
epoch k (whose posterior error estimate is zero after the reset) is zero. So, backwards from the last epoch
(``e_s(N) = 0``, ``P_s(N) = P+(N)``)::

    C_k    = P+(k) Phi(k)' P-(k+1)^-1
    e_s(k) = C_k (e_s(k+1) + dx(k+1))
    P_s(k) = P+(k) + C_k (P_s(k+1) - P-(k+1)) C_k'

and the smoothed state is the forward one with ``e_s(k)`` fed back as the filter does. A state set anew
(heading from the course, GPS reset, re-alignment) is not a linear update: the chain is cut there.

Memory: one row per filter epoch (the covariances, the transition and the correction: ``1 + n + 3 n^2``
floats, 5.5 kB with 15 states); rows go to a temporary file once more than ``ram_rows`` are held, and the
backward pass reads them back in blocks of that many (:func:`backward`).
"""
from __future__ import annotations

import dataclasses
import os
import tempfile

import numpy as np
from numba import njit

from ins_gps_kf import error_model as em
from ins_gps_kf import strapdown
from ins_gps_kf.records import Estimate

RAM_ROWS = 2048  # rows held in memory before the store spills to its temporary file


class ForwardStore:
    """What the backward pass needs, per filter epoch: P+, P-, Phi, the epoch's fed-back correction dx, and
    whether the epoch follows its predecessor by a linear update (not a state set anew)."""

    def __init__(self, n_states: int, ram_rows: int = RAM_ROWS, tmp_dir: str | None = None):
        self.n = n_states
        self.width = self.row_width(n_states)
        self.ram_rows = ram_rows
        self.tmp_dir = tmp_dir
        self._buf = np.empty((ram_rows, self.width))
        self._used = 0
        self._file = None  # the spill file (path) once rows went to disk
        self._spilled = 0
        self._phi = self._prior = None
        self._dx = np.zeros(n_states)
        self._linked = False

    @staticmethod
    def row_width(n_states: int) -> int:
        """Floats a stored epoch takes with ``n_states`` error states."""
        return 1 + n_states + 3 * n_states * n_states

    def __len__(self) -> int:
        return self._spilled + self._used

    @property
    def spilled(self) -> bool:
        """Whether rows went to the temporary file."""
        return self._file is not None

    def cut(self) -> None:
        """The state was set anew: the next stored epoch does not follow from the previous one."""
        self._linked = False

    def predicted(self, phi: np.ndarray, cov_prior: np.ndarray) -> None:
        """An epoch's propagation: its transition Phi and a-priori covariance P- (before any update)."""
        self._phi, self._prior = phi, cov_prior.copy()
        self._dx[:] = 0.0

    def corrected(self, dx: np.ndarray) -> None:
        """One fed-back correction (error-state estimate, subtracted from the state) within the epoch."""
        self._dx += dx

    def epoch(self, est: Estimate) -> None:
        """Store the epoch whose forward estimate (P+ in ``est.cov``) the filter gave out."""
        n = self.n
        if self._phi is None:  # no propagation since the start: cannot link
            self._phi, self._prior, self._linked = np.eye(n), est.cov, False
        row = self._buf[self._used]
        row[0] = 1.0 if self._linked else 0.0
        row[1:1 + n] = self._dx
        o = 1 + n
        row[o:o + n * n] = est.cov.ravel()
        row[o + n * n:o + 2 * n * n] = self._prior.ravel()
        row[o + 2 * n * n:] = self._phi.ravel()
        self._used += 1
        self._linked, self._phi = True, None
        if self._used == self.ram_rows:
            self._spill()

    def _spill(self) -> None:
        if self._file is None:
            fd, self._file = tempfile.mkstemp(prefix="ins_gps_kf_smoother_", suffix=".f64", dir=self.tmp_dir)
            os.close(fd)
        with open(self._file, "ab") as fh:
            fh.write(self._buf[:self._used].tobytes())
        self._spilled += self._used
        self._used = 0

    def read(self, lo: int, hi: int) -> np.ndarray:
        """Rows ``lo`` to ``hi`` (exclusive), a copy (hi - lo, width): read from the spill file by explicit reads, so
        the backward pass holds one block at a time (a memory map's touched pages would count as resident)."""
        if self._file is not None and self._used:
            self._spill()
        if self._file is None:
            return self._buf[lo:hi].copy()
        return np.fromfile(self._file, dtype=np.float64, count=(hi - lo) * self.width,
                           offset=lo * self.width * 8).reshape(hi - lo, self.width)

    def close(self) -> None:
        """Delete the spill file."""
        if self._file is not None:
            os.unlink(self._file)
            self._file = None


@njit(cache=True)
def _backward_block(rows, after, e_next, p_next, n):
    """The RTS recursion (see the module doc) over ``rows`` (m, width), from its last row back, ``after`` the row
    that follows them and (``e_next``, ``p_next``) its smoothed error and covariance; returns e_s (m, n), P_s
    (m, n, n)."""
    m = rows.shape[0]
    nn = n * n
    o = 1 + n
    e_s = np.zeros((m, n))
    p_s = np.zeros((m, n, n))
    for k in range(m - 1, -1, -1):
        nxt = rows[k + 1] if k + 1 < m else after
        p_post = rows[k, o:o + nn].copy().reshape(n, n)
        if nxt[0] > 0.5:
            prior = nxt[o + nn:o + 2 * nn].copy().reshape(n, n)
            phi = nxt[o + 2 * nn:].copy().reshape(n, n)
            c_t = np.linalg.solve(prior, phi @ p_post)  # C' (P+ and P- symmetric)
            c = np.ascontiguousarray(c_t.T)
            e = c @ (e_next + nxt[1:1 + n])
            p = p_post + c @ (p_next - prior) @ c_t
            p = 0.5 * (p + p.T)
        else:
            e = np.zeros(n)
            p = p_post
        e_s[k] = e
        p_s[k] = p
        e_next, p_next = e, p
    return e_s, p_s


def backward(store: ForwardStore, block_rows: int = RAM_ROWS):
    """The backward pass in blocks of ``block_rows`` epochs from the last: yields (first epoch index, e_s (m, n),
    P_s (m, n, n)) per block, so memory holds one block whatever the drive's length."""
    n, total = store.n, len(store)
    if total == 0:
        return
    after = store.read(total - 1, total)[0]
    e_next, p_next = np.zeros(n), after[1 + n:1 + n + n * n].reshape(n, n).copy()
    yield total - 1, e_next[None], p_next[None]
    hi = total - 1
    while hi > 0:
        lo = max(0, hi - block_rows)
        rows = store.read(lo, hi)
        e_s, p_s = _backward_block(rows, after, e_next, p_next, n)
        yield lo, e_s, p_s
        after, e_next, p_next, hi = rows[0], e_s[0], p_s[0], lo


def smooth(store: ForwardStore, forward: list[Estimate]) -> list[Estimate]:
    """The smoothed estimates (state and covariance) of the ``forward`` estimates the filter gave while
    ``store`` recorded it; the store's spill file is deleted."""
    if len(store) != len(forward):
        raise ValueError(f"the store holds {len(store)} epochs, the forward run {len(forward)}")
    if not forward:
        return []
    out = [None] * len(forward)
    for lo, block in smoothed_blocks(store, lambda lo, hi: forward[lo:hi]):
        out[lo:lo + len(block)] = block
    return out


def smoothed_blocks(store: ForwardStore, forward_at, block_rows: int = RAM_ROWS):
    """The smoothed estimates block by block, the last first: yields (first epoch index, list of Estimates);
    ``forward_at(lo, hi)`` gives the forward estimates of epochs ``lo`` to ``hi`` (exclusive). The store's spill
    file is deleted at the end."""
    try:
        for lo, e_s, p_s in backward(store, block_rows):
            forward = forward_at(lo, lo + len(e_s))
            yield lo, [_corrected(forward[i], e_s[i], p_s[i]) for i in range(len(e_s))]
    finally:
        store.close()


def smooth_table(store: ForwardStore, forward, block_rows: int = RAM_ROWS):
    """:func:`smooth` from and to :class:`ins_gps_kf.offline.EstimateTable` (compact rows, not Estimate objects):
    memory holds one block of ``block_rows`` epochs as objects whatever the drive's length."""
    from ins_gps_kf.offline import EstimateTable

    if len(store) != len(forward):
        raise ValueError(f"the store holds {len(store)} epochs, the forward run {len(forward)}")
    out = EstimateTable(len(forward))
    if len(forward):
        for lo, block in smoothed_blocks(store, forward.estimates, block_rows):
            out.put(lo, block)
    return out


def _corrected(est: Estimate, e: np.ndarray, cov: np.ndarray) -> Estimate:
    """``est`` with the error ``e`` (estimate minus truth) removed as the filter's feedback does, covariance ``cov``."""
    nav = strapdown.new_state(est.quat_xyzw.copy(), est.velocity_n - e[em.DV], est.position_n - e[em.DP])
    strapdown.rotate_attitude(nav, e[em.PHI])
    sf = None
    if est.scale_factors is not None:
        sf = est.scale_factors - np.concatenate([e[em.SG], e[em.SA]])
    return dataclasses.replace(est, position_n=nav[strapdown.P].copy(), velocity_n=nav[strapdown.V].copy(),
                               quat_xyzw=nav[strapdown.Q].copy(), cov=cov, gyro_bias=est.gyro_bias - e[em.BG],
                               accel_bias=est.accel_bias - e[em.BA], scale_factors=sf)


def run_smoothed(filt, run, *args, **kwargs):
    """(forward estimates, smoothed estimates): ``run(filt, *args, **kwargs)`` recorded, then the backward pass."""
    filt.recorder = ForwardStore(filt.n_states)
    try:
        forward = run(filt, *args, **kwargs)
        return forward, smooth(filt.recorder, forward)
    finally:
        filt.recorder.close()
        filt.recorder = None


def covariance_root(cov: np.ndarray) -> np.ndarray:
    """A square root ``L`` (m, k, k) of each covariance (m, k, k) (``L L' = cov``; eigen-decomposition, negative
    rounding clipped), for drawing ``L z`` with ``z`` standard normal."""
    w, v = np.linalg.eigh(0.5 * (cov + np.swapaxes(cov, 1, 2)))
    return v * np.sqrt(np.clip(w, 0.0, None))[:, None, :]


def no_worse_probability(cov_forward: np.ndarray, cov_smoothed: np.ndarray, draws: int = 2000,
                         seed: int = 0) -> np.ndarray:
    """Per epoch, the probability that an optimal smoother's error is no larger (in norm) than the forward
    filter's, from their covariances (m, k, k) (m^2): the smoothed error ``e_s ~ N(0, P_s)`` is orthogonal to the
    difference of the two estimates ``d ~ N(0, P_f - P_s)``, so the forward error is ``e_s + d`` (Monte Carlo, ``draws``
    per epoch). Where the smoother adds little (GNSS throughout) this is well below 1 even with the true model."""
    cov_f, cov_s = np.asarray(cov_forward, float), np.asarray(cov_smoothed, float)
    root = covariance_root
    rng = np.random.default_rng(seed)
    m, k = cov_f.shape[:2]
    e_s = np.einsum("mij,mdj->mdi", root(cov_s), rng.standard_normal((m, draws, k)))
    d = np.einsum("mij,mdj->mdi", root(cov_f - cov_s), rng.standard_normal((m, draws, k)))
    return np.mean(np.sum(e_s**2, axis=2) <= np.sum((e_s + d) ** 2, axis=2), axis=1)
