"""open_dataset: several files, glob patterns (numeric order), gzip-compressed files, any format."""
import gzip
import os
import shutil

import numpy as np
import pytest

from cgbound.readers import LammpsReader, MercuryReader, open_dataset

DATA = os.path.join(os.path.dirname(__file__), "data")
ATOMS, PAIRS = (os.path.join(DATA, "lammps", "hooke3d", f) for f in ("atoms.dump", "pairs.dump"))
GRAN = ("dist", "fx", "fy", "fz", "p1", "p2", "p3", "p4")
LAMMPS = dict(pair_values=GRAN, fixed_types=[2], walls=["w"], body_force=(0, 0, -1))
MERCURY = os.path.join(DATA, "mercurydpm", "ChutePeriodicDemo", "ChutePeriodicDemo")


def same_frames(a, b):
    assert len(a) == len(b)
    for k in range(len(a)):
        x, y = a[k], b[k]
        assert x.time == y.time
        for name in ("positions", "velocities", "masses", "fixed"):
            np.testing.assert_array_equal(getattr(x, name), getattr(y, name))
        for name in ("i", "j", "force", "point"):
            np.testing.assert_array_equal(getattr(x.contacts, name), getattr(y.contacts, name))


def split_lammps(path, directory, stem, names, compress=False):
    text = open(path).read()
    frames = ["ITEM: TIMESTEP" + part for part in text.split("ITEM: TIMESTEP")[1:]]
    for frame, name in zip(frames, names):
        target = directory / f"{stem}.{name}.dump"
        if compress:
            with gzip.open(str(target) + ".gz", "wt") as f:
                f.write(frame)
        else:
            target.write_text(frame)


@pytest.mark.parametrize("compress", [False, True], ids=["plain", "gzip"])
def test_lammps_per_frame_files_in_numeric_order_equal_the_single_file(tmp_path, compress):
    names = ["900", "1000", "20000"]            # string order would put 1000 first
    split_lammps(ATOMS, tmp_path, "atoms", names, compress)
    split_lammps(PAIRS, tmp_path, "pairs", names, compress)
    ext = ".dump.gz" if compress else ".dump"
    frames = open_dataset(str(tmp_path / f"atoms.*{ext}"), pairs=str(tmp_path / f"pairs.*{ext}"), **LAMMPS)
    same_frames(frames, LammpsReader(ATOMS, PAIRS, **LAMMPS))
    listed = open_dataset([tmp_path / f"atoms.{n}{ext}" for n in names],
                          pairs=[tmp_path / f"pairs.{n}{ext}" for n in names], **LAMMPS)
    same_frames(listed, frames)


def test_files_whose_numbers_contradict_their_timesteps_are_refused(tmp_path):
    split_lammps(ATOMS, tmp_path, "atoms", ["2", "1"])
    with pytest.raises(ValueError, match="first timestep 4500.*do not come after"):
        open_dataset(str(tmp_path / "atoms.*.dump"))


def test_missing_files_and_mismatched_contact_files_are_named(tmp_path):
    with pytest.raises(FileNotFoundError, match="paths: the pattern .* matches no file"):
        open_dataset(str(tmp_path / "none.*.dump"))
    split_lammps(ATOMS, tmp_path, "atoms", ["1", "2", "3"])
    split_lammps(PAIRS, tmp_path, "pairs", ["1", "2"])
    with pytest.raises(ValueError, match=r"pairs: expected one contact file per particle file \(3\), got 2"):
        open_dataset(str(tmp_path / "atoms.*.dump"), pairs=str(tmp_path / "pairs.*.dump"), **{
            k: v for k, v in LAMMPS.items()})
    with pytest.raises(ValueError, match="format: expected one of"):
        open_dataset(ATOMS, format="xyz")


def test_gzipped_mercurydpm_output_reads_as_the_plain_files(tmp_path):
    for ext in (".data", ".fstat", ".restart"):
        with open(MERCURY + ext, "rb") as src, gzip.open(tmp_path / f"c{ext}.gz", "wb") as dst:
            shutil.copyfileobj(src, dst)
    gz = open_dataset(str(tmp_path / "c.data.gz"), fstat_path=tmp_path / "c.fstat.gz",
                      restart_path=tmp_path / "c.restart.gz")
    plain = MercuryReader(MERCURY + ".data", MERCURY + ".fstat", restart_path=MERCURY + ".restart")
    same_frames(gz, plain)


def test_mercurydpm_multiple_files_read_as_one_file(tmp_path):
    # -fileType multiple: name.data.0, name.data.1, ... (and name.fstat.N), one frame each
    data = open(MERCURY + ".data").read().splitlines(keepends=True)
    k = frame = 0
    while k < len(data):
        n = int(data[k].split()[0])
        (tmp_path / f"c.data.{frame}").write_text("".join(data[k:k + n + 1]))
        k, frame = k + n + 1, frame + 1
    fstat = open(MERCURY + ".fstat").read().splitlines(keepends=True)
    starts, i = [], 0
    while i < len(fstat):                      # a frame: three '#' header lines, then its contacts
        if fstat[i].startswith("#"):
            starts.append(i)
            i += 3
        else:
            i += 1
    for f, (a, b) in enumerate(zip(starts, starts[1:] + [len(fstat)])):
        (tmp_path / f"c.fstat.{f}").write_text("".join(fstat[a:b]))
    assert frame == len(starts) == 10
    multi = open_dataset(str(tmp_path / "c.data.*"), fstat_path=str(tmp_path / "c.fstat.*"),
                         restart_path=MERCURY + ".restart")
    plain = MercuryReader(MERCURY + ".data", MERCURY + ".fstat", restart_path=MERCURY + ".restart")
    same_frames(multi, plain)
