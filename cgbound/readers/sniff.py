"""Telling a dataset's format from its first bytes (and, for MercuryDPM, its name)."""
import os

from .files import open_input

HDF5_SIGNATURE = b"\x89HDF\r\n\x1a\n"

FORMATS = ("hdf5", "lammps", "liggghts", "mdanalysis", "mercury", "yade")
ZIP_SIGNATURE = b"PK\x03\x04"


def sniff_format(path):
    """``"hdf5"``, ``"lammps"`` (LAMMPS and LIGGGHTS dumps look alike: LIGGGHTS needs ``format="liggghts"``)
    , ``"mercury"`` (gzip-compressed text too) or ``"yade"`` (a directory of, or one, ``.npz`` export); a ValueError naming the file when the format cannot be told."""
    path = os.fspath(path)
    if os.path.isdir(path):
        if any(name.endswith(".npz") for name in os.listdir(path)):
            return "yade"
        raise ValueError(f"{path}: a directory without .npz frames; expected a dataset file (or Yade exports)")
    with open_input(path) as f:
        head = f.read(4096)
    if head.startswith(HDF5_SIGNATURE):
        return "hdf5"
    if head.startswith(ZIP_SIGNATURE) and path.endswith(".npz"):
        return "yade"        # cgbound.readers.yade_export writes one .npz per frame (the reader checks its format)
    if not head.strip():
        raise ValueError(f"{path}: the file is empty; expected a dataset")
    if head.lstrip().startswith(b"ITEM: TIMESTEP"):
        return "lammps"
    name = os.path.basename(path)
    if name.endswith(".data") or ".data." in name or name.endswith(".data.gz"):
        return "mercury"
    first = head.split(b"\n", 1)[0].split()
    if len(first) in (6, 8) and _all_numbers(first):
        return "mercury"  # an XBalls header: N t xmin (ymin) zmin xmax (ymax) zmax
    raise ValueError(f"{path}: cannot tell the format (not HDF5, not a LAMMPS dump starting with 'ITEM: TIMESTEP', "
                     f"not a MercuryDPM .data file); name it with format= (the command line: --format)")


def _all_numbers(words):
    try:
        [float(w) for w in words]
    except ValueError:
        return False
    return True
