"""String options are ``Literal`` types checked once where they enter: a choice outside the
type is a ValueError naming the option and the choices (before any work), every choice the
type lists is accepted."""

from __future__ import annotations

from typing import get_args

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from updating.model.assembly import build_model
from updating.model.material import paper_material
from updating.model.profile import paper_profile
from updating.msso.factors import Mass, Stiffness, check_parameterisation, choose_groups
from updating.msso.iterate import check_prior_sigma
from updating.msso.regularisation import LambdaRule, check_regularisation
from updating.msso.update import update_elements
from updating.simulate.alterations import KINDS, AlterationKind
from updating.simulate.field_fleet import FieldKind, draw_case
from updating.simulate.integrity import INTEGRITY, Integrity
from updating.simulate.rulebook import RULEBOOK_KINDS

MODEL = build_model(paper_profile(), paper_material(), beam="timoshenko", n_elements=12)


def test_every_listed_choice_is_accepted():
    for s in (*get_args(Stiffness), None):
        for m in (*get_args(Mass), None):
            if s is None and m is None:
                continue
            check_parameterisation(s, m)
            assert choose_groups(MODEL, s, m)
    for rule in (*get_args(LambdaRule), None, 0.0, 1e-3):
        check_regularisation(rule)
    for prior in ("auto", None, 0.1):
        check_prior_sigma(prior)
    assert KINDS == get_args(AlterationKind) and INTEGRITY == get_args(Integrity)
    assert set(get_args(FieldKind)) == {"none", *KINDS}


@given(st.text(max_size=12))
def test_unknown_strings_are_refused_with_the_choices(word):
    if word not in get_args(Stiffness):
        with pytest.raises(ValueError, match=r"stiffness=.*one of element, separate, bend"):
            check_parameterisation(word, "element")
    if word not in get_args(Mass):
        with pytest.raises(ValueError, match=r"mass=.*one of element, separate, trans"):
            check_parameterisation("element", word)
    if word not in get_args(LambdaRule):
        with pytest.raises(ValueError, match="gcv, lcurve, a number >= 0 or None"):
            check_regularisation(word)
    if word != "auto":
        with pytest.raises(ValueError, match="auto, a number > 0 or None"):
            check_prior_sigma(word)
    if word not in (*KINDS, *RULEBOOK_KINDS, "none"):
        with pytest.raises(ValueError, match="unknown alteration kind.*cork"):
            draw_case(np.random.default_rng(0), word)


def test_bad_numbers_are_refused():
    for bad in (-1.0, float("nan")):
        with pytest.raises(ValueError):
            check_regularisation(bad)
        with pytest.raises(ValueError):
            check_prior_sigma(bad)
    with pytest.raises(ValueError):
        check_prior_sigma(0.0)


def test_update_elements_refuses_before_any_work(monkeypatch):
    import updating.msso.update as update

    def no_work(*a, **k):
        raise AssertionError("ran before the options were checked")

    monkeypatch.setattr(update, "_run", no_work)
    dofs = MODEL.translational_dofs[::4]
    shapes = np.ones((dofs.size, 3))
    for kw, word in (({"regularisation": "GCV"}, "regularisation"),
                     ({"prior_sigma": "Auto"}, "prior_sigma"),
                     ({"stiffness": "bending"}, "stiffness"),
                     ({"msso_parts": ("element", "rotary")}, "mass")):
        with pytest.raises(ValueError, match=word):
            update_elements(MODEL, [100.0, 200.0, 300.0], shapes, dofs, **kw)
    with pytest.raises(ValueError, match="unknown integrity case 'typo'"):
        draw_case(np.random.default_rng(0), "none", integrity="typo")
