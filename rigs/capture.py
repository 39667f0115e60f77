"""Impact capture: trigger on the force channel, cut records, check each hit.

Trigger: the force rises above ``trigger_level_n`` after having stayed below
``trigger_level_n - hysteresis_n`` for ``rearm_quiet_s`` (re-arm; longer than the gap of a
double hit, so the bounce of a tap made before arming never starts a record); a record
runs from ``pretrigger_s`` before the trigger sample for ``record_s``. Records are long
enough for the response to decay, so windows can stay weak (docs/acquisition.md).

Checks, in order, each with a reason: data lost (a gap, from frame counter or sample index,
touches the record), sensor fault, overload (device flag or a code within ``clip_fraction``
of full scale), double hit (a second force pulse after the first one has ended), force too
weak (peak below ``min_peak_n``), response not decayed (RMS of the last 5 % of the record
above ``decay_ratio`` times the peak and above 3x the pre-trigger noise).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rigs import protocol as p
from rigs.stream import DataBlock, Gap, Item


@dataclass(frozen=True)
class CaptureSettings:
    """Trigger, record and acceptance settings (SI)."""

    trigger_level_n: float = 20.0
    hysteresis_n: float = 10.0
    pretrigger_s: float = 0.01
    record_s: float = 2.0
    min_peak_n: float = 50.0
    clip_fraction: float = 0.98
    double_hit_fraction: float = 0.05
    decay_ratio: float = 0.01
    rearm_quiet_s: float = 0.05


@dataclass(frozen=True)
class HitRecord:
    """One triggered record in SI units, with what the stream said about it.

    Attributes
    ----------
    index0 : int
        device sample index of the first sample; trigger_index: of the trigger sample.
        force_n, accel_ms2: (n,) force (N) and response acceleration (m/s^2).
        full_scale_fraction: (2,) largest |code| / full-scale code on (force, response).
        overload, fault: device overload / sensor-fault flags seen within the record.
        gaps: gaps touching the record.
    """

    index0: int
    trigger_index: int
    force_n: np.ndarray
    accel_ms2: np.ndarray
    full_scale_fraction: np.ndarray
    overload: bool
    fault: bool
    gaps: tuple[Gap, ...]


@dataclass(frozen=True)
class HitCheck:
    """Verdict on one hit: reason is None when accepted, else a short canonical reason."""

    accepted: bool
    reason: str | None
    detail: str
    peak_force_n: float


class HitCapture:
    """Stateful trigger over the item stream. ``push(item)`` returns completed records.

    Triggers before ``arm(index)`` has been called, or before the armed index, are ignored
    (samples before a point was announced belong to the previous point).
    """

    def __init__(self, info: p.DeviceInfo, settings: CaptureSettings,
                 response_channel: int | None = None) -> None:
        self.info = info
        self.settings = settings
        fs = info.sample_rate_hz
        self.n_pre = int(round(settings.pretrigger_s * fs))
        self.n_rec = int(round(settings.record_s * fs))
        self.ch = np.array([info.channel_index("force"),
                            info.channel_index("acceleration") if response_channel is None
                            else response_channel])
        self.scale = info.scale_si()[self.ch]
        self._cap = 4 * (self.n_rec + self.n_pre) + 8192
        self._codes = np.zeros((self._cap, 2), dtype=np.int32)
        self._over = np.zeros(self._cap, dtype=bool)
        self._fault = np.zeros(self._cap, dtype=bool)
        self._start: int | None = None  # device index of buffer row 0
        self._len = 0
        self._search = 0  # first device index not yet searched for a trigger
        self._need_rearm = False
        self._armed: int | None = None
        self._trigger: int | None = None
        self._gaps: list[Gap] = []
        self._status: list[p.Status] = []

    @property
    def next_index(self) -> int:
        """Device index of the next sample expected."""
        return 0 if self._start is None else self._start + self._len

    @property
    def recording(self) -> bool:
        """Whether a record is being captured (triggered, not yet complete)."""
        return self._trigger is not None

    def arm(self, from_index: int) -> None:
        """Accept triggers at device sample indices >= ``from_index`` only."""
        self._armed = from_index
        self._search = max(self._search, from_index)
        self._need_rearm = True
        if self._trigger is not None and self._trigger < from_index:
            self._trigger = None

    def disarm(self) -> None:
        """Ignore triggers until the next ``arm`` and drop a record in progress."""
        self._armed = None
        self._trigger = None

    def push(self, item: Item) -> list[HitRecord]:
        """Take one stream item; return the records it completes (usually none).

        Parameters
        ----------
        item : Item
            A data block, gap, status, ACK or device info from the stream tracker.

        Returns
        -------
        list of HitRecord
            The records completed by this item, oldest first.
        """
        if isinstance(item, Gap):
            self._gaps.append(item)
        elif isinstance(item, p.Status):
            self._status.append(item)
        elif isinstance(item, DataBlock):
            self._append(item)
            return self._scan()
        return []

    # ------------------------------------------------------------ buffer
    def _append(self, blk: DataBlock) -> None:
        n = blk.codes.shape[0]
        if self._start is None or not 0 <= blk.index0 - self.next_index <= self.n_rec:
            self._start, self._len = blk.index0, 0  # first block, or a jump too big to fill
            self._trigger = None
            self._search = max(self._search, blk.index0)
        fill = blk.index0 - self.next_index  # missing samples (already reported as a Gap)
        need = self._len + fill + n
        if need > self._cap:
            keep_from = min(self._search, self._trigger if self._trigger is not None
                            else self._search) - self.n_pre
            drop = max(0, min(keep_from - self._start, self._len))
            self._shift(drop)
            need = self._len + fill + n
            if need > self._cap:
                self._grow(need)
        a = self._len
        self._codes[a:a + fill] = 0
        self._over[a:a + fill] = False
        self._fault[a:a + fill] = False
        a += fill
        self._codes[a:a + n] = blk.codes[:, self.ch]
        self._over[a:a + n] = blk.overload
        self._fault[a:a + n] = blk.fault
        self._len = a + n

    def _shift(self, drop: int) -> None:
        if drop <= 0:
            return
        m = self._len - drop
        self._codes[:m] = self._codes[drop:self._len]
        self._over[:m] = self._over[drop:self._len]
        self._fault[:m] = self._fault[drop:self._len]
        self._start += drop
        self._len = m
        self._gaps = [g for g in self._gaps if max(g.stop, g.start + 1) > self._start]
        self._status = [s for s in self._status if s.index >= self._start]

    def _grow(self, need: int) -> None:
        cap = max(need, 2 * self._cap)
        for name in ("_codes", "_over", "_fault"):
            old = getattr(self, name)
            new = np.zeros((cap,) + old.shape[1:], dtype=old.dtype)
            new[:self._len] = old[:self._len]
            setattr(self, name, new)
        self._cap = cap

    # ------------------------------------------------------------ trigger
    def _scan(self) -> list[HitRecord]:
        out = []
        while True:
            if self._trigger is None:
                if self._armed is None or not self._find_trigger():
                    return out
            end = self._trigger - self.n_pre + self.n_rec
            if self.next_index < end:
                return out
            out.append(self._cut(self._trigger))
            self._search = end
            self._need_rearm = True
            self._trigger = None

    def _find_trigger(self) -> bool:
        s = self.settings
        lo = max(self._search, self._start) - self._start
        if lo >= self._len:
            return False
        force = self._codes[lo:self._len, 0] * self.scale[0]
        if self._need_rearm:
            n_q = max(int(round(s.rearm_quiet_s * self.info.sample_rate_hz)), 1)
            quiet = np.convolve(force < s.trigger_level_n - s.hysteresis_n, np.ones(n_q),
                                "valid") >= n_q - 0.5
            first = np.flatnonzero(quiet)
            if not first.size:
                self._search = max(self._search, self.next_index - n_q + 1)
                return False
            self._need_rearm = False
            lo += int(first[0]) + n_q
            force = force[int(first[0]) + n_q:]
        above = np.flatnonzero(force >= s.trigger_level_n)
        if not above.size:
            self._search = self.next_index
            return False
        self._trigger = self._start + lo + int(above[0])
        return True

    def _cut(self, trigger: int) -> HitRecord:
        i0 = trigger - self.n_pre
        a, b = i0 - self._start, i0 - self._start + self.n_rec
        gaps = tuple(g for g in self._gaps if g.start < i0 + self.n_rec
                     and max(g.stop, g.start + 1) > i0)
        if a < 0:  # the stream (re)started inside the pre-trigger time
            gaps += (Gap(i0, self._start, "record starts before the first sample received"),)
            a = 0
        codes = np.zeros((self.n_rec, 2), dtype=np.int32)
        codes[self.n_rec - (b - a):] = self._codes[a:b]
        in_rec = [st for st in self._status if i0 <= st.index < i0 + self.n_rec]
        fs_code = self.info.full_scale_code
        return HitRecord(
            index0=i0, trigger_index=trigger,
            force_n=codes[:, 0] * self.scale[0], accel_ms2=codes[:, 1] * self.scale[1],
            full_scale_fraction=np.abs(codes).max(axis=0) / fs_code,
            overload=bool(self._over[a:b].any() or any(st.overload for st in in_rec)),
            fault=bool(self._fault[a:b].any() or any(st.fault for st in in_rec)),
            gaps=gaps,
        )


def pulses(force_n: np.ndarray, threshold_n: float, min_gap: int) -> np.ndarray:
    """Find the (k, 2) [start, stop) ranges where force > threshold (gaps < min_gap merged)."""
    above = np.r_[False, force_n > threshold_n, False]
    edges = np.flatnonzero(np.diff(above.astype(np.int8)))
    runs = edges.reshape(-1, 2)
    if runs.shape[0] > 1:
        keep = np.r_[True, runs[1:, 0] - runs[:-1, 1] >= min_gap]
        starts = runs[keep, 0]
        stops = np.r_[runs[np.flatnonzero(keep)[1:] - 1, 1], runs[-1, 1]]
        runs = np.column_stack([starts, stops])
    return runs


def check_hit(rec: HitRecord, settings: CaptureSettings, sample_rate_hz: float,
              n_pre: int) -> HitCheck:
    """Accept or reject one hit, with a reason (module docstring)."""
    f, a = rec.force_n, rec.accel_ms2
    peak = float(f.max())
    if rec.gaps:
        g = rec.gaps[0]
        return HitCheck(False, "data lost", g.reason, peak)
    if rec.fault:
        return HitCheck(False, "sensor fault", "device reported a sensor fault", peak)
    frac = rec.full_scale_fraction
    if rec.overload or frac.max() >= settings.clip_fraction:
        which = "force" if frac[0] >= frac[1] else "response"
        return HitCheck(False, "overload", f"{which} channel at {100 * frac.max():.0f} % of "
                        f"full scale{' (device overload flag)' if rec.overload else ''}", peak)
    noise_f = float(np.std(f[:max(n_pre, 2)]))
    runs = pulses(f, max(settings.double_hit_fraction * peak, 5 * noise_f),
                  max(2, int(2e-4 * sample_rate_hz)))
    if runs.shape[0] > 1:
        second = float(f[runs[1, 0]:runs[1, 1]].max())
        dt_ms = 1e3 * (runs[1, 0] - runs[0, 0]) / sample_rate_hz
        return HitCheck(False, "double hit", f"second pulse {dt_ms:.1f} ms after the first, "
                        f"{100 * second / peak:.0f} % of its peak", peak)
    if peak < settings.min_peak_n:
        return HitCheck(False, "force too weak", f"peak force {peak:.1f} N < "
                        f"{settings.min_peak_n:.1f} N", peak)
    tail = a[-max(a.size // 20, 1):]
    tail_rms = float(np.sqrt(np.mean((tail - tail.mean()) ** 2)))
    a_peak = float(np.abs(a).max())
    noise_a = float(np.std(a[:max(n_pre, 2)]))
    if tail_rms > max(settings.decay_ratio * a_peak, 3 * noise_a):
        return HitCheck(False, "response not decayed", f"last 5 % of the record at "
                        f"{100 * tail_rms / a_peak:.1f} % of the peak response", peak)
    return HitCheck(True, None, f"peak force {peak:.0f} N", peak)
