"""MercuryDPM and HDF5 readers: the C text layer's tables against np.loadtxt on the genuine files (bit for
bit), gzip equal to plain, and every damaged file an error naming the file, the frame and the line."""
import gzip
import os
import shutil

import h5py
import numpy as np
import pytest

import cgbound as cg
from cgbound.readers import HDF5Snapshots, open_dataset, write_snapshots
from cgbound.readers._mercury_files import fstat_rows, read_particles, scan_data, scan_fstat
from cgbound.readers.mercury import MercuryReader
from test_mercury_reader import DATA3, FSTAT3, RESTART3

HERE = os.path.dirname(__file__)
STEM = os.path.join(HERE, "data", "mercurydpm", "ChutePeriodicDemo", "ChutePeriodicDemo")
CG_STEM = os.path.join(HERE, "data", "mercurycg", "ChutePeriodicDemo_t15")


def lines_of(path):
    with open(path, "rb") as f:
        return f.read().split(b"\n")


def loadtxt(lines, ncols):
    return np.loadtxt([line.decode() for line in lines if line.strip()], ndmin=2, usecols=range(ncols))


@pytest.mark.parametrize("stem", [STEM, CG_STEM])
def test_data_frames_equal_loadtxt_bit_for_bit(stem):
    lines = lines_of(stem + ".data")
    frames = scan_data(stem + ".data", None)
    assert sum(1 + f[2] for f in frames) == len([line for line in lines if line.strip()])
    for offset, lineno, n, time, dim, head, start, stop in frames:
        assert float(lines[lineno - 1].split()[1]) == time
        _, lower, upper, table, species = read_particles(stem + ".data", (lineno, time, head), n, dim, start, stop)
        expected = loadtxt(lines[lineno:lineno + n], 14)
        assert table.tobytes() == expected.tobytes()
        assert species.dtype == np.int64 and np.array_equal(species, expected[:, 13])
        assert lower.tolist() == [float(w) for w in lines[lineno - 1].split()[2:5]]


@pytest.mark.parametrize("stem", [STEM, CG_STEM])
def test_fstat_frames_equal_loadtxt_bit_for_bit(stem):
    lines = lines_of(stem + ".fstat")
    frames = scan_fstat(stem + ".fstat")
    headers = [k + 1 for k, line in enumerate(lines) if line.startswith(b"#")]
    assert [f[1] for f in frames] == headers[::3]
    total = 0
    for k, (offset, lineno, time, marker, start, stop, first) in enumerate(frames):
        end = frames[k + 1][1] - 1 if k + 1 < len(frames) else len(lines)
        body = [line for line in lines[first - 1:end] if line.strip()]
        with fstat_rows(stem + ".fstat", time, start, stop, first) as (rows, ints, line_of):
            if not body:
                assert rows is None
                continue
            expected = loadtxt(body, 16)
            assert rows.tobytes() == expected.tobytes()
            assert ints.dtype == np.int64 and np.array_equal(ints, expected[:, 1:3])
            assert lines[line_of(len(body) - 1) - 1] == body[-1]
        total += len(body)
    assert total == len([line for line in lines if line.strip() and not line.startswith(b"#")])


def frames_equal(a, b):
    assert len(a) == len(b)
    for k in range(len(a)):
        fa, fb = a.frame(k), b.frame(k)
        sa, sb = fa.snapshot, fb.snapshot
        for name in ("positions", "velocities", "masses", "fixed", "species", "radii"):
            assert getattr(sa, name).tobytes() == getattr(sb, name).tobytes()
        for name in ("i", "j", "force", "point"):
            assert getattr(sa.contacts, name).tobytes() == getattr(sb.contacts, name).tobytes()
        assert fa.wall_index.tobytes() == fb.wall_index.tobytes() and fa.overlap.tobytes() == fb.overlap.tobytes()
        assert sa.time == sb.time and (fa.data_line, fa.fstat_line) == (fb.data_line, fb.fstat_line)


def test_gzip_equals_plain_bit_for_bit(tmp_path):
    for ext in (".data", ".fstat", ".restart"):
        with open(STEM + ext, "rb") as src, gzip.open(tmp_path / ("c" + ext), "wb") as dst:
            shutil.copyfileobj(src, dst)
    plain = MercuryReader(STEM + ".data", STEM + ".fstat", restart_path=STEM + ".restart")
    packed = MercuryReader(tmp_path / "c.data", tmp_path / "c.fstat", restart_path=tmp_path / "c.restart")
    frames_equal(plain, packed)
    assert sum(len(packed[k].contacts) for k in range(len(packed))) > 1000


def write(tmp_path, **files):
    out = {}
    for name, text in files.items():
        (tmp_path / name).write_bytes(text.encode() if isinstance(text, str) else text)
        out[name] = str(tmp_path / name)
    return out


def read_all(data, fstat=None, **options):
    reader = MercuryReader(data, fstat, **({"density": 1.0} | options))
    return [reader[k] for k in range(len(reader))]


def test_hand_files_still_read(tmp_path):
    f = write(tmp_path, **{"d.data": DATA3, "d.fstat": FSTAT3})
    frames = read_all(f["d.data"], f["d.fstat"], fixed=[2])
    assert [len(s.contacts) for s in frames] == [0, 4]
    with pytest.raises(ValueError, match=r"d\.fstat:9: the pair \(0, 2\) of two flowing particles is listed once; "
                                         r".*a line of the file was lost"):
        read_all(f["d.data"], f["d.fstat"])          # particle 2 taken as flowing: its pair line is one-sided


def test_fstat_whose_last_frame_lost_its_lines_is_an_error(tmp_path):
    lines = FSTAT3.splitlines(keepends=True)
    # frame 0 given one contact line (so earlier frames have contacts), then the last frame cut after its header
    text = "".join(lines[:3]) + "0 0 2 0 0.45 0.45 0.1 0 0 0 0 -1 0 0 0 0\n" + "".join(lines[3:6])
    f = write(tmp_path, **{"d.data": DATA3, "d.fstat": text})
    with pytest.raises(ValueError, match=r"d\.fstat:5: the last frame \(t = 0\.1\) has no interaction lines .*"
                                         r"truncated"):
        MercuryReader(f["d.data"], f["d.fstat"], density=1.0)
    # genuine file: the last frame's lines removed
    lines = lines_of(STEM + ".fstat")
    last = max(k for k, line in enumerate(lines) if line.startswith(b"#"))
    f = write(tmp_path, **{"g.fstat": b"\n".join(lines[:last + 1]) + b"\n"})
    with pytest.raises(ValueError, match=rf"g\.fstat:{last - 1}: the last frame \(t = 20\.0001\) has no interaction"):
        MercuryReader(STEM + ".data", f["g.fstat"], restart_path=False, density=1.0)


def test_blank_line_inside_an_fstat_header_is_an_error(tmp_path):
    f = write(tmp_path, **{"d.data": DATA3, "d.fstat": FSTAT3.replace("# 0.1 1\n", "# 0.1 1\n\n")})
    with pytest.raises(ValueError, match=r"d\.fstat:1: 4 '#' header lines in a row where \.fstat frames have 3"):
        MercuryReader(f["d.data"], f["d.fstat"], density=1.0)
    lines = lines_of(STEM + ".fstat")
    k = [i for i, line in enumerate(lines) if line.startswith(b"#")][7]      # inside the third frame's header
    f = write(tmp_path, **{"g.fstat": b"\n".join(lines[:k] + [b""] + lines[k:])})
    with pytest.raises(ValueError, match=rf"g\.fstat:\d+: \d '#' header lines? in a row"):
        MercuryReader(STEM + ".data", f["g.fstat"], restart_path=False, density=1.0)


def test_fstat_line_of_another_frame_is_an_error(tmp_path):
    text = FSTAT3.replace("0.1 0 -1 0 0 0", "0.2 0 -1 0 0 0")
    f = write(tmp_path, **{"d.data": DATA3, "d.fstat": text})
    with pytest.raises(ValueError, match=r"d\.fstat:10: an interaction line of time 0\.2 in the frame of time 0\.1"):
        read_all(f["d.data"], f["d.fstat"])


def test_truncated_restart_is_an_error(tmp_path):
    cut = RESTART3[:RESTART3.index("Particles 3")]
    f = write(tmp_path, **{"d.data": DATA3, "c.restart": cut, "m.restart": cut + "Particles 3\nSpherical"})
    with pytest.raises(ValueError, match=r"c\.restart: no 'Particles N' line: a truncated or damaged \.restart"):
        MercuryReader(f["d.data"], restart_path=f["c.restart"])
    with pytest.raises(ValueError, match=r"m\.restart:\d+: 'Particles 3' but 0 particle lines follow"):
        MercuryReader(f["d.data"], restart_path=f["m.restart"])
    lines = open(STEM + ".restart").read().splitlines(keepends=True)
    k = next(i for i, line in enumerate(lines) if line.startswith("Particles"))
    f = write(tmp_path, **{"g.restart": "".join(lines[:k])})
    with pytest.raises(ValueError, match=r"g\.restart: no 'Particles N' line"):
        MercuryReader(STEM + ".data", False, restart_path=f["g.restart"])


@pytest.mark.parametrize("change, got", [(" 0.5 0 0 0 0 0 0 0\n", 15), (" 0 0 0 0 0 0 0\n", 13)])
def test_data_row_with_an_extra_or_missing_value_is_an_error(tmp_path, change, got):
    row = "0.9 0 0.45 0 0 0"
    text = DATA3.replace(row + " 0.5 0 0 0 0 0 0 0\n", row + (" 0" + change if got == 15 else change), 1)
    f = write(tmp_path, **{"d.data": text})
    with pytest.raises(ValueError, match=rf"d\.data:3: expected 14 columns for a 3D \.data particle line, got {got} "
                                         rf"\(frame t = 0\): a value is missing or extra"):
        read_all(f["d.data"])


def test_genuine_data_row_with_an_extra_value_is_an_error(tmp_path):
    lines = lines_of(STEM + ".data")
    lines[5] = lines[5].replace(b" 0.5 ", b" 0.5 0.5 ", 1)
    f = write(tmp_path, **{"g.data": b"\n".join(lines)})
    with pytest.raises(ValueError, match=r"g\.data:6: expected 14 columns .* got 15"):
        MercuryReader(f["g.data"], density=1.0)[0]


def test_truncated_data_frame_is_an_error(tmp_path):
    text = "".join(DATA3.splitlines(keepends=True)[:-1])
    f = write(tmp_path, **{"d.data": text})
    with pytest.raises(ValueError, match=r"d\.data:5: the frame at t = 0\.1 declares 3 particles but only 2 lines "
                                         r"follow: the file is truncated"):
        MercuryReader(f["d.data"], density=1.0)


@pytest.mark.parametrize("content", [b"", b"  \n\t\n", b"\n"])
@pytest.mark.parametrize("ext", ["data", "fstat", "restart"])
def test_empty_or_whitespace_file_is_an_error(tmp_path, content, ext):
    f = write(tmp_path, **{"d.data": DATA3, "d.fstat": FSTAT3, "d.restart": RESTART3})
    (tmp_path / f"d.{ext}").write_bytes(content)
    with pytest.raises(ValueError, match=rf"d\.{ext}: the file is empty or holds only whitespace"):
        MercuryReader(f["d.data"], f["d.fstat"], restart_path=f["d.restart"])


def test_bad_bytes_and_nonfinite_values_are_value_errors_naming_the_line(tmp_path):
    f = write(tmp_path, **{"a.data": DATA3.replace("0 0.9 0.45", "0 0.9 0.4\xe95").encode("latin-1"),
                           "b.data": DATA3.replace("0.9 0 0.45 0 2 0", "0.9 0 0.45 0 nan 0"),
                           "c.data": DATA3.replace("0 0.9 0.45 0 0 0 0.5 0 0 0 0 0 0 1\n", "0 0.9 0.45 0 0 0 0.5 0 0 "
                                                   "0 0 0 0 1.5\n", 1),
                           "d.fstat": FSTAT3.replace("0.1 1 -2", "0.1 1.0 -2"),
                           "e.data": DATA3.replace("3 0.1 -1", "3 0.1\xff -1").encode("latin-1")})
    with pytest.raises(ValueError, match=r"a\.data \(t = 0\), line 4, column 3: not a number: .*0\.4"):
        read_all(f["a.data"])
    with pytest.raises(ValueError, match=r"b\.data \(t = 0\.1\), line 7, column 5: non-finite value 'nan'"):
        read_all(f["b.data"])
    with pytest.raises(ValueError, match=r"c\.data \(t = 0\), line 4, column 14: .*'1\.5'"):
        read_all(f["c.data"])
    with pytest.raises(ValueError, match=r"d\.fstat \(t = 0\.1\), line 11, column 2: .*'1\.0'"):
        read_all(write(tmp_path, **{"x.data": DATA3})["x.data"], f["d.fstat"])
    with pytest.raises(ValueError, match=r"e\.data \(a frame header\), line 5, column 2"):
        MercuryReader(f["e.data"], density=1.0)


def test_multi_file_output_and_the_structure_checks_per_file(tmp_path):
    parts = DATA3.splitlines(keepends=True)
    f = write(tmp_path, **{"m.data.0": "".join(parts[:4]), "m.data.1": "".join(parts[4:]),
                           "m.fstat.0": "".join(FSTAT3.splitlines(keepends=True)[:3]),
                           "m.fstat.1": "".join(FSTAT3.splitlines(keepends=True)[3:])})
    multi = open_dataset(str(tmp_path / "m.data.*"), fstat_path=str(tmp_path / "m.fstat.*"), density=1.0,
                         fixed=[2])
    single = write(tmp_path, **{"s.data": DATA3, "s.fstat": FSTAT3})
    one = MercuryReader(single["s.data"], single["s.fstat"], density=1.0, fixed=[2])
    assert len(multi) == 2
    for a, b in zip(multi, one):
        assert a.positions.tobytes() == b.positions.tobytes()
        assert a.contacts.force.tobytes() == b.contacts.force.tobytes()
    (tmp_path / "m.fstat.1").write_text("".join(FSTAT3.splitlines(keepends=True)[3:5]))
    with pytest.raises(ValueError, match=r"m\.fstat\.1:1: 2 '#' header lines in a row"):
        open_dataset(str(tmp_path / "m.data.*"), fstat_path=str(tmp_path / "m.fstat.*"), density=1.0, fixed=[2])


# --- HDF5 ----------------------------------------------------------------------------------------

def snapshots(n=3):
    rng = np.random.default_rng(1)
    box = cg.Box([0, 0, 0], [2, 2, 2], periodic=(True, False, False))
    return [cg.Snapshot(rng.uniform(0, 2, (5, 3)), rng.normal(size=(5, 3)), np.ones(5), box=box, time=float(k))
            for k in range(n)]


@pytest.fixture
def h5file(tmp_path):
    path = tmp_path / "s.h5"
    write_snapshots(path, snapshots())
    return path


def test_hdf5_reads_back(h5file):
    back = HDF5Snapshots(h5file)
    assert [s.time for s in back] == [0.0, 1.0, 2.0] and back[0].box.periodic == (True, False, False)


@pytest.mark.parametrize("value", [np.array([b"no", b"no", b"no"]), np.array([b"yes", b"", b"no"], dtype="S3"),
                                   np.array([0.5, 0, 0]), np.array([2, 0, 0]), np.array(True)])
def test_hdf5_periodic_attribute_of_the_wrong_type_is_refused(h5file, value):
    with h5py.File(h5file, "r+") as f:
        f["box"].attrs["periodic"] = value
    reader = HDF5Snapshots(h5file)
    with pytest.raises(ValueError, match=r"s\.h5: /box: attribute 'periodic' should hold booleans"):
        reader[0]


@pytest.mark.parametrize("name, value, kind", [("lower", np.array([b"0", b"0", b"0"]), "finite numbers"),
                                               ("upper", np.array([2.0, np.nan, 2.0]), "finite numbers")])
def test_hdf5_box_attributes_are_type_checked(h5file, name, value, kind):
    with h5py.File(h5file, "r+") as f:
        f["box"].attrs[name] = value
    with pytest.raises(ValueError, match=rf"s\.h5: /box: attribute '{name}' should hold {kind}"):
        HDF5Snapshots(h5file)[1]


def test_hdf5_time_and_schema_version_are_type_checked(h5file):
    with h5py.File(h5file, "r+") as f:
        f["frames/000001"].attrs["time"] = b"soon"
    with pytest.raises(ValueError, match=r"s\.h5: frame 000001: attribute 'time' should hold a finite number"):
        HDF5Snapshots(h5file)[1]
    with h5py.File(h5file, "r+") as f:
        f.attrs["schema_version"] = "one"
    with pytest.raises(ValueError, match=r"s\.h5: the file: attribute 'schema_version' should hold an integer"):
        HDF5Snapshots(h5file)


def test_hdf5_truncated_or_damaged_file_is_an_oserror_naming_it(h5file, tmp_path):
    data = h5file.read_bytes()
    cut = tmp_path / "cut.h5"
    cut.write_bytes(data[:len(data) // 2])
    with pytest.raises(OSError, match=r"cut\.h5: cannot open it as HDF5 .*damaged, truncated"):
        HDF5Snapshots(cut)
    junk = tmp_path / "junk.h5"
    junk.write_bytes(b"not hdf5 at all\n" * 10)
    with pytest.raises(OSError, match=r"junk\.h5: cannot open it as HDF5"):
        HDF5Snapshots(junk)
    with pytest.raises(FileNotFoundError):
        HDF5Snapshots(tmp_path / "absent.h5")


def test_hdf5_missing_dataset_is_a_value_error_naming_file_and_frame(h5file):
    with h5py.File(h5file, "r+") as f:
        del f["frames/000002/masses"]
    reader = HDF5Snapshots(h5file)
    with pytest.raises(ValueError, match=r"s\.h5: frame 000002 has no 'masses'"):
        reader[2]
