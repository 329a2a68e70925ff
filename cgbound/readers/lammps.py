"""Read LAMMPS granular dumps as a lazy sequence of :class:`cgbound.Snapshot`.

Three kinds of LAMMPS output are combined, frame by frame (matched by TIMESTEP):

* a particle ``dump custom`` with columns such as ``id type x y z vx vy vz fx fy fz radius mass``
  in any order (the order is read from the ``ITEM: ATOMS`` header). Positions may be plain
  (``x y z``), scaled (``xs ys zs``), unwrapped (``xu yu zu``) or scaled and unwrapped
  (``xsu ysu zsu``). ``ITEM: BOX BOUNDS`` gives the box; an axis is periodic when its flag is
  ``pp``. Triclinic boxes are not supported. ``omegax omegay omegaz`` and ``tqx tqy tqz`` (2D: ``omegaz``,
  ``tqz``), when present, become the snapshot's ``angular_velocities`` and ``torques``.
* a contact ``dump local`` of ``compute pair/local`` and ``compute property/local patom1 patom2``
  (optional). The values verified on LAMMPS 29 Sep 2021 (Debian 20220106) output:

  - ``fx fy fz`` of pair/local is the force on ``patom1`` from ``patom2``. For the granular pair
    styles it is only the NORMAL part (including normal damping). Verified for
    ``gran/hooke/history`` and ``granular`` (hertz + mindlin, hooke + linear_history);
    ``gran/hooke`` and ``gran/hertz/history`` share the documented convention but were not run;
  - ``p1 p2 p3`` is the tangential force on ``patom1`` (``p4`` its magnitude), for both the
    ``gran/*`` styles and ``pair granular``;
  - for ``pair granular`` only, ``p10 p11 p12`` is the branch vector ``x_patom1 - x_patom2``
    (minimum image), which the reader uses when present.

  The contact force on ``patom1`` from ``patom2`` is then ``(fx, fy, fz) + (p1, p2, p3)``, and
  the contact point is rebuilt as ``c = x_i - (R_i - delta/2) n`` with ``n`` the unit vector
  from j to i (minimum image) and ``delta = R_i + R_j - |x_i - x_j|`` the overlap.
* wall contacts from ``fix wall/gran ... contacts`` (and ``fix wall/gran/region ... contacts``),
  dumped as the fix's per-atom array ``f_ID[1..8]``: 1 = contact flag, 2-4 = force on the
  particle from the wall, 5-7 = contact point (on the wall surface), 8 = radius. Give the fix IDs
  as ``walls=["ID", ...]``; they become boundary contacts with ``j = -1``. Verified for
  ``fix wall/gran`` (plane walls) and ``fix wall/gran/region ... contacts`` with a cylinder region
  (same layout, contact points on the cylinder: tests/data/lammps/silo). LAMMPS stores one
  contact per particle and fix, so a particle touching two walls of one fix cannot be represented
  by this output.

Checks
------
Every frame read is checked (a ValueError names the atoms dump, the timestep, the atom and the contact
dump's line, the likely causes and the fix):

* the force balance (``check_forces``, below);
* the box: wrapped (``x y z``) and scaled (``xs ys zs``) positions must lie in the frame's box to
  ``BOX_SLACK`` box lengths (0.25 along a non-periodic axis, 0.5 along a periodic one; LAMMPS lets an atom
  stray only until it re-neighbours: 0.0075 at most in genuine dumps of 14 scenes); along a shrink-wrapped
  axis (boundary ``s``/``m``, which can be far thinner than that stray: a flat layer's box 4e-4 thick) by a
  length, the largest of 0.25 of the largest box length, 4 radii and the input script's ``neighbor`` skin.
  Unwrapped positions are not checked. This needs no contacts: it also checks an atoms dump read alone. A frame
  without contacts, whose positions no contact geometry checks, is held along non-periodic and shrink-wrapped axes
  to one ``neighbor`` skin (the input script's, else the engine's default for its units) where the script
  re-neighbours on every step's check without a delay (``neigh_modify delay 0``; the default delay, 10 steps in
  LAMMPS before 2023 and in LIGGGHTS, lets an atom stray further; not either where ``neigh_modify`` sets
  ``every`` > 1, ``check no`` or ``once yes``): an atom strays at most half a skin between re-neighbourings
  (genuine dumps: 0.39 skin); forces written as positions lie 0.086 box lengths out (tests/data/lammps/in.jkr3d
  at step 0, inside the 0.25);
* the contact geometry: the dumped positions must give each contact's geometry as LAMMPS wrote it. With
  ``dist`` among the pair/local values (or ``pair granular``'s branch vector ``p10 p11 p12``), the distance
  (vector) between the two positions (minimum image) must agree to ``GEOMETRY_TOLERANCE`` (1e-3) of (the
  distance + the largest coordinate written, not the box bounds: particles in a corner of a large box are
  written to the digits of their own size) for every contact and to 1e-4 for at least half of them (a ``%g``
  dump is off by 1.7e-5 of the largest coordinate), plus what the written decimals account for when floats
  have a fixed number of them (``format float %.2f``: 2 sqrt(3) 0.005 for a distance between two positions, as
  :func:`~cgbound.readers.checks.written_resolution` finds from the values). A contact across a periodic boundary (its separation changed
  by the minimum image) is held only to the second rule, to a scale that adds the largest box length: a box
  deforming with ``remap x`` leaves the ghost images pair/local uses one step stale (off by the step's strain
  times the box length: 1e-2 of the distance at 2e-3 strain per step, tests/data/lammps/in.deform). On several
  processors the ghost copies of the other processors' atoms are as stale inside the box: a frame the check
  refuses is checked again allowing twice the box's change per step, when it changes: from the input script's
  ``fix deform`` (:meth:`~cgbound.readers.lammps_input.InputScript.deform_change`) or its bounds against the
  neighbouring frames' (in other files too, where open_dataset reads one file per frame); a frame neither tells
  (read alone) is refused naming the script's fix deform first. A particle listed in contact with itself (a
  periodic length shorter than its diameter: it touches its own image) is refused; such rows without a force
  are dropped. Without
  either, a contact with a force must not join particles further apart than r_i + r_j for a repulsive model
  (``gran/*``; ``granular`` without ``jkr``, known from ``input``), or 2 (r_i + r_j) where cohesion is possible
  or not known (``pair_style="granular"``), and most contacts must not overlap by more than half of r_i + r_j.
  These bounds are loose: positions shifted by a column in a settled packing ((y, z, vx) read as (x, y, z), vx
  near 0) keep most contacts touching or overlapping, and pass them (tests/data/lammps: hooke3d, granular3d,
  jkr3d); only ``dist`` (or the branch vector) sees such a shift: dump it. Positions that are not positions (the ``ITEM: ATOMS`` labels
  ``x y z`` and ``vx vy vz`` swapped, or shifted by a column: the force balance does not see it) miss by the
  size of the distance; so does a ``dist`` read from another column (``pair_values`` in the wrong order).
  ``pair granular`` writes zeros (force and branch) for a pair it finds not touching (JKR beyond pull-off,
  pairs listed without ``cutoff radius``): those rows take the positions' separation. Measured on genuine
  output (``%g`` and ``%.17g``; gran/hooke, gran/hertz/history, granular hertz/material, dmt and jkr,
  periodic and deforming boxes, walls): errors at most 3% of the tolerance; forces only within 1.000005
  (r_i + r_j) for the repulsive styles;
* a pair listed more than once: in a periodic box thinner than two contact distances a pair can touch through two
  periodic images of each other at once, and pair/local lists it once per image (with its own ``dist`` and branch
  vector). Each listing is read as its own contact, its branch vector (``Contacts.branch``) the image that
  ``p10 p11 p12`` gives, else the one its ``dist`` gives (where two images are as far, the one along the normal
  force ``fx fy fz``); the geometry check above then holds it as any other. Without ``dist`` or the branch vector
  (or where neither tells the images apart) the frame is refused: the minimum image would give both listings
  one branch, a wrong stress (tests/data/lammps/in.thin: sigma_xx 44% low; read as here, the box-averaged
  contact stress is minus LAMMPS' virial to round-off). Listings of a pair with the same image are refused;
* wall contacts (``walls``): the contact point ``f_ID[5..7]`` (on the wall) must lie within a radius of the
  particle's centre (1.00003 radii measured, the silo's cylinder included) when the input script gives the wall
  a repulsive model, within 2 radii otherwise (``jkr``, or no script), to the same tolerance. This also checks
  an atoms dump read without a contact dump.

Writing consistent dumps
------------------------
LAMMPS evaluates ``compute pair/local`` when the dump is written, at the END of a step, with
the end-of-step velocities and contact histories, while the per-atom forces ``fx fy fz`` were
computed mid-step (velocity-Verlet, half-step velocities). Velocity-dependent damping makes the
two disagree, so frames dumped during a ``run`` do not balance: the per-contact forces plus the
body forces do not add up to the dumped per-particle forces. Inside ``run 0`` both come from
the same force evaluation (and contact histories are not advanced in setup). Write each frame
inside its own ``run 0``::

    compute         pl all pair/local dist fx fy fz p1 p2 p3 p4 cutoff radius
    compute         pp all property/local patom1 patom2 cutoff radius
    fix             w flow wall/gran hooke/history ... zplane 0.0 NULL contacts
    variable        k loop 10
    label           frame
    run             1000
    dump            a all custom 1 atoms.dump id type x y z vx vy vz fx fy fz radius mass f_w[*]
    dump            c all local 1 pairs.dump index c_pp[*] c_pl[*]
    dump_modify     a format float %.17g append yes
    dump_modify     c format float %.17g append yes
    run             0
    undump          a
    undump          c
    next            k
    jump            SELF frame

and read them with ``LammpsReader("atoms.dump", "pairs.dump", walls=["w"], fixed_types=[2],
body_force=(0, 0, -1))``. Use ``%.17g`` so the balance holds to round-off. Boundary
(fixed) particles should simply not be integrated (no ``fix nve``, no gravity); do not zero
their forces with ``fix setforce`` or ``fix freeze`` if you want their balance checked.
:meth:`LammpsReader.force_mismatch` reports how well a frame balances (~1e-15 for ``run 0``
frames with ``newton on``, ~1e-13 with ``newton off``, where LAMMPS evaluates a contact
across a periodic boundary once from each side; ~1e-3..1e-1 for frames dumped during a run
with damping).

With ``pair_style granular``, list ``p1 ... p12`` in pair/local to get the branch vector; the
reader finds the columns from ``pair_values`` (the keywords of ``compute pair/local`` in order).
Set the column names explicitly with ``pair_columns`` for other layouts.

Two dimensions
--------------
With ``dimension=2`` (the default when the input script, ``input=``, says ``dimension 2``) the LAMMPS
x and y columns become cgbound's 2-D axes (x, z); the LAMMPS z column is ignored. ``body_force`` is then given in cgbound axes (2 values, e.g. ``(0, -1)`` for
LAMMPS ``fix gravity 1.0 vector 0 -1 0``) or as the 3 LAMMPS components (z must be 0).

Particle order
--------------
Particles are sorted by LAMMPS atom ID in every frame, so index k is the same atom in every frame
(as long as no atoms are created or lost). :meth:`LammpsReader.frame` also returns the IDs, types,
timestep and the dumped per-particle forces. A timestep written more than once (a run restarted and
appending to its dump, or dumps concatenated) is read each time, with a warning: a time average counts it
that many times.
"""
from dataclasses import dataclass
import os
import warnings
from typing import NamedTuple

import numpy as np

from .._validate import flag, index_array, positive_number
from ..box import Box
from ..snapshot import Contacts, Snapshot
from ._lammps_dump import Table, scan_dump
from ._sequence import FrameReader, file_name
from .checks import (FORCE_BALANCE_TOLERANCE, GEOMETRY_TOLERANCE, box_change_per_step, check_force_balance,
                     compute_columns, contact_geometry_error, dump_local_header, force_balance, generic_columns,
                     geometry_misfits, repeated_pairs, row_norms, thin_box, warn_repeated_frames,
                     written_resolution)

__all__ = ["LammpsReader", "LammpsFrame", "pair_local_columns"]

PAIR_STYLES = ("gran", "granular", "total")

DEFAULT_PAIR_VALUES = ("dist", "fx", "fy", "fz", "p1", "p2", "p3", "p4")
DEFAULT_GRANULAR_VALUES = ("dist", "fx", "fy", "fz") + tuple(f"p{k}" for k in range(1, 13))

#: how far outside its box (in box lengths) a wrapped or scaled position may lie, along a non-periodic and a
#: periodic axis. LAMMPS remaps atoms into a periodic box, and loses those that left a fixed one, only when it
#: re-neighbours (every skin/2 of motion at most with the default check): genuine dumps of 14 scenes stray
#: 0.0075 at most. Positions that are velocities or forces (labels swapped) often lie boxes away.
BOX_SLACK = {False: 0.25, True: 0.5}
#: along a shrink-wrapped axis (boundary s or m) the slack is a length: this fraction of the box's largest length
#: (or 4 radii, or the input script's skin, if larger): a shrink-wrapped box can be thinner than an atom's stray
SHRINK_SLACK = 0.25

_POSITION_COLUMNS = (("x", "y", "z", False, False), ("xu", "yu", "zu", False, True),
                     ("xs", "ys", "zs", True, False), ("xsu", "ysu", "zsu", True, True))


def pair_local_columns(pair_compute="pl", pair_values=DEFAULT_PAIR_VALUES, property_compute="pp",
                       property_values=("patom1", "patom2"), pair_style="gran"):
    """Column names of a ``dump local`` written as ``index c_PP[*] c_PL[*]``.

    ``pair_values`` and ``property_values`` are the keywords given to ``compute pair/local`` and
    ``compute property/local``, in order. Returns a dict with keys ``id1``, ``id2``, ``force``
    (3 names), ``tangential`` (3 names or None), ``branch`` (3 names or None) and ``dist`` (a name or None).
    """
    if pair_style not in PAIR_STYLES:
        raise ValueError(f"pair_style: expected one of {PAIR_STYLES}, got {pair_style!r}")
    pv, qv = list(pair_values), list(property_values)

    def col(compute, values, key, what):
        if key not in values:
            raise ValueError(f"{what}: expected the keyword {key!r} among {values}")
        if len(values) == 1:
            return f"c_{compute}"
        return f"c_{compute}[{values.index(key) + 1}]"

    out = {"id1": col(property_compute, qv, "patom1", "property_values"),
           "id2": col(property_compute, qv, "patom2", "property_values"),
           "force": tuple(col(pair_compute, pv, k, "pair_values") for k in ("fx", "fy", "fz")),
           "tangential": None, "branch": None,
           "dist": col(pair_compute, pv, "dist", "pair_values") if "dist" in pv else None}
    if pair_style in ("gran", "granular"):
        out["tangential"] = tuple(col(pair_compute, pv, k, "pair_values") for k in ("p1", "p2", "p3"))
    if pair_style == "granular" and all(k in pv for k in ("p10", "p11", "p12")):
        out["branch"] = tuple(col(pair_compute, pv, k, "pair_values") for k in ("p10", "p11", "p12"))
    return out


def _unknown_pair_values(path, header, pair_compute, pair_style):
    generic = generic_columns(header)
    shown = " ".join(header) if len(header) <= 16 else " ".join(header[:16]) + " ..."
    example = "fx,fy,fz,p1,p2,p3,p4,dist" if pair_style != "total" else "fx,fy,fz"
    return (f"pair_values: the contact dump {path} names its columns only by compute and index "
            f"({len(generic)} such columns: {shown}); what each holds depends on the 'compute {pair_compute} "
            f"all pair/local ...' line that wrote it, which the dump does not record. Say it with "
            f"pair_values=(...) in that line's order (command line: --pair-values {example}), or give the "
            f"input script with input= (--input in.lmp); reading them in an assumed order is how a wrong "
            f"force, and a wrong stress, go unnoticed")


def _check_value_count(path, header, pair_compute, pair_values):
    """The dump must hold as many ``c_ID[k]`` columns of the pair compute as ``pair_values`` names."""
    cols = compute_columns(header, pair_compute)
    if header and cols and len(cols) != len(pair_values):
        raise ValueError(f"pair_values: {len(pair_values)} keywords ({' '.join(pair_values)}) but the contact "
                         f"dump {path} holds {len(cols)} columns of compute {pair_compute!r} ({' '.join(cols)}); "
                         f"give the keywords of that compute's line, in order")


# ----------------------------------------------------------------------------------------------

@dataclass
class LammpsFrame:
    """One frame read from LAMMPS dumps.

    Attributes: ``snapshot`` (cg.Snapshot), ``ids`` and ``types`` (N ints, sorted by ID),
    ``timestep``, ``forces`` ((N, D) dumped per-particle forces or None), ``contact_ids``
    ((M, 2) LAMMPS IDs of each contact, -1 for walls), ``overlap`` ((M,) overlaps, NaN for walls).
    """

    snapshot: Snapshot
    ids: np.ndarray
    types: np.ndarray
    timestep: int
    forces: np.ndarray
    contact_ids: np.ndarray
    overlap: np.ndarray

    def force_balance(self, fixed=False):
        """Per-particle force-balance mismatch against the dumped forces.

        Returns a dict: ``mismatch`` ((N,) |sum of contact forces + m g - dumped force|, NaN for
        particles not checked), ``scale`` (the typical force: the RMS contact-force magnitude, or
        the RMS dumped force when there are no contacts) and ``relative`` (max mismatch / scale).
        Flowing particles are checked with the body force; fixed ones, when ``fixed=True``, with
        contacts only (they are assumed to feel no body force and not to be zeroed by LAMMPS).
        """
        if self.forces is None:
            raise ValueError("force_balance: the atoms dump has no fx fy fz columns")
        snap = self.snapshot
        checked = np.ones(snap.n_particles, bool) if fixed else snap.flowing
        return force_balance(snap.particle_forces(), self.forces, snap.contacts.force, checked)


def contact_indices(ids, id1, id2, path, timestep):
    """Positions in the sorted, distinct atom ``ids`` of the contacts' atom IDs; every ID must be there."""
    n = ids.size
    if n and int(ids[-1]) - int(ids[0]) == n - 1:
        # sorted distinct IDs spanning n values are consecutive (LAMMPS numbers atoms 1..N): the position is
        # the ID minus the first, for IDs within [first, last]: exactly those whose difference, wrapped around in
        # 64 bits and read as unsigned, is at most last - first (subtracting first maps [first, last] one to one
        # onto [0, last - first]), one subtraction and one comparison per array
        first, span = ids[0], np.uint64(int(ids[-1]) - int(ids[0]))
        i, j = id1 - first, id2 - first
        bad = i.view(np.uint64) > span
        bad |= j.view(np.uint64) > span
    elif n:
        i = np.searchsorted(ids, id1)
        j = np.searchsorted(ids, id2)
        bad = (i >= n) | (j >= n)
        bad |= ids[np.minimum(i, n - 1)] != id1
        bad |= ids[np.minimum(j, n - 1)] != id2
    else:      # no atoms: every contact names an absent ID
        i = j = np.zeros(id1.shape, np.int64)
        bad = np.ones(id1.shape, bool)
    if np.any(bad):
        k = int(np.flatnonzero(bad)[0])
        raise ValueError(f"{path}: contact between atom IDs {id1[k]} and {id2[k]} at timestep {timestep}: "
                         "an ID is not in the atoms dump (dump all atoms, or both dumps for the same group)")
    return i, j


class LammpsReader(FrameReader):
    """Lazy sequence of :class:`cgbound.Snapshot` from LAMMPS dumps (see the module docstring);
    :meth:`frame` gives a :class:`LammpsFrame` (snapshot plus IDs, types, dumped forces).

    Parameters
    ----------
    atoms : path
        ``dump custom`` file. Needs ``id``, positions and ``mass`` (or ``masses=``); uses ``type``,
        velocities, ``fx fy fz``, ``radius`` (or ``diameter``) and wall-fix columns when present.
    pairs : path, optional
        ``dump local`` of ``compute property/local patom1 patom2`` and ``compute pair/local``.
    pair_style : "gran", "granular" or "total"
        "gran" (``pair gran/*``) and "granular" (pair granular): force = fx fy fz + p1 p2 p3.
        "total": fx fy fz is the whole force (non-granular pair styles). Default: the input script's, else
        "gran". It also bounds how far apart two particles with a contact force may be (``contact_reach``,
        in r_i + r_j): 1 for "gran" (repulsive), 2 for "granular" (may be cohesive: JKR) unless the input
        script's ``pair_coeff`` lines have no ``jkr``, none for "total".
    pair_compute, pair_values, property_compute, property_values :
        IDs and keywords of the two computes, used to name the columns (see :func:`pair_local_columns`).
        ``pair_values`` (the keywords of ``compute pair/local`` in order, e.g. ``("dist", "fx", "fy",
        "fz", "p1", "p2", "p3", "p4")``) is required with a contact dump: the dump's header names
        its columns only ``c_pl[1] ... c_pl[k]``, so their meaning cannot be read from the file.
    pair_columns : dict, optional
        Explicit column names, overriding the above (keys as returned by pair_local_columns).
    walls : sequence of str
        IDs of ``fix wall/gran ... contacts`` whose ``f_ID[1..8]`` columns are in the atoms dump.
    fixed_types : sequence of int
        Atom types that are boundary (fixed) particles.
    fixed_ids : sequence of int
        Atom IDs that are boundary particles (e.g. a LAMMPS group).
    body_force : (D,) array, optional
        Body force per unit mass (e.g. gravity) acting on the flowing particles, in cgbound axes
        (in 2D also accepted as the 3 LAMMPS components).
    masses : dict type -> mass, optional
        When the atoms dump has no ``mass`` column.
    dimension : 2 or 3, optional
        Default: the input script's ``dimension`` command (``input=``), else 3. A value that command contradicts
        is refused.
    dt : float, optional
        Time step size: a snapshot's time is ``timestep * dt``. Default: the dump's ``ITEM: TIME``
        when present, else the timestep number.
    wrap : bool
        Wrap positions and contact points into the box along periodic axes (default True).
    drop_inactive : bool
        Drop pair rows with no overlap and zero force (pairs within a force cutoff but not touching;
        default True).
    input : path, optional
        The LAMMPS input script that wrote the dumps (:func:`cgbound.readers.read_input`): the contact
        dump's columns come from its ``compute pair/local`` and ``dump`` lines, and ``fixed_types``,
        ``walls`` and ``body_force`` from its frozen groups, ``fix wall/gran ... contacts`` and
        ``fix gravity`` unless given here.
    variables : dict, optional
        Values of the script's variables, as ``-var NAME value`` gave them to LAMMPS.
    units : str, mapping or cgbound.Units, optional
        The units of the dumps (:mod:`cgbound.units`; e.g. ``"lj"``, ``"si"``). Default: the input
        script's ``units`` command when ``input`` is given, else not known.
    check_forces : bool
        With a contact dump and ``fx fy fz`` in the atoms dump, every frame read is checked: the
        contact forces plus the body forces must reproduce the dumped force of every flowing
        particle to ``FORCE_BALANCE_TOLERANCE`` (1e-9) of the RMS contact force, else a ValueError
        names the frame, the atom and the likely causes (wrong column order or pair style, missing
        body force, walls or fixed particles, a frame dumped during a run). Default True.
    """

    def __init__(self, atoms, pairs=None, *, pair_style=None, pair_compute="pl", pair_values=None,
                 property_compute="pp", property_values=("patom1", "patom2"), pair_columns=None,
                 walls=(), fixed_types=(), fixed_ids=(), body_force=None, masses=None, dimension=None,
                 dt=None, wrap=True, drop_inactive=True, input=None, variables=None, check_forces=True, units=None):
        self.units = units
        self.input_script = script = None
        fixed_types_from_script = False
        if input is not None:
            from .lammps_input import read_input
            script = self.input_script = read_input(input, variables)
            if units is None:
                self.units = _script_units(script)
            if pairs is not None and pair_values is None and pair_columns is None:
                pair_columns = script.pair_columns(pairs)
            if not len(fixed_types) and not len(fixed_ids):
                fixed_types = script.fixed_types
                fixed_types_from_script = True
            if body_force is None and script.gravity is not None:
                body_force = script.gravity
            if not walls:
                walls = script.walls
        if dimension is None:
            dimension = script.dimension if script is not None else 3
        if dimension not in (2, 3):
            raise ValueError(f"dimension: expected 2 or 3, got {dimension!r}")
        if script is not None and script.dimension_given and dimension != script.dimension:
            raise ValueError(f"dimension: {dimension} given, but the input script {script.path} says 'dimension "
                             f"{script.dimension}': leave dimension out (--dimension) to take the script's, or give "
                             f"the script of this run")
        self.contact_reach = _contact_reach(pair_style, script)
        if pair_style is None:
            pair_style = script.pair_style if script is not None and script.pair_style else "gran"
        if pair_style not in PAIR_STYLES:
            raise ValueError(f"pair_style: expected one of {PAIR_STYLES}, got {pair_style!r}")
        self.atoms_path = os.path.abspath(os.fspath(atoms))
        self.pairs_path = None if pairs is None else os.path.abspath(os.fspath(pairs))
        self.dimension = dimension
        self.pair_style = pair_style
        if pair_columns is None and pairs is not None:
            header = dump_local_header(self.pairs_path)
            if pair_values is None:
                raise ValueError(_unknown_pair_values(self.pairs_path, header, pair_compute, pair_style))
            pair_values = tuple(str(v) for v in pair_values)
            _check_value_count(self.pairs_path, header, pair_compute, pair_values)
            pair_columns = pair_local_columns(pair_compute, pair_values, property_compute, property_values,
                                              pair_style)
        self.pair_columns = None if pair_columns is None else dict(pair_columns)
        self.pair_values = pair_values
        if isinstance(walls, str):
            walls = [walls]
        self.walls = tuple(str(w) for w in walls)
        self.wall_reach = script.wall_reach(self.walls) if script is not None else 2.0
        self.fixed_types = tuple(index_array(list(fixed_types), "fixed_types").tolist())
        # the script's boundary types may hold no particle (LIGGGHTS runs declare a type for a wall's material only):
        # only the types a user names are refused when they select nothing
        self._named_fixed_types = () if fixed_types_from_script else self.fixed_types
        self.fixed_ids = np.unique(index_array(list(fixed_ids), "fixed_ids"))
        self.body_force = self._check_body_force(body_force, dimension, "LAMMPS")
        self.masses_by_type = None if masses is None else {int(k): float(v) for k, v in dict(masses).items()}
        self.dt = positive_number(dt, "dt", allow_none=True)
        self.wrap = flag(wrap, "wrap")
        self.drop_inactive = flag(drop_inactive, "drop_inactive")
        self.check_forces = flag(check_forces, "check_forces")
        if self.pairs_path is None and (self.walls or self.fixed_types or self.fixed_ids.size):
            warnings.warn(f"{self.atoms_path}: walls or fixed particles but no contact dump (pairs=): the contacts "
                          f"between particles are missing, so the bulk contact stress is zero and only wall "
                          f"contacts reach the boundary stress and the IFD", stacklevel=2)
        self._atoms_dump = scan_dump(self.atoms_path, "atoms")
        self._pairs_dump = None if self.pairs_path is None else scan_dump(self.pairs_path, "local")
        self._frames = self._match(list(self._atoms_dump))
        self._warn_repeated_steps()
        self._cache = None
        self._outer = (None, None)    # the neighbouring frames in the files before and after (_link_files)

    def _link_files(self, before, after):
        """Learn the frames next to this file's in the files read before and after it (readers of the same kind, or
        None): open_dataset reads one file per reader, and with one frame per file (``dump ... atoms.*.dump``) a
        frame's only neighbours are in other files (:meth:`_remap_per_step`). Keeps each as (the file's DumpIndex,
        the frame's offset, its timestep): read only when a frame's geometry check fails."""
        def edge(reader, k):
            if not isinstance(reader, LammpsReader) or not reader._frames or reader.dimension != self.dimension:
                return None
            offset, timestep, _ = reader._frames[k]
            return reader._atoms_dump, offset, timestep
        self._outer = (edge(before, -1), edge(after, 0))

    def _warn_repeated_steps(self):
        """A timestep written twice in the atoms dump (a run restarted from a restart file and appending to its dump,
        or dumps concatenated) is read twice: a time average counts it twice. Allowed, but not silently."""
        frames = ((ts, self._atoms_dump.extent[off][1]) for off, ts in self._atoms_dump)
        warn_repeated_frames(self.atoms_path, frames, lambda ts: f"timestep {ts}", "frames at lines",
                             "as by a run restarted and appending to its dump, or dumps concatenated",
                             "timestep", "step")

    def _match(self, atom_frames):
        """Pair each atoms frame with the pairs frame of the same timestep (k-th with k-th)."""
        if self.pairs_path is None:
            return [(off, ts, None) for off, ts in atom_frames]
        by_step = {}
        for off, ts in self._pairs_dump:
            by_step.setdefault(ts, []).append(off)
        used = {}
        out = []
        missing = []
        for off, ts in atom_frames:
            k = used.get(ts, 0)
            offsets = by_step.get(ts, [])
            if k < len(offsets):
                out.append((off, ts, offsets[k]))
                used[ts] = k + 1
            else:
                missing.append(ts)
        if missing:
            raise ValueError(f"pairs: no contact frame for timestep(s) {missing[:10]} of the atoms dump "
                             f"{self.atoms_path}; dump both at the same steps (see the module docstring)")
        return out

    # ------------------------------------------------------------------------------------------
    @property
    def timesteps(self):
        return [ts for _, ts, _ in self._frames]

    def _describe(self):
        return [file_name(self.atoms_path), file_name(self.pairs_path)], [f"{self.dimension}D"]

    def force_mismatch(self, index, fixed=False):
        """Max ``|sum of contact forces + m g - dumped force|`` over particles, relative to the typical
        (RMS) contact force: the force-balance mismatch of frame ``index`` (see LammpsFrame.force_balance)."""
        return self.frame(index).force_balance(fixed=fixed)["relative"]

    def dumped_forces(self, index):
        """The per-particle forces of the atoms dump for frame ``index`` ((N, D), sorted by ID)."""
        f = self.frame(index).forces
        if f is None:
            raise ValueError("dumped_forces: the atoms dump has no fx fy fz columns")
        return f

    # ------------------------------------------------------------------------------------------
    # one frame: box, atoms, contacts (pairs and walls), time

    def _axes(self):
        return (0, 1) if self.dimension == 2 else (0, 1, 2)

    def _build(self, atoms_offset, timestep, pairs_offset):
        fr = self._atoms_dump.read(atoms_offset)
        box = self._box(fr, timestep)
        atoms = self._atoms(fr["data"], box, timestep)
        atoms = atoms._replace(first_line=fr.get("first_line"), timestep=timestep)
        if atoms.span is not None:
            self._check_in_box(fr["data"], atoms, box, timestep, fr["flags"])
        parts = []
        if pairs_offset is not None:
            parts.append(self._pair_contacts(pairs_offset, timestep, atoms, box))
        parts += [self._wall_contacts(fr["data"], atoms, wall, box) for wall in self.walls]
        parts += self._dumped_wall_contacts(atoms_offset, timestep, atoms, box)
        contacts, contact_ids, overlap = _joined_contacts(parts, self.dimension)
        if not len(contacts) and atoms.span is not None and self.input_script is not None:
            # no contact geometry checks this frame's positions: the box, to the script's skin
            bound = self.input_script.stray_bound()
            if bound is not None:
                self._check_in_box(fr["data"], atoms, box, timestep, fr["flags"], skin=bound)
        safe_masses = np.where(atoms.fixed & ~(atoms.masses > 0), 1.0, atoms.masses)
        # the internal path (no copies): columns taken as parsed were refused nan/inf by the parser; computed
        # arrays (masses, scaled positions, contacts) and the contacts' pairs are checked as for user data
        parsed = ("velocities", "angular_velocities", "torques") + (("positions",) if atoms.positions_parsed else ())
        snap = Snapshot.from_reader(atoms.positions, velocities=atoms.velocities, masses=safe_masses, box=box,
                                    contacts=contacts, fixed=atoms.fixed, species=atoms.types,
                                    body_force=self.body_force, radii=atoms.radii, time=self._time(timestep, fr),
                                    angular_velocities=atoms.angular_velocities, torques=atoms.torques, parsed=parsed)
        frame = LammpsFrame(snap, atoms.ids, atoms.types, timestep, atoms.forces, contact_ids, overlap)
        if self.check_forces and atoms.forces is not None and (pairs_offset is not None or self._wall_dump is not None):
            hints = self._balance_hints()
            check_force_balance(frame.force_balance(), atoms.ids, self.atoms_path, timestep, FORCE_BALANCE_TOLERANCE,
                                hints)
        elif self.check_forces and atoms.forces is None:
            self._refuse_unread_walls(timestep)
        return frame

    def _unread_walls(self):
        """The input script's wall fixes whose contacts this reader does not read: {fix ID: why} (LAMMPS: a fix
        wall/gran without 'contacts' or not among ``walls``)."""
        script = self.input_script
        if script is None:
            return {}
        return {f: "no 'contacts' keyword, or not given as walls= (--walls)" for f in script.gran_walls
                if f not in self.walls}

    def _refuse_unread_walls(self, timestep):
        """Without the atoms' forces no force check notices a wall's contacts missing, and every field would lack its
        forces silently: refused where the input script shows such walls."""
        unread = self._unread_walls()
        if not unread:
            return
        named = "; ".join(f"fix {f}: {why}" for f, why in unread.items())
        raise ValueError(f"{self.atoms_path}: timestep {timestep}: the input script {self.input_script.path} has walls "
                         f"whose contacts are not read ({named}), and the atoms dump has no fx fy fz to check the force "
                         f"balance, so their forces would be missing from every field unnoticed. Fix: read the walls' "
                         f"contacts (see the reader's Walls section), or dump fx fy fz so that the force check shows "
                         f"whether any particle touches them; or read anyway (check_forces=False, --no-check-forces) "
                         f"knowing that their forces are missing")

    #: the dump of a wall-contact compute (a LIGGGHTS reader's wall/gran/local), None: LAMMPS has its walls' contacts
    #: in the atoms dump
    _wall_dump = None

    def _dumped_wall_contacts(self, atoms_offset, timestep, atoms, box):
        """The contacts of a wall-contact dump at this frame (a list of contact parts; none for LAMMPS)."""
        return []

    def _check_selection(self, types, ids, timestep):
        """Fixed types and IDs a user names that select no particle are errors (a typo must not read as 'no
        boundary')."""
        missing = [t for t in self._named_fixed_types if not np.any(types == t)]
        if missing:
            raise ValueError(f"fixed_types: type(s) {missing} select no particle in {self.atoms_path} at timestep "
                             f"{timestep} (types present: {sorted(set(types.tolist()))})")
        # ids are sorted and distinct (_atoms), fixed_ids too: a search instead of setdiff1d's sort of all ids
        at = np.searchsorted(ids, self.fixed_ids)
        absent = self.fixed_ids[(at >= ids.size) | (ids[np.minimum(at, ids.size - 1)] != self.fixed_ids)] \
            if ids.size else self.fixed_ids
        if absent.size:
            raise ValueError(f"fixed_ids: atom ID(s) {absent[:10].tolist()} are not in {self.atoms_path} at "
                             f"timestep {timestep}")

    def _balance_hints(self):
        named = f"pair_values={self.pair_values}" if self.pair_values else f"pair_columns={self.pair_columns}"
        return [f"the contact dump's columns are not {named} (--pair-values): check the order of the "
                f"'compute pair/local' line",
                f"the pair style is not pair_style={self.pair_style!r} (--pair-style)",
                "a body force is missing or wrong (body_force=, --gravity)",
                "fixed particles or walls are not marked (fixed_types=, fixed_ids=, walls=; "
                "--fixed-types, --fixed-ids, --walls)"]

    def _box(self, fr, timestep):
        path = self.atoms_path
        if fr["triclinic"]:
            raise NotImplementedError(f"{path}: triclinic boxes are not supported (timestep {timestep})")
        if fr["bounds"] is None:
            raise ValueError(f"{path}: no ITEM: BOX BOUNDS in the frame at timestep {timestep}")
        axes = list(self._axes())
        lower, upper = fr["bounds"][:, 0][axes], fr["bounds"][:, 1][axes]
        return Box(lower, upper, tuple(fr["flags"][a] == "pp" for a in self._axes()))

    def _atoms(self, tab, box, timestep):
        """The atoms of a frame, sorted by ID (an :class:`_Atoms`)."""
        path = self.atoms_path
        if "id" not in tab:
            raise ValueError(f"{path}: the atoms dump needs an 'id' column (has {list(tab.index)})")
        ids_raw = tab.integers("id")
        n = ids_raw.shape[0]
        if np.all(ids_raw[1:] > ids_raw[:-1]):
            # already sorted by ID (dump_modify sort id, or one process): the order is the identity, and the
            # columns are copied instead of gathered
            order, rows, ids = np.arange(n), None, ids_raw.copy()
        else:
            order = rows = np.argsort(ids_raw, kind="stable")
            ids = np.take(ids_raw, order)
            if np.any(ids[1:] == ids[:-1]):
                raise ValueError(f"{path}: duplicate atom IDs at timestep {timestep}")

        def column(values):
            """A column of the table (a strided view) in ID order, as a new array."""
            return values.copy() if rows is None else np.take(values, rows)

        def cols(names, what):
            missing = [c for c in names if c not in tab]
            if missing:
                raise ValueError(f"{path}: {what} needs columns {missing} (has {list(tab.index)})")
            return self._vectors(tab, names, rows) if n else np.zeros((0, self.dimension))

        for xn, yn, zn, scaled, unwrapped in _POSITION_COLUMNS:
            if xn in tab:
                pos = cols((xn, yn, zn), "positions")
                if scaled:
                    pos = box.lower + pos * (box.upper - box.lower)
                positions_parsed = not scaled
                break
        else:
            raise ValueError(f"{path}: no position columns (x y z, xu yu zu, xs ys zs or xsu ysu zsu)")
        # the size of the coordinates as written (before wrapping): how far their last digits reach; and their
        # range, which the box must hold (not for unwrapped positions)
        # (the written coordinates, not the box bounds: particles in a corner of a large box are written to the
        # digits of their own size); scaled ones s are off by their rounding times the box length
        extent, span, resolution = 0.0, None, 0.0
        if n:
            # (a reduction per column: 25 times faster than pos.min(axis=0) on (N, 3), the same values)
            lowest = np.array([pos[:, a].min() for a in range(pos.shape[1])])
            highest = np.array([pos[:, a].max() for a in range(pos.shape[1])])
            span = None if unwrapped else (lowest, highest, xn, scaled)
            if scaled:
                extent = float(max(np.max(np.abs(highest - box.lower)), np.max(np.abs(lowest - box.lower))))
            else:
                extent = max(float(highest.max()), -float(lowest.min()))
            resolution = written_resolution(*(tab[c] for c in (xn, yn, zn) if c in tab))
            if scaled:
                resolution *= float(np.max(box.upper - box.lower))
        if self.wrap and any(box.periodic):    # (wrapping moves coordinates along periodic axes only)
            pos = box.wrap(pos)
        types = column(tab.integers("type")) if "type" in tab else np.ones(n, np.int64)
        vel = cols(("vx", "vy", "vz"), "velocities") if "vx" in tab else None
        forces = cols(("fx", "fy", "fz"), "forces") if "fx" in tab else None
        masses = self._masses(tab, column, types)
        radius_resolution = 0.0
        if "radius" in tab:
            radii = column(tab["radius"])
            radius_resolution = written_resolution(tab["radius"])
        elif "diameter" in tab:
            radii = 0.5 * column(tab["diameter"])
            radius_resolution = 0.5 * written_resolution(tab["diameter"])
        else:
            radii = None
        fixed = np.isin(types, self.fixed_types) | np.isin(ids, self.fixed_ids)
        self._check_selection(types, ids, timestep)
        # pseudo-vectors: (omegax, omegay, omegaz) in 3D; in 2D (x-y runs) the z component, the normal
        # that makes cgbound's (axis 0, axis 1, normal) right-handed
        spin = self._pseudo_vectors(tab, ("omegax", "omegay", "omegaz"), order, "angular velocities")
        torques = self._pseudo_vectors(tab, ("tqx", "tqy", "tqz"), order, "torques")
        return _Atoms(ids, order, types, pos, vel, forces, masses, radii, fixed, spin, torques, positions_parsed,
                      extent, span=span, resolution=resolution, radius_resolution=radius_resolution)

    def _check_in_box(self, tab, atoms, box, timestep, flags=None, skin=None):
        """Refuse positions (wrapped or scaled, not unwrapped) outside the box by more than BOX_SLACK box lengths
        (see the module docstring): LAMMPS lets an atom stray out of its box only until it next re-neighbours.
        Along a shrink-wrapped axis (boundary ``s`` or ``m``, ``flags``: the dump's BOX BOUNDS flags) the box may be
        far thinner than the stray (a flat layer: 4e-4 thick, atoms 0.04 out): there the slack is a length,
        SHRINK_SLACK of the largest box length, 4 of the largest radius or the input script's skin, whichever is
        largest. ``skin`` (a frame without contacts, whose positions no contact geometry checks; the input script's
        :meth:`~cgbound.readers.lammps_input.InputScript.stray_bound`): along non-periodic and shrink-wrapped axes
        the slack is that length instead (an atom strays at most half a skin between re-neighbourings)."""
        lowest, highest, xn, scaled = atoms.span
        length = box.upper - box.lower
        stray = np.maximum(box.lower - lowest, highest - box.upper)
        allowed = np.array([BOX_SLACK[p] for p in box.periodic]) * length
        axes = self._axes()
        shrink = np.array([flags is not None and any(c in "sm" for c in flags[a]) for a in axes])
        if shrink.any():
            slack = SHRINK_SLACK * float(length.max())
            if atoms.radii is not None and atoms.radii.size:
                slack = max(slack, 4 * float(atoms.radii.max()))
            if self.input_script is not None and self.input_script.skin is not None:
                slack = max(slack, self.input_script.skin)
            allowed = np.where(shrink, slack, allowed)
        if skin is not None:
            allowed = np.where(np.asarray(box.periodic) & ~shrink, allowed, skin)
        if not np.any(stray > allowed):
            return
        axis = int(np.argmax(stray - allowed))
        name = {"x": ("x", "y", "z"), "xs": ("xs", "ys", "zs")}[xn][axes[axis]]
        written = tab[name]
        value = box.lower[axis] + written * length[axis] if scaled else written
        row = int(np.argmax(np.maximum(box.lower[axis] - value, value - box.upper[axis])))
        atom = int(tab.integers("id")[row])
        line = "" if atoms.first_line is None else f" (line {atoms.first_line + row})"
        kind = ("shrink-wrapped" if shrink[axis] else "periodic" if box.periodic[axis] else "non-periodic")
        shown = f"{name} = {written[row]:.9g}" + (f" ({name[0]} = {value[row]:.9g})" if scaled else "")
        if skin is not None and (shrink[axis] or not box.periodic[axis]):
            script = self.input_script
            given = ("the skin of its 'neighbor' command" if script.neighbor_given else
                     f"the default skin for units {script.units or 'lj'}, as it has no 'neighbor' command")
            by = (f"by {stray[axis]:.3g} ({stray[axis] / length[axis]:.3g} box lengths; refused beyond one neighbor "
                  f"skin, {skin:.3g}: {given} in {script.path}), in a frame without contacts, whose positions no "
                  f"contact geometry checks (an atom strays at most half a skin between re-neighbourings)")
        elif shrink[axis]:
            by = (f"by {stray[axis]:.3g} (refused beyond {allowed[axis]:.3g}: the largest of {SHRINK_SLACK:g} of the "
                  f"largest box length, 4 radii and the skin)")
        else:
            by = f"by {stray[axis] / length[axis]:.3g} box lengths (refused beyond {BOX_SLACK[box.periodic[axis]]:g})"
        raise ValueError(
            f"{self.atoms_path}: timestep {timestep}: atom {atom}{line} has {shown}, outside the "
            f"box [{box.lower[axis]:.9g}, {box.upper[axis]:.9g}] along that {kind} axis {by}; LAMMPS lets an atom "
            f"stray only until it re-neighbours. Likely causes: "
            f"the atoms dump's position columns are not the positions: its 'ITEM: ATOMS' labels swapped (e.g. "
            f"'{name}' with 'v{name[0]}') or shifted against the columns, by an edit, a merge or a converter; or the "
            f"BOX BOUNDS are not this frame's. Fix: read the dump as LAMMPS wrote it, with the positions under their "
            f"own labels")

    def _pseudo_vectors(self, tab, names, order, what):
        """(n, 3) in 3D, the z column (n,) in 2D; None if the dump has none of the columns."""
        wanted = names if self.dimension == 3 else names[2:]
        present = [c for c in wanted if c in tab]
        if not present:
            return None
        if len(present) < len(wanted):
            raise ValueError(f"{self.atoms_path}: {what} need columns {[c for c in wanted if c not in tab]} "
                             f"(has {list(tab.index)})")
        if self.dimension == 2:
            return np.asarray(tab[names[2]][order], float)
        return np.stack([tab[c][order] for c in names], axis=1)

    def _vectors(self, tab, names, rows=None):
        """A new (n, D) array of the columns ``names`` (one per LAMMPS axis) at ``rows`` (None: all), cgbound axes."""
        return table_columns(tab, [names[a] for a in self._axes()], rows)

    def _masses(self, tab, column, types):
        """The masses in ID order: the mass column (``column`` takes a column to that order), else by type."""
        if "mass" in tab:
            return column(tab["mass"])
        if self.masses_by_type is not None:
            try:
                return np.array([self.masses_by_type[int(t)] for t in types], float)
            except KeyError as exc:
                raise ValueError(f"masses: no mass given for atom type {exc.args[0]}") from None
        raise ValueError(f"{self.atoms_path}: no 'mass' column; dump it or pass masses={{type: mass}}")

    def _time(self, timestep, fr):
        if self.dt is not None:
            return timestep * self.dt
        if fr["time"] is not None:
            return fr["time"]
        return float(timestep)

    def _wall_contacts(self, tab, atoms, wall, box):
        """The contacts of ``fix wall/gran ... contacts`` ID ``wall``, from its f_ID[1..8] columns."""
        names = [f"f_{wall}[{k}]" for k in range(1, 9)]
        missing = [c for c in names[:7] if c not in tab]
        if missing:
            raise ValueError(f"{self.atoms_path}: wall {wall!r} needs columns {missing} (dump f_{wall}[*] from "
                             f"'fix {wall} ... wall/gran ... contacts')")
        order = atoms.order
        k = np.flatnonzero(tab[names[0]][order] != 0)
        force = self._vectors(tab, names[1:4], order[k])
        point = self._vectors(tab, names[4:7], order[k])
        if atoms.radii is not None and k.size:
            self._check_wall_geometry(wall, atoms, k, point, box)
        if self.wrap and any(box.periodic):
            point = box.wrap(point)
        wall_j = np.full(k.shape, -1, np.int64)
        return k, wall_j, force, point, np.stack([atoms.ids[k], wall_j], axis=1), np.full(k.shape, np.nan), None

    def _check_wall_geometry(self, wall, atoms, k, point, box):
        """Refuse wall contacts whose contact point (on the wall) is further from the particle's centre than
        ``wall_reach`` radii (the module docstring): positions that are not positions miss the wall's points."""
        def location(j):
            text = f"atom {int(atoms.ids[k[j]])}"
            if atoms.first_line is not None:
                text += f" (the atoms dump's line {atoms.first_line + int(atoms.order[k[j]])})"
            return text

        self._refuse_far_wall_points(atoms, k, point, box, f"fix {wall}", f"f_{wall}[5..7]",
                                     (point[:, 0], point[:, -1]), location, [], f"fix {wall} wall/gran granular ... jkr")

    def _refuse_far_wall_points(self, atoms, k, point, box, wall, columns, written, location, hints, cohesive,
                                touching=None):
        """The wall contacts' reach rule (shared by the readers' walls): refuse contacts whose contact point ``point``
        (written as ``columns``; ``written``: their values as read, for their written decimals) lies further from
        the particle's centre than ``wall_reach`` radii; only the rows ``touching`` count where given (the others
        are not contacts). ``wall`` names the walls, ``location(j)`` the j-th contact's lines, ``hints`` the causes
        of the reader's own, ``cohesive`` the wall model that would pull beyond contact."""
        reach = self.wall_reach
        radii = np.take(atoms.radii, k)
        dist = row_norms(box.minimum_image(np.take(atoms.positions, k, axis=0) - point))
        slack = np.sqrt(3) * (atoms.resolution + written_resolution(*written)) + reach * atoms.radius_resolution
        err = dist - reach * radii
        if touching is not None:
            err = np.where(touching, err, -radii)
        found = geometry_misfits(err, radii + atoms.extent, slack=slack)
        if found is None:
            return
        bad, tol, ratio = found
        hints = hints + ["the radius (diameter) column is not the radii"]
        if reach == 1:
            what = (f"have their contact point ({columns}) further than the radius from the particle's centre, "
                    "which a repulsive wall model cannot")
            hints.append(f"the wall model pulls beyond contact ({cohesive}): give the input script (--input)")
        else:
            what = (f"have their contact point ({columns}) further than {reach:g} radii from the particle's "
                    "centre, which no wall model can")

        def detail(j):
            return (f"the contact point is {dist[j]:.9g} from the centre, {dist[j] / radii[j]:.6g} radii (r = "
                    f"{radii[j]:.6g}; tolerance {tol * (radii[j] + atoms.extent) + slack:.2g})")

        raise contact_geometry_error(self.atoms_path, f"the wall contacts of {wall}", atoms.timestep, bad,
                                     ratio / tol, what, detail, location, hints)

    def _pair_contacts(self, offset, timestep, atoms, box):
        """The contacts of the pairs dump's frame at ``offset``: (i, j, force, point, contact IDs, overlap)."""
        fr = self._pairs_dump.read(offset, ("index",), self._pair_id_columns())
        if fr["n"] == 0:
            dim = self.dimension
            return (np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros((0, dim)), np.zeros((0, dim)),
                    np.zeros((0, 2), np.int64), np.zeros(0), None)
        where = _Where(timestep, fr.get("first_line"), atoms)
        return self._pairs_from_table(fr["data"], fr["n"], timestep, atoms.ids, atoms.positions, atoms.radii, box,
                                      where)

    def _pair_id_columns(self):
        """The contact dump's atom-ID columns: whole numbers (in the dump's float format), read as int64."""
        return (self.pair_columns["id1"], self.pair_columns["id2"])

    def _pairs_from_table(self, tab, m, timestep, ids, pos, radii, box, where=None):
        path = self.pairs_path
        names = self.pair_columns
        needed = [names["id1"], names["id2"], *names["force"]]
        for key in ("tangential", "branch"):
            if names.get(key):
                needed += list(names[key])
        missing = [c for c in needed if c not in tab]
        if missing:
            raise ValueError(f"{path}: expected columns {missing} in the dump local (has "
                             f"{list(tab.index)}); set pair_compute/pair_values/property_compute "
                             "or pair_columns to match your computes")
        id1 = tab.integers(names["id1"])
        id2 = tab.integers(names["id2"])
        i, j = contact_indices(ids, id1, id2, path, timestep)
        if np.any(id1 == id2):
            tab, m, id1, id2, i, j = self._without_self_rows(
                tab, id1, id2, i, j, [names["force"], names.get("tangential") or ()], radii, box, where, timestep)
        force = self._vectors(tab, names["force"])
        if names.get("tangential"):
            force += self._vectors(tab, names["tangential"])
        # np.take: a gather along axis 0, 5-7 times faster than pos[i] on (N, D) arrays (the same values)
        pos_i = np.take(pos, i, axis=0)
        separation = np.take(pos, j, axis=0)
        np.subtract(pos_i, separation, out=separation)   # (in place: a new array's pages cost the kernel's zeroing)
        crossed = None
        if any(box.periodic):   # (the minimum image changes components along periodic axes only)
            raw, separation = separation, box.minimum_image(separation)
            # contacts across a periodic boundary: pair/local took j's ghost image (see _check_pair_geometry)
            crossed = raw[:, 0] != separation[:, 0]
            for a in range(1, raw.shape[1]):
                crossed |= raw[:, a] != separation[:, a]
        if radii is None:
            raise ValueError(f"{self.atoms_path}: rebuilding contact points needs a 'radius' or 'diameter' column")
        radii_i = np.take(radii, i)
        radii_sum = radii_i + np.take(radii, j)
        images = None
        if any(box.periodic) and radii_sum.size and thin_box(box, radii_sum):
            repeated = repeated_pairs(i, j, ids.size)
            if repeated is not None:
                has_dist = bool(names.get("dist")) and names["dist"] in tab
                separation, crossed = self._listed_images(
                    where, i, j, id1, id2, separation, crossed, box, repeated, force,
                    written_branch=self._vectors(tab, names["branch"]) if names.get("branch") else None,
                    written_dist=tab[names["dist"]] if has_dist else None,
                    normal=self._vectors(tab, names["force"]) if self.pair_style != "total" else None,
                    fix=("add 'dist' to compute pair/local (pair granular: p10 p11 p12, the branch vector) and name it "
                         "in pair_values= (--pair-values, or give the input script, --input)"))
                images = separation.copy()     # (the snapshot's branches: the point is rebuilt in place below)
                if self.input_script is not None and self.input_script.newton is False:
                    # (refused whatever check_forces says: pair/local's values of such pairs do not give the stress)
                    axis = "xyz"[int(np.argmin(np.asarray(box.lengths, float)))]
                    raise ValueError(
                        f"{path}: timestep {timestep}: pairs listed once per periodic image (the periodic box length "
                        f"along {axis}, {min(box.lengths):.6g}, is less than two contact distances) with 'newton off' "
                        f"in the input script {self.input_script.path}: LAMMPS then evaluates such pairs from each "
                        f"side, and neither its per-atom forces nor pair/local's values give their stress "
                        f"(tests/data/lammps/in.thin with newton off: the contacts' virial 0.4-46 % off compute "
                        f"pressure's). Fix: run with 'newton on' (the default), or a box at least two contact "
                        f"distances wide")
        if names.get("branch"):
            branch = self._vectors(tab, names["branch"])
            # pair granular writes zeros (force and branch) for a pair it finds not touching (JKR beyond its
            # pull-off distance): the branch of those rows is the positions' separation
            unset = branch[:, 0] == 0
            for a in range(1, branch.shape[1]):
                unset &= branch[:, a] == 0
            if unset.any():
                branch[unset] = separation[unset]
        else:
            branch = separation
        dist = row_norms(branch)
        if where is not None:
            self._check_pair_geometry(tab, where, i, j, id1, id2, separation, dist, branch, radii_sum, force,
                                      crossed, box)
        overlap = radii_sum - dist
        kept = None
        if self.drop_inactive:
            keep = overlap > 0
            for a in range(force.shape[1]):     # (one pass per column, not a boolean (M, D) array reduced)
                keep |= force[:, a] != 0
            if not keep.all():     # (every row kept: no copies)
                kept = keep
                i, j, force, branch, dist, overlap, pos_i, radii_i = (
                    i[keep], j[keep], force[keep], branch[keep], dist[keep], overlap[keep], pos_i[keep], radii_i[keep])
                if images is not None:
                    images = images[keep]
        if np.any(dist == 0):
            raise ValueError(f"{path}: two atoms at the same position at timestep {timestep}")
        # point = pos[i] - (radii[i] - overlap / 2) n, n = branch / dist: the same operations, in place (over the
        # branches, this function's own array)
        point = np.divide(branch, dist[:, None], out=branch)
        np.multiply(point, (radii_i - 0.5 * overlap)[:, None], out=point)
        np.subtract(pos_i, point, out=point)
        if self.wrap and any(box.periodic):
            point = box.wrap(point)
        # ids[i], ids[j]: the contacts' own IDs (contact_indices found each one there), taken from the table
        contact_ids = np.empty((len(i), 2), np.int64)
        contact_ids[:, 0], contact_ids[:, 1] = (id1, id2) if kept is None else (id1[kept], id2[kept])
        return i, j, force, point, contact_ids, overlap, images

    def _without_self_rows(self, tab, id1, id2, i, j, force_columns, radii, box, where, timestep):
        """The contact rows without those of a particle paired with itself (id1 == id2): in a periodic box shorter
        than a particle's diameter plus the neighbour skin the engine lists the particle with its own image. Such a
        row without a force (``force_columns``: tuples of column names; the image within the cutoff, not touching)
        carries nothing and is dropped; one with a force (the particle touches its own image: a periodic length
        less than its diameter) is refused, as cgbound does not model self-contacts. Returns (tab, m, id1, id2, i,
        j) of the rows kept."""
        same = id1 == id2
        acting = np.zeros(same.shape, bool)
        for cols in force_columns:
            for c in cols:
                acting |= tab[c] != 0
        bad = np.flatnonzero(same & acting)
        if bad.size:
            k = int(bad[0])
            lengths = np.asarray(box.upper, float) - np.asarray(box.lower, float)
            axes = "xyz"[:lengths.size]
            periodic = [a for a in range(lengths.size) if box.periodic[a]]
            diameter = None if radii is None else 2.0 * float(radii[i[k]])
            short = [a for a in periodic if diameter is None or lengths[a] < diameter] or periodic
            a = min(short, key=lambda b: lengths[b]) if short else int(np.argmin(lengths))
            size = "its contact distance" if diameter is None else f"the particle's diameter ({diameter:.6g})"
            atom_line = "" if where is None or where.atoms.first_line is None else \
                f" (the atoms dump's line {where.atoms.first_line + int(where.atoms.order[i[k]])})"
            pair_line = "" if where is None or where.pairs_line is None else \
                f", the contact dump's line {where.pairs_line + k}"
            raise ValueError(
                f"{self.pairs_path}: timestep {timestep}: atom {int(id1[k])}{atom_line} is listed in contact with "
                f"itself{pair_line} ({bad.size} such row{'s' if bad.size > 1 else ''} with a force in the frame, atoms "
                f"dump {self.atoms_path}): the periodic length along {axes[a]}, {lengths[a]:.6g}, is less than {size}, "
                f"so it touches its own periodic image; cgbound does not model self-contacts (a particle's force on "
                f"itself). Fix: make the box at least one diameter wide along its periodic axes (better two contact "
                f"distances, so that no pair touches through two images either)")
        keep = ~same
        rows = Table(tab.values[keep], list(tab.index))     # (its integer columns: those rows of the frame's)
        rows.integer_columns = {c: v[keep] for c, v in tab.integer_columns.items()}
        return rows, int(np.count_nonzero(keep)), id1[keep], id2[keep], i[keep], j[keep]

    def _listed_images(self, where, i, j, id1, id2, separation, crossed, box, repeated, force, written_branch=None,
                       written_dist=None, normal=None, fix=""):
        """The separations of a pair listed more than once (``repeated``: bools of those rows): in a periodic box
        thinner than two contact distances a pair can touch through two periodic images of each other at once, and
        LAMMPS (pair/local) lists it once per image, each listing its own contact with its own branch vector. The
        image of each such listing is the one its ``written_branch`` ((M, D): pair granular's p10-p12) gives, else
        its ``written_dist`` ((M,): 'dist'): the nearest,
        or where two are as near (a pair half a box length apart along an axis) the one along ``normal`` ((M, D),
        forces along the branch: gran, granular); refused where neither tells, and without either (``fix``: how to
        dump them). Rows without a ``force`` carry nothing and take the nearest. Returns (separations, crossed) with
        those rows' images; the geometry check then holds them to the contact dump's values as any other. The
        listings of one pair that carry a force must take distinct images."""
        timestep = where.timestep
        lengths = box.upper - box.lower
        periodic = np.asarray(box.periodic, bool)
        rows = np.flatnonzero(repeated)
        s = separation[rows]
        active = np.any(force[rows] != 0, axis=1)

        def lines(ks):
            return "" if where.pairs_line is None else \
                f" (the contact dump's lines {', '.join(str(where.pairs_line + int(k)) for k in ks)})"

        def thin():
            # (the axes along which a second image is within the contact reach)
            reach = (self.contact_reach or 2.0) * float(np.max(np.take(where.atoms.radii, i[rows])
                                                               + np.take(where.atoms.radii, j[rows])))
            axes = "xyz" if self.dimension == 3 else "xy"
            short = [f"{axes[a]} ({lengths[a]:.6g})" for a in range(len(axes)) if periodic[a]
                     and 0.5 * lengths[a] <= reach] or [f"{axes[a]} ({lengths[a]:.6g})" for a in range(len(axes))
                                                        if periodic[a]]
            return f"the periodic box length{'s' if len(short) > 1 else ''} along {', '.join(short)} " + (
                "are" if len(short) > 1 else "is")

        # the candidate images: -1, 0 or 1 box lengths along each periodic axis
        axes = np.flatnonzero(periodic)
        shifts = np.array(np.meshgrid(*[(-1.0, 0.0, 1.0)] * axes.size, indexing="ij")).reshape(axes.size, -1).T
        steps = np.zeros((shifts.shape[0], lengths.size))
        steps[:, axes] = shifts

        first = rows[0]
        pair_rows = rows[(np.minimum(i[rows], j[rows]) == min(i[first], j[first]))
                         & (np.maximum(i[rows], j[rows]) == max(i[first], j[first]))]

        def by_dist(sub):
            """The images of rows[sub] whose distance is their written one."""
            written = np.take(written_dist, rows[sub])
            candidates = s[sub][:, None, :] + steps[None] * lengths                 # (rows, images, D)
            err = np.abs(np.sqrt(np.sum(candidates ** 2, axis=2)) - written[:, None])
            best = np.argmin(err, axis=1)
            r = np.arange(len(written))
            near = err - err[r, best][:, None] <= GEOMETRY_TOLERANCE * (written + where.atoms.extent)[:, None]
            if normal is not None:
                f = normal[rows[sub]]
                cross = np.cross(candidates, f[:, None, :]) if lengths.size == 3 else \
                    (candidates[..., 0] * f[:, None, 1] - candidates[..., 1] * f[:, None, 0])[..., None]
                with np.errstate(divide="ignore", invalid="ignore"):    # (rows without a force: NaN, not along)
                    sine = np.sqrt(np.sum(cross ** 2, axis=2)) / (np.sqrt(np.sum(candidates ** 2, axis=2))
                                                                  * row_norms(f)[:, None])
                along = near & (sine <= GEOMETRY_TOLERANCE)
                pick = along.any(axis=1) & active[sub]
                best = np.where(pick, np.argmax(along, axis=1), best)
                near = np.where(pick[:, None], along, near)
            tie = (np.count_nonzero(near, axis=1) > 1) & active[sub]
            if tie.any():
                k = int(np.flatnonzero(tie)[0])
                row = rows[sub][k]
                raise ValueError(
                    f"{self.atoms_path}: timestep {timestep}: atoms {int(id1[row])} and {int(id2[row])} are listed "
                    f"more than once in {self.pairs_path}{lines([row])}, once per periodic image they touch through "
                    f"({thin()} less than two contact distances), and two images are as far apart as the contact "
                    f"dump says ({written[k]:.9g}){' and as much along its force' if normal is not None else ''}: "
                    f"which one this listing is cannot be told. Fix: dump the branch vector (pair granular: p10 p11 "
                    f"p12 in compute pair/local) and name it in "
                    f"pair_values= (--pair-values, or give the input script, --input), or make the box at least two "
                    f"contact distances wide along its periodic axes")
            return steps[best]

        if written_branch is not None:
            written = written_branch[rows]
            image = np.where(periodic, np.rint((written - s) / lengths), 0.0)
            # pair granular's zero rows (an image it finds not touching): their image from 'dist' if dumped, else
            # (it cannot be told, and they carry nothing) the farthest, which drop_inactive drops and which no
            # listing with a force takes
            unset = np.all(written == 0, axis=1)
            if unset.any():
                if written_dist is not None:
                    image[unset] = by_dist(unset)
                else:
                    far = np.sum((s[unset][:, None, :] + steps[None] * lengths) ** 2, axis=2)
                    image[unset] = steps[np.argmax(far, axis=1)]
        elif written_dist is not None:
            image = by_dist(np.ones(rows.size, bool))
        else:
            raise ValueError(
                f"{self.atoms_path}: timestep {timestep}: atoms {int(id1[first])} and {int(id2[first])} are listed "
                f"{pair_rows.size} times in {self.pairs_path}{lines(pair_rows)}: {thin()} less than two contact "
                f"distances, so a pair can touch through two periodic images of each other at once, and the engine "
                f"lists it once per image, each listing its own contact. Which image a listing is cannot be told "
                f"from the positions alone (the minimum image would give both the same branch vector: a wrong "
                f"stress). Fix: {fix}; or make the box at least two contact distances wide along its periodic axes")
        separation = separation.copy()
        separation[rows] = s + image * lengths
        moved = np.any(image != 0, axis=1)
        crossed = crossed.copy()
        crossed[rows[moved]] = True
        # the listings of one pair that carry a force: distinct images (oriented on the smaller index, as (j, i)
        # lists the same; a listing without a force carries nothing, and drop_inactive drops it when not touching)
        rows, image = rows[active], image[active]
        sign = np.where(i[rows] < j[rows], 1.0, -1.0)[:, None]
        key = np.column_stack([np.minimum(i[rows], j[rows]), np.maximum(i[rows], j[rows]),
                               (sign * image).astype(np.int64)])
        _, first_of, count = np.unique(key, axis=0, return_index=True, return_counts=True)
        if np.any(count > 1):
            k = int(first_of[np.flatnonzero(count > 1)[0]])
            same = rows[np.all(key == key[k], axis=1)]
            raise ValueError(
                f"{self.atoms_path}: timestep {timestep}: atoms {int(id1[rows[k]])} and {int(id2[rows[k]])} are "
                f"listed {same.size} times in {self.pairs_path}{lines(same)} with the same periodic image (the same "
                f"branch vector): a contact written twice. Likely causes: contact dumps concatenated or merged, or "
                f"'newton off' with a contact counted from both sides. Fix: read the contact dump as the engine wrote it")
        return separation, crossed

    def _check_pair_geometry(self, tab, where, i, j, id1, id2, separation, dist, branch, radii_sum, force,
                             crossed=None, box=None):
        """Refuse a frame whose positions do not give its contacts' geometry (see the module docstring): the
        branch vector (pair granular's p10-p12) or the ``dist`` the contact dump holds against the minimum-image
        ``separation`` of the positions; without either, that a contact force acts only where the particles touch
        (repulsive styles) or within 2 (r_i + r_j) (any granular model).

        ``crossed``: bools of the contacts across a periodic boundary (the minimum image changed their
        separation). In a box that deforms with ``remap x`` LAMMPS remaps the atoms at the end of a step but
        their ghost images keep the old box length until the next step: such a contact's geometry is off by the
        step's strain times the box length (measured: 3.8e-3 of the scale at 1e-3 strain per step; contacts
        inside the box: exactly 0). Those are held only to the rule for most contacts, their scale including
        the largest box length."""
        names, extent = self.pair_columns, where.atoms.extent
        hints = [self._balance_hints()[0]]    # (a 'dist' or branch read from another column)
        # what the written decimals account for (format float %.2f): each coordinate off by half its last decimal,
        # a separation by sqrt(3) of twice that
        slack = 2 * np.sqrt(3) * where.atoms.resolution
        if names.get("branch"):
            def error():
                return row_norms(branch - separation)
            scale = dist + extent
            cols = names["branch"]
            slack += np.sqrt(3) * written_resolution(*(tab[c] for c in cols))
            what = f"have a branch vector x_i - x_j (columns {' '.join(cols)}) that their positions do not give"

            def detail(k):
                return (f"the contact dump's branch vector is ({', '.join(f'{v:.9g}' for v in branch[k])}), the "
                        f"positions give ({', '.join(f'{v:.9g}' for v in separation[k])})")
        elif names.get("dist") and names["dist"] in tab:
            written = tab[names["dist"]]

            def error():
                err = np.subtract(written, dist)
                return np.abs(err, out=err)    # (in place: new arrays' pages cost the kernel's zeroing)
            scale = np.abs(written)
            scale += extent
            slack += written_resolution(written)
            what = f"have a distance ('dist', column {names['dist']}) that their positions do not give"

            def detail(k):
                return (f"'dist' is {written[k]:.9g} in the contact dump, the positions are {dist[k]:.9g} apart "
                        f"(r_i + r_j = {radii_sum[k]:.6g})")
        elif self.contact_reach is not None:
            hint = ("the pair style pulls beyond contact (pair granular with jkr): say so with pair_style='granular' "
                    "(--pair-style granular), or give the input script (--input)")
            self._check_reach(where, i, j, id1, id2, dist, radii_sum, force, hint)
            return
        else:
            return
        if crossed is not None and box is not None:
            np.add(scale, float(np.max(box.upper - box.lower)), out=scale, where=crossed)
        fit = (dist if names.get("branch") is None else row_norms(separation), radii_sum)
        self._refuse_geometry_deforming(box, where, i, j, id1, id2, error, scale, what, detail, hints, lenient=crossed,
                                        slack=slack, fit=fit)

    def _refuse_geometry_deforming(self, box, where, i, j, id1, id2, error, scale, what, detail, hints, slack=0.0,
                                   **options):
        """:meth:`_refuse_geometry` (``error``: a function giving the errors, a new array each call) with a box that
        deforms allowed for: atoms are remapped at the end of a step, the ghost images pair/local (LIGGGHTS:
        pair/gran/local) takes for a contact across a periodic boundary, and on several processors the ghost copies
        of the other processors' atoms, not; a frame refused is checked again allowing twice the box's change per
        step: the larger of the input script's fix deform's (InputScript.deform_change) and the neighbouring frames'
        (:func:`~cgbound.readers.checks.box_change_per_step`; read only when the check fails)."""
        try:
            self._refuse_geometry(where, i, j, id1, id2, error(), scale, what, detail, hints, slack=slack, **options)
        except ValueError:
            scripted = None      # (the script's: 0 where no fix deform acts at this step, None where not known)
            if self.input_script is not None and box is not None:
                scripted = self.input_script.deform_change(where.timestep, box.lower, box.upper, self._deform_units)
            # (the larger of the two: the neighbours' boxes measure what the script says, and were the rule before)
            moved = max(scripted or 0.0, self._remap_per_step(where.timestep, box))
            if not moved:
                deforms = [] if self.input_script is None else self.input_script.deforms
                if not deforms or scripted is not None:
                    raise
                # the script deforms the box, and no neighbouring frame tells by how much a step: say so first
                fid, line = deforms[0]
                first = (f"a deforming box (fix deform {fid} in {line}), its change per step unknown from one frame: "
                         f"the engine remaps the atoms at the end of a step but not the ghost images (or, on several "
                         f"processors, the other processors' copies) the contact dump's geometry comes from, off by "
                         f"up to that change; cgbound allows twice it, taken from the script's fix deform (styles "
                         f"final, delta, scale, vel, erate, trate, in runs the script's steps tell; 'final' not at "
                         f"its run's last step) or the neighbouring frames' boxes",
                         "read the frames together (all the dump files in one open_dataset call or one cgbound "
                         "command: a pattern such as atoms.*.dump with pairs.*.dump), so that each frame sees its "
                         "neighbours' boxes")
                self._refuse_geometry(where, i, j, id1, id2, error(), scale, what, detail, hints, slack=slack,
                                      first=first, **options)
                raise
            self._refuse_geometry(where, i, j, id1, id2, error(), scale, what, detail, hints, slack=slack + 2 * moved,
                                  **options)

    #: the units of fix deform's lengths without a 'units' keyword: LAMMPS' default (LIGGGHTS': box)
    _deform_units = "lattice"

    def _remap_per_step(self, timestep, box):
        """How far a box that deforms moves an atom per step (``remap x``), from the box bounds of this frame and its
        neighbours in the atoms dump (:func:`~cgbound.readers.checks.box_change_per_step`). With several
        processors, pair/local takes the ghost copies of atoms other processors own, not yet remapped at the end of
        the step: a contact inside the box is then off by up to this (2 processors, 2e-3 strain per step: 1e-2 of
        the distance, tests/data/lammps/deform_mpi)."""
        steps = [ts for _, ts, _ in self._frames]
        if timestep not in steps or box is None:
            return 0.0
        k = steps.index(timestep)
        axes = list(self._axes())
        others = []
        # (a frame first or last in its file: the neighbouring file's frame, when open_dataset read them together)
        outer = getattr(self, "_outer", (None, None))
        for n, beyond in ((k - 1, outer[0]), (k + 1, outer[1])):
            if 0 <= n < len(steps):
                index, offset, step = self._atoms_dump, self._frames[n][0], steps[n]
            elif beyond is not None:
                index, offset, step = beyond
            else:
                continue
            if step != timestep:
                bounds = index.read(offset)["bounds"]
                if bounds is not None:
                    others.append((bounds[:, 0][axes], bounds[:, 1][axes], abs(step - timestep)))
        return box_change_per_step(box.lower, box.upper, others)

    def _check_reach(self, where, i, j, id1, id2, dist, radii_sum, force, hint):
        """Refuse contacts that carry a force with their particles further apart than ``contact_reach`` (r_i + r_j)."""
        reach = self.contact_reach
        active = force[:, 0] != 0
        for a in range(1, force.shape[1]):
            active |= force[:, a] != 0
        err = np.where(active, dist - reach * radii_sum, -np.inf)
        scale = radii_sum + where.atoms.extent
        slack = 2 * np.sqrt(3) * where.atoms.resolution + 2 * reach * where.atoms.radius_resolution
        hints = ["the radius (diameter) column is not the radii"]
        if reach == 1:
            what = ("carry a force while their particles do not touch (|x_i - x_j| > r_i + r_j), which a repulsive "
                    "granular model cannot")
            hints.append(hint)
        else:
            what = (f"carry a force with their particles apart by more than {reach:g} (r_i + r_j), which no "
                    "granular contact model, cohesive or not, can")

        def detail(k):
            return (f"their centres are {dist[k]:.9g} apart, {dist[k] / radii_sum[k]:.6g} times r_i + r_j "
                    f"({radii_sum[k]:.6g})")

        self._refuse_geometry(where, i, j, id1, id2, err, scale, what, detail, hints, active, slack=slack)
        # nor can most contacts overlap by more than half of r_i + r_j (a centre inside the other sphere; genuine
        # frames reach 0.17, JKR and liquid bridges included): positions that are small numbers (forces, velocities)
        # put the particles of every contact nearly on top of each other
        deep = active & (dist < 0.5 * radii_sum)
        if 2 * int(np.count_nonzero(deep)) > int(np.count_nonzero(active)):
            what = ("carry a force with their centres closer than (r_i + r_j) / 2, an overlap of more than half the "
                    "radii's sum, which a granular simulation does not reach on most of its contacts")
            self._refuse_geometry(where, i, j, id1, id2, np.where(deep, 1.0, -1.0), np.ones(deep.shape),
                                  what, detail, hints[:1], active, tolerance=False)

    def _refuse_geometry(self, where, i, j, id1, id2, err, scale, what, detail, hints, checked=None, tolerance=True,
                         lenient=None, slack=0.0, fit=None, first=None):
        """Raise (contact_geometry_error) for the contacts :func:`geometry_misfits` refuses (``tolerance``: show
        each one's tolerance; ``lenient``: bools of the contacts held only to the rule for most contacts;
        ``slack``: a length the written decimals account for; ``fit``: (the positions' distances, r_i + r_j), to
        tell whether the positions look right, the contact dump's columns then the likely fault)."""
        found = geometry_misfits(err, scale, checked, lenient, slack)
        if found is None:
            return
        bad, tol, ratio = found
        atoms = where.atoms
        touching = None
        if fit is not None:
            with np.errstate(divide="ignore", invalid="ignore"):
                apart = fit[0] / fit[1]
            near = (apart >= 0.7) & (apart <= 1.01)
            touching = float(np.mean(near if checked is None else near[checked])) if apart.size else None

        def location(k):
            text = f"atoms {int(id1[k])} and {int(id2[k])}"
            if atoms.first_line is not None:
                text += (f" (the atoms dump's lines {atoms.first_line + int(atoms.order[i[k]])} and "
                         f"{atoms.first_line + int(atoms.order[j[k]])})")
            return text + ("" if where.pairs_line is None else f", the contact dump's line {where.pairs_line + k}")

        raise contact_geometry_error(
            self.atoms_path, f"the contacts of {self.pairs_path}", where.timestep, bad,
            ratio / tol, what,
            (lambda k: f"{detail(k)} (tolerance {tol * scale[k] + slack:.2g})") if tolerance else detail, location,
            [*hints, "the two dumps are not of the same run"], checked, touching, first)


def _contact_reach(pair_style, script):
    """How far apart, in units of r_i + r_j, two particles that exert a contact force on each other can be: 1 for
    the repulsive granular models, 2 where cohesion is possible or not known (a bound no granular contact model
    reaches: JKR's pull-off distance and a liquid bridge's rupture distance are fractions of a radius), None (no
    bound) for other pair styles. ``pair_style``: the reader's argument (None: not given); ``script``: the
    InputScript or None."""
    known = script is not None and bool(script.pair_command)
    family = pair_style if pair_style is not None else (script.pair_style if known else "gran")
    if family not in ("gran", "granular"):
        return None
    if known and script.pair_style == family and script.cohesive is not None:
        return 2.0 if script.cohesive else 1.0
    # named only by the family: "gran" is LAMMPS' gran/* styles (repulsive), "granular" may be jkr
    return 1.0 if family == "gran" else 2.0


class _Where(NamedTuple):
    """Where a contact frame is: its timestep, the contact dump's line of its first row, the frame's atoms."""
    timestep: int
    pairs_line: object
    atoms: object


def table_columns(tab, names, rows=None):
    """A new C-contiguous (n, len(names)) float64 array of the table's columns ``names`` at ``rows`` (indices;
    None: all rows), filled a column at a time (np.take of a strided column: 2-6 times faster than a fancy
    index of each column stacked, or a gather of a block of rows; the same values)."""
    values = tab.values
    out = np.empty((values.shape[0] if rows is None else len(rows), len(names)))
    for a, name in enumerate(names):
        column = values[:, tab.index[name]]
        if rows is None:
            out[:, a] = column
        else:
            np.take(column, rows, out=out[:, a])
    return out


class _Atoms(NamedTuple):
    """The atoms of one frame, sorted by ID; ``order`` takes the dump's rows to that order."""
    ids: np.ndarray
    order: np.ndarray
    types: np.ndarray
    positions: np.ndarray
    velocities: object
    forces: object
    masses: np.ndarray
    radii: object
    fixed: np.ndarray
    angular_velocities: object = None
    torques: object = None
    positions_parsed: bool = False   # the positions as the dump has them (not scaled): finite, the parser says
    extent: float = 0.0              # the largest coordinate magnitude as written (and the box bounds')
    first_line: object = None        # the atoms dump's line of the frame's first row (None: not known)
    timestep: object = None
    span: object = None              # (lowest, highest coordinate per axis, the x column's name, scaled) or None
    resolution: float = 0.0          # half the positions' last written decimal (fixed decimals; else 0), a length
    radius_resolution: float = 0.0   # the same of the radii


def _joined_contacts(parts, dim):
    """Contacts, contact IDs and overlaps from the (i, j, force, point, ids, overlap[, branch or None]) of each
    source."""
    if not parts:
        return Contacts.empty(dim), np.zeros((0, 2), np.int64), np.zeros(0)
    # a source's branches (a pair listed once per periodic image), None (the minimum image): walls' rows 0
    branches = [p[6] if len(p) > 6 else None for p in parts]
    branch = None
    if any(b is not None for b in branches):
        branch = np.concatenate([b if b is not None else np.zeros((len(p[0]), dim)) for b, p in zip(branches, parts)])
    if len(parts) == 1:    # one source (the pair dump): its arrays as they are, Contacts copies them once
        i, j, force, point, ids, overlap = parts[0][:6]
    else:
        i, j, force, point, ids, overlap = (np.concatenate(column) for column in list(zip(*parts))[:6])
    return (Contacts.from_reader(i, j, force.reshape(-1, dim), point.reshape(-1, dim), branch=branch),
            ids.reshape(-1, 2), overlap)


def _script_units(script):
    """The units named by the input script's ``units`` command; None (not known: labels then say
    "simulation units") for a style cgbound has no table for (LAMMPS' ``electron``)."""
    from ..units import SYSTEMS
    return script.units if script.units in SYSTEMS and script.units != "mercury" else None
