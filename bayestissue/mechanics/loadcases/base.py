r"""What a load case is: which strain components its protocol prescribes, which stay stress-free, and what is
observed.

A load case turns the protocol's driving history :math:`d(t_n)` (a nominal stress under force control, a stretch
under stretch control, an amount of shear under shear control; :mod:`~bayestissue.mechanics.protocols`) into the
solver's per-component conditions (:mod:`~bayestissue.mechanics.solver`: ``kinds`` 0 stress-free, 1 dead load, 2
prescribed stretch, 3 prescribed strain; ``values`` per step) and lists its observed channels, each a solver output
(displacement, nominal stress or simple-shear stress of a face) with the data column it is compared with and the
factor from kPa to the data's unit (a face's reference area for a force). A load case is one small class registered
in :mod:`bayestissue.mechanics.loadcases`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from bayestissue._validation import ValidationError

__all__ = ["FREE", "LOAD", "STRAIN", "STRETCH", "Channel", "LoadCase"]

#: The solver's component conditions.
FREE, LOAD, STRETCH, STRAIN = 0, 1, 2, 3


@dataclass(frozen=True)
class Channel:
    """One observed quantity: the solver output (``kind`` 0 displacement of face ``axis``, 1 nominal stress on it, 2
    the simple-shear stress), its name, unit and data column, and the factor from the solver's unit (mm or kPa)."""

    kind: int
    axis: int
    quantity: str
    unit: str
    column: str
    scale: float = 1.0

    @property
    def label(self) -> str:
        """``"force on face 2 (mN)"``-like text for tables and axes."""
        return f"{self.quantity} ({self.unit})"


class LoadCase:
    """A homogeneous load case (subclasses fill the class attributes and :meth:`prescribe`, :meth:`channels`)."""

    #: name in experiment files (``[protocol] mode = "..."``)
    name: ClassVar[str] = ""
    #: the protocol controls it accepts
    controls: ClassVar[tuple[str, ...]] = ()
    #: one line for the docs
    title: ClassVar[str] = ""
    #: options the experiment file may give, with their defaults
    options: ClassVar[dict] = {}

    def __init__(self, **options):
        unknown = sorted(set(options) - set(self.options))
        if unknown:
            raise ValidationError(f"protocol mode {self.name} option", unknown[0], f"one of {sorted(self.options)}")
        self.settings = {**self.options, **options}

    def check_controls(self, controls: str) -> None:
        if controls not in self.controls:
            raise ValidationError(f"protocol mode {self.name!r}", f"a {controls}-controlled protocol",
                                  f"a protocol controlling {' or '.join(self.controls)}")  # fmt: skip

    def check_second_history(self) -> None:
        """Refuse a second face's own history (a ``stretch_2`` or ``force_2_mN`` column): only the general biaxial case
        takes one."""
        raise ValidationError(f"protocol mode {self.name!r}",
                              "a second load history (a stretch_2 or force_2_mN column)",
                              "mode = 'biaxial' without a ratio for two independent loads")  # fmt: skip

    def prescribe(self, history: np.ndarray, controls: str) -> tuple[np.ndarray, np.ndarray]:
        """``(kinds (6,), values (n_steps + 1, 6))`` from the driving history (step 0: the unloaded state)."""
        raise NotImplementedError

    def channels(self, controls: str, columns, specimen_mm) -> tuple[Channel, ...]:
        """The observed channels given the data ``columns`` available (none: what a simulation reports)."""
        raise NotImplementedError

    def __repr__(self) -> str:
        return f"{type(self).__name__}({', '.join(f'{k}={v!r}' for k, v in self.settings.items())})"


def stress_or_force(axis: int, suffix: str, columns, area: float) -> Channel:
    """The channel of a stretch-controlled face: its force (mN) if the data give it, else its nominal stress (kPa)
    if they give that, else (a simulation) the force."""
    force, stress = f"force{suffix}_mN", f"nominal_stress{suffix}_kpa"
    face = f" on face {axis + 1}" if suffix else ""
    if stress in columns and force not in columns:
        return Channel(1, axis, f"nominal stress{face}", "kPa", stress)
    return Channel(1, axis, f"force{face}", "mN", force, area)
