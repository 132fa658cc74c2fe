"""Load cases as plug-ins: one module per homogeneous test, registered here by the name experiment files use
(``[protocol] mode = "..."``, default ``"uniaxial"``).

:class:`Uniaxial` (tension or compression, force or stretch control: the paper's tests), :class:`Equibiaxial`,
:class:`Biaxial` (a ratio between the two in-plane stretches or loads), :class:`PureShear` (planar tension),
:class:`SimpleShear`. A new load case is one module (a :class:`~bayestissue.mechanics.loadcases.base.LoadCase` that
says which components its protocol prescribes and what it observes) plus its entry here: the time loop
(:mod:`bayestissue.mechanics.solver`) is the same for all.
"""

from __future__ import annotations

from bayestissue._validation import ValidationError, check_known_keys
from bayestissue.mechanics.loadcases.base import Channel, LoadCase
from bayestissue.mechanics.loadcases.biaxial import Biaxial, Equibiaxial, PureShear
from bayestissue.mechanics.loadcases.simple_shear import SimpleShear
from bayestissue.mechanics.loadcases.uniaxial import Uniaxial

__all__ = [
    "LOAD_CASES",
    "Biaxial",
    "Channel",
    "Equibiaxial",
    "LoadCase",
    "PureShear",
    "SimpleShear",
    "Uniaxial",
    "load_case",
]

#: Load cases by name.
LOAD_CASES: dict[str, type[LoadCase]] = {
    cls.name: cls for cls in (Uniaxial, Equibiaxial, Biaxial, PureShear, SimpleShear)
}


def load_case(name: str, **options) -> LoadCase:
    """The load case ``name`` with its options; an unknown name gets the nearest valid one."""
    if not isinstance(name, str):
        raise ValidationError("protocol mode", name, f"one of {sorted(LOAD_CASES)}")
    check_known_keys("protocol mode", {name: None}, LOAD_CASES)
    return LOAD_CASES[name](**options)
