"""What readers verify on every frame they read, and the errors that say what was found, the likely
causes and the fix (nothing read silently wrong)."""
import re
import warnings

import numpy as np

from .files import open_input

#: A frame balances when the contact forces plus the body forces reproduce the dumped per-particle
#: forces to this fraction of the RMS contact force. Frames written inside ``run 0`` with ``%.17g``
#: reach 1e-15 (``newton on``) to 1e-13 (``newton off``); frames dumped during a run with damping
#: 1e-3 to 1e-1; a wrong column order, pair style or missing body force order 1.
FORCE_BALANCE_TOLERANCE = 1e-9

#: Contact geometry the engine wrote (LAMMPS' ``dist`` and branch vector, LIGGGHTS' particle positions and
#: overlap) must agree with the dumped positions to this fraction of (the value + the largest coordinate) for
#: every contact, and to GEOMETRY_TOLERANCE_MOST for at least half of them. A coordinate written with ``%g``
#: (6 digits) is off by 5e-6 of its size, so a distance by at most 2 sqrt(3) 5e-6 = 1.7e-5 of the largest
#: coordinate (``%.17g``: 1e-16); fixed decimals (``%.2f``) add their half last place, an absolute slack
#: (:func:`written_resolution`). A box that deforms (fix deform ... remap x, barostats) remaps the atoms at
#: the end of a step but not their ghost copies, which pair/local uses: a contact across a periodic boundary (or
#: between processors) is then off by the step's strain times the box length (measured: 2.8e-4 of a box of 7.7
#: compressed 20% in 4000 steps, 3.6e-5 of the extent; 1e-2 of the distance at 2e-3 strain per step: contacts
#: across a periodic boundary are held to the second rule only). Positions that are not positions (labels swapped,
#: columns shifted) miss by the size of the distance itself, on nearly every contact.
GEOMETRY_TOLERANCE = 1e-3
GEOMETRY_TOLERANCE_MOST = 1e-4

_GENERIC = re.compile(r"^c_[A-Za-z0-9_]+\[\d+\]$")


def dump_local_header(path):
    """The column names of the first ``ITEM: ENTRIES`` line of a LAMMPS dump local (empty if none)."""
    with open_input(path) as fh:
        for line in fh:
            if line.startswith(b"ITEM: ENTRIES"):
                return line.decode(errors="replace").split()[2:]
    return []


def compute_columns(header, compute):
    """The columns of ``header`` that hold values of compute ``compute`` (``c_ID`` or ``c_ID[k]``)."""
    return [c for c in header if c == f"c_{compute}" or c.startswith(f"c_{compute}[")]


def generic_columns(columns):
    """The columns of a dump header that name only a compute and an index (``c_pl[3]``)."""
    return [c for c in columns if _GENERIC.match(c)]


def row_squares(vectors):
    """The squared Euclidean norm of each row of an (M, D) array, as np.sum(vectors ** 2, axis=1) adds it
    ((x0 x0 + x1 x1) + x2 x2: the same bits, tests/test_reader_fast_paths.py) in a pass per column instead of an
    (M, D) square and a reduction along the short axis (5 times slower)."""
    out = vectors[:, 0] * vectors[:, 0]
    for a in range(1, vectors.shape[1]):
        out += vectors[:, a] * vectors[:, a]
    return out


def row_norms(vectors):
    """np.linalg.norm(vectors, axis=1), the same bits: the square root of :func:`row_squares`."""
    out = row_squares(vectors)
    return np.sqrt(out, out=out)


def force_balance(total, dumped, contact_forces, checked=None):
    """How well per-particle force sums reproduce the forces an engine wrote.

    ``total`` and ``dumped``: (N, D) forces; ``contact_forces``: (M, D), whose RMS magnitude is the
    scale (the RMS of ``dumped`` without contacts); ``checked``: (N,) bools of the particles compared
    (default all). Returns a dict: ``mismatch`` ((N,) norms, NaN where not checked), ``scale`` and
    ``relative`` (the largest checked mismatch / scale).
    """
    diff = row_norms(total - dumped)
    if checked is None:
        checked = np.ones(diff.shape[0], bool)
    if contact_forces.shape[0]:
        scale = float(np.sqrt(np.mean(row_squares(contact_forces))))
    else:
        scale = float(np.sqrt(np.mean(row_squares(dumped)))) if dumped.shape[0] else 0.0
    worst = float(np.max(diff[checked])) if checked.any() else 0.0
    return {"mismatch": np.where(checked, diff, np.nan), "scale": scale,
            "relative": worst / scale if scale > 0 else worst}


def check_force_balance(balance, ids, path, timestep, tolerance, hints):
    """Raise when a frame's contact and body forces do not reproduce its dumped forces.

    ``balance``: the dict of ``LammpsFrame.force_balance``; ``hints``: the reader's options that could
    explain a mismatch, as text naming the API keyword and the command-line flag.
    """
    if not balance["relative"] > tolerance:
        return
    mismatch = balance["mismatch"]
    worst = int(np.nanargmax(mismatch))
    raise ValueError(
        f"{path}: timestep {timestep}: the contact forces plus the body forces do not reproduce the dumped "
        f"per-particle forces: mismatch {balance['relative']:.2g} of the RMS contact force "
        f"({balance['scale']:.3g}) at atom ID {int(ids[worst])}, tolerance {tolerance:g}. Likely causes: "
        + "; ".join(hints) + ". Frames dumped during a run (not inside 'run 0') mismatch by 1e-3..1e-1: "
        "write each frame inside its own 'run 0' (the recipe in the cgbound.readers.lammps docstring), or "
        "read them anyway with check_forces=False (--no-check-forces). Values written with 6 significant digits "
        "(the dumps' default format, %g) mismatch by about 1e-7..1e-4: write them with 'dump_modify ID format "
        "float %.17g'")


def check_selects(selected, name, flag, path, where, present):
    """Refuse a selection that selects nothing: ``selected`` is a bool mask of particles."""
    if not np.any(selected):
        raise ValueError(f"{name}: selects no particle in {path} at {where} (present: {present}); "
                         f"check {flag}")


_POWERS = 10.0 ** np.arange(13)


def written_resolution(*columns, sample=64):
    """Half the last decimal place of values written with a fixed number of decimals (``format float %.2f``:
    0.005), judged from about ``sample`` values of each column (strided); 0 when they have more than 12 decimals
    (``%g``, ``%.17g``: their rounding is relative, a fraction of the values' size). Finer values than the sample
    shows are harmless (the estimate errs coarse: it loosens the tolerances it is added to); coarser ones are
    ``%g``'s large values, whose relative rounding the tolerances' own scale covers. Values exact at a few decimals (a lattice's
    0.5, 1.5) read as coarse: the tolerance of such a frame is loosened by them."""
    parts = [np.asarray(c)[::max(1, len(c) // sample)] for c in columns if len(c)]
    if not parts:
        return 0.0
    values = np.concatenate(parts)
    values = values[np.isfinite(values)]
    # every decimal count at once ((n, 13): one pass, not 13 of NumPy's per-call costs). A value parsed from k
    # decimals is a whole number times 10^-k to double precision; a chance near-whole number only where
    # 1e-9 |scaled| >= 0.5, a resolution of 1e-9 of the values, which changes nothing
    scaled = values[:, None] * _POWERS
    near = np.abs(scaled - np.rint(scaled)) <= 1e-9 * np.maximum(np.abs(scaled), 1.0)
    whole = np.flatnonzero(near.all(axis=0))
    return 0.5 * 10.0 ** -int(whole[0]) if whole.size else 0.0


def geometry_misfits(err, scale, checked=None, lenient=None, slack=0.0):
    """The contacts refused for their geometry, or None: ``err`` (M,) how far each is off, ``scale`` (M,) the size
    the tolerances are fractions of, ``checked`` (M,) bools of the contacts that count (default all), ``lenient``
    (M,) bools of the contacts held only to the second rule (default none). Refused: any contact (not lenient) off
    by more than GEOMETRY_TOLERANCE of its scale; else, when more than half of the checked contacts are off by more
    than GEOMETRY_TOLERANCE_MOST, those; ``slack``: a length taken off each error first (what the written
    decimals can account for: :func:`written_resolution`). Returns (bools of the refused, their tolerance, err / scale), the ratio
    written over ``err`` (a float array the caller gives up). One division and a maximum decide the usual case, a
    frame that holds."""
    if slack:
        np.subtract(err, slack, out=err)
        np.maximum(err, 0.0, out=err)
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.divide(err, scale, out=err)
    if not ratio.size:
        return None
    worst = ratio.max()
    if worst > GEOMETRY_TOLERANCE:
        bad = ratio > GEOMETRY_TOLERANCE
        if lenient is not None:
            bad &= ~lenient
        if bad.any():
            return bad, GEOMETRY_TOLERANCE, ratio
    if not worst > GEOMETRY_TOLERANCE_MOST:
        return None
    bad = ratio > GEOMETRY_TOLERANCE_MOST
    count = int(np.count_nonzero(checked)) if checked is not None else err.shape[0]
    if 2 * int(np.count_nonzero(bad)) > count:
        return bad, GEOMETRY_TOLERANCE_MOST, ratio
    return None


def box_change_per_step(lower, upper, others):
    """How far a box that deforms (``fix deform ... remap x``) moves an atom per step: the largest change of a bound
    or a length per step along each axis, combined over the axes (0 for a box that does not change), from the
    frame's bounds ``lower``, ``upper`` ((D,) each) and ``others``, (lower, upper, steps apart) of its neighbouring
    frames. The engine remaps the atoms at the end of a step but not their ghost images: a contact's geometry
    written from a ghost is off by up to this."""
    moved = 0.0
    for lo, hi, steps in others:
        change = np.maximum(np.maximum(np.abs(lo - lower), np.abs(hi - upper)), np.abs((hi - lo) - (upper - lower)))
        moved = max(moved, float(np.sqrt(np.sum(change ** 2))) / steps)
    return moved


def thin_box(box, radii_sum):
    """Whether a periodic box length is short enough for a pair to touch through two images of each other (the
    second image is at least half a box length away; cohesive models reach 2 (r_i + r_j))."""
    reach = 2.0 * float(radii_sum.max())
    return any(p and 0.5 * (hi - lo) <= reach for p, lo, hi in zip(box.periodic, box.lower, box.upper))


def repeated_pairs(i, j, n):
    """Bools of the contacts whose pair (in either order) is listed more than once, or None if none is."""
    key = np.minimum(i, j) * np.int64(n) + np.maximum(i, j)
    order = np.argsort(key, kind="stable")
    ranked = key[order]
    same = ranked[1:] == ranked[:-1]
    if not same.any():
        return None
    repeated = np.zeros(key.size, bool)
    repeated[order[1:][same]] = True
    repeated[order[:-1][same]] = True
    return repeated


def contact_geometry_error(atoms_path, source, timestep, bad, score, what, detail, location, hints=(), checked=None,
                           touching=None, first=None):
    """The error for contacts whose geometry the dumped positions do not give (nothing is raised here).

    ``source``: the contacts' origin ("the contacts of PAIRS"); ``bad``: (M,) bools of the contacts refused;
    ``score``: (M,) how far each is beyond its tolerance (the worst, largest, is shown); ``what``: what the refused
    contacts do ("have a 'dist' that ..."); ``detail(k)``: the numbers of contact k; ``location(k)``: where it is
    (its atoms, their lines); ``hints``: other likely causes, as text naming the reader's option; ``checked``:
    bools of the contacts checked (default all); ``touching``: the fraction of the checked contacts whose positions
    are as far apart as touching particles are (0.7 to 1.01 r_i + r_j), or None: from 0.9 on the positions look
    right, and the contact dump's own columns (``hints``, first: their order) lead the causes; ``first``: (cause,
    fix) known to lead them all (a deforming box whose change per step is not known).
    """
    rows = np.flatnonzero(bad)
    total = bad.size if checked is None else int(np.count_nonzero(checked))
    k = int(rows[np.argmax(score[rows])])
    causes = ("the atoms dump's position columns are not the positions: its 'ITEM: ATOMS' labels swapped (e.g. "
              "'x y z' with 'vx vy vz') or the columns shifted against their labels, by an edit, a merge or a "
              "converter")
    fix = ("read the dumps as LAMMPS/LIGGGHTS wrote them, with the positions under their own labels (x y z, xu yu "
           "zu or xs ys zs); write floats with 'dump_modify ... format float %.17g' (few digits also blur this "
           "comparison)")
    lead = ""
    if touching is not None and touching >= 0.9:
        causes = "; ".join([*hints, causes])
        lead = (f"The positions look right: {100 * touching:.0f}% of these contacts join particles as far apart as "
                "touching ones are (0.7 to 1.01 r_i + r_j), so the contact dump's columns are the likely fault. ")
        fix = ("name the contact dump's columns in the order its compute line gives them (pair_values=, "
               "--pair-values; or give the input script, --input); else " + fix)
    else:
        causes = "; ".join([causes, *hints])
    if first is not None:
        lead = ""
        causes = f"{first[0]}; else {causes}"
        fix = f"{first[1]}; else {fix}"
    return ValueError(
        f"{atoms_path}: timestep {timestep}: the positions do not fit {source}: {rows.size} of {total} contacts "
        f"{what}. The worst: {location(k)}: {detail(k)}. {lead}Likely causes: {causes}. Fix: {fix}")


def warn_repeated_frames(path, keyed_lines, name, lines_word, cause, unit, each):
    """Warn when a frame key (a timestep, a time) is written more than once in ``path``: each copy is read, so a
    time average counts it that many times (a run restarted and appending to its files). ``keyed_lines``: (key,
    line) of each frame; the first repeated key is named by ``name(key)``, its frames' lines after ``lines_word``;
    ``unit``/``each``: what the keys are, in the count of the others and in the advice."""
    seen = {}
    for key, line in keyed_lines:
        seen.setdefault(key, []).append(line)
    repeated = [(key, lines) for key, lines in seen.items() if len(lines) > 1]
    if not repeated:
        return
    key, lines = repeated[0]
    more = f" (and {len(repeated) - 1} more {unit}(s))" if len(repeated) > 1 else ""
    warnings.warn(f"{path}: {name(key)} is written {len(lines)} times ({lines_word} {', '.join(map(str, lines))})"
                  f"{more}, {cause}; each copy is read, so a time average counts it {len(lines)} times: select the "
                  f"frames (start/stop/step, --start/--stop/--step) to count each {each} once", stacklevel=4)
