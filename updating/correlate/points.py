"""Where a test's mode shapes are given, and the re-test's points matched to the baseline's.

A roving-hammer test gives its shapes at the impact nodes, a roving-accelerometer test at
the accelerometers; the driving point's node is where the accelerometer sits. A re-test is
compared with its baseline point by point, so its points are matched to the baseline's
(marks on the bat, ``POINT_TOL_M``) and its shape rows re-ordered to the baseline's order.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from updating.correlate.measured import MeasuredModes
from updating.model.units import IN_TO_M

if TYPE_CHECKING:
    from ema.io.frf_data import FrfTest

POINT_TOL_M = 0.25 * IN_TO_M
"""A re-test impact point may sit this far from the baseline's (marks on the bat)."""


def point_positions_m(test: FrfTest) -> np.ndarray:
    """Return the positions of the nodes a test's mode shapes are given at.

    The roving side of the test: the impact nodes for a roving hammer, the accelerometers
    for a roving accelerometer.

    Parameters
    ----------
    test : FrfTest
        The test's FRFs, ``frf`` of shape (n_freq, n_response, n_reference).

    Returns
    -------
    numpy.ndarray
        (n_points,) positions from the knob end, m.
    """
    nodes = test.reference_nodes if test.frf.shape[2] >= test.frf.shape[1] else \
        test.response_nodes
    return test.x_m(nodes)


def sensor_x_m(test: FrfTest) -> float:
    """Return the position of the accelerometer: the driving point's node.

    Parameters
    ----------
    test : FrfTest
        The test's FRFs with a driving point.

    Returns
    -------
    float
        Position from the knob end, m.
    """
    i, _ = test.driving_point
    return float(test.node_x_m[int(test.response_nodes[i])])


def match_points(baseline_x_m: np.ndarray, retest_x_m: np.ndarray, retest_name: str) -> np.ndarray:
    """Match each baseline point to the re-test's point nearest it.

    The re-test must have as many points as the baseline, each baseline point one re-test
    point within ``POINT_TOL_M``, no re-test point taken twice.

    Parameters
    ----------
    baseline_x_m, retest_x_m : numpy.ndarray
        (n_points,) positions of the two tests' points, m.
    retest_name : str
        The re-test's file name, for the error message.

    Returns
    -------
    numpy.ndarray
        (n_points,) index into the re-test's points for each baseline point.

    Raises
    ------
    ValueError
        When the re-test's points are not the baseline's (their count, or a point further
        than ``POINT_TOL_M`` from any).
    """
    base = np.asarray(baseline_x_m, dtype=float)
    new = np.asarray(retest_x_m, dtype=float)
    if base.size != new.size:
        raise ValueError(f"{retest_name}: {new.size} test points, the baseline has {base.size}")
    order = np.argmin(np.abs(base[:, None] - new[None, :]), axis=1)
    miss = np.abs(new[order] - base)
    if np.unique(order).size != base.size or miss.max() > POINT_TOL_M:
        k = int(np.argmax(miss))
        raise ValueError(f"{retest_name}: test points do not match the baseline's (baseline "
                         f"point at {base[k] / IN_TO_M:.2f} in has no re-test point within "
                         f"{POINT_TOL_M / IN_TO_M:.2f} in)")
    return order


def listed_points_reason(listed_m: np.ndarray, tested_m: np.ndarray,
                         test_name: str) -> str | None:
    """Say how a list of impact points (meta.json's points_in) differs from a test's.

    They agree when they have as many points and, in order along the bat, each listed point
    is within ``POINT_TOL_M`` of a tested one.

    Parameters
    ----------
    listed_m, tested_m : numpy.ndarray
        The listed points and the test's impact points, from the knob end, m.
    test_name : str
        The test's file, for the message.

    Returns
    -------
    str or None
        What differs, in inches ("has 16 points, baseline.uff has 17 impact points"), None
        when they agree.
    """
    a = np.sort(np.asarray(listed_m, dtype=float))
    b = np.sort(np.asarray(tested_m, dtype=float))
    if a.size != b.size:
        return f"has {a.size} points, {test_name} has {b.size} impact points"
    miss = np.abs(a - b)
    if miss.max(initial=0.0) > POINT_TOL_M:
        k = int(np.argmax(miss))
        return (f"has {a[k] / IN_TO_M:.2f} in where {test_name} has its impact point at "
                f"{b[k] / IN_TO_M:.2f} in (more than {POINT_TOL_M / IN_TO_M:.2f} in apart)")
    return None


def reorder(modes: MeasuredModes, order: np.ndarray) -> MeasuredModes:
    """Take the modes' point rows in another order.

    Parameters
    ----------
    modes : MeasuredModes
        The modes of a test.
    order : numpy.ndarray
        (n_points,) row index of each point in the new order (``match_points``).

    Returns
    -------
    MeasuredModes
        The same modes with their shapes' rows and positions re-ordered.
    """
    return MeasuredModes(modes.freq_hz, modes.shapes[order], modes.x_m[order],
                         modes.damping_ratio, modes.sensor_x_m, modes.freq_std_hz,
                         band_top_hz=modes.band_top_hz, members=modes.members,
                         plane_pair_hz=modes.plane_pair_hz,
                         plane_pair_std_hz=modes.plane_pair_std_hz,
                         shape_noise_rel=modes.shape_noise_rel)
