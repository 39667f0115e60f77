"""`batlab fit`: a test file's automatic modal analysis, its modes file and its figures."""

from __future__ import annotations

from ema.io.frf_data import FrfTest
from ema.modal_fit import MIN_SNR

__all__ = [
    "MIN_SNR", "fit_test_file", "plot_fit_files", "write_modes_file",
]


def fit_test_file(test: FrfTest, band_hz=None, method: str = "lscf", max_order=None,
                  known_mass_kg: float | None = None, refine: bool = False,
                  min_snr: float = MIN_SNR, name: str = "the test"):
    """Run `batlab fit`'s automatic modal analysis of a test (``ema.modal_fit.fit_test``).

    Parameters
    ----------
    test : FrfTest
        The FRFs.
    band_hz : tuple of float or None
        The band fitted, Hz (None: automatic).
    method : str
        The pole estimator.
    max_order : int or None
        The highest model order.
    known_mass_kg : float or None
        The bat's weighed mass, kg.
    refine : bool
        Refine the poles by a nonlinear fit.
    min_snr : float
        The least signal-to-noise ratio of a kept mode.
    name : str
        The file, named when the fit fails on its numbers.

    Returns
    -------
    ModalFit
        The fit.
    """
    from batlab.pipeline.files import numeric_failure
    from ema.modal_fit import fit_test

    with numeric_failure(name):
        return fit_test(test, band_hz=band_hz, method=method, max_order=max_order,
                        known_mass_kg=known_mass_kg, refine=refine, min_snr=min_snr)


def write_modes_file(path, fit) -> None:
    """Write a fit's real mass-normalised modes as UFF 55 (``ema.io.uff_modes``).

    Parameters
    ----------
    path : str or os.PathLike
        The file written.
    fit : ModalFit
        The fit.
    """
    from ema.io.uff_modes import write_modes_uff

    write_modes_uff(path, fit.freq_hz, fit.damping_ratio, fit.real_shapes, fit.nodes, fit.x_m)


def plot_fit_files(fit, test: FrfTest, out_dir) -> list:
    """Draw a fit's stabilisation.png, synthesis.png and automac.png (``ema.plots.plot_fit``).

    Parameters
    ----------
    fit : ModalFit
        The fit.
    test : FrfTest
        Its FRFs (the fitted band is drawn).
    out_dir : str or os.PathLike
        The folder written to.

    Returns
    -------
    list of pathlib.Path
        The files written.
    """
    from ema.plots import plot_fit

    sel = (test.freq_hz >= fit.band_hz[0]) & (test.freq_hz <= fit.band_hz[1])
    sel &= test.freq_hz > 0
    return list(plot_fit(fit, test.frf[sel], out_dir))
