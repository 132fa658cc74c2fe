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
from bayestissue.mechanics.tissue import PAPER_TISSUE, TissueConfig
from bayestissue.paper import KIND_BOUNDS

__all__ = ["TissuePreset", "PRESETS", "preset"]


@dataclass(frozen=True)
class TissuePreset:
    """A named composition and the box of each parameter kind (``mu``, ``kappa``, ``ginf``, ``gamma``, ``beta``;
    kPa, 1, 1/s)."""

    name: str
    tissue: TissueConfig
    boxes: dict
    description: str


_MATRIX_ONLY = {"directions": [], "phi_fibres": [], "phi_matrix": 1.0, "bulk_kpa": 2.0e6}

PRESETS = {
    p.name: p
    for p in (
        TissuePreset("slug", PAPER_TISSUE, KIND_BOUNDS, "the paper's slug-foot smooth muscle"),
        TissuePreset(
            "tendon",
            TissueConfig(directions=[[1.0, 0.0, 0.0]], phi_fibres=[0.7], phi_matrix=0.3, bulk_kpa=2.0e6),
            {"mu": (1e-2, 1e4), "kappa": (1e-2, 1e4), "ginf": (1e2, 1e7), "gamma": (0.1, 0.95), "beta": (1e-4, 10.0)},
            "tendon or ligament",
        ),
        TissuePreset(
            "brain",
            TissueConfig(**_MATRIX_ONLY),
            {"mu": (1e-4, 100.0), "kappa": (1e-4, 100.0)},
            "brain tissue",
        ),
        TissuePreset(
            "rubber",
            TissueConfig(**_MATRIX_ONLY),
            {"mu": (1.0, 1e5), "kappa": (1.0, 1e5)},
            "rubber and other isotropic elastomers",
        ),
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
        "| preset | composition | bulk modulus (kPa) | mu, kappa (kPa) | ginf (kPa) | gamma | beta (1/s) |",
        "|---|---|---|---|---|---|---|",
    ]
    for p in PRESETS.values():
        t, b = p.tissue, p.boxes

        def box(kind, b=b):
            return f"[{b[kind][0]:g}, {b[kind][1]:g}]" if kind in b else "-"

        pairs = zip(t.phi_fibres, t.directions, strict=True)
        fibres = ", ".join(f"{phi:g} along ({', '.join(f'{x:.3g}' for x in v)})" for phi, v in pairs)
        lines.append(
            f"| `{p.name}` | {p.description}: matrix {t.phi_matrix:g}"
            + (f"; fibres {fibres}" if fibres else "")
            + f" | {t.bulk_kpa:g} | {box('mu')}, {box('kappa')} | {box('ginf')} | {box('gamma')} | {box('beta')} |"
        )
    lines += ["", "Priors: log-uniform on the box for mu, kappa, ginf and beta, uniform for gamma (as for Table 1)."]
    return "\n".join(lines) + "\n"
