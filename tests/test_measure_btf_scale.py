"""measure --btf on every scheduler and with a checkpoint: the same CD-BTF, bit for bit, wherever and however it ran.

Ground truth: the CD-BTF measured on the synchronous scheduler without a
checkpoint (the rectification itself is checked against the rig's model in
tests/test_measure_btf.py). Interrupted runs are simulated as the CDBRDF
checkpoint tests do (the ``_interrupt_after`` hook).
"""

from __future__ import annotations

import logging
import shutil

import numpy as np
import pytest

from cdbrdf import CDBTF
from cdbrdf.btf import load as load_btf
from cdbrdf.cli import main
from cdbrdf.errors import OptionError
from cdbrdf.measure import MeasurementInterrupted, measure
from cdbrdf.measure.checkpoint import checkpoint_path

from .render_helpers import require_llvm_module  # noqa: E402

require_llvm_module()

from cdbrdf.rig import RigOptions, simulate_capture  # noqa: E402

from .measure_helpers import kill_after_first_batch  # noqa: E402
from .test_measure_btf import SMALL, texture  # noqa: E402


@pytest.fixture(scope="module")
def capture(tmp_path_factory):
    """The fast capture (4 x 4 texels, a flat and a convex stand) and its CD-BTF measured synchronously."""
    folder = tmp_path_factory.mktemp("btfscale") / "cap"
    simulate_capture(texture(SMALL, 4, (0.3, 0.3)), folder, RigOptions(seed=1))
    ref, rep = measure(folder, btf=4, scheduler="synchronous")
    return folder, ref, rep


def same_btf(a: CDBTF, b: CDBTF) -> None:
    """Bit-identical CD-BTFs: every texel and sample, the tile mean, the compression and the provenance."""
    np.testing.assert_array_equal(a.decode(), b.decode())
    np.testing.assert_array_equal(a.mean().values, b.mean().values)
    np.testing.assert_array_equal(a.mean().measured, b.mean().measured)
    assert a.compression == b.compression and a.attrs["provenance"] == b.attrs["provenance"]


def test_threads_give_the_synchronous_btf(capture):
    folder, ref, rep = capture
    got, rep2 = measure(folder, btf=4, scheduler="threads", num_workers=2)
    same_btf(got, ref)
    assert rep2.n_measured == rep.n_measured and rep2.n_images == rep.n_images > 100


def test_processes_give_the_same_btf(capture):
    """The geometry is made again in each worker process (it is pickled without it): the same CD-BTF."""
    folder, ref, _ = capture
    got, _ = measure(folder, btf=4, scheduler="processes", num_workers=2)
    same_btf(got, ref)


def test_local_cluster_gives_the_same_btf(capture):
    distributed = pytest.importorskip("distributed")
    folder, ref, _ = capture
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=False,
                                  dashboard_address=None) as cluster:
        got, _ = measure(folder, btf=4, scheduler=cluster.scheduler_address)
        with distributed.Client(cluster) as client:
            got2, _ = measure(folder, btf=4, scheduler=client)
    same_btf(got, ref)
    same_btf(got2, ref)


def test_interrupt_and_resume_is_bit_identical(capture, tmp_path, monkeypatch):
    """A run stopped after its third batch resumes them: only the rest is read, the same file as a fresh run."""
    from cdbrdf.measure import btf as mbtf

    folder, ref, rep = capture
    out = tmp_path / "out.h5"
    with pytest.raises(MeasurementInterrupted):
        measure(folder, out, btf=4, batch_size=16, _interrupt_after=40)
    ck = checkpoint_path(out)
    assert not out.exists() and ck.is_dir() and len(list(ck.glob("batch-*.npz"))) == 3
    read: list[int] = []
    real = mbtf._condition_tasks

    def counting(jobs):
        read.extend(len(j[2]) for j in jobs)
        return real(jobs)

    monkeypatch.setattr(mbtf, "_condition_tasks", counting)
    got, rep2 = measure(folder, out, btf=4, batch_size=16)
    n_samples = rep.n_images - rep.n_white - rep.n_dark
    assert 40 <= rep2.n_images_resumed <= 48 and sum(read) == n_samples - rep2.n_images_resumed
    assert out.exists() and not ck.exists()
    same_btf(got, ref)
    same_btf(load_btf(out), ref)


def test_checkpoint_of_another_texel_count_is_discarded(capture, tmp_path, caplog):
    folder, _, _ = capture
    out = tmp_path / "out.h5"
    with pytest.raises(MeasurementInterrupted):
        measure(folder, out, btf=4, batch_size=16, _interrupt_after=16)
    ref2, _ = measure(folder, btf=2)
    with caplog.at_level(logging.WARNING):
        got, rep = measure(folder, out, btf=2)
    assert rep.n_images_resumed == 0 and "checkpoint of a different run" in caplog.text
    assert got.texels == (2, 2) and not checkpoint_path(out).exists()
    same_btf(got, ref2)


def test_checkpoint_of_the_cdbrdf_path_is_not_taken_for_texels(capture, tmp_path):
    folder, ref, _ = capture
    out = tmp_path / "out.h5"
    with pytest.raises(MeasurementInterrupted):
        measure(folder, out, batch_size=16, _interrupt_after=16)
    got, rep = measure(folder, out, btf=4)
    assert rep.n_images_resumed == 0
    same_btf(got, ref)


def test_no_checkpoint_when_asked(capture, tmp_path):
    folder, ref, _ = capture
    with pytest.raises(MeasurementInterrupted):
        measure(folder, tmp_path / "out.h5", btf=4, checkpoint=False, batch_size=16, _interrupt_after=16)
    assert sorted(p.name for p in tmp_path.iterdir()) == []


def test_bad_options_are_one_line(capture, tmp_path, capsys):
    from cdbrdf.measure.btf import measure_btf
    from cdbrdf.measure.options import MeasureOptions

    folder, _, _ = capture
    for kw, match in (({"scheduler": "bogus"}, "neither a scheduler address"),
                      ({"batch_size": 0}, "batch_size: expected a positive"),
                      ({"num_workers": True}, "num_workers: expected a positive")):
        for fn in (measure, measure_btf):
            with pytest.raises(OptionError, match=match) as e:
                if fn is measure:
                    fn(folder, tmp_path / "m.h5", btf=4, **kw)
                elif "scheduler" in kw:
                    fn(folder, tmp_path / "m.h5", texels=4, **kw)
                else:  # measure_btf takes the shared options as one record, checked when it is made
                    fn(folder, tmp_path / "m.h5", texels=4, options=MeasureOptions(**kw))
            assert "\n" not in str(e.value)
    assert main(["-q", "measure", str(folder), "--btf", "4", "-o", str(tmp_path / "m.h5"),
                 "--scheduler", "bogus"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "scheduler: 'bogus'" in err
    assert sorted(p.name for p in tmp_path.iterdir()) == []


def test_unreachable_scheduler_fails_before_the_checkpoint_is_created(capture, tmp_path, monkeypatch):
    distributed = pytest.importorskip("distributed")
    shutil.copytree(capture[0], tmp_path / "cap")

    def unreachable(address, **kw):
        assert not (tmp_path / "m.h5.ckpt").exists()  # not created before the connection
        raise OSError(f"Timed out trying to connect to {address} after 10 s")

    monkeypatch.setattr(distributed, "Client", unreachable)
    with pytest.raises(OSError, match=r"scheduler tcp://127.0.0.1:9: cannot connect \(Timed out"):
        measure(tmp_path / "cap", tmp_path / "m.h5", btf=4, scheduler="tcp://127.0.0.1:9")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["cap"]


def test_a_changed_photograph_is_read_again(capture, tmp_path):
    """A condition is reused only while its photographs' sizes and modification times are unchanged."""
    import os

    from cdbrdf.measure.capture import read_capture

    folder, ref, _ = capture
    shutil.copytree(folder, tmp_path / "cap")
    out = tmp_path / "out.h5"
    with pytest.raises(MeasurementInterrupted):
        measure(tmp_path / "cap", out, btf=4, batch_size=16, _interrupt_after=16)
    saved = sorted(int(r) for f in checkpoint_path(out).glob("batch-*.npz") for r in np.load(f)["rows"])
    cap = read_capture(tmp_path / "cap")
    size = {idx[0]: len(idx) for idx in cap.brackets("sample").values()}
    photo = tmp_path / "cap" / cap.rows[saved[0]].file
    st = photo.stat()
    os.utime(photo, ns=(st.st_atime_ns, st.st_mtime_ns + 10**9))
    got, rep = measure(tmp_path / "cap", out, btf=4)
    assert saved and rep.n_images_resumed == sum(size[r] for r in saved) - size[saved[0]]
    same_btf(got, ref)


def test_killed_process_resumes(capture, tmp_path):
    """SIGKILL a process measuring the CD-BTF after its first checkpointed batch; the rerun resumes, bit for bit."""
    folder, ref, _ = capture
    out = tmp_path / "out.h5"
    assert kill_after_first_batch(folder, out, btf=4, batch_size=16, num_workers=1) >= 1
    assert not out.exists()
    got, rep = measure(folder, out, btf=4)
    assert rep.n_images_resumed >= 16
    same_btf(got, ref)
    same_btf(load_btf(out), ref)


@pytest.mark.parametrize("scheduler", ["threads", "processes"])
def test_an_error_in_a_task_is_one_line_and_leaves_no_checkpoint(capture, tmp_path, scheduler):
    """Too many texels for the photographs: found in the workers, raised in one line, nothing left behind."""
    from cdbrdf.errors import CaptureError

    with pytest.raises(CaptureError, match="do not resolve 32 x 32 texels") as e:
        measure(capture[0], tmp_path / "m.h5", btf=32, scheduler=scheduler, num_workers=2)
    assert "\n" not in str(e.value) and sorted(p.name for p in tmp_path.iterdir()) == []
