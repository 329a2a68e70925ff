"""Read LIGGGHTS granular dumps as a lazy sequence of :class:`cgbound.Snapshot`.

LIGGGHTS dumps are LAMMPS-format dumps, so this reader is a :class:`~cgbound.readers.LammpsReader`
(same frame matching by TIMESTEP, laziness, ``len()``/slicing, pickling as paths + byte offsets,
:meth:`frame`, :meth:`force_mismatch`) with its own contact dump:

* a particle ``dump custom`` exactly as for LAMMPS (``id type x y z vx vy vz fx fy fz radius mass``,
  any order, plain/scaled/unwrapped positions);
* a contact ``dump local`` of ``compute pair/gran/local``, written as ``c_ID[1] c_ID[2] ...``
  (LIGGGHTS 3.8 has no ``c_ID[*]`` wildcard: list every column).

Columns of compute pair/gran/local
----------------------------------
LIGGGHTS writes the values in a FIXED order, whatever the order of the keywords on the compute
line. Verified on LIGGGHTS-PUBLIC 3.8.0 (Debian) output, with the keywords given in two different
orders: ``pos`` (x_i then x_j, 6), ``vel`` (v_i then v_j, 6), ``id`` (ID_i, ID_j and a periodic
flag, 3), ``force`` (3), ``torque`` (3), ``delta`` (1), ``contactPoint`` (3). From the LIGGGHTS
source, and not run here: ``force_normal`` and ``force_tangential`` (3 each) come right after
``force``; ``history`` (``history=`` values, pair-style dependent), ``contactArea`` and ``delta``
between ``torque`` and ``contactPoint``; ``heatFlux`` is assumed to be last. Without keywords
LIGGGHTS writes its default set (pos vel id force torque history contactArea); give the keywords
explicitly.

The values verified against the per-particle forces and positions:

- ``force`` is the whole contact force (normal + tangential, with damping) ON ``ID_i`` FROM ``ID_j``;
- ``contactPoint`` is ``x_i - R_i/(R_i+R_j) (x_i - x_j)`` (radius-weighted, on the centre line; not
  the middle of the overlap). It is computed with the (possibly ghost) image of j, so across a
  periodic boundary it can lie outside the box: the reader wraps it in (minimum image relative
  to particle i). Without ``contactPoint`` the reader rebuilds it the same way;
- ``delta`` is ``R_i + R_j - |x_i - x_j|``.

Checks
------
As for :class:`~cgbound.readers.LammpsReader` (the force balance and the contact geometry), the geometry
from this compute's values: ``pos`` (x_i and x_j, against the atoms dump's positions, minimum image), else
``delta`` (against r_i + r_j - |x_i - x_j|), else the reach of a contact force: r_i + r_j when the input
script's ``pair_style gran`` has no ``cohesion`` model, else 2 (r_i + r_j) (cohesion possible or not known:
liquid bridges pull beyond contact, 1.0066 (r_i + r_j) measured on tests/data/liggghts/in.easo), and
most contacts not overlapping by more than half of r_i + r_j (loose bounds: positions shifted by a column in a
settled packing can pass them; dump ``pos`` to have the positions checked). In a box that deforms (``fix deform
... remap x``) the ghost image of j that pair/gran/local takes for a contact across a periodic boundary keeps the
old box length, its ``pos`` (and ``delta``) off by the box's change in a step: a frame the check refuses is checked
again allowing twice that change (as LAMMPS' is, from the script's fix deform, its lengths in box units by
default in LIGGGHTS, and the neighbouring frames'; tests/data/liggghts/in.deform: 2e-3 strain per step, 11 of 33
contacts off by up to 5.9e-6 m, the box 2.9e-3 m long).
In a periodic box thinner than two contact distances LIGGGHTS lists a pair that touches through two periodic
images once per image, and its output for those pairs does not balance (tests/data/liggghts/in.thin: up to 0.74 of
the RMS contact force inside ``run 0``, the contacts' virial 1-7% off compute pressure's): such a frame is refused
(the LAMMPS reader reads LAMMPS' output of such boxes, one contact per image).

Writing consistent dumps
------------------------
As in LAMMPS, frames dumped during a ``run`` do not balance: compute pair/gran/local re-evaluates
the contacts at the END of a step (end-of-step velocities and history), while ``fx fy fz`` were
computed mid-step. Write each frame inside its own ``run 0`` (``dump_modify ... append yes``), where
both come from the same force evaluation. Old-style ``dump_modify format`` takes one format string
for the whole line; use ``%.17g`` for the floats. See tests/data/liggghts/in.settle::

    compute         pgl all pair/gran/local pos vel id force torque delta contactPoint
    ...
    run             1500
    dump            a all custom 1 atoms.dump id type x y z vx vy vz fx fy fz radius mass
    dump            c all local 1 pairs.dump c_pgl[1] c_pgl[2] ... c_pgl[25]
    dump_modify     a format "%d %d %.17g ... %.17g" append yes
    dump_modify     c format "%.17g ... %.17g" append yes
    run             0
    undump          a
    undump          c

and read them with ``LiggghtsReader("atoms.dump", "pairs.dump", fixed_types=[2],
body_force=(0, 0, -9.81))``. Measured on tests/data/liggghts (relative to the RMS contact force):
~2.5e-16 for ``run 0`` frames on particles without periodic contacts, up to ~3e-13..2.5e-12 on
particles with a contact across a periodic boundary (LIGGGHTS granular pair styles run with
``newton off``, so such a contact is evaluated once from each side, with positions differing by
a box length; the dump holds one of the two); 0.1..1.4 for frames dumped during the run.

Walls
-----
Mesh walls' contacts are read from a ``dump local`` of ``compute ID all wall/gran/local KEYWORDS`` given as
``wall_contacts=`` (keywords from ``input=`` or ``wall_values=``; ``pos``, ``id`` and ``force`` or both of its
parts needed). They become boundary contacts (``j = -1``): the force on the particle, the contact point on the
wall. The values come in pair/gran/local's fixed order with other meanings (LIGGGHTS-PUBLIC 3.8's
``ComputePairGranLocal::add_wall_1/2`` and ``fix_wall_gran_base.h``; run on tests/data/liggghts/mesh/in.mesh):
``pos`` is the contact point on the wall (x - delta vector) then the particle's centre, ``vel`` the wall's
velocity then the particle's, ``id`` the mesh's index in the fix's ``meshes`` list, the triangle's ID and the
particle's ID; ``torque_normal``/``torque_tangential`` (3 each) follow ``torque``; ``delta`` is r - |x - contact
point| and ``contactArea`` pi (r^2 - |x - contact point|^2); ``contactPoint`` is counted but never written for a wall
(not read). Checked: the dump's column count against the keywords, its timesteps against the atoms dump's, the
particle IDs, the centre it wrote against the atoms dump's, the contact point within a radius of the centre (2 for a
wall model with ``cohesion`` or without ``input=``). Measured on the mesh scene: every particle balances to 2e-12 of
the RMS contact force; at rest the wall force is the weight to 1e-6.

Rows without a force are dropped: with ``neigh_modify contact_distance_factor`` > 1 LIGGGHTS lists walls near a
particle that do not touch it (``delta`` < 0, force 0), which are not contacts. LIGGGHTS 3.8 takes one mesh
``fix wall/gran`` (every mesh in its ``meshes`` list; a second one is an error there) and never reports primitive
walls (``primitive ... zplane``: a warning, no rows). Their contacts stay missing: the force check refuses such
frames naming them, and where the atoms dump has no ``fx fy fz`` to check, a frame of a run whose input script
(``input=``) has such walls, or mesh walls without ``wall_contacts=``, is refused. A moving mesh (``fix
move/mesh``) with a velocity fails the force check on LIGGGHTS 3.8's own output: inside ``run 0`` wall/gran/local
recomputes tangential forces other than those the particles felt (1.8-3.1 times the RMS contact force on a drum
and a conveyor floor), so such runs are refused; a mesh at rest, or moved with zero velocity, balances. (``fix wall/gran ... store_force yes`` writes a primitive wall's force on each
particle as ``f_force_ID[1..3]``, verified on LIGGGHTS 3.8; reading it is not implemented.)
"""
import os

import numpy as np

from .._validate import integer
from ._lammps_dump import scan_dump
from .checks import (compute_columns, contact_geometry_error, dump_local_header, geometry_misfits, repeated_pairs,
                     row_norms, thin_box, written_resolution)
from .lammps import LammpsReader, contact_indices
from .lammps_input import LIGGGHTS_FLAG_KEYWORDS, LIGGGHTS_LAYOUT, LIGGGHTS_WALL_LAYOUT

__all__ = ["LiggghtsReader", "pair_gran_local_columns", "wall_gran_local_columns"]

# (keyword, number of values) in the order LIGGGHTS 3.8 writes them (the input script parser's table, one place);
# history's count is set by the caller
_LAYOUT = tuple((k, None if m is None else len(m)) for k, m in LIGGGHTS_LAYOUT)
KEYWORDS = tuple(k for k, _ in _LAYOUT)
DEFAULT_VALUES = ("pos", "vel", "id", "force", "torque", "delta", "contactPoint")


# compute wall/gran/local: (keyword, number of values), likewise
_WALL_LAYOUT = tuple((k, None if m is None else len(m)) for k, m in LIGGGHTS_WALL_LAYOUT)
WALL_KEYWORDS = tuple(k for k, _ in _WALL_LAYOUT)
DEFAULT_WALL_VALUES = ("pos", "id", "force")


def pair_gran_local_columns(compute="pgl", values=DEFAULT_VALUES, history=0):
    """Column names of each keyword of ``compute ID all pair/gran/local VALUES`` dumped as
    ``c_ID[1] c_ID[2] ...``: a dict keyword -> tuple of names (e.g. ``"force"`` -> 3 names).

    ``values`` are the keywords given to the compute (any order: LIGGGHTS writes a fixed order).
    ``history`` is the number of history values when ``history`` is among them.
    """
    return _layout_columns(_LAYOUT, "pair/gran/local", compute, values, history, "values")


def wall_gran_local_columns(compute="wgl", values=DEFAULT_WALL_VALUES, history=0):
    """Column names of each keyword of ``compute ID all wall/gran/local VALUES`` dumped as ``c_ID[1] c_ID[2] ...``
    (the module docstring: ``pos`` is the contact point then the particle's centre, ``id`` the mesh, the triangle,
    then the particle): a dict keyword -> tuple of names."""
    return _layout_columns(_WALL_LAYOUT, "wall/gran/local", compute, values, history, "wall_values")


def _history_count(columns_of, compute, values, history, path):
    """The number of history values: ``history`` where given (or where 'history' is not among ``values``), else what
    the dump ``path``'s columns of ``compute`` leave after the other keywords' (their number depends on the contact
    model, so a script cannot tell it); ``columns_of``: pair_gran_local_columns or wall_gran_local_columns."""
    if "history" not in values or history:
        return history
    others = [v for v in values if v != "history" and v not in LIGGGHTS_FLAG_KEYWORDS]
    taken = sum(len(c) for c in columns_of(compute, others, 0).values()) if others else 0
    left = len(compute_columns(dump_local_header(os.fspath(path)), compute)) - taken
    return left if left > 0 else history


def _layout_columns(layout, style, compute, values, history, argument):
    """The ``c_ID[k]`` names of each keyword of ``values`` in ``layout``'s fixed order (flags such as 'verbose'
    write none)."""
    values = [v for v in values if v not in LIGGGHTS_FLAG_KEYWORDS]
    keywords = tuple(k for k, _ in layout)
    unknown = [v for v in values if v not in keywords]
    if unknown:
        raise ValueError(f"{argument}: unknown {style} keyword(s) {unknown}; expected some of {keywords}")
    if not values:
        raise ValueError(f"{argument}: give the compute's keywords explicitly (LIGGGHTS' default set has "
                         "pair-style dependent history columns)")
    if "history" in values and integer(history, "history") <= 0:
        raise ValueError(f"history: expected the number of history values (> 0), got {history!r}")
    out, k = {}, 1
    for key, count in layout:
        if key not in values:
            continue
        count = int(history) if count is None else count
        out[key] = tuple(f"c_{compute}[{k + a}]" for a in range(count))
        k += count
    return out


class LiggghtsReader(LammpsReader):
    """Lazy sequence of :class:`cgbound.Snapshot` from LIGGGHTS dumps (see the module docstring).

    Parameters
    ----------
    atoms : path
        ``dump custom`` file (as for :class:`LammpsReader`).
    pairs : path, optional
        ``dump local`` of ``compute pair/gran/local`` written as ``c_ID[1] c_ID[2] ...``. Needs the
        ``id`` keyword and ``force`` (or both ``force_normal`` and ``force_tangential``).
    pair_compute : str
        The compute's ID (default ``"pgl"``).
    pair_values : sequence of str
        The compute's keywords (default ``pos vel id force torque delta contactPoint``).
    history : int
        Number of history values when ``history`` is among ``pair_values``.
    pair_columns : dict, optional
        Explicit column names per keyword (as returned by :func:`pair_gran_local_columns`).
    wall_contacts : path, optional
        ``dump local`` of ``compute wall/gran/local`` (mesh walls; see the module docstring), all timesteps of the
        atoms dump in one file.
    wall_compute : str
        Its compute's ID (default ``"wgl"``).
    wall_values : sequence of str, optional
        Its compute's keywords (default: from ``input``'s compute wall/gran/local line); ``pos`` and ``id`` needed.
    wall_history : int
        Number of history values when ``history`` is among ``wall_values``.
    fixed_types, fixed_ids, body_force, masses, dimension, dt, wrap, input, variables, check_forces :
        As for :class:`LammpsReader` (every frame's force balance is checked by default; with ``input``
        the compute's ID and keywords come from the script's ``compute pair/gran/local`` line).

    Notes
    -----
    The number of ``c_ID[k]`` columns in the dump must be what ``pair_values`` (and ``history``)
    give: keywords other than the compute's are an error, not a shifted reading.
    """

    def __init__(self, atoms, pairs=None, *, pair_compute="pgl", pair_values=None, history=0,
                 pair_columns=None, wall_contacts=None, wall_compute="wgl", wall_values=None, wall_history=0,
                 fixed_types=(), fixed_ids=(), body_force=None, masses=None, dimension=None,
                 dt=None, wrap=True, input=None, variables=None, check_forces=True, units=None):
        # the wall dump's arguments first: a wrong keyword list is refused before any file is scanned
        wall_spec = self._wall_spec(wall_contacts, wall_compute, wall_values, wall_history, input, variables)
        if input is not None and pairs is not None and pair_values is None and pair_columns is None:
            from .lammps_input import read_input
            spec = read_input(input, variables).compute_for(pairs)
            pair_compute, pair_values = spec.id, spec.values
        if pair_values is None:
            pair_values = DEFAULT_VALUES
        from_values = pair_columns is None and pairs is not None
        if from_values:
            history = _history_count(pair_gran_local_columns, pair_compute, pair_values, history, pairs)
            pair_columns = pair_gran_local_columns(pair_compute, pair_values, history)
        if pair_columns is not None:
            pair_columns = {k: tuple(v) for k, v in dict(pair_columns).items()}
            if "id" not in pair_columns or len(pair_columns["id"]) < 2:
                raise ValueError("pair_values: compute pair/gran/local needs the 'id' keyword")
            if "force" not in pair_columns and not ("force_normal" in pair_columns
                                                    and "force_tangential" in pair_columns):
                raise ValueError("pair_values: compute pair/gran/local needs 'force' (or both "
                                 "'force_normal' and 'force_tangential')")
        if from_values:
            found = compute_columns(dump_local_header(os.fspath(pairs)), pair_compute)
            expected = sum(len(v) for v in pair_columns.values())
            if found and len(found) != expected:
                raise ValueError(f"pair_values: the keywords {' '.join(pair_values)} make {expected} columns but "
                                 f"the contact dump {os.fspath(pairs)} holds {len(found)} columns of compute "
                                 f"{pair_compute!r}; give the keywords of that compute's line (--pair-values)")
        super().__init__(atoms, pairs, pair_style="total", pair_columns=pair_columns, fixed_types=fixed_types,
                         fixed_ids=fixed_ids, body_force=body_force, masses=masses, dimension=dimension,
                         dt=dt, wrap=wrap, drop_inactive=False, input=input, variables=variables,
                         check_forces=check_forces, units=units)
        # without 'pos' or 'delta' in the contact dump: a force between particles apart by more than this many
        # r_i + r_j is refused (1: the script's model has no cohesion; 2 where it may have: no model reaches that)
        script = self.input_script
        self.contact_reach = 1.0 if script is not None and script.cohesive is False else 2.0
        self.wall_contacts_path = self.wall_columns = None
        self.wall_compute, self.wall_values = wall_spec[:2] if wall_spec else (wall_compute, wall_values)
        if wall_spec:
            self._open_wall_dump(*wall_spec)

    @staticmethod
    def _wall_spec(path, compute, values, history, input, variables):
        """(compute ID, keywords, column names, path) of the wall-contact dump, or None without one; the keywords
        from the input script's compute wall/gran/local line when not given."""
        if path is None:
            if values is not None:
                raise ValueError("wall_values: given without wall_contacts (--wall-contacts), the dump they describe")
            return None
        path = os.path.abspath(os.fspath(path))
        if values is None and input is not None:
            from .lammps_input import read_input
            spec = read_input(input, variables).wall_compute_for(path)
            compute, values = spec.id, spec.values
        if values is None:
            raise ValueError(f"wall_values: the keywords of the 'compute {compute} all wall/gran/local' line that "
                             f"wrote {path} are needed (wall_values=, --wall-values; or the input script, --input)")
        values = tuple(str(v) for v in values)
        columns = wall_gran_local_columns(compute, values, _history_count(wall_gran_local_columns, compute, values,
                                                                         history, path))
        if "id" not in columns or not ("force" in columns or {"force_normal", "force_tangential"} <= set(columns)):
            raise ValueError(f"wall_values: compute wall/gran/local needs 'id' (the particle's ID) and 'force' (or "
                             f"both 'force_normal' and 'force_tangential'), got {' '.join(values)}")
        if "pos" not in columns:
            raise ValueError(f"wall_values: compute wall/gran/local needs 'pos' (its first three values are the "
                             f"contact point on the wall, which no other keyword gives), got {' '.join(values)}")
        found = compute_columns(dump_local_header(path), compute)
        expected = sum(len(v) for v in columns.values())
        if len(found) != expected:
            raise ValueError(f"wall_values: the keywords {' '.join(values)} make {expected} columns but the wall "
                             f"contact dump {path} holds {len(found)} columns of compute {compute!r}; give the "
                             f"keywords of that compute's line (--wall-values) and its ID (--wall-compute)")
        return compute, values, columns, path

    def _open_wall_dump(self, compute, values, columns, path):
        """Scan the wall-contact dump and pair each atoms frame with its frame of the same timestep (k-th with
        k-th, as the pair dump's); the wall model's reach from the script's fix wall/gran lines."""
        self.wall_contacts_path, self.wall_columns = path, columns
        self._wall_dump = scan_dump(path, "local")
        by_step = {}
        for off, ts in self._wall_dump:
            by_step.setdefault(ts, []).append(off)
        self._wall_offsets, missing = {}, []
        for off, ts, _ in self._frames:
            offsets = by_step.get(ts, [])
            if offsets:
                self._wall_offsets[off] = offsets.pop(0)
            else:
                missing.append(ts)
        if missing:
            raise ValueError(f"wall_contacts: no frame for timestep(s) {missing[:10]} of the atoms dump "
                             f"{self.atoms_path} in the wall contact dump {path} (it has timesteps "
                             f"{sorted(set(ts for _, ts in self._wall_dump))[:10]}); dump both at the same steps, "
                             f"each frame inside its own 'run 0' (see the module docstring)")
        script = self.input_script
        models = [] if script is None else list(script.gran_walls.values())
        # repulsive wall models touch within a radius; a cohesive one (or one not known) may pull from further
        self.wall_reach = 1.0 if models and not any("cohesion" in m for m in models) else 2.0

    #: fix deform's lengths without a 'units' keyword are box lengths in LIGGGHTS (tests/data/liggghts/in.deform:
    #: 'final 0 0.0024' after 'lattice sc 0.001' ends at a box 0.0024 wide)
    _deform_units = "box"

    def _balance_hints(self):
        """The causes of a force mismatch that apply to LIGGGHTS (LAMMPS's name --pair-style and --walls, which
        LIGGGHTS input does not take, and miss its walls, whose contacts this reader does not read)."""
        return [f"the contact dump's columns are not pair_columns={self.pair_columns} (--pair-values): check the "
                f"keywords of the 'compute pair/gran/local' line",
                "a body force is missing or wrong (body_force=, --gravity)",
                "fixed particles are not marked (fixed_types=, fixed_ids=; --fixed-types, --fixed-ids)",
                self._walls_hint()]

    def _unread_walls(self):
        """The input script's fix wall/gran whose contacts are not read: primitive walls (LIGGGHTS' wall/gran/local
        reports mesh walls only), and mesh walls without a wall contact dump (wall_contacts=)."""
        script = self.input_script
        if script is None:
            return {}
        unread = {}
        for fix, words in script.gran_walls.items():
            if "primitive" in words:
                unread[fix] = "a primitive wall, whose contacts LIGGGHTS' wall/gran/local does not report"
            elif self._wall_dump is None:
                unread[fix] = "a mesh wall: give its compute wall/gran/local dump (wall_contacts=, --wall-contacts)"
        return unread

    def _walls_hint(self):
        """The cause 'walls' of a force mismatch: their contacts not given, or not all of them in the dump given."""
        unread = self._unread_walls()
        if unread:
            return ("the run has walls whose contacts are not read (" + "; ".join(f"fix {f}: {why}" for f, why in
                                                                           unread.items()) + "); make primitive walls "
                    "meshes or a boundary of fixed particles, or read anyway (check_forces=False, --no-check-forces) "
                    "knowing that their forces are missing from every field")
        if self._wall_dump is None:
            return ("the run has walls (fix wall/gran) whose contacts are not given: for mesh walls dump "
                    "'compute ID all wall/gran/local pos id force' and give that dump (wall_contacts=, "
                    "--wall-contacts; its keywords wall_values=, --wall-values, or --input); primitive walls are not "
                    "read (LIGGGHTS' wall/gran/local reports mesh walls only): make them meshes or a boundary of fixed "
                    "particles, or read anyway (check_forces=False, --no-check-forces) knowing that the walls' forces "
                    "are missing from every field")
        return (f"a wall's contacts are not in the wall contact dump {self.wall_contacts_path}: LIGGGHTS' "
                f"wall/gran/local never reports primitive walls (make them meshes of the one mesh fix wall/gran), a "
                f"moving mesh's tangential forces there need not be those the particles felt (fix move/mesh), or the "
                f"dump is not this run's")

    def _dumped_wall_contacts(self, atoms_offset, timestep, atoms, box):
        """The wall contacts of this frame from the wall/gran/local dump: boundary contacts (j = -1), the force on
        the particle, the contact point on the wall."""
        if self._wall_dump is None:
            return []
        path, names = self.wall_contacts_path, self.wall_columns
        fr = self._wall_dump.read(self._wall_offsets[atoms_offset], (), (names["id"][2],))
        dim = self.dimension
        if fr["n"] == 0:
            return [(np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros((0, dim)), np.zeros((0, dim)),
                     np.zeros((0, 2), np.int64), np.zeros(0), None)]
        tab = fr["data"]
        missing = [c for cols in names.values() for c in cols if c not in tab]
        if missing:
            raise ValueError(f"{path}: timestep {timestep}: expected columns {missing} in the wall contact dump (has "
                             f"{list(tab.index)}); set wall_compute/wall_values (--wall-compute, --wall-values) to "
                             f"the ID and keywords of its compute wall/gran/local")
        particle = tab.integers(names["id"][2])
        k, _ = contact_indices(atoms.ids, particle, particle, path, timestep)
        if "force" in names:
            force = self._vectors(tab, names["force"])
        else:
            force = self._vectors(tab, names["force_normal"]) + self._vectors(tab, names["force_tangential"])
        point = self._vectors(tab, names["pos"][:3])
        written = self._vectors(tab, names["pos"][3:6])
        # rows without a force: walls near a particle, not touching it, which LIGGGHTS lists where neigh_modify
        # contact_distance_factor > 1 (delta < 0); not contacts (they would count in coordination numbers and fabric)
        touching = (force != 0.0).any(axis=1)
        self._check_wall_rows(tab, fr.get("first_line"), timestep, atoms, box, k, point, written, touching)
        if self.wrap and any(box.periodic):
            point = box.wrap(point)
        overlap = tab[names["delta"][0]].copy() if "delta" in names else np.full(k.shape, np.nan)
        k, force, point, overlap = k[touching], force[touching], point[touching], overlap[touching]
        wall_j = np.full(k.shape, -1, np.int64)
        return [(k, wall_j, force, point, np.stack([atoms.ids[k], wall_j], axis=1), overlap, None)]

    def _check_wall_rows(self, tab, first_line, timestep, atoms, box, k, point, written, touching):
        """Refuse wall contacts whose geometry the atoms dump does not give: the particle's centre as the wall dump
        wrote it ('pos' values 4-6) against the atoms dump's, and the contact point of the rows with a force
        (``touching``) within the wall model's reach (a radius for a repulsive model) of the centre."""
        names, path = self.wall_columns, self.wall_contacts_path
        centre = np.take(atoms.positions, k, axis=0)
        off = row_norms(box.minimum_image(written - centre))
        slack = np.sqrt(3) * (atoms.resolution + written_resolution(*(tab[c] for c in names["pos"][3:6])))
        scale = np.full(k.shape, atoms.extent)
        what = (f"have a particle centre (wall/gran/local 'pos' values 4-6, columns {' '.join(names['pos'][3:6])}) "
                "other than the atoms dump's")
        hints = [f"the wall contact dump's columns are not what wall_values={' '.join(self.wall_values)} says "
                 f"(--wall-values): check the keywords of the 'compute wall/gran/local' line"]

        def centres(j):
            show = ", ".join
            return (f"the wall dump has ({show(f'{v:.9g}' for v in written[j])}), the atoms dump "
                    f"({show(f'{v:.9g}' for v in centre[j])})")

        def location(j):
            line = "" if first_line is None else f" (the wall contact dump's line {first_line + j})"
            return f"atom {int(atoms.ids[k[j]])}'s wall contact{line}"
        found = geometry_misfits(off, scale, slack=slack)
        if found is not None:
            bad, tol, ratio = found
            raise contact_geometry_error(self.atoms_path, f"the wall contacts of {path}", timestep, bad, ratio / tol,
                                         what, centres, location, hints)
        if atoms.radii is not None:
            self._refuse_far_wall_points(atoms, k, point, box, path,
                                         f"wall/gran/local 'pos' values 1-3, columns {' '.join(names['pos'][:3])}",
                                         tuple(tab[c] for c in names["pos"][:3]), location, hints,
                                         "fix wall/gran ... cohesion", touching)

    def _pair_id_columns(self):
        return self.pair_columns["id"][:2]

    def _pairs_from_table(self, tab, m, timestep, ids, pos, radii, box, where=None):
        path = self.pairs_path
        names = self.pair_columns
        needed = [c for cols in names.values() for c in cols]
        missing = [c for c in needed if c not in tab]
        if missing:
            raise ValueError(f"{path}: expected columns {missing} in the dump local (has {list(tab.index)}); "
                             "set pair_compute/pair_values (the keywords of compute pair/gran/local) or "
                             "pair_columns to match the dump")
        id1 = tab.integers(names["id"][0])
        id2 = tab.integers(names["id"][1])
        i, j = contact_indices(ids, id1, id2, path, timestep)
        if np.any(id1 == id2):
            tab, m, id1, id2, i, j = self._without_self_rows(
                tab, id1, id2, i, j, [names[k] for k in ("force", "force_normal", "force_tangential") if k in names],
                radii, box, where, timestep)
        if "force" in names:
            force = self._vectors(tab, names["force"])
        else:
            force = self._vectors(tab, names["force_normal"]) + self._vectors(tab, names["force_tangential"])
        if any(box.periodic) and radii is not None and len(i):
            self._refuse_listed_twice(where, i, j, id1, id2, ids, radii, box)
        pos_i = np.take(pos, i, axis=0)     # (np.take: 5-7 times faster than pos[i], the same values)
        branch = box.minimum_image(pos_i - np.take(pos, j, axis=0))
        dist = row_norms(branch)
        if "contactPoint" in names:
            point = self._vectors(tab, names["contactPoint"])
        else:
            if radii is None:
                raise ValueError(f"{self.atoms_path}: rebuilding contact points needs a 'radius' or "
                                 "'diameter' column (or dump contactPoint)")
            radii_i = np.take(radii, i)
            point = pos_i - (radii_i / (radii_i + np.take(radii, j)))[:, None] * branch
        # minimum image relative to particle i, then into the box
        point = pos_i + box.minimum_image(point - pos_i)
        if self.wrap:
            point = box.wrap(point)
        if "delta" in names:
            overlap = tab[names["delta"][0]]
        elif radii is not None:
            overlap = np.take(radii, i) + np.take(radii, j) - dist
        else:
            overlap = np.full(m, np.nan)
        if where is not None:
            self._check_geometry(tab, where, i, j, id1, id2, pos_i, pos, dist, radii, overlap, force, box)
        contact_ids = np.stack([id1, id2], axis=1)
        return i, j, force, point, contact_ids, overlap

    def _refuse_listed_twice(self, where, i, j, id1, id2, ids, radii, box):
        """Refuse a pair listed more than once: in a periodic box thinner than two contact distances LIGGGHTS lists a
        pair once per periodic image it touches through, and its output for such pairs is not consistent (measured,
        LIGGGHTS 3.8, tests/data/liggghts/in.thin: the atoms of such pairs miss their dumped forces by up to 0.74 of
        the RMS contact force inside 'run 0', and the contacts' virial misses compute pressure's by 1-7%), so no
        image reading of them can be verified."""
        radii_sum = np.take(radii, i) + np.take(radii, j)
        repeated = repeated_pairs(i, j, ids.size) if thin_box(box, radii_sum) else None
        if repeated is None:
            return
        rows = np.flatnonzero(repeated)
        first = rows[0]
        same = rows[(np.minimum(i[rows], j[rows]) == min(i[first], j[first]))
                    & (np.maximum(i[rows], j[rows]) == max(i[first], j[first]))]
        lines = "" if where.pairs_line is None else \
            f" (the contact dump's lines {', '.join(str(where.pairs_line + int(k)) for k in same)})"
        lengths = box.upper - box.lower
        axes = "xyz" if self.dimension == 3 else "xy"
        thin = ", ".join(f"{axes[a]} ({lengths[a]:.6g})" for a in range(len(axes))
                         if box.periodic[a] and 0.5 * lengths[a] <= self.contact_reach * float(radii_sum.max()))
        raise ValueError(
            f"{self.atoms_path}: timestep {where.timestep}: atoms {int(id1[first])} and {int(id2[first])} are listed "
            f"{same.size} times in {self.pairs_path}{lines}: the periodic box is thinner than two contact distances "
            f"along {thin}, so a pair touches through two periodic images of each other at once and LIGGGHTS lists it "
            f"once per image; its output for such pairs does not balance (LIGGGHTS 3.8: their atoms miss the dumped "
            f"forces by up to 0.74 of the RMS contact force, the contacts' virial misses compute pressure's by 1-7%), "
            f"so their stress cannot be read reliably. Fix: make the box at least two contact distances wide along "
            f"its periodic axes (LAMMPS' pair/local output of such boxes is read: one contact per image)")

    def _check_geometry(self, tab, where, i, j, id1, id2, pos_i, pos, dist, radii, overlap, force, box):
        """Refuse a frame whose positions do not give its contacts' geometry: the positions compute pair/gran/local
        wrote (``pos``), else its overlap (``delta``), else the reach of a contact force (see LammpsReader)."""
        names, extent = self.pair_columns, where.atoms.extent
        hints = ["the contact dump's columns are not what pair_values says (--pair-values): check the keywords "
                 "of the 'compute pair/gran/local' line"]
        if "pos" in names:
            written_i = self._vectors(tab, names["pos"][:3])
            written_j = self._vectors(tab, names["pos"][3:6])
            pos_j = np.take(pos, j, axis=0)
            # minimum image: the dump's j may be a periodic image (a ghost), and its i unwrapped by a step
            def error():
                return np.maximum(row_norms(box.minimum_image(written_i - pos_i)),
                                  row_norms(box.minimum_image(written_j - pos_j)))
            scale = np.full(len(i), extent)
            slack = np.sqrt(3) * (where.atoms.resolution + written_resolution(*(tab[c] for c in names["pos"])))
            what = f"have positions (pair/gran/local 'pos', columns {' '.join(names['pos'])}) other than the atoms dump's"

            def detail(k):
                show = ", ".join
                return (f"x_i ({show(f'{v:.9g}' for v in written_i[k])}) and x_j "
                        f"({show(f'{v:.9g}' for v in written_j[k])}) in the contact dump, ({show(f'{v:.9g}' for v in pos_i[k])}) "
                        f"and ({show(f'{v:.9g}' for v in pos_j[k])}) in the atoms dump")
        elif "delta" in names and radii is not None:
            radii_sum = np.take(radii, i) + np.take(radii, j)
            def error():
                return np.abs(overlap - (radii_sum - dist))
            scale = radii_sum + extent
            slack = (written_resolution(overlap) + 2 * where.atoms.radius_resolution
                     + 2 * np.sqrt(3) * where.atoms.resolution)
            what = (f"have an overlap (pair/gran/local 'delta', column {names['delta'][0]}) that their positions and "
                    "radii do not give")
            hints.append("the radius (diameter) column is not the radii")

            def detail(k):
                return (f"'delta' is {overlap[k]:.9g} in the contact dump, r_i + r_j - |x_i - x_j| = "
                        f"{radii_sum[k]:.9g} - {dist[k]:.9g} = {radii_sum[k] - dist[k]:.9g}")
        elif radii is not None:
            radii_sum = np.take(radii, i) + np.take(radii, j)
            hint = ("the contact model pulls beyond contact (cohesion): give the input script (--input)")
            self._check_reach(where, i, j, id1, id2, dist, radii_sum, force, hint)
            return
        else:
            return
        fit = None if radii is None else (dist, np.take(radii, i) + np.take(radii, j))
        self._refuse_geometry_deforming(box, where, i, j, id1, id2, error, scale, what, detail, hints, slack=slack,
                                        fit=fit)
