"""Trichrome rendering: determinism, colours, misregistration bookkeeping, bad input."""

import numpy as np
import pytest

from bayestissue._validation import ValidationError
from bayestissue.stereology.micrographs.phantom import CAVITY, ECM, SMC, PhantomOptions, make_phantom
from bayestissue.stereology.micrographs.render import (
    StainOptions,
    render_sections,
    rigid_matrix,
    section_phantom,
    stack_frame,
)


@pytest.fixture(scope="module")
def phantom():
    return make_phantom(PhantomOptions(extent_um=(30.0, 60.0, 60.0)), rng=5)


def test_same_seed_same_images(phantom):
    a = render_sections(phantom, rng=1)
    b = render_sections(phantom, rng=1)
    c = render_sections(phantom, rng=2)
    assert np.array_equal(a.images, b.images) and np.array_equal(a.transforms, b.transforms)
    assert not np.array_equal(a.images, c.images)


def test_sections_and_reference_frame(phantom):
    s = render_sections(phantom, thickness_um=5.0, rng=0)
    assert s.images.shape[0] == 6 and s.images.dtype == np.uint8
    assert np.array_equal(s.plane_index, [2, 7, 12, 17, 22, 27])  # slab mid-planes
    assert np.all(s.transforms[0] == 0)  # section 0 is the reference
    planes, _ = section_phantom(phantom, thickness_um=5.0)
    m = s.margin_px
    assert np.array_equal(s.labels[0], planes[0, m:-m, m:-m])
    assert not np.array_equal(s.labels[1], planes[1, m:-m, m:-m])  # moved
    t = s.truth()
    assert len(t["consecutive_misregistration"]) == 5


def test_stain_colours_without_noise(phantom):
    st = StainOptions(stain_cv=0, texture_sd=0, blur_px=0, noise_sd=0, shift_sd_px=0,
                      rotation_sd_deg=0)  # fmt: skip
    s = render_sections(phantom, stain=st, margin_px=0, rng=0)
    for code, rgb in ((SMC, st.smc_rgb), (ECM, st.ecm_rgb), (CAVITY, st.background_rgb)):
        px = s.images[s.labels == code].astype(float) / 255
        expect = np.array(rgb) * (np.array(st.background_rgb) if code != CAVITY else 1)
        assert np.allclose(px.mean(axis=0), expect, atol=1 / 255)


def test_rigid_matrix_rotates_about_the_centre():
    M = rigid_matrix(90.0, 1.0, 2.0, (10.0, 10.0))
    assert np.allclose(M @ [10, 10, 1], [11, 12, 1])
    assert np.allclose(M @ [11, 10, 1], [11, 13, 1])  # +x turns to +y


def test_stack_frame_permutes_axes():
    v = np.array([0.1, 0.2, 0.3])
    assert np.allclose(stack_frame("z") @ v, v)
    assert np.allclose(stack_frame("x") @ v, [0.2, 0.3, 0.1])
    assert np.allclose(stack_frame("y") @ v, [0.1, 0.3, 0.2])


def test_bad_render_input(phantom):
    with pytest.raises(ValidationError, match="section_axis: expected one of"):
        render_sections(phantom, axis="w")
    with pytest.raises(ValidationError, match="thickness_um: expected between the voxel size"):
        render_sections(phantom, thickness_um=100.0)
    with pytest.raises(ValidationError, match="margin_px"):
        render_sections(phantom, margin_px=40)
    with pytest.raises(ValidationError, match="smc_rgb: expected three intensities"):
        StainOptions(smc_rgb=(1.2, 0.2, 0.2))
