"""Stands (cdbrdf.measure.stands): geometry, occlusion, the stands of stands.json."""

from __future__ import annotations

import contextlib
import json
import math

import numpy as np
import pytest

from cdbrdf import Grid
from cdbrdf.measure.stands import Stand, footprint_mm, hidden_mask, read_stands


def test_convex_and_flat_hide_nothing():
    th, ph = np.meshgrid(np.arange(0, 90, 5.0), np.arange(0, 360, 10.0))
    for k in (0.0, 0.13, 0.22):
        assert not Stand(k).hides(th, ph).any()


def test_concave_horizon_analytic():
    st = Stand(-0.2, face_width_mm=5.0, wall_height_mm=1.5)
    r = 5.0
    a = 2.5 / r
    x_e, z_e = r * math.sin(a), r * (1 - math.cos(a))
    assert st.edge_mm == pytest.approx((x_e, z_e))
    elev = math.degrees(math.atan2(z_e + 1.5, x_e))  # elevation of the wall top from the centre
    theta_b = 90 - elev
    # along x (phi 0 and 180): hidden just beyond the boundary, visible just inside
    for phi in (0.0, 180.0):
        assert st.hides(theta_b + 0.01, phi) and not st.hides(theta_b - 0.01, phi)
    # along the cylinder axis nothing is hidden
    assert not st.hides(89.0, 90.0) and not st.hides(89.0, 270.0)
    # oblique: the x-z projection decides: tan(theta) |cos(phi)| vs 1 / slope
    phi = 50.0
    tb = math.degrees(math.atan(1 / (st.horizon_slope() * math.cos(math.radians(phi)))))
    assert st.hides(tb + 0.01, phi) and not st.hides(tb - 0.01, phi)


def test_patch_margin_analytic():
    """From a face point m mm towards the wall, the wall top is seen higher."""
    st = Stand(-0.2, face_width_mm=5.0, wall_height_mm=1.0)
    r, m = 5.0, 0.4
    x_e, z_e = st.edge_mm
    px, pz = r * math.sin(m / r), r * (1 - math.cos(m / r))
    assert st.horizon_slope(m) == pytest.approx((z_e + 1.0 - pz) / (x_e - px))
    assert st.horizon_slope(m) > st.horizon_slope(0.0)
    assert math.isinf(st.horizon_slope(2.5))  # the patch reaches the face's edge
    th = np.arange(0, 90, 1.0)
    assert np.all(st.hides(th, 0.0) <= st.hides(th, 0.0, margin_mm=m))


def test_hidden_mask_with_footprint():
    assert footprint_mm(60.0, pixel_mm=0.1, patch_px=7) == pytest.approx(3.5 * math.sqrt(2) * 0.1 / 0.5)
    g = Grid.regular(theta_step_deg=15, phi_step_deg=30, kappa=[-0.13, 0.13])
    st = [Stand(-0.13), Stand(0.13)]
    h0 = hidden_mask(g, st) > 0
    h1 = hidden_mask(g, st, pixel_mm=0.06) > 0
    assert np.all(h1 >= h0) and h1.sum() > h0.sum() and not h1[1].any()
    # the margin follows the view elevation: the light test is stricter for oblique views
    k, pl, tl, pv = 0, 0, 4, 0  # light at 60 deg along x
    col = h1[k, pl, tl, pv, :]
    assert list(col) == sorted(col)


def test_deeper_trough_hides_more():
    th, ph = np.meshgrid(np.arange(0, 90, 1.0), np.arange(0, 360, 5.0))
    n1 = Stand(-0.13).hides(th, ph).sum()
    n2 = Stand(-0.22).hides(th, ph).sum()
    n3 = Stand(-0.22, wall_height_mm=3).hides(th, ph).sum()
    assert 0 < n1 < n2 < n3


def test_stand_validation():
    with pytest.raises(ValueError, match="spans"):
        Stand(-0.5, face_width_mm=8.0)
    with pytest.raises(ValueError, match="must be positive"):
        Stand(0.1, face_width_mm=-1)


def test_hidden_mask_layout():
    g = Grid.regular(theta_step_deg=15, phi_step_deg=30, kappa=[-0.22, 0.0])
    st = [Stand(-0.22), Stand(0.0)]
    h = hidden_mask(g, st)
    assert not h[1].any()
    view = st[0].hides(g.theta_v[None, :], g.phi_v[:, None])
    light = st[0].hides(g.theta_l[None, :], g.phi_l[:, None])
    np.testing.assert_array_equal(h[0] & 1 > 0, np.broadcast_to(view[None, None], h[0].shape))
    np.testing.assert_array_equal(h[0] & 2 > 0, np.broadcast_to(light[:, :, None, None], h[0].shape))


# --------------------------------------------------------------------------- stands.json
def test_read_stands_errors(tmp_path):
    p = tmp_path / "stands.json"
    p.write_text("{not json")
    with pytest.raises(ValueError, match="not valid JSON"):
        read_stands(p)
    p.write_text(json.dumps({"stands": [{"kappa": 0.1, "radius": 3}]}))
    with pytest.raises(ValueError, match="unknown keys"):
        read_stands(p)


@pytest.mark.parametrize("text,msg", [
    ('{"stands": [{"kappa": NaN}]}', "NaN is not a number JSON allows"),
    ('{"stands": [{"kappa": 0.1, "face_width_mm": 0}]}', "stand 0: .*must be positive"),
    ('{"stands": [{"kappa": 0.1, "face_width_mm": -2}]}', "must be positive"),
    ('{"stands": [{"kappa": 0.1, "wall_height_mm": -1}]}', "non-negative"),
    ('{"stands": [{"kappa": 0.1, "length_mm": 1e999}]}', "stand 0 length_mm: must be finite"),
    ('{"stands": [{"kappa": true}]}', "stand 0 kappa: expected a number, got True"),
    ('{"stands": [{"kappa": "0.1"}]}', "expected a number"),
    ('{"stands": [{"kappa": 0.1}, {"kappa": 0.1}]}', "stand 1: a second stand for kappa 0.1"),
    ('{"stands": []}', "non-empty list"),
    ('[1, 2]', "expected a JSON object, got list"),
    ('{"stands": [{"kappa": 1' + "0" * 5000 + '}]}', "not valid JSON"),
    ('{"stands": ' + "[" * 100_000 + "]" * 100_000 + "}", "nested too deeply"),
    ('{"stands": [{"kappa": 0.1}]', "line 1: not valid JSON"),
])
def test_read_stands_refuses_bad_values(tmp_path, text, msg):
    from cdbrdf.errors import CaptureError

    p = tmp_path / "stands.json"
    p.write_text(text)
    with pytest.raises(CaptureError, match=msg) as exc:
        read_stands(p)
    assert str(p) in str(exc.value) and "\n" not in str(exc.value)


def test_read_stands_encoding_and_size_limit(tmp_path, monkeypatch):
    from cdbrdf.errors import CaptureError, LimitError

    p = tmp_path / "stands.json"
    p.write_bytes(b"\xef\xbb\xbf" + json.dumps({"stands": [{"kappa": 0.1}]}).encode())  # UTF-8 BOM is fine
    assert set(read_stands(p)) == {0.1}
    p.write_bytes(b'{"stands": [{"kappa": 0.1}], "material": "d\xe9nim"}')
    with pytest.raises(CaptureError, match="line 1: not UTF-8"):
        read_stands(p)
    p.write_text(json.dumps({"stands": [{"kappa": 0.1}], "pad": "x" * 5000}))
    monkeypatch.setenv("CDBRDF_MAX_JSON_BYTES", "4096")
    with pytest.raises(LimitError, match="CDBRDF_MAX_JSON_BYTES"):
        read_stands(p)


@contextlib.contextmanager
def unblocking(fifo, after_s=5.0):
    """While inside: after ``after_s``, feed any reader that blocked on ``fifo``, so that it fails, never hangs."""
    import os
    import threading

    stop = threading.Event()

    def writer():
        if stop.wait(after_s):
            return
        while not stop.is_set():
            try:
                fd = os.open(fifo, os.O_WRONLY | os.O_NONBLOCK)
            except OSError:  # no reader now
                stop.wait(0.2)
                continue
            try:
                os.write(fd, b'{"stands": [{"kappa": 0.1}]}')
            except OSError:
                pass
            os.close(fd)

    t = threading.Thread(target=writer, daemon=True)
    t.start()
    try:
        yield
    finally:
        stop.set()
        t.join()


@pytest.mark.parametrize("kind", ["fifo", "/dev/zero", "folder"])
def test_json_that_is_not_a_regular_file_is_refused_at_once(tmp_path, kind):
    """A FIFO blocked the reader forever, /dev/zero read until memory ran out."""
    import os
    import time

    from cdbrdf.errors import CaptureError
    from cdbrdf.measure.stands import load_json_object

    p = tmp_path / "stands.json"
    if kind == "fifo":
        os.mkfifo(p)
    elif kind == "folder":
        p.mkdir()
    else:
        p.symlink_to(kind)
    t0 = time.monotonic()
    with unblocking(p), pytest.raises(CaptureError, match=r"stands.json: not a regular file \(a (FIFO|character "
                                                           r"device|folder)\)"):
        load_json_object(p)
    assert time.monotonic() - t0 < 4.5  # refused before opening: a blocked reader is fed only after 5 s


def test_json_is_read_with_a_bounded_read(tmp_path, monkeypatch):
    """At most the limit + 1 bytes are read, whatever the file's size says (a file that grows)."""
    from cdbrdf import fsutil
    from cdbrdf.errors import LimitError
    from cdbrdf.measure import stands

    p = tmp_path / "stands.json"
    p.write_text(json.dumps({"stands": [{"kappa": 0.1}], "pad": "x" * 5000}))
    asked = []
    real = fsutil.read_regular

    def spy(path, *, max_bytes):
        asked.append(max_bytes)
        return real(path, max_bytes=max_bytes)

    monkeypatch.setattr(stands, "read_regular", spy)
    monkeypatch.setenv("CDBRDF_MAX_JSON_BYTES", "100")
    with pytest.raises(LimitError, match=r"stands.json: JSON file: 5,\d+ bytes exceed the limit of 100 "
                                         r"\(raise it with CDBRDF_MAX_JSON_BYTES\)"):
        read_stands(p)
    assert asked == [100]
