"""``cdbrdf.importers.stack`` and the ``import`` / ``stack`` commands.

Per-stand plain BRDFs stacked along kappa: exact copies (masks and fill
sources carried over) for one-curvature CDBRDF files on one grid, resampling
for other formats, refusals that name the file and the disagreement, nothing
written on error; the stacked table goes through info, mosaic, the lookup and
the renderer.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

import cdbrdf
from cdbrdf import CDBRDF, Grid, TableError
from cdbrdf.cli import main
from cdbrdf.importers import stack

from .conftest import make_table
from .import_helpers import write_merl, write_utia


def _slice(tmp_path, name, k=0.0, *, seed=0, grid=None, **attrs):
    g = grid or Grid.paper(kappa=[k])
    rng = np.random.default_rng(seed)
    measured = rng.random(g.shape) > 0.1
    src = np.full(g.shape, -1)
    filled = np.flatnonzero(~measured.ravel())
    good = np.flatnonzero(measured.ravel())
    src.ravel()[filled] = good[rng.integers(0, good.size, filled.size)]
    a = {"quantity": "brdf", "material": "denim"}
    a.update(attrs)
    t = make_table(g, seed=seed, measured=measured, fill_source=src, attrs=a)
    p = tmp_path / f"{name}.h5"
    t.save(p)
    return p, t


def test_stack_of_tables_on_one_grid_is_an_exact_copy_with_masks(tmp_path):
    p1, t1 = _slice(tmp_path, "flat", 0.0, seed=1)
    p2, t2 = _slice(tmp_path, "s22", 0.22, seed=2)
    p0, t0 = _slice(tmp_path, "trough", -0.13, seed=3)
    s = stack([(0.22, p2), (0.0, p1), (-0.13, p0)])
    assert s.kappa.tolist() == [-0.13, 0.0, 0.22]
    for i, t in enumerate((t0, t1, t2)):
        np.testing.assert_array_equal(s.values[i], t.values[0])
        np.testing.assert_array_equal(s.measured[i], t.measured[0])
    per = int(np.prod(s.grid.shape[1:]))
    fs = s.fill_source[1]
    np.testing.assert_array_equal(np.where(fs >= 0, fs - per, fs), t1.fill_source[0])
    prov = s.attrs["provenance"]
    assert prov["kind"] == "stacked" and [x["kappa"] for x in prov["slices"]] == [-0.13, 0.0, 0.22]
    assert s.attrs["material"] == "denim" and s.quantity == "brdf"
    # the stacked table is a CDBRDF like any other
    out = tmp_path / "stack.h5"
    s.save(out)
    assert cdbrdf.load(out) == s
    assert s.brdf(0.0).values.shape == t1.values.shape


@pytest.mark.parametrize("change,match", [
    ({"quantity": "relative"}, r"quantity 'relative' \(1\) differs from .*'brdf' \(1/sr\)"),
    ({"colour_space": "ACEScg"}, "colour space 'ACEScg' differs"),
    ({"material": "silk"}, r"material 'silk' differs from .* \(name the stack"),
])
def test_files_that_disagree_are_refused(tmp_path, change, match):
    p1, _ = _slice(tmp_path, "a", 0.0)
    p2, _ = _slice(tmp_path, "b", 0.1, **change)
    with pytest.raises(TableError, match=match) as err:
        stack([(0.0, p1), (0.1, p2)])
    assert str(err.value).startswith(str(p2))


def test_material_name_override_and_other_refusals(tmp_path):
    p1, _ = _slice(tmp_path, "a", 0.0)
    p2, _ = _slice(tmp_path, "b", 0.1, material="silk")
    assert stack([(0.0, p1), (0.1, p2)], material="mixed").attrs["material"] == "mixed"
    with pytest.raises(TableError, match="kappa 0 1/mm is also given to"):
        stack([(0.0, p1), (0.0, p2)], material="x")
    with pytest.raises(TableError, match="at least two"):
        stack([(0.0, p1)])
    coarse = Grid(kappa=[0.2], theta_l=[0, 30, 60], phi_l=np.arange(0, 360, 90.0), theta_v=[0, 30, 60],
                  phi_v=np.arange(0, 360, 90.0))
    p3, _ = _slice(tmp_path, "coarse", grid=coarse)
    with pytest.raises(TableError, match=r"its grid, anisotropic 4x3x4x3 .* differs from .*; give a target grid"):
        stack([(0.0, p1), (0.2, p3)])
    # with a target grid every file is resampled onto it
    s = stack([(0.0, p1), (0.2, p3)], grid="paper", spacing_deg=10.0, estimate=False)
    assert s.grid.shape[1:] == Grid.paper().shape[1:]
    multi = tmp_path / "multi.h5"
    make_table(Grid.paper(), seed=0, attrs={"material": "denim", "quantity": "brdf"}).save(multi)
    with pytest.raises(cdbrdf.FormatError, match="holds 5 curvatures; a plain BRDF"):
        stack([(0.0, p1), (0.1, multi)])


def test_stack_of_merl_files_is_isotropic_and_mixed_formats_anisotropic(tmp_path):
    a = write_merl(tmp_path / "denim.binary")
    b = write_merl(tmp_path / "denim_bent.binary")
    s = stack([(0.0, a), (0.13, b)], grid="regular:15,30", spacing_deg=3.0, estimate=False, material="denim")
    assert s.isotropic and s.kappa.tolist() == [0.0, 0.13]
    np.testing.assert_allclose(s.values[0], s.values[1])
    u = write_utia(tmp_path / "denim.bin")
    with pytest.raises(TableError, match="quantity 'relative' .* differs"):
        stack([(0.0, a), (0.13, u)], material="denim")


def test_cli_import_and_stack_and_the_toolchain(tmp_path, capsys):
    a = write_merl(tmp_path / "lobe.binary")
    out = tmp_path / "lobe.h5"
    args = ["import", str(a), "-o", str(out), "--grid", "regular:15,30", "--spacing", "7.5", "--kappa", "0.1"]
    assert main(args) == 0
    line = capsys.readouterr().out
    assert "wrote" in line and "isotropic" in line and "expected error" in line
    t = cdbrdf.load(out)
    assert t.isotropic and t.kappa.tolist() == [0.1]
    assert main(["info", str(out), "--json"]) == 0
    info = json.loads(capsys.readouterr().out)
    assert info["symmetry"] == "isotropic" and info["provenance"]["source"]["format"] == "merl"
    p2 = tmp_path / "flat.h5"
    assert main(["-q", "import", str(a), "-o", str(p2), "--grid", "regular:15,30", "--spacing", "7.5"]) == 0
    st = tmp_path / "stack.h5"
    assert main(["stack", "--kappa", "0", str(p2), "--kappa", "0.1", str(out), "-o", str(st)]) == 0
    s = cdbrdf.load(st)
    assert s.kappa.tolist() == [0.0, 0.1] and s.isotropic
    png = tmp_path / "stack.png"
    assert main(["mosaic", str(st), "-o", str(png)]) == 0 and png.stat().st_size > 1000
    v = s.evaluate(40.0, 100.0, 30.0, 280.0, 0.05)
    np.testing.assert_allclose(v, s.evaluate(40.0, 120.0, 30.0, 300.0, 0.05), rtol=1e-12)


def test_cli_errors_are_one_line_and_write_nothing(tmp_path, capsys):
    bad = tmp_path / "bad.binary"
    bad.write_bytes(b"\x5a\x00\x00\x00\x5a\x00\x00\x00\xb4\x00\x00\x00" + b"\0" * 100)
    out = tmp_path / "out.h5"
    assert main(["import", str(bad), "-o", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("cdbrdf import: error: ") and str(bad) in err and "wrong size" in err
    assert "\n" not in err and not out.exists() and list(tmp_path.iterdir()) == [bad]
    p1, _ = _slice(tmp_path, "a", 0.0)
    p2, _ = _slice(tmp_path, "b", 0.1, quantity="relative")
    assert main(["stack", "--kappa", "0", str(p1), "--kappa", "0.1", str(p2), "-o", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert "quantity" in err and str(p2) in err and not out.exists()
    with pytest.raises(SystemExit) as ex:  # a token that is neither a curvature nor a file: refused while parsing
        main(["stack", "--kappa", "zero", str(p1), "--kappa", "0.1", str(p2), "-o", str(out)])
    assert ex.value.code == 2 and "zero: no such file" in capsys.readouterr().err
    assert main(["stack", "--kappa", str(p1), str(p1), "--kappa", "0.1", str(p2), "-o", str(out)]) == 2
    assert f"--kappa {p1} {p1}" in capsys.readouterr().err and not out.exists()
    with pytest.raises(SystemExit) as ex:
        main(["import", str(bad), "-o", str(out), "--grid", "regular:0,5"])
    assert ex.value.code == 2


def test_isotropic_stack_renders_with_the_plug_in(tmp_path):
    from .lookup_cases import need_mitsuba

    need_mitsuba()
    import cdbrdf.render as cr
    from cdbrdf.render.picture import render_scene
    from cdbrdf.render.scenes import sine_scene
    from cdbrdf.render.spec import RenderSpec

    cr.set_variant("llvm_ad_rgb")
    g = Grid.regular(theta_step_deg=15, phi_step_deg=30, kappa=[-0.2, 0.2], symmetry="isotropic")
    t = CDBRDF(np.full(g.shape + (3,), 0.5 / np.pi), **g.axes(), symmetry="isotropic")
    img = render_scene(sine_scene(t, RenderSpec(size=(32, 24), spp=4, max_depth=2)), spp=4)
    assert np.isfinite(img).all() and img.mean() > 0
