"""How the wood of one real bat differs from a uniform beam, along its length.

A ``WoodField`` gives factors on Young's modulus, on the shear modulus (by default the same
as Young's) and on density as functions of x from the knob end. The virtual rig multiplies
the truth model's section properties by them at every quadrature point
(``apply_wood_field``): EI by the modulus factor, kGA by the shear factor, rhoA and rhoI by
the density factor. Factors compose by multiplication (``WoodField.times``). Sizes
(docs/method.md, "Real bats"):

- moisture: one point of moisture content changes E by about -2 % and weight by about +1 %;
  end grain exchanges water many times faster than side grain, so within a few inches of
  each end the change is up to about twice the middle's (``moisture_field``);
- temperature: E and G fall by 0.1-0.3 % per degree C (``temperature_field``; G may be
  given its own rate);
- billet: E and density vary smoothly along the billet by a few percent, the same in every
  test of that bat (``billet_field``).

Wood's shear modulus is more sensitive to moisture and temperature than E; a field with its
own ``g_factor`` (``moisture_field``'s and ``temperature_field``'s ``g_per_*``) moves G by
another amount than E. Without one, G follows E exactly (every field before the option).

The factors act on the whole section, fill included; for a cored bat that misplaces the
fill's share of a 1-2 % moisture change (a few 0.01 % of the bat's mass), far below noise.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from updating.model.assembly import BatModel, parts_from_samples
from updating.model.sections import SectionProps
from updating.model.units import IN_TO_M

MOISTURE_E_PER_POINT = -0.02
"""Relative change of E per percentage point of moisture content."""
MOISTURE_MASS_PER_POINT = 0.01
"""Relative change of density per percentage point of moisture content."""


@dataclass(frozen=True)
class WoodField:
    """Modulus and density factors sampled along the bat (linear interpolation between).

    Attributes
    ----------
    x_m : np.ndarray
        (n,) ascending positions from the knob end, m.
    e_factor : np.ndarray
        (n,) factor on E there (and on G when ``g_factor`` is None).
    rho_factor : np.ndarray
        (n,) factor on density there.
    g_factor : np.ndarray or None
        (n,) factor on the shear modulus G there; None: G follows E (``e_factor``).
    """

    x_m: np.ndarray
    e_factor: np.ndarray
    rho_factor: np.ndarray
    g_factor: np.ndarray | None = None

    def at(self, x_m) -> tuple[np.ndarray, np.ndarray]:
        """(modulus factor, density factor) at positions ``x_m``."""
        x = np.asarray(x_m, dtype=float)
        return (np.interp(x, self.x_m, self.e_factor), np.interp(x, self.x_m, self.rho_factor))

    def shear_at(self, x_m) -> np.ndarray:
        """Return the shear modulus factor at positions ``x_m`` (E's when G follows E)."""
        g = self.e_factor if self.g_factor is None else self.g_factor
        return np.interp(np.asarray(x_m, dtype=float), self.x_m, g)

    def times(self, other: WoodField | None) -> WoodField:
        """Multiply two fields, on the union of their sample positions.

        The product has its own shear factor only when one of the two has.
        """
        if other is None:
            return self
        x = np.union1d(self.x_m, other.x_m)
        e1, r1 = self.at(x)
        e2, r2 = other.at(x)
        g = None
        if self.g_factor is not None or other.g_factor is not None:
            g = self.shear_at(x) * other.shear_at(x)
        return WoodField(x, e1 * e2, r1 * r2, g)


def grid_m(length_m: float, step_in: float = 0.25) -> np.ndarray:
    """Sample positions every ``step_in`` inches over the bat, both ends included."""
    n = max(2, int(np.ceil(length_m / (step_in * IN_TO_M))) + 1)
    return np.linspace(0.0, length_m, n)


def uniform_field(length_m: float, e_factor: float = 1.0, rho_factor: float = 1.0) -> WoodField:
    """Return a uniform field: factors ``e_factor`` and ``rho_factor`` along the whole bat."""
    x = np.array([0.0, length_m])
    return WoodField(x, np.full(2, e_factor), np.full(2, rho_factor))


def moisture_profile_pct(
    x_m: np.ndarray, length_m: float, middle_pct: float, knob_end_ratio: float = 1.0,
    barrel_end_ratio: float = 1.0, decay_in: float = 2.0,
) -> np.ndarray:
    """Moisture-content change along the bat, percentage points.

        dMC(x) = m [1 + (r_k - 1) exp(-x / l) + (r_b - 1) exp(-(L - x) / l)]

    with m the middle's change, r_k and r_b the end-to-middle ratios at the knob and barrel
    ends (about 2 for end grain), l the decay length.
    """
    x = np.asarray(x_m, dtype=float)
    lam = decay_in * IN_TO_M
    return middle_pct * (1 + (knob_end_ratio - 1) * np.exp(-x / lam)
                         + (barrel_end_ratio - 1) * np.exp(-(length_m - x) / lam))


def moisture_field(
    length_m: float, middle_pct: float, knob_end_ratio: float = 1.0,
    barrel_end_ratio: float = 1.0, decay_in: float = 2.0,
) -> WoodField:
    """Return the coupled E and density factors of a moisture change (``moisture_profile_pct``).

    E x (1 - 0.02 dMC), density x (1 + 0.01 dMC).
    """
    x = grid_m(length_m)
    d = moisture_profile_pct(x, length_m, middle_pct, knob_end_ratio, barrel_end_ratio,
                             decay_in)
    return moisture_factors(x, d)


def moisture_factors(
    x_m: np.ndarray, d_pct: np.ndarray, e_per_point: float = MOISTURE_E_PER_POINT,
    g_per_point: float | None = None,
) -> WoodField:
    """Return the field of a moisture change ``d_pct`` (points) sampled at ``x_m`` (m).

        E x (1 + e dMC),  G x (1 + g dMC),  density x (1 + 0.01 dMC)

    with e = ``e_per_point`` (default -0.02 per point) and g = ``g_per_point`` (None: G
    follows E, no shear factor of its own).
    """
    d = np.asarray(d_pct, dtype=float)
    g = None if g_per_point is None else 1 + g_per_point * d
    return WoodField(np.asarray(x_m, dtype=float), 1 + e_per_point * d,
                     1 + MOISTURE_MASS_PER_POINT * d, g)


def temperature_field(
    length_m: float, delta_c: float, per_c: float = 0.002, g_per_c: float | None = None,
) -> WoodField:
    """E x (1 - per_c dT) and G x (1 - g_per_c dT): a test ``delta_c`` degrees warmer.

    Relative to the reference state; ``g_per_c`` None: G follows E (no shear factor).
    """
    field = uniform_field(length_m, 1 - per_c * delta_c, 1.0)
    if g_per_c is None:
        return field
    return replace(field, g_factor=np.full(2, 1 - g_per_c * delta_c))


def billet_field(
    length_m: float, e_amplitude: float, rho_amplitude: float, phase: float,
) -> WoodField:
    """Return smooth billet gradients: E x (1 + a_E g(x)), density x (1 + a_rho g(x)).

    g(x) = cos(pi x / L + phase), a half-wave across the bat (one end stiffer and denser than
    the other when the amplitudes share a sign).
    """
    x = grid_m(length_m)
    g = np.cos(np.pi * x / length_m + phase)
    return WoodField(x, 1 + e_amplitude * g, 1 + rho_amplitude * g)


def apply_wood_field(model: BatModel, field: WoodField | None) -> BatModel:
    """Rebuild the model with its section properties multiplied by the field.

    At every quadrature sample: EI by the modulus factor, kGA by the shear factor (the
    modulus factor unless the field has its own), rhoA, rhoI by the density factor.
    """
    if field is None:
        return model
    s = model.samples
    e, r = field.at(s.x_m)
    g = field.shear_at(s.x_m)
    props = SectionProps(s.props.ei * e, s.props.kga * g, s.props.rhoa * r, s.props.rhoi * r)
    samples = replace(s, props=props)
    phi, parts = parts_from_samples(model.node_x_m, samples, model.beam, model.rotary_inertia)
    return replace(model, samples=samples, phi=phi, parts=parts)
