r"""Exponential fibre (Holzapfel-Gasser-Ogden) with dispersion and an optional recruitment stretch.

The family's structure tensor carries the dispersion of its directions (Gasser, Ogden & Holzapfel 2006, the paper's
reference [4]): :math:`H = \kappa I + (1 - 3\kappa) M`, :math:`M = v \otimes v`, :math:`\kappa \in [0, 1/3]`
(0: all fibres along :math:`v`; 1/3: isotropic), and its invariant :math:`I_4^* = H : C = 1 + 2\varepsilon` with the
fibre strain :math:`\varepsilon = H : E`. The fibres are straight beyond the recruitment stretch :math:`\lambda_r`
(:math:`\lambda_r = 1` unless ``recruitment = true``) and carry load only in tension:

.. math:: w = \frac{k_1}{2 k_2}\left(e^{k_2 E_f^2} - 1\right), \quad E_f = I_4^* - \lambda_r^2
          = 2(\varepsilon - \varepsilon_r),\ \varepsilon_r = \tfrac12(\lambda_r^2 - 1), \quad (E_f > 0;\ w = 0\
          \text{otherwise}),

.. math:: \sigma = \frac{dw}{d\varepsilon} = 4 k_1 (\varepsilon - \varepsilon_r) e^{k_2 E_f^2}, \qquad
          \frac{d\sigma}{d\varepsilon} = 4 k_1 e^{k_2 E_f^2}(1 + 2 k_2 E_f^2),

so :math:`S = \phi\,\sigma\, H`. Below the recruitment stretch the fibre is slack (a toe region: the stress rises
from zero with zero slope); the family's slack strain :math:`\varepsilon_0` of the tissue adds to
:math:`\varepsilon_r`.

References: Holzapfel, Gasser & Ogden (2000) J Elasticity 61:1, doi:10.1023/A:1010835316564; Gasser, Ogden &
Holzapfel (2006) J R Soc Interface 3:15, doi:10.1098/rsif.2005.0073.
"""

from __future__ import annotations

import math

import numpy as np

from bayestissue._validation import ValidationError
from bayestissue.mechanics._jit import kernel
from bayestissue.mechanics.laws.base import FibreLaw, LawParameter

__all__ = ["ExponentialFibre", "exponential_fibre_derivatives", "exponential_fibre_energy", "exponential_fibre_stress"]


@kernel
def _shift(p, off, recruit):
    """:math:`\\varepsilon_r = (\\lambda_r^2 - 1)/2` (0 without recruitment)."""
    if recruit:
        lr = p[off + 3]
        return 0.5 * (lr * lr - 1.0)
    return 0.0


@kernel
def exponential_fibre_stress(x, p, off, recruit):
    """:math:`(\\sigma, d\\sigma/d\\varepsilon)` at :math:`x = \\varepsilon - \\varepsilon_0`; parameters
    ``p[off:]`` = k1, k2, kappa (, lambda_r)."""
    y = x - _shift(p, off, recruit)
    if not (y > 0.0):
        return 0.0, 0.0
    k1 = p[off]
    k2 = p[off + 1]
    ef = 2.0 * y
    g = math.exp(k2 * ef * ef)
    return 4.0 * k1 * y * g, 4.0 * k1 * g * (1.0 + 2.0 * k2 * ef * ef)


@kernel
def exponential_fibre_energy(x, p, off, recruit):
    """:math:`w` at :math:`x = \\varepsilon - \\varepsilon_0` (module docstring)."""
    y = x - _shift(p, off, recruit)
    if not (y > 0.0):
        return 0.0
    ef = 2.0 * y
    return p[off] / (2.0 * p[off + 1]) * math.expm1(p[off + 1] * ef * ef)


@kernel
def exponential_fibre_derivatives(x, p, off, recruit, out):
    """``out[j]``: :math:`\\partial\\sigma/\\partial p_j` at fixed :math:`\\varepsilon` for k1, k2, kappa
    (0: kappa acts through the strain and the structure tensor) and lambda_r."""
    for j in range(4):
        out[j] = 0.0
    y = x - _shift(p, off, recruit)
    if not (y > 0.0):
        return
    k1 = p[off]
    k2 = p[off + 1]
    ef = 2.0 * y
    g = math.exp(k2 * ef * ef)
    sig = 4.0 * k1 * y * g
    out[0] = sig / k1
    out[1] = sig * ef * ef
    if recruit:
        dsig = 4.0 * k1 * g * (1.0 + 2.0 * k2 * ef * ef)
        out[3] = -dsig * p[off + 3]  # d eps_r / d lambda_r = lambda_r


class ExponentialFibre(FibreLaw):
    r"""The exponential (HGO) fibre with dispersion :math:`\kappa` and, with ``recruitment = true``, a recruitment
    stretch (module docstring)."""

    name = "hgo"
    code = 1
    title = "exponential (Holzapfel-Gasser-Ogden) with dispersion kappa (GOH 2006) and optional recruitment stretch"
    reference = "Holzapfel et al. 2000, doi:10.1023/A:1010835316564; Gasser et al. 2006, doi:10.1098/rsif.2005.0073"
    options = {"recruitment": False}

    def __init__(self, **options):
        super().__init__(**options)
        if not isinstance(self.settings["recruitment"], bool):
            raise ValidationError("tissue recruitment", self.settings["recruitment"], "true or false")

    def kernel_options(self) -> int:
        return int(self.settings["recruitment"])

    def parameters(self):
        out = [
            LawParameter("k1", "kPa", 0.001, 1e4, "log", "modulus", 10.0, "fibre stiffness"),
            LawParameter("k2", "1", 0.01, 1000.0, "log", "exponent", 1.0, "exponential stiffening"),
            LawParameter("disp", "1", 0.0, 1.0 / 3.0, "linear", "dispersion", 0.1,
                         "dispersion kappa of the directions (0 aligned, 1/3 isotropic)"),
        ]  # fmt: skip
        if self.settings["recruitment"]:
            out.append(LawParameter("lamr", "1", 1.0, 1.2, "linear", "recruitment_stretch", 1.02,
                                    "stretch at which the fibres become taut"))  # fmt: skip
        return tuple(out)

    def energy_reference(self, strain, params):
        k1, k2 = params[0], params[1]
        lr = params[3] if len(params) > 3 else 1.0
        ef = 2.0 * strain - (lr * lr - 1.0)
        return np.where(np.real(ef) > 0, k1 / (2.0 * k2) * (np.exp(k2 * ef * ef) - 1.0), 0.0)
