"""Every remaining input check of the stereology library raises a ValidationError that names the problem."""

import numpy as np
import pytest

from bayestissue._validation import ValidationError
from bayestissue.io.stereology_files import read_line_system, read_point_counts, read_replicates
from bayestissue.paper import PAPER_DIRECTIONS
from bayestissue.stereology.axial import fit_watson_mixture
from bayestissue.stereology.known_object import TwoBallPhantom, simulate_surs_counts
from bayestissue.stereology.lines import (
    LineSystem,
    segments_from_polylines,
    stack_volume,
    to_upper_hemisphere,
)
from bayestissue.stereology.point_counts import PointCounts
from bayestissue.stereology.replicates import (
    fibre_fraction_split,
    fit_fibre_directions,
    replicate_table,
)
from bayestissue.stereology.rose import preferential_directions, rose_of_directions
from bayestissue.stereology.sections import nugget_variance, surs_sum_variance
from bayestissue.stereology.uncertainty import (
    cluster_fraction_bootstrap,
    confidence_cones,
    logistic_normal_draws,
    naive_section_bootstrap,
)

C3 = np.array([[10, 5], [12, 6], [11, 7]])
S = np.zeros((2, 3))
E = np.array([[1.0, 0, 0], [0, 2.0, 0]])
ROSE = rose_of_directions(np.eye(3), n=4)
D3 = np.broadcast_to(PAPER_DIRECTIONS, (2, 3, 3))
FR = {"smc": np.full(2, 0.6), "ecm": np.full(2, 0.4)}


def _pc(**kw):
    args = dict(section=[0, 6, 12], counts=C3, components=("smc", "ecm"))
    args.update(kw)
    return PointCounts(**args)


CASES = [
    (lambda: nugget_variance([1.0, 2.0], shape_factor=0), "shape_factor"),
    (lambda: surs_sum_variance([]), "non-empty array"),
    (lambda: _pc(section=[0, 6]), "section: expected \\(3,\\)"),
    (lambda: _pc(grid_spacing_um=-1), "grid_spacing_um"),
    (lambda: _pc(profiles_per_section=0), "profiles_per_section"),
    (lambda: _pc(block=[1, 2]), "block"),
    (lambda: _pc(counts=np.zeros((3, 2))).volume_fractions(), "positive reference count"),
    (lambda: to_upper_hemisphere([[0, 0, 0]]), "non-zero finite directions"),
    (lambda: stack_volume(1.0, -2.0, 3, 5.0), "extent_y_um"),
    (lambda: segments_from_polylines([np.zeros((2, 3))], [1, 2]), "one per polyline"),
    (lambda: LineSystem(S, E[:1], [1, 2]), "equal \\(n >= 1, 3\\) arrays"),
    (lambda: LineSystem(S, E * np.nan, [1, 2]), "finite coordinates"),
    (lambda: LineSystem(S, E, [1, 2], volume_um3=-5.0), "volume_um3"),
    (lambda: rose_of_directions(np.eye(3), [1.0, -1.0, 1.0], n=4), "finite lengths >= 0"),
    (lambda: preferential_directions(ROSE, merge_deg=120), "merge_deg"),
    (lambda: fit_watson_mixture(np.eye(3), 2, init_axes=np.eye(3)), "init_axes"),
    (lambda: logistic_normal_draws([0.6, 0.4], np.eye(3), 5), "cov"),
    (lambda: cluster_fraction_bootstrap(C3, [1, 2], n_boot=5), "one label per section"),
    (lambda: naive_section_bootstrap(np.ones((1, 2)), n_boot=5), "n_sections >= 2"),
    (lambda: confidence_cones(D3, PAPER_DIRECTIONS, level=1.0), "level"),
    (lambda: fibre_fraction_split([0.6], method="length", shares=[1, -1, 0.5]), "length shares >= 0"),
    (lambda: replicate_table(FR, D3, split="volume"), "'paper' or 'length'"),
    (lambda: replicate_table(FR, D3, split="length"), "length shares for split='length'"),
    (
        lambda: fit_fibre_directions(
            LineSystem(np.zeros((3, 3)), np.tile([0, 0, 1.0], (3, 1)), [1, 2, 3]), method="rose"
        ),
        ">= 3 distinct directions",
    ),
    (lambda: TwoBallPhantom(radius_ref=0), "radius_ref"),
    (lambda: TwoBallPhantom(1.0, 0.8, 0.3), "the phase must fit"),
    (lambda: simulate_surs_counts(TwoBallPhantom(), 0.0, 10), "spacing"),
    (lambda: simulate_surs_counts(TwoBallPhantom(), 0.1, 10, size_jitter=-1), "size_jitter"),
    (lambda: simulate_surs_counts(TwoBallPhantom(), 0.1, 10, grid_spacing=0), "grid_spacing"),
]


@pytest.mark.parametrize(("call", "match"), CASES)
def test_library_errors(call, match):
    with pytest.raises(ValidationError, match=match):
        call()


def test_file_errors(tmp_path):
    p = tmp_path / "c.csv"
    p.write_text("section,smc_points,ecm_points\n0,a,2\n6,b,4\n")
    with pytest.raises(
        ValidationError, match=r"c.csv line 2 column smc_points: expected a finite number \(decimal point\), got 'a'"
    ):
        read_point_counts(p)
    q = tmp_path / "l.csv"
    q.write_text("cell,x0_um,y0_um,z0_um,x1_um,y1_um,z1_um\n1,a,0,0,1,1,1\n")
    with pytest.raises(
        ValidationError, match=r"l.csv line 2 column x0_um: expected a finite number \(decimal point\), got 'a'"
    ):
        read_line_system(q)
    cols = ["replicate", "phi_smc", "phi_ecm", "phi_matrix", "phi_fibre1", "phi_fibre2", "phi_fibre3"]
    cols += [f"v{k}_{c}" for k in (1, 2, 3) for c in "xyz"]
    row = [1, 0.6, 0.4, 1.4, 0.2, 0.2, 0.2, *PAPER_DIRECTIONS.ravel()]
    r = tmp_path / "r.csv"
    r.write_text(",".join(cols) + "\n" + ",".join(str(x) for x in row) + "\n")
    with pytest.raises(ValidationError, match="volume fractions in \\[0, 1\\]"):
        read_replicates(r)
