"""The one resolver of table sources (cdbrdf.sources.open_source): kinds, names, and each file opened once."""

from __future__ import annotations

import h5py
import numpy as np
import pytest

from cdbrdf import CDBRDF, CDBTF, Grid
from cdbrdf.errors import OptionError
from cdbrdf.sources import Source, open_source

from .conftest import make_table

GRID = Grid.regular(theta_step_deg=30, phi_step_deg=90, kappa=[-0.2, 0.0, 0.2])


def _btf(material="velvet"):
    rng = np.random.default_rng(3)
    mean = make_table(GRID, attrs={"material": material})
    basis = 0.01 * rng.standard_normal(GRID.shape + (2, 3))
    return CDBTF(mean, 0.5 * rng.standard_normal((3, 4, 2)), basis, repeat_mm=(2.0, 1.5))


@pytest.fixture
def opens(monkeypatch):
    """The HDF5 files opened (h5py.File calls) while the test runs."""
    seen: list[str] = []

    class Counting(h5py.File):
        def __init__(self, name, *args, **kw):
            seen.append(str(name))
            super().__init__(name, *args, **kw)

    monkeypatch.setattr(h5py, "File", Counting)
    return seen


def test_objects_are_taken_as_they_are():
    t = make_table(GRID, attrs={"material": "denim"})
    src = open_source(t)
    assert src.table is t and src.name == "denim" and not src.is_btf and src.flat is t and src.btf is None
    assert open_source(src) is src
    b = _btf()
    table, name = open_source(b)  # unpacks as a pair
    assert table is b and name == "velvet" and open_source(b).is_btf
    assert np.array_equal(open_source(b).flat.values, b.mean().values)
    assert open_source(make_table(GRID)).name == "table"


def test_a_cdbrdf_file_is_opened_once(tmp_path, opens):
    t = make_table(GRID)
    t.save(tmp_path / "shot.h5")
    opens.clear()
    src = open_source(tmp_path / "shot.h5")
    assert isinstance(src.table, CDBRDF) and src.name == "shot"  # no material attribute: the file's stem
    assert np.array_equal(src.table.values, t.values)
    assert len(opens) == 1


def test_a_cdbtf_file_gives_its_cdbtf_in_two_opens(tmp_path, opens):
    b = _btf()
    b.save(tmp_path / "v.h5")
    opens.clear()
    src = open_source(str(tmp_path / "v.h5"))
    assert isinstance(src.table, CDBTF) and src.name == "velvet"
    assert np.allclose(src.table.weights, b.weights) and src.table.repeat_mm == b.repeat_mm
    assert len(opens) == 2  # the CDBRDF variables (which say it is a CD-BTF), then the CD-BTF's own


def test_anything_else_is_refused_in_one_line(tmp_path):
    with pytest.raises(OptionError, match=r"^table: expected a CDBRDF, a CDBTF or a file name, got int$"):
        open_source(3)
    with pytest.raises(FileNotFoundError):
        open_source(tmp_path / "missing.h5")
    assert isinstance(open_source(make_table(GRID)), Source)


def test_render_compare_opens_its_file_once(tmp_path, opens):
    """``cdbrdf render --compare`` reads its table once (it was four opens: is_btf twice, load twice)."""
    pytest.importorskip("mitsuba")
    from cdbrdf.cli import main

    from .render_helpers import needs_llvm_marker

    if needs_llvm_marker().args[0]:
        pytest.skip("no usable LLVM for Mitsuba's llvm variant")
    make_table(Grid.paper(), attrs={"material": "denim"}).save(tmp_path / "t.h5")
    opens.clear()
    assert main(["-q", "render", str(tmp_path / "t.h5"), "--scene", "sine", "--compare", "--size", "16x12", "--spp", "1",
                 "-o", str(tmp_path / "c.png")]) == 0
    assert [o for o in opens if o.endswith("t.h5")] == [str(tmp_path / "t.h5")]
