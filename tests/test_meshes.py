"""Generated meshes: the draped cloth."""

from __future__ import annotations

import numpy as np
import pytest

from cdbrdf.mesh import DrapedCloth, draped_cloth_height, draped_cloth_mesh, max_curvature


def test_draped_cloth_has_uvs_and_both_curvature_signs():
    cloth = DrapedCloth(resolution=121)
    m = draped_cloth_mesh(cloth)
    assert m.uv is not None and m.uv.min() == 0.0 and m.uv.max() == 1.0
    assert m.faces.shape[1] == 3 and m.vertices.shape == (121 * 121, 3)
    k = max_curvature(m.vertices, m.faces)
    centre = np.argmin(np.linalg.norm(m.vertices[:, :2], axis=1))
    # the dome's apex: a Gaussian of height H and width s has curvature H / s^2 there
    assert k[centre] == pytest.approx(cloth.height_mm / cloth.sigma_mm**2, rel=0.05)
    # folds give convex ridges and concave valleys within the paper's range
    assert np.percentile(k, 2) < -0.08 and np.percentile(k, 98) > 0.08
    assert np.abs(k).max() < 0.5


def test_normals_point_up_and_match_the_faces():
    m = draped_cloth_mesh(DrapedCloth(resolution=41))
    assert (m.normals[:, 2] > 0).all()
    v = m.vertices
    f = m.faces
    fn = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
    assert (fn[:, 2] > 0).all()  # counter-clockwise seen from above


def test_height_is_the_dome_at_the_centre():
    assert draped_cloth_height(0.0, 0.0) == pytest.approx(DrapedCloth().height_mm)


@pytest.mark.parametrize("kw, match", [
    (dict(size_mm=-1.0), "size_mm: must be a positive length"),
    (dict(folds=2.5), "folds: must be a positive integer"),
    (dict(resolution=4), "resolution: must be an integer >= 8"),
])
def test_bad_parameters(kw, match):
    with pytest.raises(ValueError, match=match):
        DrapedCloth(**kw)
