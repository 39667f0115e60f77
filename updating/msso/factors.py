"""Element change factors and the parameter groups that carry them.

Per element i: K_I = sum (1 + beta_bend_i) k_bend_i + (1 + beta_shear_i) k_shear_i and
M_I = sum (1 + alpha_trans_i) m_trans_i + (1 + alpha_rot_i) m_rot_i. A parameter *group* is
one unknown per element acting on one or more of these parts:

    "k"     -> bend and shear together (the paper's beta: a factor on the whole k_i)
    "m"     -> trans and rot together  (the paper's alpha)
    "bend", "shear", "trans", "rot" -> one part each (separable updating).

In the exact (section-rebuilding) model, "bend" scales EI, "shear" kGA, "trans" rhoA and
"rot" rhoI of the element.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal, get_args

import numpy as np

from updating.model.assembly import BatModel, scale_sections

Stiffness = Literal["element", "separate", "bend"]
"""Stiffness parameterisation: the paper's one beta per element (k_i), bending and shear
separately, or bending only; None: stiffness not updated."""
Mass = Literal["element", "separate", "trans"]
"""Mass parameterisation: the paper's one alpha per element (m_i), translational and rotary
separately, or translational only; None: mass not updated."""

GROUP_PARTS = {"k": ("bend", "shear"), "m": ("trans", "rot"), "bend": ("bend",),
               "shear": ("shear",), "trans": ("trans",), "rot": ("rot",)}
STIFFNESS: dict[Stiffness | None, tuple[str, ...]] = {
    "element": ("k",), "separate": ("bend", "shear"), "bend": ("bend",), None: ()}
MASS: dict[Mass | None, tuple[str, ...]] = {
    "element": ("m",), "separate": ("trans", "rot"), "trans": ("trans",), None: ()}
assert set(STIFFNESS) == {*get_args(Stiffness), None} and set(MASS) == {*get_args(Mass), None}
PART_ATTR = {"bend": "k_bend", "shear": "k_shear", "trans": "m_trans", "rot": "m_rot"}
SECTION_OF = {"bend": "ei", "shear": "kga", "trans": "rhoa", "rot": "rhoi"}


def is_stiffness(group: str) -> bool:
    """Return whether ``group`` is a stiffness group ("k", "bend" or "shear")."""
    return group in ("k", "bend", "shear")


def check_parameterisation(stiffness: Stiffness | None, mass: Mass | None) -> None:
    """ValueError naming the option and its choices unless both are known."""
    for name, value, choices in (("stiffness", stiffness, Stiffness), ("mass", mass, Mass)):
        if value is not None and value not in get_args(choices):
            raise ValueError(f"unknown parameterisation {name}={value!r} (one of "
                             f"{', '.join(get_args(choices))} or None)")


def choose_groups(model: BatModel, stiffness: Stiffness | None = "element",
                  mass: Mass | None = "element") -> tuple[str, ...]:
    """Choose the factor groups of a stiffness and a mass option.

    Stiffness: "element", "separate", "bend" or None; mass: "element", "separate", "trans"
    or None. Parts that are zero in the model (shear of an Euler-Bernoulli beam, rotary
    inertia when off) are dropped.

    Returns
    -------
    tuple of str
        The groups, stiffness first.
    """
    check_parameterisation(stiffness, mass)
    out = []
    for g in STIFFNESS[stiffness] + MASS[mass]:
        parts = [p for p in GROUP_PARTS[g] if np.any(getattr(model.parts, PART_ATTR[p]))]
        if parts:
            out.append(g)
    if not out:
        raise ValueError("no parameters to update")
    return tuple(out)


def group_matrices(model: BatModel, group: str) -> np.ndarray:
    """(e, 4, 4) element matrices multiplied by the group's factor."""
    return sum(getattr(model.parts, PART_ATTR[p]) for p in GROUP_PARTS[group])


@dataclass(frozen=True)
class ElementFactors:
    """Per-element relative changes (e,) of the four parts (0 = unchanged)."""

    beta_bend: np.ndarray
    beta_shear: np.ndarray
    alpha_trans: np.ndarray
    alpha_rot: np.ndarray

    def part(self, name: str) -> np.ndarray:
        """Return one part's factors: "bend", "shear", "trans" or "rot"."""
        return {"bend": self.beta_bend, "shear": self.beta_shear, "trans": self.alpha_trans,
                "rot": self.alpha_rot}[name]

    def vector(self, groups: tuple[str, ...]) -> np.ndarray:
        """Stacked parameters of the groups (first part of each group)."""
        return np.concatenate([self.part(GROUP_PARTS[g][0]) for g in groups])

    def compose(self, other: ElementFactors) -> ElementFactors:
        """(1 + a)(1 + b) - 1 part by part: ``other`` applied on top of ``self``."""
        return ElementFactors(*[(1 + a) * (1 + b) - 1 for a, b in
                                zip(self.as_tuple(), other.as_tuple(), strict=True)])

    def as_tuple(self) -> tuple[np.ndarray, ...]:
        """Return the four parts in the order bend, shear, trans, rot."""
        return self.beta_bend, self.beta_shear, self.alpha_trans, self.alpha_rot


def zero_factors(n_elements: int) -> ElementFactors:
    """Return all-zero factors (the unchanged reference) for ``n_elements`` elements."""
    z = np.zeros(n_elements)
    return ElementFactors(z, z.copy(), z.copy(), z.copy())


def factors_from_vector(y: np.ndarray, groups: tuple[str, ...], n_elements: int
                        ) -> ElementFactors:
    """Spread a stacked parameter vector onto the parts (unused parts stay 0).

    Parameters
    ----------
    y : (len(groups) * n_elements,) array
        One block of ``n_elements`` factors per group, in the order of ``groups``.
    groups : tuple of str
        Parameter groups (``GROUP_PARTS`` keys); a group's block goes to each of its parts.
    n_elements : int
        Number of elements e.

    Returns
    -------
    ElementFactors
    """
    parts = {p: np.zeros(n_elements) for p in PART_ATTR}
    for k, g in enumerate(groups):
        for p in GROUP_PARTS[g]:
            parts[p] = np.array(y[k * n_elements:(k + 1) * n_elements], dtype=float)
    return ElementFactors(parts["bend"], parts["shear"], parts["trans"], parts["rot"])


def apply_factors(model: BatModel, factors: ElementFactors) -> BatModel:
    """Scale the exact model's sections: EI (1+beta_bend), kGA (1+beta_shear), ..."""
    return scale_sections(model, ei=1 + factors.beta_bend, kga=1 + factors.beta_shear,
                          rhoa=1 + factors.alpha_trans, rhoi=1 + factors.alpha_rot)
