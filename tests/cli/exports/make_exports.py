"""Writes the machine-export fixtures of this folder: SYNTHETIC tendon tests in the layouts three testing machines'
software documents for its raw-data export (module docstring of bayestissue/io/machine_export.py). No measured data:
every value comes from the formulas below, and every file says so in a metadata line.

The curve: a ramp to 5 % strain at 5 mm/min over a 14.33 mm gauge length (diameter 0.376 mm), then a hold, sampled at
10 Hz. Nominal stress during the ramp sigma = E (eps + eps^2 / eps_t) (E = 150 MPa, eps_t = 0.04: a stiffening toe);
during the hold it relaxes as sigma_peak (0.49 + 0.30 exp(-t/2 s) + 0.21 exp(-t/30 s)), to 0.513 of the peak after
60 s. A preload of 9.8 mN at zero extension. Deterministic noise: 0.5 mN x sin(7.3 i). Three files:

* ``instron_bluehill_relaxation.csv``: Instron Bluehill ``Specimen_RawData`` style (quoted cells, "Specimen
  properties : ..." and "Test : ..." lines, a blank line, names and units rows), a 60 s hold;
* ``mts_testsuite_slip.txt``: MTS TestSuite style (tab separated, "Key:" lines, bare units), a grip slip during the
  ramp (at 4 s the load drops by 20 % and climbs back over 1.5 s), a 30 s hold;
* ``zwick_testxpert_failure.csv``: Zwick testXpert style (semicolons, decimal commas, ISO 6892 symbols d0 and L0,
  kN), the specimen fails 2 s into the hold (the load falls to 2 % within 0.2 s).

    python tests/cli/exports/make_exports.py      # rewrites the three files
"""

from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
GAUGE, DIAMETER, RATE = 14.33, 0.376, 5.0 / 60.0  # mm, mm, mm/s
E_MPA, EPS_T, PRELOAD = 150.0, 0.04, 9.8  # MPa, -, mN
AREA = np.pi * DIAMETER**2 / 4.0
NOTE = "SYNTHETIC fixture written by tests/cli/exports/make_exports.py (no measured data)"


def curve(hold_s, slip=False, fail_at=None):
    t_ramp = 0.05 * GAUGE / RATE
    t = np.round(np.arange(0.0, t_ramp + hold_s + 1e-9, 0.1), 6)
    u = np.minimum(t, t_ramp) * RATE
    eps = u / GAUGE
    sigma = E_MPA * (eps + eps**2 / EPS_T)
    peak = sigma.max()
    hold = t > t_ramp
    th = t[hold] - t_ramp
    sigma[hold] = peak * (0.49 + 0.30 * np.exp(-th / 2.0) + 0.21 * np.exp(-th / 30.0))
    f = sigma * AREA * 1e3 + PRELOAD + 0.5 * np.sin(7.3 * np.arange(t.size))  # mN
    if slip:
        s = (t >= 4.0) & (t < 5.5)
        f[s] -= (f[s][0] - 0.8 * f[t < 4.0][-1]) * (1.0 - (t[s] - 4.0) / 1.5)
    if fail_at is not None:
        k = t >= t_ramp + fail_at
        f[k] = 0.02 * f[k]
    return t, u, f


def bluehill():
    t, u, f = curve(60.0)
    rows = ['Specimen properties : Specimen label,"rat_tail_A"', f'Specimen properties : Comment,"{NOTE}"',
            f'Specimen properties : Diameter,"{DIAMETER:.5f}",mm', f'Specimen properties : Length,"{GAUGE:.5f}",mm',
            'Test : Rate 1,"5.00000",mm/min', 'Test : Hold time,"60.00000",s', "",
            "Extension,Load,Tensile stress,Time", "(mm),(N),(MPa),(s)"]  # fmt: skip
    rows += [f'"{a:.5f}","{b / 1e3:.5f}","{b / 1e3 / AREA:.5f}","{c:.5f}"' for a, b, c in zip(u, f, t, strict=True)]
    (HERE / "instron_bluehill_relaxation.csv").write_text("\r\n".join(rows) + "\r\n")


def testsuite():
    t, u, f = curve(30.0, slip=True)
    rows = ["Test Run Name:\tRun 3", "Specimen Name:\trat_tail_B", f"Note:\t{NOTE}", f"Diameter:\t{DIAMETER}\tmm",
            f"Gauge Length:\t{GAUGE}\tmm", "", "Time\tAxial Displacement\tAxial Force", "sec\tmm\tN"]  # fmt: skip
    rows += [f"{c:.3f}\t{a:.5f}\t{b / 1e3:.6f}" for a, b, c in zip(u, f, t, strict=True)]
    (HERE / "mts_testsuite_slip.txt").write_text("\n".join(rows) + "\n")


def testxpert():
    t, u, f = curve(10.0, fail_at=2.0)

    def de(x, fmt):
        return format(x, fmt).replace(".", ",")

    rows = ["Prüfprotokoll;rat_tail_C", f"Bemerkung;{NOTE}", f"d0;{de(DIAMETER, '.3f')};mm",
            f"L0;{de(GAUGE, '.2f')};mm", "Prüfgeschwindigkeit;5;mm/min", "", "Test time;Standard travel;Standard force",
            "s;mm;kN"]  # fmt: skip
    rows += [f"{de(c, '.2f')};{de(a, '.5f')};{de(b / 1e6, '.8f')}" for a, b, c in zip(u, f, t, strict=True)]
    (HERE / "zwick_testxpert_failure.csv").write_text("\r\n".join(rows) + "\r\n", encoding="utf-8")


if __name__ == "__main__":
    bluehill()
    testsuite()
    testxpert()
