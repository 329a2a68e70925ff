"""MercuryDPM text files (layouts in cgbound/readers/mercury.py): frames of ``.data`` and ``.fstat``
found by a scan, one frame read at a time; the keys of a ``.restart``."""
import numpy as np

from .files import open_input

__all__ = ["DATA_COLUMNS", "FSTAT_COLUMNS", "read_fstat_rows", "read_particles", "read_restart", "scan_data",
           "scan_fstat"]

DATA_COLUMNS = {3: 14, 2: 8}
FSTAT_COLUMNS = 16


def parse_floats(words, path, lineno):
    try:
        return [float(w) for w in words]
    except ValueError:
        raise ValueError(f"{path}:{lineno}: expected numbers, got {' '.join(words)[:80]!r}") from None


def _numbered_lines(fh, lineno=0):
    """(byte offset, line number, line) of each line of a binary file from its current position;
    the first line gets ``lineno + 1``."""
    while True:
        offset = fh.tell()
        line = fh.readline()
        if not line:
            return
        lineno += 1
        yield offset, lineno, line


def scan_data(path, dim):
    """Frames of a .data file: list of (byte offset of the header, line number, n, time, dim)."""
    frames = []
    with open_input(path) as fh:
        lines = _numbered_lines(fh)
        for offset, lineno, line in lines:
            words = line.split()
            if not words or words[0].startswith(b"#"):
                continue
            head = parse_floats([w.decode() for w in words], path, lineno)
            if len(head) not in (6, 8):
                raise ValueError(f"{path}:{lineno}: expected a header 'N time xmin ymin [zmin] xmax ymax [zmax]' "
                                 f"(6 values in 2D, 8 in 3D), got {len(head)} values")
            d = 3 if len(head) == 8 else 2
            if dim is not None and d != dim:
                raise ValueError(f"{path}:{lineno}: a {d}D header, but dim={dim} was given")
            n = head[0]
            if n != int(n) or n < 0:
                raise ValueError(f"{path}:{lineno}: expected a particle count, got {words[0].decode()!r}")
            n = int(n)
            frames.append((offset, lineno, n, head[1], d))
            for _ in range(n):
                row = next(lines, (None, None, b""))[2]
                if not row.endswith(b"\n") and not row.strip():
                    raise ValueError(f"{path}: truncated frame at t = {head[1]}: expected {n} particle lines")
    return frames


def scan_fstat(path):
    """Frames of a .fstat file: list of (byte offset of the first header line, line number, time, marker)."""
    frames = []
    with open_input(path) as fh:
        in_header = 0   # header lines seen in the current block (3 per frame)
        for offset, lineno, line in _numbered_lines(fh):
            if line.startswith(b"#"):
                if in_header in (0, 3):
                    words = line[1:].split()
                    vals = parse_floats([w.decode() for w in words[:2]], path, lineno)
                    if not vals:
                        raise ValueError(f"{path}:{lineno}: expected '# time marker', got {line[:60]!r}")
                    marker = int(vals[1]) if len(vals) > 1 else 0
                    frames.append((offset, lineno, vals[0], marker))
                    in_header = 0
                in_header += 1
                continue
            in_header = 0
            if line.strip() and not frames:
                raise ValueError(f"{path}:{lineno}: contact line before the first '# time' header")
    return frames


def read_restart(path):
    """Key-based parse of a .restart: species densities, the particles' invMass and positions (by id),
    periodic normals.

    Particles are the lines of the ``Particles N`` section whose first word names a particle class
    (``BaseParticle``, ``SphericalParticle``, ...); other lines with particle keys, such as the
    template particle embedded in an insertion boundary's line, are not particles. A section with
    fewer than N particle lines (a truncated file) is an error.
    """
    density, normals, particle_dim = {}, [], None
    inv_mass, positions = [], []
    declared, declared_line = None, None
    with open_input(path, text=True) as fh:
        for lineno, line in enumerate(fh, 1):
            words = line.split()
            if not words:
                continue
            keys = {w: k for k, w in reversed(list(enumerate(words)))}

            def val(key, n=1):
                k = keys[key]
                return [float(x) for x in words[k + 1:k + 1 + n]]

            if words[0] == "Particles" and len(words) == 2 and words[1].isdigit():
                declared, declared_line = int(words[1]), lineno
                continue
            try:
                if "particleDimensions" in keys:
                    particle_dim = int(val("particleDimensions")[0])
                if "density" in keys and "id" in keys and words[0].endswith("Species"):
                    density[int(val("id")[0])] = val("density")[0]
                elif words[0].endswith("Particle") and "invMass" in keys and "position" in keys:
                    inv_mass.append(val("invMass")[0])
                    positions.append(val("position", 3))
                elif words[0] == "PeriodicBoundary" and "normal" in keys:
                    normals.append(val("normal", 3))
            except (ValueError, IndexError):
                raise ValueError(f"{path}:{lineno}: cannot read the values of this {words[0]} line "
                                 f"(a damaged .restart?)") from None
    if declared is not None and len(inv_mass) != declared:
        raise ValueError(f"{path}:{declared_line}: 'Particles {declared}' but {len(inv_mass)} particle lines follow "
                         f"(a truncated or damaged .restart); write it again, or pass fixed= instead")
    # the file's order is the particle handler's, which is the order of the .data rows
    return {"density": density, "inv_mass": np.array(inv_mass, dtype=float),
            "positions": np.array(positions, dtype=float).reshape(-1, 3), "normals": normals,
            "particle_dim": particle_dim}


def read_particles(path, offset, first_line, n, dim):
    """The .data frame whose header is at ``offset`` (line ``first_line``): (time, lower, upper, table)
    with the (n, DATA_COLUMNS[dim]) particle table (extra trailing columns dropped)."""
    ncol = DATA_COLUMNS[dim]
    with open_input(path) as fh:
        fh.seek(offset)
        head = fh.readline().split()
        rows = [fh.readline() for _ in range(n)]
    time = float(head[1])
    hv = [float(w) for w in head[2:]]
    lower, upper = np.array(hv[:dim]), np.array(hv[dim:2 * dim])
    table = np.zeros((n, ncol))
    for k, row in enumerate(rows):
        words = row.split()
        if len(words) < ncol:
            raise ValueError(f"{path}:{first_line + 1 + k}: expected {ncol} columns for a {dim}D .data "
                             f"particle line, got {len(words)}")
        table[k] = parse_floats([w.decode() for w in words[:ncol]], path, first_line + 1 + k)
    return time, lower, upper, table


def read_fstat_rows(path, offset, first_line):
    """The interaction lines of the .fstat frame whose first header line is at ``offset`` (line
    ``first_line``): an (M, FSTAT_COLUMNS) table and the line number of each row; None, None if M = 0."""
    rows, numbers = [], []
    with open_input(path) as fh:
        fh.seek(offset)
        seen_data, headers = False, 0
        for _, lineno, line in _numbered_lines(fh, first_line - 1):
            if line.startswith(b"#"):
                headers += 1
                if seen_data or headers > 3:
                    break
                continue
            if not line.strip():
                continue
            seen_data = True
            words = line.split()
            if len(words) < FSTAT_COLUMNS:
                raise ValueError(f"{path}:{lineno}: expected {FSTAT_COLUMNS} columns "
                                 "'time i j cx cy cz delta deltat fn ft nx ny nz tx ty tz', got "
                                 f"{len(words)}")
            rows.append(parse_floats([w.decode() for w in words[:FSTAT_COLUMNS]], path, lineno))
            numbers.append(lineno)
    if not rows:
        return None, None
    return np.array(rows), np.array(numbers)
