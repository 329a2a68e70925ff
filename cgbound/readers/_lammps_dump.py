"""LAMMPS text dumps (``dump custom`` and ``dump local``; also LIGGGHTS'): frames found by a scan of
byte offsets, one frame read at a time into a table of named columns."""
import numpy as np

from .files import open_input

__all__ = ["Table", "TextTable", "read_dump_frame", "scan_dump"]


def scan_dump(path, kind):
    """Byte offsets of the frames of a LAMMPS text dump: list of (offset, timestep)."""
    count_item = "ITEM: NUMBER OF ATOMS" if kind == "atoms" else "ITEM: NUMBER OF ENTRIES"
    frames = []
    with open_input(path) as fh:
        while True:
            offset = fh.tell()
            line = fh.readline()
            if not line:
                break
            if not line.strip():
                continue
            if not line.startswith(b"ITEM: TIMESTEP"):
                raise ValueError(f"{path}: expected 'ITEM: TIMESTEP' at byte {offset}, got {line[:60]!r}")
            timestep = int(fh.readline().split()[0])
            n = None
            while True:
                line = fh.readline()
                if not line:
                    raise ValueError(f"{path}: truncated frame at timestep {timestep}")
                text = line.decode()
                if text.startswith(count_item):
                    n = int(fh.readline().split()[0])
                elif text.startswith("ITEM: NUMBER OF"):
                    other = "dump local" if kind == "atoms" else "dump custom (atoms)"
                    raise ValueError(f"{path}: found {text.strip()!r}; this looks like a {other} file")
                elif text.startswith("ITEM: ATOMS") or text.startswith("ITEM: ENTRIES"):
                    break
            if n is None:
                raise ValueError(f"{path}: no '{count_item}' in the frame at timestep {timestep}")
            for _ in range(n):
                row = fh.readline()
                if not row.endswith(b"\n"):
                    raise ValueError(f"{path}: truncated frame at timestep {timestep}: expected {n} rows")
            frames.append((offset, timestep))
    return frames


def read_dump_frame(path, offset):
    """One frame: dict with timestep, time (or None), box bounds/flags, column names and rows."""
    with open_input(path) as fh:
        fh.seek(offset)
        head = {"time": None, "bounds": None, "flags": None, "triclinic": False}
        line = fh.readline().decode()
        assert line.startswith("ITEM: TIMESTEP")
        head["timestep"] = int(fh.readline().split()[0])
        n = 0
        while True:
            text = fh.readline().decode()
            if text.startswith("ITEM: TIME"):
                head["time"] = float(fh.readline().split()[0])
            elif text.startswith("ITEM: NUMBER OF"):
                n = int(fh.readline().split()[0])
            elif text.startswith("ITEM: BOX BOUNDS"):
                words = text.split()[3:]
                if words[:3] == ["xy", "xz", "yz"]:
                    head["triclinic"] = True
                    words = words[3:]
                head["flags"] = words
                rows = [fh.readline().split() for _ in range(3)]
                head["bounds"] = np.array([[float(v) for v in r[:2]] for r in rows])
            elif text.startswith("ITEM: ATOMS") or text.startswith("ITEM: ENTRIES"):
                head["columns"] = text.split()[2:]
                break
            elif not text:
                raise ValueError(f"{path}: truncated frame at byte {offset}")
        raw = b"".join(fh.readline() for _ in range(n))
    ncol = len(head["columns"])
    values = np.fromstring(raw.decode(), sep=" ") if n else np.zeros(0)
    if values.size != n * ncol:
        # non-numeric columns (e.g. element names): convert column by column when asked
        table = np.array(raw.decode().split(), dtype=object).reshape(n, ncol)
        head["data"] = TextTable(table, head["columns"])
    else:
        head["data"] = Table(values.reshape(n, ncol), head["columns"])
    head["n"] = n
    return head


class Table:
    """The numeric table of a frame: a column by its header name, as float64."""

    def __init__(self, values, columns):
        self.values = values
        self.index = {c: k for k, c in enumerate(columns)}

    def __contains__(self, name):
        return name in self.index

    def __getitem__(self, name):
        return np.asarray(self.values[:, self.index[name]], dtype=float)


class TextTable(Table):
    """A table with non-numeric columns (e.g. element names): a column is converted when asked for."""

    def __getitem__(self, name):
        try:
            return np.asarray(self.values[:, self.index[name]], dtype=float)
        except ValueError:
            raise ValueError(f"column {name!r} is not numeric") from None
