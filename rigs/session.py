"""Roving-hammer session: points in order, N accepted hits each, FRFs from accepted hits.

For each point the host announces it (POINT command; the ACK's sample index arms the trigger,
so taps recorded before the announcement never count for the new point), then takes records
until ``hits_per_point`` are accepted. The raw stream is on disk before a hit is checked.
Progress goes to ``progress`` (stderr in the CLI): "point 5/16 (#9), hit 2/3, rejected:
double hit (...)".
"""

from __future__ import annotations

import struct
from collections.abc import Callable
from dataclasses import asdict, dataclass, field

import numpy as np

from rigs import protocol as p
from rigs.capture import CaptureSettings, HitCapture, HitRecord, check_hit
from rigs.driver import DeviceError
from rigs.frf_estimate import FrfEstimate, estimate_frf

DEFAULT_POINTS_IN = tuple(float(x) for x in np.arange(1.0, 32.0, 2.0))
"""The default impact marks, inches from the knob end: 16 marks, every 2 in from 1 in."""


@dataclass(frozen=True)
class HitLog:
    """One triggered record: where, which attempt, verdict and why."""

    point: int
    hit: int
    accepted: bool
    reason: str | None
    detail: str
    trigger_index: int
    peak_force_n: float


@dataclass(frozen=True)
class SessionResult:
    """FRFs of a roving-hammer test, one fixed response.

    Attributes
    ----------
    freq_hz : np.ndarray
        (F,) frequency lines, Hz.
    h1, h2 : np.ndarray
        (F, 1, n_points) H1 and H2 estimates of the accelerance, (m/s^2)/N.
    coherence : np.ndarray
        (F, 1, n_points) ordinary coherence, 0..1.
    points : np.ndarray
        (n_points,) impact point numbers in the order of the last axis.
    exp_window_tau_s : float | None
        exponential window time constant (None: no window).
    hits : list[HitLog]
        every triggered record with its verdict.
    info : p.DeviceInfo
        the device's description.
    n_averages : np.ndarray
        (n_points,) accepted hits averaged at each point.
    """

    freq_hz: np.ndarray
    h1: np.ndarray
    h2: np.ndarray
    coherence: np.ndarray
    points: np.ndarray
    exp_window_tau_s: float | None
    hits: list[HitLog]
    info: p.DeviceInfo
    n_averages: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=int))

    def hits_as_dicts(self) -> list[dict]:
        """Return the hit log as plain dicts (for JSON)."""
        return [asdict(h) for h in self.hits]


def _quiet(_: str) -> None:
    return None


def acquire_point(source, capture: HitCapture, point: int, hits_per_point: int,
                  settings: CaptureSettings, log: list[HitLog], label: str,
                  progress: Callable[[str], None], max_rejects: int = 20,
                  read_timeout_s: float = 0.2) -> list[HitRecord]:
    """Collect ``hits_per_point`` accepted records at one point (see module docstring).

    Every hit, accepted or not, is appended to ``log``; ``max_rejects`` rejections in a row
    raise ValueError naming the point and the last reason.

    Returns
    -------
    list of HitRecord
        The accepted records, in the order they were hit.
    """
    ack = source.request(p.POINT, struct.pack("<H", point))
    capture.arm(ack.index if ack is not None else capture.next_index)
    progress(f"{label}: tap point {point}")
    accepted: list[HitRecord] = []
    attempt = rejects = 0
    while len(accepted) < hits_per_point:
        try:
            item = source.next_item(read_timeout_s)
        except (DeviceError, EOFError, OSError):
            if capture.recording:
                log.append(HitLog(point, attempt + 1, False, "device stopped mid-hit",
                                  "stream ended before the record was complete", -1, 0.0))
                progress(f"{label}, hit {len(accepted) + 1}/{hits_per_point}, rejected: "
                         "device stopped mid-hit")
            raise
        if item is None:
            continue
        for rec in capture.push(item):
            if len(accepted) >= hits_per_point:
                break
            attempt += 1
            source.flush_raw()
            chk = check_hit(rec, settings, capture.info.sample_rate_hz, capture.n_pre)
            log.append(HitLog(point, attempt, chk.accepted, chk.reason, chk.detail,
                              rec.trigger_index, chk.peak_force_n))
            head = f"{label}, hit {len(accepted) + 1}/{hits_per_point}"
            if chk.accepted:
                accepted.append(rec)
                rejects = 0
                progress(f"{head}, accepted ({chk.detail})")
            else:
                rejects += 1
                progress(f"{head}, rejected: {chk.reason} ({chk.detail})")
                if rejects >= max_rejects:
                    raise ValueError(f"point {point}: {rejects} hits rejected in a row "
                                     f"(last: {chk.reason})")
    capture.disarm()
    return accepted


def run_session(source, points: list[int], hits_per_point: int,
                settings: CaptureSettings | None = None,
                exp_window_tau_s: float | None = None, fmax_hz: float | None = None,
                progress: Callable[[str], None] = _quiet, max_rejects: int = 20,
                done: dict[int, FrfEstimate] | None = None,
                on_point: Callable[[int, FrfEstimate, list[HitLog]], None] | None = None,
                ) -> SessionResult:
    """Run the roving-hammer test on a source that has completed its handshake.

    ``done``: points already measured (a resumed session), skipped and used as they are;
    ``on_point(point, estimate, log)`` is called as each point completes with the hit log so
    far (the caller saves them, so a killed session keeps its completed points and their log).
    A stream that ends raises :class:`SessionInterrupted` carrying the completed points.

    Parameters
    ----------
    source : SerialDevice or ReplaySource
        The item source (``next_item``, ``request``, ``info``, ``flush_raw``), handshaken.
    points : list of int
        Impact point numbers, in the order they are tapped.
    hits_per_point : int
        Accepted hits averaged at each point.
    settings : CaptureSettings, optional
        Trigger and hit checks (default ``CaptureSettings()``).
    exp_window_tau_s : float or None, optional
        Time constant of an exponential window on the response, s; None for none.
    fmax_hz : float or None, optional
        Highest frequency line kept, Hz; None keeps up to Nyquist.
    progress : callable, optional
        ``progress(message)`` for one line per point and per hit.
    max_rejects : int, optional
        Hits rejected in a row at one point before the session gives up (ValueError).
    done : dict of int to FrfEstimate, optional
        Points already measured (a resumed session).
    on_point : callable, optional
        ``on_point(point, estimate, log)``, called as each point completes.

    Returns
    -------
    SessionResult
        The FRFs (H1, H2, coherence) of every point, and the hit log.
    """
    if hits_per_point < 1 or not points:
        raise ValueError("need at least one point and one hit per point")
    settings = settings or CaptureSettings()
    info = source.info
    capture = HitCapture(info, settings)
    log: list[HitLog] = []
    estimates: dict[int, FrfEstimate] = dict(done or {})
    for k, point in enumerate(points):
        if point in estimates:
            progress(f"point {k + 1}/{len(points)} (#{point}): already measured")
            continue
        try:
            recs = acquire_point(source, capture, point, hits_per_point, settings, log,
                                 f"point {k + 1}/{len(points)} (#{point})", progress,
                                 max_rejects)
        except (DeviceError, EOFError, OSError) as exc:
            raise SessionInterrupted(str(exc), estimates, log, info) from exc
        est = estimate_frf(np.array([r.force_n for r in recs]),
                           np.array([r.accel_ms2 for r in recs]),
                           info.sample_rate_hz, exp_window_tau_s, fmax_hz=fmax_hz)
        estimates[point] = est
        if on_point is not None:
            on_point(point, est, log)
    return combine(points, estimates, exp_window_tau_s, log, info)


def combine(points: list[int], estimates: dict[int, FrfEstimate],
            exp_window_tau_s: float | None, log: list[HitLog], info) -> SessionResult:
    """Assemble the session's FRFs from per-point estimates, in ``points`` order."""
    ests = [estimates[n] for n in points]
    stack = {name: np.stack([getattr(e, name) for e in ests], axis=-1)[:, None, :]
             for name in ("h1", "h2", "coherence")}
    return SessionResult(ests[0].freq_hz, stack["h1"], stack["h2"], stack["coherence"],
                         np.asarray(points, dtype=int), exp_window_tau_s, log, info,
                         np.array([e.n_averages for e in ests]))


class SessionInterrupted(OSError):
    """The stream ended (device lost, recording cut) before every point was measured.

    Attributes
    ----------
    completed : dict[int, FrfEstimate]
        The points measured so far and their FRF estimates.
    log : list[HitLog]
        The hit log.
    info : p.DeviceInfo
        The device's description.
    """

    def __init__(self, message: str, completed: dict, log: list[HitLog], info) -> None:
        super().__init__(message)
        self.completed, self.log, self.info = dict(completed), log, info
