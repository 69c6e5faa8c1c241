"""The data model's names (cdbrdf.schema): units per quantity, channel defaults, parts, one layout."""

from __future__ import annotations

import ast
from pathlib import Path

import numpy as np
import pytest

import cdbrdf
from cdbrdf import schema
from cdbrdf.errors import TableError
from cdbrdf.table import _of_parts as table_of_parts

from .conftest import make_table

_SRC = Path(cdbrdf.__file__).resolve().parent


def test_axes_are_the_conventions_order():
    assert schema.AXES == ("kappa", "phi_l", "theta_l", "phi_v", "theta_v", "channel")
    assert schema.SAMPLE_AXES == schema.AXES[:-1]
    assert schema.CHANNEL == "channel"
    assert cdbrdf.table.AXES is schema.AXES and cdbrdf.table.QUANTITIES is schema.QUANTITIES
    assert set(schema.AXIS_UNITS) == set(schema.SAMPLE_AXES)
    assert schema.DATA_VARIABLES[schema.REFLECTANCE] == schema.AXES
    assert schema.DATA_VARIABLES[schema.MEASURED] == schema.SAMPLE_AXES


@pytest.mark.parametrize("quantity, units", [("brdf", "1/sr"), ("relative", "1")])
def test_reflectance_units_per_quantity(quantity, units):
    assert schema.reflectance_units(quantity) == units
    assert schema.variable_attrs("reflectance", quantity)["units"] == units
    assert schema.variable_attrs("reflectance_std", quantity)["units"] == units
    assert schema.variable_attrs("kappa", quantity) == {
        "units": "1/mm", "long_name": "surface curvature (> 0 convex, < 0 concave)"
    }
    for name in ("phi_l", "theta_l", "phi_v", "theta_v"):
        assert schema.variable_attrs(name, quantity)["units"] == "degree"


@pytest.mark.parametrize("quantity", ["BRDF", "", None, 1, ["brdf"]])
def test_unknown_quantity_lists_the_valid_ones(quantity):
    with pytest.raises(TableError, match=r"attrs\['quantity'\]: .* is not one of brdf, relative"):
        schema.reflectance_units(quantity)
    with pytest.raises(TableError, match="is not one of brdf, relative"):
        schema.variable_attrs("kappa", quantity)


def test_variable_attrs_of_every_variable():
    for name in (*schema.AXES, *schema.DATA_VARIABLES):
        attrs = schema.variable_attrs(name, "brdf")
        assert attrs and all(isinstance(k, str) for k in attrs)
    flags = schema.variable_attrs("measured", "relative")
    assert flags["flag_meanings"] == "filled measured"
    assert flags["flag_values"].dtype == np.uint8 and flags["flag_values"].tolist() == [0, 1]
    assert "units" not in schema.variable_attrs("channel", "brdf")
    with pytest.raises(TableError, match=r"variable 'albedo': not one of kappa, .*reflectance_std"):
        schema.variable_attrs("albedo", "brdf")


def test_variable_attrs_are_fresh_copies():
    a = schema.variable_attrs("measured", "brdf")
    a["flag_values"][0] = 9
    a["extra"] = 1
    assert schema.variable_attrs("measured", "brdf")["flag_values"].tolist() == [0, 1]
    assert "extra" not in schema.variable_attrs("measured", "brdf")


@pytest.mark.parametrize(
    "n, names",
    [(1, ["c0"]), (2, ["c0", "c1"]), (3, ["R", "G", "B"]), (4, ["c0", "c1", "c2", "c3"])],
)
def test_default_channels(n, names):
    assert schema.default_channels(n) == names
    assert schema.is_default_channels(names)
    assert schema.channel_names({}, n) == names
    assert schema.channel_names({"channels": ["x"] * (n + 1)}, n) == names  # wrong length: defaults


def test_channel_names_from_attrs():
    assert schema.channel_names({"channels": ["nir", "uv"]}, 2) == ["nir", "uv"]
    assert schema.channel_names({"channels": ("X", "Y", "Z")}, 3) == ["X", "Y", "Z"]
    assert not schema.is_default_channels(["G", "R", "B"])
    assert not schema.is_default_channels(["c1"])


@pytest.mark.parametrize("names", [["R", "G"], "RGB", [1, 2, 3], ["R", "G", None]])
def test_check_channel_names_refuses(names):
    with pytest.raises(TableError, match=r"attrs\['channels'\]: .* is not a list of 3 channel name\(s\)"):
        schema.check_channel_names({"channels": names}, 3)


def test_check_channel_names_accepts():
    schema.check_channel_names({}, 3)
    schema.check_channel_names({"channels": ["a", "b", "c"]}, 3)
    schema.check_channel_names({"channels": ("a",)}, 1)


def test_with_channel_names():
    attrs = {"material": "m"}
    assert schema.with_channel_names(attrs, ["R", "G", "B"]) == attrs
    assert schema.with_channel_names(attrs, ["nir", "uv"]) == {"material": "m", "channels": ["nir", "uv"]}
    assert attrs == {"material": "m"}  # not changed in place
    kept = {"channels": ["a", "b"]}
    assert schema.with_channel_names(kept, ["nir", "uv"]) == kept


def test_parts_of_a_table_round_trip(small_grid):
    t = make_table(small_grid, std=np.full(small_grid.shape + (3,), 0.1), attrs={"quantity": "brdf"})
    parts = schema.TableParts.of(t)
    assert list(parts.axes) == list(schema.SAMPLE_AXES)
    assert list(parts.variables()) == ["reflectance", "measured", "fill_source", "reflectance_std",
                                       "fill_method", "fill_sources", "fill_weights"]
    assert parts.values is t.values and parts.quantity == "brdf" and parts.channels == ["R", "G", "B"]
    assert table_of_parts(parts) == t
    no_std = schema.TableParts.of(make_table(small_grid))
    assert "reflectance_std" not in no_std.variables()


def test_parts_with_a_changed_quantity_are_refused(small_grid, tmp_path):
    t = make_table(small_grid)
    t.attrs["quantity"] = "absolute"  # attrs stay mutable; the writer checks again
    with pytest.raises(TableError, match="'absolute' is not one of brdf, relative"):
        t.save(tmp_path / "t.h5")
    assert not list(tmp_path.iterdir())


def test_file_and_xarray_carry_the_same_variable_attributes(tmp_path, small_grid):
    import xarray as xr
    t = make_table(small_grid, channels=2, std=np.full(small_grid.shape + (2,), 0.1),
                   attrs={"quantity": "brdf", "channels": ["nir", "uv"]})
    p = tmp_path / "t.h5"
    t.save(p)
    mem = t.to_xarray()
    with xr.open_dataset(p, engine="h5netcdf", mask_and_scale=False, decode_cf=False) as disk:
        assert list(disk.data_vars) == list(mem.data_vars)
        assert set(schema.DATA_VARIABLES) - set(mem.data_vars) == {"fill_std"}  # the only one this table lacks
        for name in (*schema.AXES, schema.FILL_SLOT, *mem.data_vars):
            a, b = dict(disk[name].attrs), dict(mem[name].attrs)
            assert a.keys() == b.keys(), name
            for key in a:
                np.testing.assert_array_equal(a[key], b[key])
            assert disk[name].dims == mem[name].dims
        assert list(disk["channel"].values) == list(mem["channel"].values) == ["nir", "uv"]


def _imports(path: Path) -> set[str]:
    """The modules ``path`` imports (relative ones as ``.name``)."""
    out = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            out.update(a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module is None:  # from . import x
            out.update("." * node.level + a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom):
            out.add("." * node.level + node.module)
    return out


def test_schema_imports_only_numpy_and_errors():
    cdbrdf_imports = {m for m in _imports(_SRC / "schema.py") if m.startswith((".", "cdbrdf"))}
    assert cdbrdf_imports == {".errors"}
    assert {m.split(".")[0] for m in _imports(_SRC / "schema.py")} - {""} <= {
        "__future__", "collections", "dataclasses", "types", "typing", "numpy",
    }


def test_io_does_not_import_the_table():
    imports = _imports(_SRC / "io.py")
    assert not any(m.endswith("table") for m in imports), imports
