r"""Tissue presets: a composition (fibre families, volume fractions, bulk modulus) with the parameter boxes that suit
the material's scale.

``[tissue] preset = "tendon"`` in an experiment file starts from the preset; any other ``[tissue]`` key overrides
its value; the calibration then takes the preset's boxes as the parameters' default bounds (``[parameters] bounds``
still override them). Every modulus is in kPa whatever the material (a tendon's fibres in the 1e5-1e7 kPa range,
brain tissue's matrix below 1 kPa); only the boxes move. Boxes are two to three decades either side of the
material's reported scale, log-uniform for moduli and rates.

Scales the boxes are centred on: the paper's Table 1 for the slug tissue; for tendon a Young's modulus of about
1.2 GPa along the fibres in vivo (Maganaris & Paul 1999, J Physiol 521:307-313) and relaxation over seconds to
minutes; for brain tissue shear moduli of 0.4-1.4 kPa in uniaxial tension (Budday et al. 2017, Acta Biomater
48:319-340); for rubber Mooney-Rivlin constants C10 ~ 0.1-0.2 MPa (Treloar 1944). Bulk moduli: the paper's 1000 kPa
for the slug tissue; 2 GPa (the order of water's) for the nearly incompressible others.
"""

from __future__ import annotations

from dataclasses import dataclass

from bayestissue._validation import ValidationError
from bayestissue.mechanics.laws import LawParameter
from bayestissue.mechanics.tissue import PAPER_TISSUE, TissueConfig

__all__ = ["BOX_KEYS", "TissuePreset", "PRESETS", "preset"]

#: What a preset's boxes are keyed by: the component and the parameter's role (from its specification, never its
#: name); a role not given keeps the law's default box.
BOX_KEYS = ("matrix modulus", "fibre modulus", "viscous_fraction", "relaxation_rate")


@dataclass(frozen=True)
class TissuePreset:
    """A named composition and the boxes of its parameters by :data:`BOX_KEYS` (kPa, 1, 1/s)."""

    name: str
    tissue: TissueConfig
    boxes: dict
    description: str

    def box(self, component: str, spec: LawParameter) -> tuple[float, float, float]:
        """``(lower, upper, initial)`` of a parameter of the ``"matrix"`` or ``"fibre"`` with specification ``spec``:
        the preset's box for its component and role (a linear-scale modulus, which may be negative, takes
        ``(-upper, upper)``), the initial value the box's midpoint (geometric on a log scale) where the box moved;
        the law's default otherwise."""
        key = f"{component} {spec.role}" if spec.role == "modulus" else spec.role
        if key not in self.boxes:
            return spec.lower, spec.upper, spec.initial
        lo, hi = (float(x) for x in self.boxes[key])
        if spec.scale == "linear" and spec.role == "modulus":
            lo = -hi
        if (lo, hi) == (spec.lower, spec.upper):
            return lo, hi, spec.initial
        return lo, hi, (lo * hi) ** 0.5 if spec.scale == "log" else 0.5 * (lo + hi)


_MATRIX_ONLY = {"directions": [], "phi_fibres": [], "phi_matrix": 1.0, "bulk_kpa": 2.0e6}

PRESETS = {
    p.name: p
    for p in (
        TissuePreset("slug", PAPER_TISSUE, {}, "the paper's slug-foot smooth muscle"),
        TissuePreset(
            "tendon",
            TissueConfig(directions=[[1.0, 0.0, 0.0]], phi_fibres=[0.7], phi_matrix=0.3, bulk_kpa=2.0e6),
            {
                "matrix modulus": (1e-2, 1e4),
                "fibre modulus": (1e2, 1e7),
                "viscous_fraction": (0.1, 0.95),
                "relaxation_rate": (1e-4, 10.0),
            },
            "tendon or ligament",
        ),  # fmt: skip
        TissuePreset("brain", TissueConfig(**_MATRIX_ONLY), {"matrix modulus": (1e-4, 100.0)}, "brain tissue"),
        TissuePreset(
            "rubber",
            TissueConfig(**_MATRIX_ONLY),
            {"matrix modulus": (1.0, 1e5)},
            "rubber and other isotropic elastomers",
        ),  # fmt: skip
    )
}


def preset(name: str) -> TissuePreset:
    """The preset ``name``; a ValidationError lists the known ones."""
    if name not in PRESETS:
        raise ValidationError("tissue.preset", name, f"one of {sorted(PRESETS)}")
    return PRESETS[name]


def presets_markdown() -> str:
    """``docs/presets.md``: every preset's composition and boxes."""
    lines = [
        "# Tissue presets",
        "",
        "<!-- Generated from bayestissue/mechanics/presets.py (presets_markdown); "
        "tests/mechanics/test_presets.py keeps it equal. -->",
        "",
        __doc__.strip().split("\n\n", 1)[1].replace("\n", " ").replace("``", "`"),
        "",
        "| preset | composition | bulk modulus (kPa) | " + " | ".join(BOX_KEYS) + " |",
        "|---|---|---|" + "---|" * len(BOX_KEYS),
    ]
    for p in PRESETS.values():
        t = p.tissue
        pairs = zip(t.phi_fibres, t.directions, strict=True)
        fibres = ", ".join(f"{phi:g} along ({', '.join(f'{x:.3g}' for x in v)})" for phi, v in pairs)
        boxes = " | ".join(f"[{p.boxes[k][0]:g}, {p.boxes[k][1]:g}]" if k in p.boxes else "law default"
                           for k in BOX_KEYS)  # fmt: skip
        lines.append(
            f"| `{p.name}` | {p.description}: matrix {t.phi_matrix:g}"
            + (f"; fibres {fibres}" if fibres else "")
            + f" | {t.bulk_kpa:g} | {boxes} |"
        )
    lines += [
        "",
        "A preset's box applies to every parameter of that component and role (docs/laws.md: the law defaults are "
        "the paper's Table 1 boxes for its laws); a modulus on a linear scale (one that may be negative, e.g. Yeoh's "
        "c2) takes [-upper, upper]. Priors: log-uniform on a log-scale box, uniform on a linear one.",
    ]
    return "\n".join(lines) + "\n"
