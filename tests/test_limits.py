"""Resource limits (cdbrdf.limits): values from the environment, parsed strictly."""

from __future__ import annotations

import pytest

from cdbrdf import limits
from cdbrdf.cli import main
from cdbrdf.errors import LimitError


@pytest.mark.parametrize("raw", ["inf", "-inf", "nan", "1e400", "1e6", "abc", "-5", "0", "00", "1.5", "+5",
                                 "0x10", "5 000", "9223372036854775808", "9" * 5000])
def test_bad_variable_is_a_limit_error_naming_it(monkeypatch, raw):
    monkeypatch.setenv("CDBRDF_MAX_JSON_BYTES", raw)
    with pytest.raises(LimitError, match=r"^CDBRDF_MAX_JSON_BYTES=.*expected a whole number of bytes from 1"):
        limits.limit("json_bytes").value()
    # the check itself never blames the input (or overflows) for a bad variable
    with pytest.raises(LimitError, match="CDBRDF_MAX_JSON_BYTES="):
        limits.check("json_bytes", 10, what="x.json: JSON file")


@pytest.mark.parametrize(("raw", "value"), [("1000", 1000), (" 1000\n", 1000), ("1_000_000", 1_000_000),
                                            ("9223372036854775807", 2**63 - 1), ("", 16 * 1024 * 1024)])
def test_good_variable(monkeypatch, raw, value):
    monkeypatch.setenv("CDBRDF_MAX_JSON_BYTES", raw)
    assert limits.limit("json_bytes").value() == value
    limits.check_environment()


def test_unset_variable_gives_the_default(monkeypatch):
    for lim in limits.LIMITS.values():
        monkeypatch.delenv(lim.env, raising=False)
        assert lim.value() == lim.default
    limits.check_environment()


@pytest.mark.parametrize("var", sorted(lim.env for lim in limits.LIMITS.values()))
def test_cli_refuses_a_bad_variable_before_any_work(tmp_path, monkeypatch, capsys, var):
    monkeypatch.setenv(var, "inf")
    out = tmp_path / "plan"
    assert main(["-q", "plan", "-o", str(out), "--kappa", "0", "--theta-step", "40", "--theta-max", "40",
                 "--phi-step", "120"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith(f"cdbrdf plan: error: {var}='inf': expected a whole number")
    assert not out.exists()


def test_cli_names_the_variable_not_the_option_that_uses_it(tmp_path, monkeypatch, capsys):
    """render --size checks the render_pixels limit while parsing: the error is about the variable."""
    monkeypatch.setenv("CDBRDF_MAX_RENDER_PIXELS", "1e400")
    assert main(["render", "t.h5", "--scene", "sine", "-o", str(tmp_path / "a.png"), "--size", "8x8"]) == 2
    err = capsys.readouterr().err
    assert err == ("cdbrdf render: error: CDBRDF_MAX_RENDER_PIXELS='1e400': expected a whole number of pixels "
                   "from 1 to 9,223,372,036,854,775,807 in decimal digits (e.g. 67108864), or unset it for the "
                   "default\n")
    with pytest.raises(SystemExit) as exc:  # help still works
        main(["render", "--help"])
    assert exc.value.code == 0
