"""Writers under hostile conditions: killed mid-write, modes, symlinks, hard links, stale temporaries."""
import os
import signal
import subprocess
import sys
import textwrap
import time

import numpy as np
import pytest

from cgbound._atomic import TMP_MARK, atomic_write, remove_stale_temporaries, temporary_prefix


def _write_text(text):
    def write(tmp):
        with open(tmp, "w") as f:
            f.write(text)
    return write


def _temporaries(directory):
    return sorted(p.name for p in directory.iterdir() if TMP_MARK in p.name)


def test_temporary_is_named_after_the_target_and_removed_on_success(tmp_path):
    target = tmp_path / "fields.npz"
    seen = []

    def write(tmp):
        seen.append(os.path.basename(tmp))
        assert os.path.dirname(tmp) == str(tmp_path)
        _write_text("new")(tmp)
    atomic_write(target, write)
    assert seen[0].startswith(".fields.npz.cgbound-tmp-%d-" % os.getpid())
    assert target.read_text() == "new"
    assert _temporaries(tmp_path) == []


def test_failed_write_keeps_old_data_and_leaves_no_temporary(tmp_path):
    target = tmp_path / "out.txt"
    target.write_text("precious")

    def write(tmp):
        _write_text("half")(tmp)
        raise OSError("disk full")
    with pytest.raises(OSError, match="disk full"):
        atomic_write(target, write)
    assert target.read_text() == "precious"
    assert _temporaries(tmp_path) == []


@pytest.mark.parametrize("mode", [0o600, 0o640, 0o604, 0o755])
def test_replacing_keeps_the_mode(tmp_path, mode):
    target = tmp_path / "out.txt"
    target.write_text("old")
    os.chmod(target, mode)
    atomic_write(target, _write_text("new"))
    assert target.read_text() == "new"
    assert os.stat(target).st_mode & 0o7777 == mode


def test_new_file_gets_the_umask_default(tmp_path):
    old = os.umask(0o027)
    try:
        atomic_write(tmp_path / "a.txt", _write_text("x"))
        with open(tmp_path / "plain.txt", "w") as f:
            f.write("x")
    finally:
        os.umask(old)
    assert os.stat(tmp_path / "a.txt").st_mode & 0o777 == 0o640
    assert os.stat(tmp_path / "plain.txt").st_mode & 0o777 == 0o640


def test_symlink_is_written_through(tmp_path):
    real_dir = tmp_path / "data"
    real_dir.mkdir()
    real = real_dir / "real.h5"
    real.write_text("old")
    os.chmod(real, 0o600)
    link = tmp_path / "link.h5"
    link.symlink_to(real)
    seen = []

    def write(tmp):
        seen.append(tmp)
        _write_text("new")(tmp)
    atomic_write(link, write)
    assert link.is_symlink() and os.readlink(link) == str(real)
    assert real.read_text() == "new" and link.read_text() == "new"
    assert os.path.dirname(seen[0]) == str(real_dir)          # temporary beside the real file
    assert os.stat(real).st_mode & 0o777 == 0o600
    assert _temporaries(real_dir) == [] and _temporaries(tmp_path) == []


def test_relative_symlink_chain_and_dangling_link(tmp_path):
    (tmp_path / "real.txt").write_text("old")
    os.symlink("real.txt", tmp_path / "mid.txt")
    os.symlink("mid.txt", tmp_path / "top.txt")
    atomic_write(tmp_path / "top.txt", _write_text("new"))
    assert (tmp_path / "real.txt").read_text() == "new"
    assert (tmp_path / "top.txt").is_symlink() and (tmp_path / "mid.txt").is_symlink()
    os.symlink("missing.txt", tmp_path / "dangling.txt")
    atomic_write(tmp_path / "dangling.txt", _write_text("made"))
    assert (tmp_path / "dangling.txt").is_symlink()
    assert (tmp_path / "missing.txt").read_text() == "made"


def test_hard_links_are_split_as_documented(tmp_path):
    """Replacing by rename: the written path has the new data, the other link keeps the old (documented)."""
    target = tmp_path / "a.txt"
    target.write_text("old")
    os.link(target, tmp_path / "b.txt")
    atomic_write(target, _write_text("new"))
    assert target.read_text() == "new"
    assert (tmp_path / "b.txt").read_text() == "old"
    import cgbound._atomic
    assert "Hard links" in cgbound._atomic.__doc__


def test_stale_temporaries_of_dead_writers_are_removed_on_next_write(tmp_path):
    target = tmp_path / "out.txt"
    target.write_text("old")
    # a process that has exited: its pid is free (for the time of this test)
    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait()
    stale = tmp_path / f"{temporary_prefix(str(target))}{dead.pid}-deadbeef.txt"
    stale.write_text("partial")
    alive = tmp_path / f"{temporary_prefix(str(target))}{os.getppid()}-cafebabe.txt"   # a running process
    alive.write_text("in progress")
    other = tmp_path / f"{temporary_prefix(str(tmp_path / 'other.txt'))}{dead.pid}-deadbeef.txt"
    other.write_text("another target's")
    atomic_write(target, _write_text("new"))
    assert not stale.exists()
    assert alive.exists() and other.exists()
    assert target.read_text() == "new"


_CHILD = textwrap.dedent("""
    import sys, time
    from cgbound._atomic import atomic_write
    def write(tmp):
        with open(tmp, "wb") as f:
            f.write(b"x" * 100000)
            f.flush()
            print("writing", flush=True)
            time.sleep(60)
    atomic_write(sys.argv[1], write)
""")


@pytest.mark.parametrize("kind", ["plain", "hdf5"])
def test_sigkill_mid_write_keeps_the_target_and_next_write_cleans_up(tmp_path, kind):
    target = tmp_path / ("fields.h5" if kind == "hdf5" else "fields.npz")
    import cgbound as cg
    box = cg.Box([0, 0, 0], [1, 1, 1])
    snap = cg.Snapshot([[0.5, 0.5, 0.5]], velocities=[[1.0, 0, 0]], masses=[1.0], box=box)
    out = cg.coarse_grain(snap, cg.Grid(box, (2, 2, 2)), cg.Lucy(0.5), fields=("density",))
    (out.to_hdf5 if kind == "hdf5" else out.to_npz)(target)
    before = target.read_bytes()
    # the child imports the cgbound this test imported (the installed one in CI, not the uncompiled checkout)
    env = dict(os.environ, PYTHONPATH=os.path.dirname(os.path.dirname(os.path.abspath(cg.__file__))))
    child = subprocess.Popen([sys.executable, "-c", _CHILD, str(target)], stdout=subprocess.PIPE, env=env,
                             cwd=tmp_path)
    try:
        assert child.stdout.readline().strip() == b"writing"
        assert len(_temporaries(tmp_path)) == 1
        os.kill(child.pid, signal.SIGKILL)
    finally:
        child.wait(timeout=30)
        child.stdout.close()
    assert child.returncode == -signal.SIGKILL
    assert target.read_bytes() == before                      # the target survived intact
    leftover = _temporaries(tmp_path)
    assert len(leftover) == 1 and leftover[0].startswith(f".{target.name}{TMP_MARK}{child.pid}-")
    (out.to_hdf5 if kind == "hdf5" else out.to_npz)(target)    # the next write cleans up
    assert _temporaries(tmp_path) == []
    if kind == "hdf5":
        import h5py
        with h5py.File(target, "r") as f:
            rho = f["fields/density"][()]
    else:
        rho = np.load(target)["density"]
    np.testing.assert_array_equal(rho, out["density"])


def test_remove_stale_temporaries_ignores_unrelated_and_malformed_names(tmp_path):
    target = str(tmp_path / "t.txt")
    (tmp_path / f"{temporary_prefix(target)}notapid-x").write_text("?")
    (tmp_path / ".cgbound-abc.txt").write_text("old-style")
    assert remove_stale_temporaries(target) == []
    assert len(list(tmp_path.iterdir())) == 2


@pytest.mark.skipif(os.geteuid() == 0, reason="root writes into read-only directories")
def test_read_only_directory_is_a_named_permission_error(tmp_path):
    target = tmp_path / "out.txt"
    target.write_text("old")
    os.chmod(tmp_path, 0o500)
    try:
        with pytest.raises(PermissionError, match="path: cannot create a file"):
            atomic_write(target, _write_text("new"))
    finally:
        os.chmod(tmp_path, 0o700)
    assert target.read_text() == "old"


@pytest.mark.parametrize("bad, kind", [(None, TypeError), (3, TypeError), ("", ValueError)])
def test_bad_paths_are_named(bad, kind):
    with pytest.raises(kind, match="^path: "):
        atomic_write(bad, _write_text("x"))


def test_directory_and_missing_directory_are_named(tmp_path):
    with pytest.raises(IsADirectoryError, match="path: expected a file name"):
        atomic_write(tmp_path, _write_text("x"))
    with pytest.raises(FileNotFoundError, match="path: the directory"):
        atomic_write(tmp_path / "missing" / "x.txt", _write_text("x"))
