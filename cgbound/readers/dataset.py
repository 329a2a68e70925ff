"""One entry point to every reader: a file, several files or a glob pattern, any supported format."""
import os

from .files import ConcatenatedFrames, expand_paths
from .sniff import FORMATS, sniff_format

#: the keyword that names each format's companion file of contacts, one per particle file
CONTACT_FILES = {"lammps": "pairs", "liggghts": "pairs", "mercury": "fstat_path"}


def open_dataset(paths, format=None, **options):
    """Open a dataset as one lazy sequence of Snapshots.

    Parameters
    ----------
    paths : path, glob pattern, or sequence of them
        Several files (``dump.*``: LAMMPS writes one file per frame; ``name.data.*``: MercuryDPM's
        ``-fileType multiple``) are ordered by the numbers in their names and their frames read one
        after another; the frames' timesteps must increase from file to file. Gzip-compressed files
        are read as they are.
    format : "hdf5", "lammps", "liggghts", "mercury", "yade" or "mdanalysis", optional
        Default: told from the first file (HDF5 signature, ``ITEM: TIMESTEP``, MercuryDPM's ``.data``);
        LIGGGHTS dumps look like LAMMPS dumps and need ``format="liggghts"``.
    **options
        The reader's keywords; every reader takes ``units=`` (:mod:`cgbound.units`: ``"si"``, ``"lj"``, ...). The contact file (``pairs=`` for LAMMPS/LIGGGHTS, ``fstat_path=`` for
        MercuryDPM) may be a pattern or a sequence too: one per particle file, in the same order.
    """
    if format is not None and format not in FORMATS:
        raise ValueError(f"format: expected one of {', '.join(FORMATS)}, got {format!r}")
    if format == "mdanalysis":
        from .mdanalysis import MDAnalysisReader
        return MDAnalysisReader(paths, **options)
    single = isinstance(paths, (str, os.PathLike)) and os.path.isdir(paths)
    if format == "yade" or (format is None and single and sniff_format(paths) == "yade"):
        from .yade import YadeReader
        return YadeReader(paths, **options)       # a directory, a pattern or files of .npz exports
    files = expand_paths(paths, "paths")
    fmt = format or sniff_format(files[0])
    if fmt == "yade":
        from .yade import YadeReader
        return YadeReader(files, **options)
    contact_key = CONTACT_FILES.get(fmt)
    contacts = [None] * len(files)
    if contact_key and options.get(contact_key) is not None:
        contacts = expand_paths(options.pop(contact_key), contact_key)
        if len(contacts) != len(files):
            raise ValueError(f"{contact_key}: expected one contact file per particle file ({len(files)}), got "
                             f"{len(contacts)}: {', '.join(os.path.basename(c) for c in contacts[:4])}")
    readers = [_reader(fmt, path, contact_key, contact, options) for path, contact in zip(files, contacts)]
    if len(readers) == 1:
        return readers[0]
    frames = ConcatenatedFrames(readers, "paths")
    frames.units = readers[0].units
    return frames


def _reader(fmt, path, contact_key, contact, options):
    if contact_key and contact is not None:
        options = dict(options, **{contact_key: contact})
    if fmt == "hdf5":
        from .hdf5 import HDF5Snapshots
        return HDF5Snapshots(path, **options)
    if fmt == "lammps":
        from .lammps import LammpsReader
        return LammpsReader(path, **options)
    if fmt == "liggghts":
        from .liggghts import LiggghtsReader
        return LiggghtsReader(path, **options)
    from .mercury import MercuryReader
    return MercuryReader(path, **options)
