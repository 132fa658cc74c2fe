"""Write the synthetic replicas of the paper's tests T1 and T2 to data/ (the measured curves are not public).

T1 (creep, 10.6 kPa for 1200 s) is simulated with the paper's final T1 parameters, T2 (1.6 kPa for 240 s, then
+3.24 kPa/min up to 852 s) with the final T2 parameters (docs/model.md Table 1), on the paper's simulation step (6 s),
sampled at the paper's data steps (3 s, 6 s), and given seeded Gaussian noise of sd 0.02 mm. Each data file records
in its header that it is synthetic, the generating parameters, the seed and the noise sd.

    python studies/make_replica_data.py [--seed 20120] [--noise-sd 0.02] [--out data]
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from bayestissue import __version__
from bayestissue.io.tables import write_table
from bayestissue.mechanics import CreepProtocol, Experiment, RampProtocol, param_names, simulate
from bayestissue.paper import PAPER_PARAMETERS

#: Specimens and protocols of paper Section 3.2 (docs/model.md): name -> (size mm, protocol, TOML protocol table,
#: duration s, data step s, simulation step s, generating parameter set).
REPLICAS = {
    "T1": (
        (5.33, 2.43, 3.9),
        CreepProtocol(stress_kpa=10.6),
        'kind = "creep"\nstress_kpa = 10.6',
        1200.0,
        3.0,
        6.0,
        "T1",
    ),
    "T2": (
        (4.97, 1.71, 3.61),
        RampProtocol(hold_stress_kpa=1.6, hold_s=240.0, rate_kpa_per_s=3.24 / 60.0),
        'kind = "ramp"\nhold_stress_kpa = 1.6\nhold_s = 240.0\nrate_kpa_per_s = 0.054  # 3.24 kPa/min = 20 mN/min',
        852.0,
        6.0,
        6.0,
        "T2",
    ),
}

TOML = """# Experiment description (format: bayestissue/mechanics/experiment.py)
name = "{name}"
description = "SYNTHETIC replica of the paper's test {name} (Section 3.2): simulated with the paper's Table 1 {key} \
parameters plus Gaussian noise; not measured data"
synthetic = true

[specimen]
length_x_mm = {lx}
length_y_mm = {ly}
length_z_mm = {lz}

[protocol]
{protocol}

[simulation]
dt_s = {dt}

[data]
file = "{name}.csv"
"""


def make_replica(name: str, *, seed: int, noise_sd: float, out: Path) -> Path:
    dims, protocol, protocol_toml, duration, data_step, dt, key = REPLICAS[name]
    time_s = np.arange(0.0, duration + 0.5 * data_step, data_step)
    exp = Experiment(name, dims, protocol, time_s, dt)
    params = PAPER_PARAMETERS[key]
    clean = simulate(exp, params)
    rng = np.random.default_rng([seed, list(REPLICAS).index(name)])
    noisy = clean + rng.normal(0.0, noise_sd, size=clean.shape)
    noisy[0] = 0.0  # the unloaded reference state is known exactly
    force = protocol.nominal_stress_kpa(time_s, exp.area_mm2) * exp.area_mm2
    meta = {
        "synthetic": "yes -- simulated replica of the paper's test, NOT measured data",
        "generator": f"studies/make_replica_data.py (bayestissue {__version__})",
        "generating_parameters": ", ".join(f"{n}={v:g}" for n, v in zip(param_names(3), params, strict=True)),
        "generating_set": f"paper Table 1, {key} final",
        "seed": f"{seed} (stream {list(REPLICAS).index(name)})",
        "noise_sd_mm": f"{noise_sd:g}",
        "units": "time_s [s], displacement_mm [mm], force_mN [mN]",
    }
    out.mkdir(parents=True, exist_ok=True)
    write_table(
        out / f"{name}.csv",
        {"time_s": time_s, "displacement_mm": noisy, "force_mN": force},
        meta=meta,
    )
    path = out / f"{name}.toml"
    path.write_text(TOML.format(name=name, key=key, lx=dims[0], ly=dims[1], lz=dims[2], protocol=protocol_toml, dt=dt))
    return path


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seed", type=int, default=20120)
    ap.add_argument("--noise-sd", type=float, default=0.02, help="noise sd, mm")
    ap.add_argument("--out", type=Path, default=Path(__file__).resolve().parents[1] / "data")
    args = ap.parse_args(argv)
    t0 = time.perf_counter()
    for name in REPLICAS:
        print("wrote", make_replica(name, seed=args.seed, noise_sd=args.noise_sd, out=args.out))
    print(f"make_replica_data: {time.perf_counter() - t0:.1f} s")


if __name__ == "__main__":
    main()
