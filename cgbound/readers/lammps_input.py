"""Learn from a LAMMPS or LIGGGHTS input script what its dumps hold.

A ``dump local`` of ``compute pair/local`` is headed only by generic names (``c_pl[1] c_pl[2] ...``);
what each column means is written in the input script. :func:`read_input` reads the script (as LAMMPS
does: ``#`` comments, ``&`` continuations, quotes, ``include``, ``${name}``/``$x``/``$(expr)``
substitution from ``variable`` commands and from ``-var NAME value`` given by the caller) and returns
an :class:`InputScript`:

* ``computes``: every ``compute pair/local``, ``property/local`` (LAMMPS) and ``pair/gran/local``
  (LIGGGHTS) with the meaning of each of its columns;
* ``dumps``: every ``dump``, with its file name and, for each column, the header name LAMMPS writes
  (``c_pl[3]``) and what it is (``"pl:fy"``); :meth:`InputScript.dump_for` finds the dump that wrote a
  file (``dump.*`` patterns included) and :meth:`InputScript.pair_columns` gives the column names the
  LAMMPS reader needs (the ``pair_columns=`` dict of :class:`~cgbound.readers.lammps.LammpsReader`);
* ``walls``: IDs of ``fix wall/gran ... contacts`` (and ``wall/gran/region``);
* ``fixed_types``: atom types that are boundary: in a group frozen by ``fix freeze``, or by
  ``fix setforce 0 0 0`` together with ``velocity ... set 0 0 0``, or never integrated (no ``nve``-type
  fix covers them, when every integrator acts on a type-defined group);
* ``gravity``: the ``fix gravity`` acceleration vector (magnitude times the unit direction of its
  ``vector``, ``chute`` or ``spherical`` style, as LAMMPS computes it), or None;
* ``pair_style`` (``"gran"``, ``"granular"`` or ``"total"``: the LAMMPS reader's names) and ``dimension``;
  ``pair_command`` (the words of the last ``pair_style`` line) and ``cohesive``: whether the contact model
  can pull beyond contact (True: LAMMPS ``granular`` with a ``jkr`` ``pair_coeff``, LIGGGHTS
  ``gran ... cohesion ...``; False: LAMMPS ``gran/*``, ``granular`` without ``jkr``, LIGGGHTS ``gran`` without
  ``cohesion``; None: not a granular style, or none given).

The script is read in order, once: ``label``/``jump``/``next`` loops are not followed (a dump defined
inside a loop is seen once). Constructs that would change what the dumps mean and cannot be
resolved raise :class:`InputScriptError` naming the script, the line and what was not understood:
a compute keyword not known here, an undefined variable, a dump column from an unknown compute, an
``if`` command that defines computes, dumps or fixes, two dumps writing one file with different
columns, two gravity fixes.

Column orders (verified on Debian's LAMMPS 20220106 and LIGGGHTS-PUBLIC 3.8, see the readers):
``compute pair/local`` and ``property/local`` write their values in the order given on the line
(``cutoff`` and its argument are options, not values). LIGGGHTS's ``compute pair/gran/local``
writes in a FIXED order whatever the order of the keywords: pos (6), vel (6), id (3: ID_i, ID_j,
periodic flag), force (3), force_normal (3), force_tangential (3), torque (3), history (pair-style
dependent: refused here), contactArea (1), delta (1), contactPoint (3), heatFlux (1, "always last"
in LIGGGHTS's source); without keywords it writes pos vel id force torque history contactArea.
"""
import ast
import fnmatch
import math
import os
import re
import shlex
from dataclasses import dataclass, field

import numpy as np

from .files import decode_text

__all__ = ["InputScript", "InputScriptError", "ComputeSpec", "DumpSpec", "read_input", "LIGGGHTS_LAYOUT",
           "LIGGGHTS_WALL_LAYOUT", "LIGGGHTS_FLAG_KEYWORDS"]

#: compute pair/gran/local: (keyword, meanings of its columns) in the order LIGGGHTS writes them
LIGGGHTS_LAYOUT = (
    ("pos", ("x1", "y1", "z1", "x2", "y2", "z2")),
    ("vel", ("vx1", "vy1", "vz1", "vx2", "vy2", "vz2")),
    ("id", ("id1", "id2", "periodic")),
    ("force", ("fx", "fy", "fz")),
    ("force_normal", ("fnx", "fny", "fnz")),
    ("force_tangential", ("ftx", "fty", "ftz")),
    ("torque", ("tqx", "tqy", "tqz")),
    ("history", None),
    ("contactArea", ("contactArea",)),
    ("delta", ("delta",)),
    ("contactPoint", ("cpx", "cpy", "cpz")),
    ("heatFlux", ("heatFlux",)),
)
#: compute wall/gran/local: the same fixed order, other meanings (LIGGGHTS 3.8's ComputePairGranLocal::add_wall_1/2,
#: and its output, tests/data/liggghts/mesh): pos is the contact point on the wall then the particle's centre, vel the
#: wall's velocity then the particle's, id the mesh's index in the fix's 'meshes' list, the triangle's ID, then the
#: particle's ID; delta is r - |x - contact point|; contactPoint is counted but not written for walls (left unset)
LIGGGHTS_WALL_LAYOUT = (
    ("pos", ("cpx", "cpy", "cpz", "x", "y", "z")),
    ("vel", ("wvx", "wvy", "wvz", "vx", "vy", "vz")),
    ("id", ("mesh", "triangle", "id")),
    ("force", ("fx", "fy", "fz")),
    ("force_normal", ("fnx", "fny", "fnz")),
    ("force_tangential", ("ftx", "fty", "ftz")),
    ("torque", ("tqx", "tqy", "tqz")),
    ("torque_normal", ("tqnx", "tqny", "tqnz")),
    ("torque_tangential", ("tqtx", "tqty", "tqtz")),
    ("history", None),
    ("contactArea", ("contactArea",)),
    ("delta", ("delta",)),
    ("contactPoint", ("unset1", "unset2", "unset3")),
    ("heatFlux", ("heatFlux",)),
)
#: keywords of compute pair/gran/local and wall/gran/local that write no column (LIGGGHTS 3.8: 'verbose' on a
#: wall/gran/local line, its dump as wide as the other keywords make it)
LIGGGHTS_FLAG_KEYWORDS = ("verbose",)
_LIGGGHTS_DEFAULT = ("pos", "vel", "id", "force", "torque", "history", "contactArea")
_PAIR_LOCAL = re.compile(r"^(dist|eng|force|fx|fy|fz|p[1-9][0-9]*)$")
_PROPERTY_LOCAL = re.compile(r"^(natom[1-4]|ntype[1-4]|batom[12]|btype|aatom[1-3]|atype|datom[1-4]|dtype|"
                             r"iatom[1-4]|itype|patom[12]|ptype[12])$")
_INTEGRATORS = re.compile(r"^(nve|nvt|npt|nph|nve/sphere|nve/limit|nve/asphere|nvt/sphere|npt/sphere|nph/sphere|"
                          r"nve/noforce|rigid.*|nve/sphere/.*|nve/.*)$")
_WALL_FIXES = ("wall/gran", "wall/gran/region")


class InputScriptError(ValueError):
    """A construct of the input script that cannot be understood; the message names the file and line."""


def _script_text(path, data):
    """The text of an input script (LAMMPS reads plain text: a gzipped, binary or non-UTF-8 file is refused)."""
    if data[:2] == b"\x1f\x8b":
        raise InputScriptError(f"{path}: a gzipped file; LAMMPS reads input scripts as plain text: pass the "
                               f"script itself (gunzip it)")
    text = decode_text(path, data, "a LAMMPS input script", InputScriptError)
    if text.lstrip().startswith("ITEM:"):   # the likely mix-up: a dump given where the script was meant
        raise InputScriptError(f"{path}: line 1: this is a LAMMPS dump (it starts with 'ITEM:'), not an input script; "
                               f"pass the script that wrote the dumps as input=, the dumps as the data")
    return text


@dataclass
class ComputeSpec:
    """``compute ID group style values...``: ``columns`` holds the meaning of each column (1-based
    column k is ``columns[k - 1]``); ``values`` the keywords as given."""
    id: str
    style: str
    values: tuple
    columns: tuple
    where: str


@dataclass
class DumpSpec:
    """``dump ID group style N file columns...``: ``names`` are the header names LAMMPS writes,
    ``meanings`` what each is (``"COMPUTE:meaning"`` for compute columns, the keyword otherwise)."""
    id: str
    style: str
    file: str
    names: tuple
    meanings: tuple
    where: str


#: the ``neighbor`` command's default skin per units style (LAMMPS and LIGGGHTS documentation)
_DEFAULT_SKIN = {"lj": 0.3, "real": 2.0, "metal": 2.0, "si": 0.001, "cgs": 0.1}


@dataclass
class InputScript:
    path: str
    dimension: int = 3
    dimension_given: bool = False  # a ``dimension`` command seen (else 3, LAMMPS's default, or a restart file's)
    units: str = None              # the ``units`` command's style (lj, si, real, ...), None without one
    pair_style: str = None
    pair_command: tuple = ()       # the words of the pair_style line ("gran/hooke/history", "2000.0", ...)
    pair_coeffs: list = field(default_factory=list)   # the words of each pair_coeff line
    skin: float = None             # the ``neighbor`` command's skin distance, None without one
    neighbor_given: bool = False   # a ``neighbor`` command seen (its skin may be a variable: skin None)
    neighbor_checked: bool = True  # re-neighbouring on the default check (no ``neigh_modify`` every N > 1, check no,
                                   # once yes)
    neighbor_delay_zero: bool = False  # ``neigh_modify delay 0`` given (the default delay is 10 in LAMMPS before
                                       # 2023 and in LIGGGHTS, 0 in later LAMMPS: not known from the script)
    restart_read: bool = False     # a ``read_restart`` command seen (its units not in the script)
    newton: bool = None            # the ``newton`` command's pair setting (None without one: LAMMPS' default, on)
    computes: dict = field(default_factory=dict)
    dumps: list = field(default_factory=list)
    walls: tuple = ()
    wall_models: dict = field(default_factory=dict)   # wall fix ID -> the words after its style ("hooke", ...)
    gran_walls: dict = field(default_factory=dict)    # every fix wall/gran(/region) ID -> the words after its style
    fixed_types: tuple = ()
    gravity: np.ndarray = None
    gravity_group: str = None
    deforms: list = field(default_factory=list)   # (fix ID, "SCRIPT: line N") of each ``fix deform``: a box that
                                                  # changes
    deform_runs: list = field(default_factory=list)   # (first step, last step, _Deform or None: not understood) of
                                                      # each run with a fix deform defined; (a step it comes after or
                                                      # None, None, None) where its steps are not known
    variables: dict = field(default_factory=dict)
    notes: list = field(default_factory=list)

    @property
    def cohesive(self):
        """Whether the granular contact model can pull beyond contact (a force with the particles apart):
        True, False, or None when the style is not granular (or no pair_style was given)."""
        if not self.pair_command or self.pair_style not in ("gran", "granular"):
            return None
        style, args = self.pair_command[0], self.pair_command[1:]
        if style == "granular":
            # LAMMPS pair granular: the normal model is a pair_coeff keyword; only jkr acts beyond contact
            # (its pull-off distance); hooke, hertz, hertz/material and dmt act only when overlapping
            return any("jkr" in words for words in self.pair_coeffs)
        if style == "gran" or "model" in args:
            # LIGGGHTS "pair_style gran model hertz tangential history [cohesion sjkr|easo/capillary/viscous ...]"
            return "cohesion" in args
        return False    # LAMMPS gran/hooke, gran/hooke/history, gran/hertz/history: repulsive contact forces

    def stray_bound(self):
        """How far an atom can stray outside its box between re-neighbourings (the box check of a frame without
        contacts): one skin, twice the re-neighbouring trigger (skin / 2 of motion, ``neigh_modify check yes``);
        the ``neighbor`` command's skin, else the engine's default for the units (lj 0.3, real and metal 2.0, si
        0.001, cgs 0.1; the same in LIGGGHTS). Only where the script re-neighbours on every step's check without
        a delay (``neigh_modify delay 0``: the default delay, 10 steps in LAMMPS before 2023 and in LIGGGHTS, lets
        an atom stray further); None where not known: a delay, a skin from a variable, other units, units from a
        restart file, or re-neighbouring not on every step's check (``every N`` with N > 1, ``check no``,
        ``once yes``)."""
        if not self.neighbor_checked or not self.neighbor_delay_zero:
            return None
        if self.neighbor_given:
            return self.skin
        if self.units is None and self.restart_read:
            return None
        return _DEFAULT_SKIN.get(self.units or "lj")

    def deform_change(self, timestep, lower, upper, default_units="lattice"):
        """How far the box's bounds move per step at ``timestep`` (the largest change of a bound or a length per step
        along each axis, combined over the axes; deformed every N steps: N times that), from the script's ``fix
        deform`` (styles final, delta, scale, vel, erate, trate; ``units lattice`` with the lattice spacing of a
        ``lattice`` command without orient/spacing/a1-a3 keywords; ``default_units``: the engine's default, "lattice"
        for LAMMPS, "box" for LIGGGHTS); ``lower``, ``upper``: the frame's box (D,).
        0.0 where no fix deform acts at that step; None where the script does not tell (a style not understood, runs
        in a loop, after a restart or a minimisation, a frame at a run's last step of a ``final`` deformation)."""
        if not self.deforms:
            return 0.0
        known = [r for r in self.deform_runs if r[1] is not None]
        runs = [r for r in known if r[0] < timestep <= r[1]] or [r for r in known if r[0] == timestep]
        if not runs:
            # a run whose steps are not known (after a loop's label, a restart ...) after step r[0] (None: any)
            if any(r[1] is None and (r[0] is None or timestep > r[0]) for r in self.deform_runs):
                return None
            return 0.0
        run = runs[0]
        if run[2] is None:
            return None
        return run[2].change(timestep, run[0], run[1], np.asarray(lower, float), np.asarray(upper, float),
                             default_units)

    def wall_reach(self, walls):
        """How far from a particle's centre, in radii, the contact point of a wall contact of the fixes ``walls``
        can be: 1 when the script defines each of them with a repulsive model (``hooke``, ``hooke/history``,
        ``hertz/history``, ``granular`` without ``jkr``), else 2 (a model that may pull beyond contact, or a wall
        the script does not define)."""
        models = [self.wall_models.get(w) for w in walls]
        return 1.0 if all(m is not None and "jkr" not in m for m in models) else 2.0

    def dump_for(self, path):
        """The dump that wrote ``path`` (matched by file name; ``*`` and ``%`` in the dump's name match
        anything). Raises InputScriptError if none or several different dumps match."""
        name = os.path.basename(os.fspath(path))
        hits = [d for d in self.dumps
                if fnmatch.fnmatchcase(name, os.path.basename(d.file).replace("%", "*"))]
        distinct = {(d.names, d.meanings) for d in hits}
        if not hits:
            raise InputScriptError(f"{self.path}: no dump command writes a file named {name!r}; the script's "
                                   f"dumps write {sorted({d.file for d in self.dumps})}")
        if len(distinct) > 1:
            raise InputScriptError(f"{self.path}: dumps at {', '.join(d.where for d in hits)} all write {name!r} "
                                   "with different columns")
        return hits[0]

    def compute_for(self, path):
        """The pair/local or pair/gran/local :class:`ComputeSpec` whose columns the dump of ``path`` holds."""
        dump = self.dump_for(path)
        ids = {m.split(":", 1)[0] for m in dump.meanings if m and ":" in m}
        specs = [self.computes[i] for i in sorted(ids) if i in self.computes
                 and self.computes[i].style in ("pair/local", "pair/gran/local")]
        if len(specs) != 1:
            raise InputScriptError(f"{self.path}: {dump.where}: expected the dump of {dump.file!r} to hold one "
                                   f"pair/local or pair/gran/local compute, got {len(specs)}")
        return specs[0]

    def wall_compute_for(self, path):
        """The wall/gran/local :class:`ComputeSpec` whose columns the dump of ``path`` holds."""
        dump = self.dump_for(path)
        ids = {m.split(":", 1)[0] for m in dump.meanings if m and ":" in m}
        specs = [self.computes[i] for i in sorted(ids) if i in self.computes
                 and self.computes[i].style == "wall/gran/local"]
        if len(specs) != 1:
            raise InputScriptError(f"{self.path}: {dump.where}: expected the dump of {dump.file!r} to hold one "
                                   f"wall/gran/local compute, got {len(specs)}")
        return specs[0]

    def pair_columns(self, path):
        """Column names of the pair dump ``path`` for :class:`~cgbound.readers.lammps.LammpsReader`'s
        ``pair_columns=``: keys ``id1``, ``id2``, ``force`` (3 names), ``tangential`` (3 or None),
        ``branch`` (3 or None), ``dist`` (or None)."""
        dump = self.dump_for(path)
        by_meaning = {}
        for name, meaning in zip(dump.names, dump.meanings):
            key = meaning.split(":", 1)[-1] if meaning else None
            if key is not None:
                by_meaning.setdefault(key, []).append((name, meaning, dump.where))

        def one(key, required=True):
            hits = by_meaning.get(key, [])
            if len(hits) > 1:
                raise InputScriptError(f"{self.path}: {dump.where}: the dump holds {key!r} twice "
                                       f"({', '.join(h[0] for h in hits)})")
            if not hits:
                if required:
                    raise InputScriptError(f"{self.path}: {dump.where}: the dump of {dump.file!r} has no {key!r} "
                                           f"column; it holds {', '.join(m or '?' for m in dump.meanings)}")
                return None
            return hits[0][0]

        out = {"id1": one("patom1"), "id2": one("patom2"), "force": tuple(one(k) for k in ("fx", "fy", "fz")),
               "tangential": None, "branch": None, "dist": one("dist", False)}
        if self.pair_style in ("gran", "granular"):
            out["tangential"] = tuple(one(k) for k in ("p1", "p2", "p3"))
        if self.pair_style == "granular" and all(one(k, False) for k in ("p10", "p11", "p12")):
            out["branch"] = tuple(one(k) for k in ("p10", "p11", "p12"))
        return out


# ----------------------------------------------------------------------------------------------
class _Parser:
    def __init__(self, path, variables):
        self.result = InputScript(path=path)
        self.vars = {}            # name -> (style, value)
        for k, v in (variables or {}).items():
            self.vars[str(k)] = ("index", str(v))
        self.groups = {"all": None}          # name -> set of types, or None for "every type"/unknown
        self.group_types_known = {"all": True}
        self.ntypes = None
        self.frozen_groups, self.setforce_zero, self.velocity_zero, self.integrated = [], set(), set(), []
        self.gravity = {}
        self.walls = {}
        self.where = ""
        self.include_depth = 0
        self.step = 0              # the timestep (None: not known: a restart, a minimisation, a loop)
        self.known_step = 0        # the last step known (later steps come after it; None: not even that)
        self.dt = None             # the ``timestep`` command's size (None: the units' default)
        self.lattice = (1.0, 1.0, 1.0)   # the lattice spacings (None: not understood)
        self.deform = {}           # fix ID -> _Deform or None (not understood) of the fix deform defined

    def fail(self, what):
        raise InputScriptError(f"{self.where}: {what}")

    # -- lines ---------------------------------------------------------------------------------
    def logical_lines(self, path):
        try:
            with open(path, "rb") as fh:
                data = fh.read()
        except OSError as exc:
            raise InputScriptError(f"{path}: cannot read the input script: {exc.strerror}") from None
        raw = _script_text(path, data).split("\n")
        k = 0
        while k < len(raw):
            start, text = k + 1, raw[k]
            while text.rstrip().endswith("&") and k + 1 < len(raw):
                text = text.rstrip()[:-1] + " " + raw[k + 1]
                k += 1
            k += 1
            yield start, text

    @staticmethod
    def strip_comment(text):
        quote = None
        for pos, ch in enumerate(text):
            if quote:
                if ch == quote:
                    quote = None
            elif ch in "\"'":
                quote = ch
            elif ch == "#":
                return text[:pos]
        return text

    def substitute(self, text):
        out, pos = [], 0
        quote = None
        while pos < len(text):
            ch = text[pos]
            if ch in "\"'" and quote is None:
                quote = ch
            elif ch == quote:
                quote = None
            if ch == "$" and quote is None and pos + 1 < len(text):   # LAMMPS: no substitution inside quotes
                nxt = text[pos + 1]
                if nxt == "{":
                    end = text.find("}", pos)
                    if end < 0:
                        self.fail("unterminated ${...}")
                    out.append(self.value(text[pos + 2:end]))
                    pos = end + 1
                    continue
                if nxt == "(":
                    depth, end = 0, pos + 1
                    while end < len(text):
                        depth += {"(": 1, ")": -1}.get(text[end], 0)
                        if depth == 0:
                            break
                        end += 1
                    value = self.evaluate(text[pos + 2:end])
                    out.append(repr(value) if not float(value).is_integer() else str(int(value)))
                    pos = end + 1
                    continue
                out.append(self.value(nxt))
                pos += 2
                continue
            out.append(ch)
            pos += 1
        return "".join(out)

    def value(self, name):
        if name not in self.vars:
            self.fail(f"the variable {name!r} is not defined (define it in the script or pass it as -var {name} VALUE)")
        style, value = self.vars[name]
        if style == "equal":
            v = self.evaluate(value)
            return repr(v) if not float(v).is_integer() else str(int(v))
        return value

    def evaluate(self, expression):
        """A LAMMPS equal-style formula of numbers, v_ references, + - * / ^ and a few math functions."""
        expr = expression.strip().strip("\"'")
        expr = re.sub(r"v_([A-Za-z0-9_]+)", lambda m: f"({self.value(m.group(1))})", expr)
        expr = expr.replace("^", "**")
        names = {"PI": math.pi, "sqrt": math.sqrt, "sin": math.sin, "cos": math.cos, "tan": math.tan,
                 "exp": math.exp, "ln": math.log, "log": math.log10, "abs": abs, "floor": math.floor,
                 "ceil": math.ceil, "atan": math.atan, "asin": math.asin, "acos": math.acos}
        try:
            tree = ast.parse(expr, mode="eval")
        except SyntaxError:
            self.fail(f"cannot evaluate the formula {expression!r}")
        for node in ast.walk(tree):
            ok = isinstance(node, (ast.Expression, ast.BinOp, ast.UnaryOp, ast.Constant, ast.operator, ast.unaryop,
                                   ast.Call, ast.Name, ast.Load))
            if not ok or (isinstance(node, ast.Name) and node.id not in names):
                self.fail(f"cannot evaluate the formula {expression!r} here (only numbers, v_ variables, "
                          "+ - * / ^ and math functions; thermo keywords and atom values are not known "
                          "before the run)")
        try:
            return float(eval(compile(tree, "<formula>", "eval"), {"__builtins__": {}}, names))
        except (ArithmeticError, ValueError, TypeError):
            self.fail(f"cannot evaluate the formula {expression!r}")

    # -- commands --------------------------------------------------------------------------------
    def run_file(self, path):
        for number, text in self.logical_lines(path):
            self.where = f"{path}: line {number}"
            text = self.strip_comment(text).strip()
            if not text:
                continue
            words_raw = text.split()
            cmd = words_raw[0]
            # "variable" lines are substituted like others, except in their own formula text
            text = self.substitute(text)
            try:
                words = shlex.split(text, posix=True)
            except ValueError:
                self.fail("unbalanced quotes")
            if not words:
                continue
            self.command(cmd, words, path)

    def command(self, cmd, w, path):
        if cmd == "include":
            if len(w) != 2:
                self.fail("include: expected one file name")
            name = w[1] if os.path.isabs(w[1]) else os.path.join(os.path.dirname(path), w[1])
            if self.include_depth > 20:
                self.fail("include: nested more than 20 deep")
            self.include_depth += 1
            where = self.where
            self.run_file(name)
            self.include_depth -= 1
            self.where = where
        elif cmd == "variable":
            self.variable(w)
        elif cmd == "dimension":
            self.result.dimension = self.integer(w, 1, "dimension")
            self.result.dimension_given = True
        elif cmd == "read_restart":
            self.result.restart_read = True
            self.step = self.known_step = None
        elif cmd in ("minimize", "read_dump", "rerun", "label", "jump", "next"):
            self.step = None       # (steps taken not known, or runs not followed: a loop)
        elif cmd == "reset_timestep" and len(w) > 1:
            try:
                self.step = int(w[1])
            except ValueError:
                self.step = None
            self.known_step = self.step if self.known_step is not None and self.step is not None \
                and self.step >= self.known_step else None     # (steps may go back: any step)
        elif cmd == "timestep" and len(w) > 1:
            try:
                self.dt = float(w[1])
            except ValueError:
                self.dt = None
        elif cmd == "lattice":
            self.lattice = _lattice_spacings(w, self.result.units, self.result.dimension)
        elif cmd == "run":
            self.run(w)
        elif cmd == "units":
            if len(w) != 2:
                self.fail("units: expected one style (lj, real, metal, si, cgs, electron, micro, nano)")
            self.result.units = w[1]
        elif cmd == "create_box":
            self.ntypes = self.integer(w, 1, "create_box")
        elif cmd == "pair_style":
            if len(w) < 2:
                self.fail("pair_style: expected a style")
            style = w[1]
            self.result.pair_style = ("granular" if style == "granular" else
                                      "gran" if style.startswith("gran") else "total")
            self.result.pair_command = tuple(w[1:])
            self.result.pair_coeffs = []
        elif cmd == "pair_coeff":
            self.result.pair_coeffs.append(tuple(w[1:]))
        elif cmd == "newton" and len(w) > 1:
            self.result.newton = w[1] == "on"
        elif cmd == "neigh_modify":
            for key, value in zip(w[1:], w[2:]):
                if (key == "check" and value != "yes") or (key == "every" and value != "1") or \
                        (key == "once" and value != "no"):
                    self.result.neighbor_checked = False
                if key == "delay":
                    self.result.neighbor_delay_zero = value == "0"
        elif cmd == "neighbor" and len(w) > 1:
            self.result.neighbor_given = True
            self.result.skin = None
            try:
                self.result.skin = float(w[1])
            except ValueError:      # (a variable: the box check then goes without the skin)
                pass
        elif cmd == "group":
            self.group(w)
        elif cmd == "compute":
            self.compute(w)
        elif cmd == "uncompute":
            pass   # a dump already defined keeps its meaning; later dumps cannot name it
        elif cmd == "dump":
            self.dump(w)
        elif cmd == "fix":
            self.fix(w)
        elif cmd == "unfix":
            if len(w) == 2:
                self.gravity.pop(w[1], None)
                self.deform.pop(w[1], None)
        elif cmd == "velocity":
            if len(w) >= 6 and w[2] == "set" and all(self.is_zero(x) for x in w[3:6]):
                self.velocity_zero.add(w[1])
        elif cmd == "if":
            body = " ".join(w[2:])
            if re.search(r"\b(compute|dump|fix|group|include|variable)\b", body):
                self.fail("an 'if' command that defines computes, dumps, fixes, groups or variables cannot be "
                          "followed; give the column meanings explicitly instead")

    @staticmethod
    def is_zero(token):
        try:
            return float(token) == 0.0
        except ValueError:
            return False

    def integer(self, w, k, what):
        try:
            return int(w[k])
        except (IndexError, ValueError):
            self.fail(f"{what}: expected an integer, got {' '.join(w[k:k + 1])!r}")

    def variable(self, w):
        if len(w) < 3:
            self.fail("variable: expected 'variable NAME STYLE args'")
        name, style, args = w[1], w[2], w[3:]
        if style in ("index", "loop", "world", "universe", "uloop", "getenv", "file", "atomfile", "internal"):
            if name in self.vars:     # LAMMPS ignores the redefinition of these styles (-var wins)
                return
            if style == "loop":
                if not args:
                    self.fail(f"variable {name} loop: expected 'N' or 'N1 N2' after 'loop'")
                self.vars[name] = ("index", "1" if len(args) == 1 else args[0])
            elif args:
                self.vars[name] = ("index", args[0])
        elif style in ("string", "format"):
            self.vars[name] = ("index", " ".join(args))
        elif style == "equal":
            self.vars[name] = ("equal", " ".join(args))
        elif style == "delete":
            self.vars.pop(name, None)
        else:
            self.vars[name] = ("other", " ".join(args))   # atom/vector/python: not a script-time value
        self.result.variables[name] = self.vars.get(name, (None, None))[1]

    def types(self, tokens):
        out = set()
        for t in tokens:
            m = re.fullmatch(r"(\d*)([:*])?(\d*)", t) if ("*" in t or ":" in t) else None
            try:
                if m:
                    lo = int(m.group(1)) if m.group(1) else 1
                    hi = int(m.group(3)) if m.group(3) else (self.ntypes or lo)
                    out.update(range(lo, hi + 1))
                else:
                    out.add(int(t))
            except ValueError:
                self.fail(f"group: expected atom types, got {t!r}")
        return out

    def group(self, w):
        if len(w) < 3:
            self.fail("group: expected 'group NAME style args'")
        name, style = w[1], w[2]
        if style == "type":
            if len(w) > 4 and w[3] in ("<", "<=", ">", ">=", "==", "!=", "<>"):
                self.fail("group ... type with a comparison is not understood; list the types")
            self.groups[name] = self.types(w[3:])
            self.group_types_known[name] = True
        elif style in ("delete", "clear"):
            self.groups.pop(name, None)
        else:
            self.groups[name] = set()
            self.group_types_known[name] = False

    def compute(self, w):
        if len(w) < 4:
            return
        cid, style, args = w[1], w[3], w[4:]
        if style not in ("pair/local", "property/local", "pair/gran/local", "wall/gran/local"):
            return
        if style in ("pair/local", "property/local"):
            values = []
            k = 0
            while k < len(args):
                if args[k] == "cutoff":
                    k += 2
                    continue
                pattern = _PAIR_LOCAL if style == "pair/local" else _PROPERTY_LOCAL
                if not pattern.match(args[k]):
                    self.fail(f"compute {style}: unknown keyword {args[k]!r}")
                values.append(args[k])
                k += 1
            columns = tuple(values)
        else:
            keywords = tuple(a for a in args if a not in LIGGGHTS_FLAG_KEYWORDS) if args else _LIGGGHTS_DEFAULT
            layout = LIGGGHTS_WALL_LAYOUT if style == "wall/gran/local" else LIGGGHTS_LAYOUT
            known = {k for k, _ in layout}
            for k in keywords:
                if k not in known:
                    self.fail(f"compute {style}: unknown keyword {k!r}")
            columns = []
            for key, meanings in layout:
                if key not in keywords:
                    continue
                if meanings is None:
                    columns.append(None)   # history: its length is set by the pair style
                    break
                columns.extend(meanings)
            else:
                columns = tuple(columns)
            if isinstance(columns, list):
                columns = tuple(columns)   # columns after 'history' are unknown: ends with None
            values = keywords
        self.result.computes[cid] = ComputeSpec(cid, style, tuple(values), columns, self.where)

    def dump(self, w):
        if len(w) < 6:
            self.fail("dump: expected 'dump ID group style N file ...'")
        did, style, fname, args = w[1], w[3], w[5], w[6:]
        names, meanings = [], []
        for tok in args:
            m = re.fullmatch(r"([cf])_([A-Za-z0-9_\-]+)(?:\[(\*|\d+)\])?", tok)
            if not m:
                names.append(tok)
                meanings.append(tok)
                continue
            kind, ident, index = m.groups()
            if kind == "f":
                if ident in self.walls and index == "*":
                    for k in range(1, 9):
                        names.append(f"f_{ident}[{k}]")
                        meanings.append(f"{ident}:wall[{k}]")
                else:
                    names.append(tok)
                    meanings.append(f"{ident}:wall[{index}]" if ident in self.walls else tok)
                continue
            spec = self.result.computes.get(ident)
            if spec is None:
                if style == "local":
                    self.fail(f"dump {did}: {tok} names compute {ident!r}, which is not a pair/local, "
                              "property/local, pair/gran/local or wall/gran/local compute defined before this line")
                names.append(tok)
                meanings.append(tok)
                continue
            cols = spec.columns
            if index == "*":
                if cols and cols[-1] is None:
                    self.fail(f"dump {did}: {tok}: compute {ident} has 'history' columns whose number depends on "
                              "the pair style; list the columns you need as c_ID[k]")
                picked = list(range(1, len(cols) + 1))
            elif index is None:
                if len(cols) != 1:
                    self.fail(f"dump {did}: {tok}: compute {ident} has {len(cols)} columns; name one as {tok}[k]")
                picked = [None]
            else:
                picked = [int(index)]
            for k in picked:
                if k is None:
                    names.append(tok)
                    meanings.append(f"{ident}:{cols[0]}")
                    continue
                if k < 1 or (k > len(cols) and not (cols and cols[-1] is None)):
                    self.fail(f"dump {did}: {tok}: compute {ident} has {len(cols)} columns")
                meaning = cols[k - 1] if k <= len(cols) else None
                if meaning is None and cols and cols[-1] is None and k >= len(cols):
                    # (a history value or one after them: their number depends on the contact model; the reader
                    # counts them from the dump's columns)
                    meaning = f"after history {k - len(cols) + 1}"
                names.append(f"c_{ident}[{k}]")
                meanings.append(f"{ident}:{meaning}")
        spec = DumpSpec(did, style, fname, tuple(names), tuple(meanings), self.where)
        self.result.dumps.append(spec)

    def fix(self, w):
        if len(w) < 4:
            return
        fid, group, style, args = w[1], w[2], w[3], w[4:]
        if style in _WALL_FIXES:
            self.result.gran_walls[fid] = tuple(args)
            if "contacts" in args:
                self.walls[fid] = self.where
                self.result.wall_models[fid] = tuple(args)
        elif style == "freeze":
            self.frozen_groups.append(group)
        elif style == "setforce":
            if len(args) >= 3 and all(self.is_zero(x) for x in args[:3]):
                self.setforce_zero.add(group)
        elif style == "gravity":
            self.gravity_fix(fid, group, args)
        elif style == "deform":
            self.result.deforms.append((fid, self.where))
            self.deform[fid] = _Deform.parse(args, self.lattice, self.dt if self.dt is not None else
                                             _DEFAULT_DT.get(self.result.units or "lj"))
        elif fid in self.deform:
            self.deform.pop(fid)     # (the ID redefined as another fix)
        elif _INTEGRATORS.match(style):
            self.integrated.append(group)

    def run(self, w):
        """A ``run N`` advances the timestep by N (``upto``: to N); each fix deform defined deforms over it."""
        try:
            n = int(float(w[1]))
        except (IndexError, ValueError):
            n = None
        rest = w[2:]
        if n is None or self.step is None or any(k in rest for k in ("start", "stop")):
            if self.deform:
                self.result.deform_runs.append((self.known_step, None, None))
            self.step = None
            return
        first, last = self.step, (n if "upto" in rest else self.step + n)
        self.known_step = last
        if self.deform:
            fixes = list(self.deform.values())
            self.result.deform_runs.append((first, last, fixes[0] if len(fixes) == 1 else None))
        self.step = last

    def gravity_fix(self, fid, group, args):
        if self.gravity:
            other = next(iter(self.gravity))
            self.fail(f"fix gravity {fid}: a second gravity fix (the first is {other!r}); cgbound takes one body force")
        if not args:
            self.fail("fix gravity: expected 'magnitude style args'")
        magnitude = args[0]
        if magnitude.startswith("v_"):
            magnitude = self.value(magnitude[2:])
        try:
            g = float(magnitude)
        except ValueError:
            self.fail(f"fix gravity: cannot evaluate the magnitude {args[0]!r}")
        style, rest = (args[1] if len(args) > 1 else None), args[2:]
        try:
            nums = [float(self.value(x[2:]) if x.startswith("v_") else x) for x in rest]
        except ValueError:
            self.fail(f"fix gravity: expected numbers after {style!r}, got {' '.join(rest)!r}")
        dim = self.result.dimension
        deg = math.pi / 180.0
        if style == "vector" and len(nums) >= 3:
            u = np.array(nums[:3])
            if dim == 2:
                u[2] = 0.0
            norm = np.linalg.norm(u)
            if norm == 0:
                self.fail("fix gravity: the vector is zero")
            u = u / norm
        elif style == "chute" and len(nums) >= 1:
            a = nums[0] * deg
            u = np.array([math.sin(a), 0.0, -math.cos(a)]) if dim == 3 else np.array([math.sin(a), -math.cos(a), 0.0])
        elif style == "spherical" and len(nums) >= 2:
            phi, theta = nums[0] * deg, nums[1] * deg
            if dim == 2:
                u = np.array([math.sin(theta), math.cos(theta), 0.0])
            else:
                u = np.array([math.sin(theta) * math.cos(phi), math.sin(theta) * math.sin(phi), math.cos(theta)])
        else:
            self.fail(f"fix gravity: style {style!r} with {len(nums)} values is not understood (expected vector x y z, "
                      "chute angle or spherical phi theta)")
        self.gravity[fid] = (g * u, group, self.where)

    # -- results --------------------------------------------------------------------------------
    def finish(self):
        r = self.result
        r.walls = tuple(self.walls)
        if self.gravity:
            vec, group, _ = next(iter(self.gravity.values()))
            r.gravity, r.gravity_group = vec, group
        fixed = set()
        for g in self.frozen_groups + sorted(self.setforce_zero & self.velocity_zero):
            fixed |= self.types_of(g, "fix freeze/setforce")
        if self.ntypes and self.integrated and all(self.group_types_known.get(g, False) for g in self.integrated):
            integrated = set()
            for g in self.integrated:
                integrated |= self.types_of(g, "integrator")
            never = set(range(1, self.ntypes + 1)) - integrated
            if never:
                r.notes.append(f"types {sorted(never)} are never integrated: boundary")
            fixed |= never
        r.fixed_types = tuple(sorted(fixed))
        return r

    def types_of(self, group, what):
        if group == "all":
            if not self.ntypes:
                self.fail(f"{what} on group all before create_box gave the number of types")
            return set(range(1, self.ntypes + 1))
        if group not in self.groups:
            raise InputScriptError(f"{self.result.path}: {what}: group {group!r} is not defined")
        if not self.group_types_known.get(group):
            raise InputScriptError(f"{self.result.path}: {what}: group {group!r} is not defined by atom type, so "
                                   "its particles cannot be named by type; give fixed_ids/fixed_types explicitly")
        return set(self.groups[group])


def read_input(path, variables=None):
    """Read a LAMMPS/LIGGGHTS input script (see the module docstring); ``variables``: ``{name: value}``
    as given with ``-var NAME value`` on the command line. Returns an :class:`InputScript`."""
    path = os.path.abspath(os.fspath(path))
    parser = _Parser(path, variables)
    parser.run_file(path)
    return parser.finish()


#: LAMMPS' default time step per units style (the ``timestep`` command's doc)
_DEFAULT_DT = {"lj": 0.005, "real": 1.0, "metal": 0.001, "si": 1e-8, "cgs": 1e-8, "electron": 0.001, "micro": 2.0,
               "nano": 0.00045}
#: basis atoms per unit cell and the cell's edges in lattice constants, of LAMMPS' lattice styles
_LATTICES = {"sc": (1, (1, 1, 1)), "bcc": (2, (1, 1, 1)), "fcc": (4, (1, 1, 1)), "diamond": (8, (1, 1, 1)),
             "hcp": (4, (1, math.sqrt(3), math.sqrt(8 / 3))), "sq": (1, (1, 1, 1)), "sq2": (2, (1, 1, 1)),
             "hex": (2, (1, math.sqrt(3), 1))}


def _lattice_spacings(w, units, dimension):
    """The x, y, z lattice spacings of a ``lattice`` command (as LAMMPS computes them for units lattice), or None
    where not understood (custom, orient, spacing, a1-a3 keywords)."""
    try:
        style, scale = w[1], float(w[2])
    except (IndexError, ValueError):
        return None
    if any(k in w[3:] for k in ("orient", "spacing", "a1", "a2", "a3", "basis")):
        return None
    if style == "none":
        return (scale, scale, scale)
    if style not in _LATTICES or scale <= 0:
        return None
    nbasis, edges = _LATTICES[style]
    # lj units: the scale is a reduced density, the lattice constant (nbasis / (rho volume))^(1/dimension), the unit
    # cell's volume (area in 2D) in lattice constants
    volume = float(np.prod(edges[:dimension]))
    a = (nbasis / (scale * volume)) ** (1.0 / dimension) if (units or "lj") == "lj" else scale
    return tuple(a * e for e in edges)


class _Deform:
    """The box change of a ``fix deform`` over a run, per axis (x y z with styles final, delta, scale, vel,
    erate, trate), as LAMMPS' fix deform defines them."""

    def __init__(self, every, axes, units, lattice):
        # axes: {axis: (style, values)}, per step (vel, erate, trate); units: "box", "lattice" or None (the engine's
        # default: lattice in LAMMPS, box in LIGGGHTS, whose genuine in.deform gives 'final' in box units)
        self.every, self.axes, self.units, self.lattice = every, axes, units, lattice

    @classmethod
    def parse(cls, args, lattice, dt):
        """From the words after ``fix ID group deform``; None where not understood (the change then not known)."""
        try:
            every = int(args[0])
        except (IndexError, ValueError):
            return None
        sizes = {"final": 2, "delta": 2, "scale": 1, "vel": 1, "erate": 1, "trate": 1}
        axes, k, units = {}, 1, None
        raw = {}
        while k < len(args):
            key = args[k]
            if key in ("x", "y", "z"):
                style = args[k + 1] if k + 1 < len(args) else None
                if style not in sizes:
                    return None      # (volume, wiggle, variable, pressure ...: not known here)
                try:
                    raw[key] = (style, [float(v) for v in args[k + 2:k + 2 + sizes[style]]])
                except ValueError:
                    return None
                if len(raw[key][1]) != sizes[style]:
                    return None
                k += 2 + sizes[style]
            elif key in ("xy", "xz", "yz"):
                return None
            elif key in ("remap", "flip", "couple", "vol/balance/p", "max/rate", "normalize/pressure"):
                k += 2
            elif key == "units":
                units = args[k + 1] if k + 1 < len(args) else None
                k += 2
            else:
                return None
        if units not in ("box", "lattice", None) or not raw:
            return None
        for key, (style, values) in raw.items():
            a = "xyz".index(key)
            if style in ("vel", "erate", "trate"):
                if dt is None:
                    return None
                values = [v * dt for v in values]     # (per step)
            axes[a] = (style, values)
        return cls(every, axes, units, lattice)

    def change(self, timestep, first, last, lower, upper, default_units="lattice"):
        """The bounds' change per step at ``timestep`` of a run from step ``first`` to ``last`` (see
        InputScript.deform_change), the frame's box ``lower``, ``upper``; None where not known."""
        units = self.units or default_units
        if units == "lattice" and self.lattice is None and any(st in ("final", "delta", "vel")
                                                               for st, _ in self.axes.values()):
            return None
        span = last - first
        if span <= 0:
            return 0.0
        done = timestep - first
        moved = np.zeros(lower.size)
        for a, (style, values) in self.axes.items():
            if a >= lower.size:
                continue
            lo, hi = lower[a], upper[a]
            length = hi - lo
            if style in ("final", "delta", "vel") and units == "lattice":
                values = [v * self.lattice[a] for v in values]
            if style == "final":
                if timestep >= last:
                    return None       # (the box is the final one: its start not known from this frame)
                d_lo, d_hi = (values[0] - lo) / (last - timestep), (values[1] - hi) / (last - timestep)
            elif style == "delta":
                d_lo, d_hi = values[0] / span, values[1] / span
            elif style == "scale":
                start = length / (1.0 + (values[0] - 1.0) * done / span)
                d_hi = 0.5 * (values[0] - 1.0) * start / span
                d_lo = -d_hi
            elif style == "vel":
                d_hi, d_lo = 0.5 * values[0], -0.5 * values[0]
            elif style == "erate":
                start = length / (1.0 + values[0] * done)
                d_hi = 0.5 * values[0] * start
                d_lo = -d_hi
            else:    # trate: L0 exp(rate t); per step at most rate L e^|rate|
                d_hi = 0.5 * abs(values[0]) * length * math.exp(abs(values[0]))
                d_lo = -d_hi
            moved[a] = max(abs(d_lo), abs(d_hi), abs(d_hi - d_lo))
        return self.every * float(np.sqrt(np.sum(moved ** 2)))
