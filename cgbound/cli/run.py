"""``cgbound run``: read a dataset, coarse-grain it, write the fields (and a figure).

Every argument is checked before any work: first what the text alone decides (numbers, names, file
names and extensions), then, once the first frame's header is read, what depends on the data
(dimension, axes, the types and IDs that fixed particles are selected by).
"""
import os
import sys
import time

import numpy as np

from .errors import UsageError, as_usage
from .figures import check_matplotlib, figure_format, save_figure
from .values import (existing_file, integers, numbers, output_directory_exists, output_not_input, positive_number,
                     replaceable_figure, replaceable_output, split_list, type_masses)

KERNELS = ("gaussian", "lucy", "heaviside")
OUTPUTS = (".h5", ".hdf5", ".npz", ".vtk", ".stat")
FORMATS = ("hdf5", "lammps", "liggghts", "mdanalysis", "mercury", "yade")

#: reader flags and the formats they apply to (a flag given for another format is an error, not ignored)
FLAG_FORMATS = {
    "pairs": ("lammps", "liggghts", "mercury"), "pair_style": ("lammps",),
    "no_check_forces": ("lammps", "liggghts", "yade"), "input": ("lammps", "liggghts"), "var": ("lammps", "liggghts"),
    "pair_compute": ("lammps", "liggghts"), "pair_values": ("lammps", "liggghts"),
    "fixed_types": ("lammps", "liggghts"), "fixed_ids": ("lammps", "liggghts", "mercury", "yade"),
    "walls": ("lammps",), "wall_contacts": ("liggghts",), "wall_compute": ("liggghts",),
    "wall_values": ("liggghts",), "masses": ("lammps", "liggghts"), "dt": ("lammps", "liggghts"),
    "dimension": ("lammps", "liggghts"), "restart": ("mercury",), "density": ("mercury",),
    "gravity": ("lammps", "liggghts", "mercury", "yade"), "gravity_override": ("mercury", "yade"),
}

EXAMPLES = """\
examples, one per format:
  cgbound HDF5 (cgbound.readers.write_snapshots), a depth profile:
    cgbound run chute.h5 --grid 1,1,400 --average x,y --width 0.25 \\
        --fields density,stress,interaction_force_density -o profile.h5 --figure profile.pdf
  LAMMPS (dump custom + dump local of compute property/local patom1 patom2 and pair/local), per-frame files:
    cgbound run 'atoms.*.dump' --pairs 'pairs.*.dump' --pair-values dist,fx,fy,fz,p1,p2,p3,p4 \\
        --fixed-types 2 --walls floor --gravity 0,0,-1 --grid 1,1,200 --average x,y -o profile.h5
  LIGGGHTS (compute pair/gran/local with ID pgl2):
    cgbound run atoms.dump --format liggghts --pairs pairs.dump --pair-compute pgl2 --fixed-types 2 \\
        --gravity 0,0,-9.81 --width 0.00025 --grid 20,20,40 -o fields.h5
  MercuryDPM (name.fstat and name.restart next to name.data are used when present; gravity from the .restart):
    cgbound run chute.data --kernel lucy --cutoff 1.5 --grid 1,1,100 --average x,y -o chute.h5
  LAMMPS read with its input script (columns, frozen types, walls and gravity from the script):
    cgbound run atoms.dump --pairs pairs.dump --input in.chute --var angle=26 --grid 1,1,200 --average x,y \\
        -o profile.h5
  Yade (a directory of exports written by cgbound.readers.yade_export inside Yade):
    cgbound run yade_frames/ --grid 1,1,50 --average x,y --fields density,stress -o yade.h5
  MercuryCG's .stat format out (Lucy: MercuryCG's width is the cutoff; its 1-D kernel over averaged axes):
    cgbound run chute.data --kernel lucy --cutoff 1 --grid 1,1,140 --average x,y \\
        --averaged-kernel lower-dimensional -o chute.stat
  MDAnalysis (topology and trajectory):
    cgbound run topol.tpr traj.xtc --format mdanalysis --grid 40,40,40 --fields density -o density.npz

Exit status: 0 on success, 2 for an argument that cannot be used (the message names the flag),
1 for data that cannot be read or coarse-grained. --debug shows the traceback.
"""


def add_parser(sub):
    import argparse

    r = sub.add_parser("run", help="coarse-grain a dataset and write the fields",
                       description="Read snapshots (cgbound HDF5, LAMMPS or LIGGGHTS dumps, MercuryDPM output, "
                                   "MDAnalysis trajectories), coarse-grain them and write HDF5, .npz or VTK.",
                       epilog=EXAMPLES, formatter_class=argparse.RawDescriptionHelpFormatter)
    r.add_argument("paths", nargs="+", metavar="PATH",
                   help="the dataset: a file, several files or a quoted glob pattern ('dump.*'), ordered by the "
                        "numbers in their names")
    r.add_argument("--format", choices=FORMATS, help="input format (default: told from the first file)")
    g = r.add_argument_group("LAMMPS, LIGGGHTS and MercuryDPM input")
    g.add_argument("--pairs", metavar="PATH", help="the contact dump local (LAMMPS, LIGGGHTS) or the .fstat file "
                                                   "(MercuryDPM); a pattern for per-frame files")
    g.add_argument("--pair-style", choices=["gran", "granular", "total"],
                   help="lammps: pair style family that wrote the contact dump (default: the --input script's, "
                        "else gran); it also bounds how far apart two particles with a contact force may be (gran: "
                        "touching; granular: may be cohesive)")
    g.add_argument("--pair-compute", metavar="ID", help="lammps/liggghts: the ID of compute pair/local "
                                                        "(default pl) or pair/gran/local (default pgl)")
    g.add_argument("--pair-values", metavar="LIST",
                   help="lammps/liggghts: the keywords of the pair compute in order, e.g. fx,fy,fz,p1,p2,p3,p4,dist")
    g.add_argument("--input", metavar="SCRIPT",
                   help="lammps/liggghts: the input script that wrote the dumps: the contact dump's columns, and "
                        "fixed types, walls and gravity unless given by their flags")
    g.add_argument("--var", metavar="NAME=VALUE", action="append",
                   help="lammps/liggghts: a variable of --input as LAMMPS's -var gave it (repeat for several)")
    g.add_argument("--fixed-types", metavar="LIST", help="lammps/liggghts: atom types of fixed particles, e.g. 2")
    g.add_argument("--fixed-ids", metavar="LIST",
                   help="atom IDs (lammps/liggghts) or particle indices (mercury) of fixed particles")
    g.add_argument("--walls", metavar="LIST", help="lammps: IDs of fix wall/gran ... contacts, e.g. floor")
    g.add_argument("--wall-contacts", metavar="PATH",
                   help="liggghts: the dump local of compute wall/gran/local (mesh walls' contacts; its keywords from "
                        "--wall-values or --input)")
    g.add_argument("--wall-compute", metavar="ID", help="liggghts: the ID of compute wall/gran/local (default wgl)")
    g.add_argument("--wall-values", metavar="LIST",
                   help="liggghts: the keywords of compute wall/gran/local, e.g. pos,id,force")
    g.add_argument("--gravity", metavar="VECTOR", help="body force per unit mass on flowing particles, e.g. 0,0,-1 "
                                                       "(mercury, yade: default the run's gravity, which it must match "
                                                       "unless that is 0 or --gravity-override is given)")
    g.add_argument("--gravity-override", action="store_const", const=True, default=None,
                   help="mercury, yade: use --gravity although the run's stored gravity differs (a body force changed "
                        "during the run or applied by the driver's own code)")
    g.add_argument("--masses", metavar="TYPE=MASS,...",
                   help="lammps/liggghts: masses per atom type when the dump has no mass column")
    g.add_argument("--dt", metavar="DT", help="lammps/liggghts: time step size (time = timestep x dt)")
    g.add_argument("--no-check-forces", action="store_const", const=True, default=None,
                   help="lammps/liggghts: read frames whose contact and body forces do not reproduce the dumped "
                        "per-particle forces (dumps written during a run; by default such a frame is an error)")
    g.add_argument("--dimension", type=int, choices=[2, 3], help="lammps/liggghts: dimension of the run "
                                                                  "(default: the --input script's, else 3)")
    g.add_argument("--restart", metavar="PATH", help="mercury: the .restart file (fixed particles, densities, "
                                                     "periodic axes)")
    g.add_argument("--density", metavar="RHO", help="mercury: particle material density (masses from radii)")
    g.add_argument("--units", metavar="SYSTEM", default=None,
                   help="the units of the data, for labels and the files' units attributes: lj, si, cgs, real, "
                        "metal, micro, nano (LAMMPS) or mercury (d = m = g = 1); default: the --input script's "
                        "units command, else '(simulation units)'")
    k = r.add_argument_group("kernel and grid")
    k.add_argument("--kernel", choices=KERNELS, default="gaussian", help="coarse-graining kernel (default gaussian)")
    k.add_argument("--width", help="Gaussian width w, also the default scale of the others (default 0.25, for "
                                   "particles of diameter about 1; refused for particles far larger or smaller)")
    k.add_argument("--cutoff", default=None, help="support radius (Gaussian default 5 w; Lucy 3 w; Heaviside w)")
    k.add_argument("--normalize", choices=["full", "truncated"], default="full", help="Gaussian normalisation (default full)")
    k.add_argument("--grid", default="20,20,20", help="nodes per axis, e.g. 1,1,400 (averaged axes take 1; default 20,20,20)")
    k.add_argument("--average", default="", help="averaged axes, e.g. x,y")
    k.add_argument("--averaged-kernel", choices=["marginal", "lower-dimensional"], default="marginal",
                   help="the kernel over averaged axes: marginal (default; the exact marginal of the 3-D kernel) "
                        "or lower-dimensional (MercuryCG's: for a Z profile the 1-D Lucy; needed to write a "
                        "Lucy or Heaviside profile as .stat)")
    k.add_argument("--lower", default=None, metavar="VECTOR",
                   help="the grid's lower corner (default the data's box; empty entries keep the box: ,,0)")
    k.add_argument("--upper", default=None, metavar="VECTOR", help="the grid's upper corner (as --lower)")
    f = r.add_argument_group("fields and time")
    f.add_argument("--fields", default="density,velocity,stress", help="comma-separated field names (default density,velocity,stress)")
    f.add_argument("--convention", choices=["tension", "compression"], default="tension", help="stress sign: tension-positive (the paper) or compression-positive (MercuryCG); default tension")
    f.add_argument("--couple-stress-form", choices=["contact_point", "branch_line"], default="contact_point",
                   help="how couple_stress, stress_torque_density and boundary_couple_density split the contact "
                        "torques: at the contact points (default) or along the branch lines (the torque density "
                        "is then the antisymmetric part of the paper's stress; no averaged axis)")
    f.add_argument("--species", type=int, default=None, help="partial fields of this species")
    f.add_argument("--time-average", default="mean", help="mean (default), none (every frame), or a Gaussian time width")
    f.add_argument("--start", type=int, default=None, help="first frame")
    f.add_argument("--stop", type=int, default=None, help="stop before this frame")
    f.add_argument("--step", type=int, default=None, help="frame step")
    o = r.add_argument_group("output")
    o.add_argument("-o", "--output", default="cgbound_fields.h5",
                   help="output file: .h5, .npz, .vtk or .stat (MercuryCG's format; default cgbound_fields.h5)")
    o.add_argument("--figure", "--png", dest="figure", default=None, metavar="FILE",
                   help="also plot the fields (profiles or maps) to FILE: .png, .pdf or .svg")
    o.add_argument("--figure-fields", default=None, metavar="LIST",
                   help="the fields to plot (default: every field of --fields)")
    o.add_argument("-q", "--quiet", action="store_true", help="no progress bar")
    r.set_defaults(func=run, check=check)
    return r


# --- checks that need only the text ------------------------------------------------------------------

def check(args):
    """Every argument that the text alone decides, before anything is read."""
    from ..fields import FIELDS
    ext = os.path.splitext(args.output)[1].lower()
    if ext not in OUTPUTS:
        raise UsageError("--output", f"expected a file name ending in {', '.join(OUTPUTS)}, got {args.output!r}")
    output_directory_exists(args.output, "--output")
    if args.units is not None:
        from ..units import as_units
        with as_usage("--units"):
            args.units = as_units(args.units)
    args.fields = split_list(args.fields)
    if not args.fields:
        raise UsageError("--fields", "expected at least one field name")
    for name in args.fields:
        if name not in FIELDS:
            raise UsageError("--fields", f"unknown field {name!r}; expected some of {', '.join(FIELDS)}")
    args.width_given = args.width is not None
    args.width = positive_number(args.width if args.width_given else DEFAULT_WIDTH, "--width")
    args.cutoff = None if args.cutoff is None else positive_number(args.cutoff, "--cutoff")
    args.grid = integers(args.grid, "--grid", positive=True, allow_x=True)
    args.average = tuple(split_list(args.average))
    if args.time_average not in ("mean", "none"):
        try:
            width = float(args.time_average)
        except ValueError:
            raise UsageError("--time-average", f"expected mean, none or a positive time width, "
                                               f"got {args.time_average!r}") from None
        if not (np.isfinite(width) and width > 0):
            raise UsageError("--time-average", f"expected mean, none or a positive time width, got {args.time_average!r}")
        args.time_average = width
    if ext == ".vtk" and args.time_average != "mean":
        # (the VTK writer takes one frame: the others were computed and dropped)
        raise UsageError("--output", f"a .vtk file holds one result, but --time-average {args.time_average} gives "
                                     f"one per frame (or output time): write .h5 or .npz, or use --time-average mean")
    if args.step == 0:
        raise UsageError("--step", "expected a non-zero integer")
    args.lower = None if args.lower is None else numbers(args.lower, "--lower", allow_empty=True)
    args.upper = None if args.upper is None else numbers(args.upper, "--upper", allow_empty=True)
    if args.figure:
        args.figure_format = figure_format(args.figure, "--figure")
        replaceable_figure(args.figure, "--figure")
        check_matplotlib("--figure")
        args.figure_fields = split_list(args.figure_fields) if args.figure_fields else list(args.fields)
        for name in args.figure_fields:
            if name not in args.fields:
                raise UsageError("--figure-fields", f"{name!r} is not among --fields ({', '.join(args.fields)})")
        if args.time_average != "mean":
            raise UsageError("--figure", "a figure shows one result: use --time-average mean (the default)")
    elif args.figure_fields:
        raise UsageError("--figure-fields", "given without --figure")
    args.gravity = None if args.gravity is None else numbers(args.gravity, "--gravity")
    args.fixed_types = None if args.fixed_types is None else integers(args.fixed_types, "--fixed-types")
    args.fixed_ids = None if args.fixed_ids is None else integers(args.fixed_ids, "--fixed-ids")
    args.walls = None if args.walls is None else split_list(args.walls)
    args.pair_values = None if args.pair_values is None else split_list(args.pair_values)
    args.wall_values = None if args.wall_values is None else split_list(args.wall_values)
    args.masses = None if args.masses is None else type_masses(args.masses)
    args.dt = None if args.dt is None else positive_number(args.dt, "--dt")
    args.density = None if args.density is None else positive_number(args.density, "--density")
    if args.var is not None:
        args.var = variables(args.var)
    if args.var and args.input is None:
        raise UsageError("--var", "given without --input (variables are the input script's)")
    if ext == ".stat":
        stat_kernel_check(args)
    if args.wall_contacts and any(c in args.wall_contacts for c in "*?["):
        raise UsageError("--wall-contacts", f"one file holding every frame's wall contacts, not a pattern "
                                            f"({args.wall_contacts!r}): join the per-frame files in time order "
                                            f"(e.g. cat walls.*.dump > walls.dump, the names sorted by timestep)")
    for name in ("restart", "input", "wall_contacts"):
        if getattr(args, name):
            existing_file(getattr(args, name), "--" + name.replace("_", "-"))


def variables(items):
    out = {}
    for item in items:
        name, sep, value = item.partition("=")
        if not sep or not name.strip():
            raise UsageError("--var", f"expected NAME=VALUE, got {item!r}")
        out[name.strip()] = value
    return out


def stat_kernel_check(args):
    """MercuryCG's Gauss is cut off at 3 widths and renormalised over the ball, and over averaged axes its
    kernels are the lower-dimensional ones: a .stat says so, so the kernel must be that one (checked before
    the run, not after it)."""
    if args.kernel == "gaussian" and not (args.normalize == "truncated" and args.cutoff is not None
                                          and abs(args.cutoff - 3 * args.width) <= 1e-12 * args.cutoff):
        raise UsageError("--output", f"a MercuryCG .stat file holds MercuryCG's Gauss (cut off at 3 w and "
                                     f"renormalised): add --cutoff {3 * args.width:g} --normalize truncated")
    if args.kernel != "gaussian" and 0 < len(set(args.average)) < 3 and args.averaged_kernel != "lower-dimensional":
        raise UsageError("--output", f"a MercuryCG .stat file holds MercuryCG's lower-dimensional {args.kernel} "
                                     f"kernel over the averaged axes: add --averaged-kernel lower-dimensional")


# --- opening the dataset -----------------------------------------------------------------------------

def input_files(args):
    from ..readers.files import expand_paths
    try:
        if args.format == "mdanalysis":
            return [existing_file(p, "PATH") for p in args.paths]
        if len(args.paths) == 1 and os.path.isdir(args.paths[0]):
            return list(args.paths)            # a directory of Yade exports
        return expand_paths(args.paths, "PATH")
    except (OSError, ValueError) as exc:
        raise UsageError(None, str(exc)) from None


def data_format(args, paths):
    from ..readers.sniff import sniff_format
    if args.format:
        return args.format
    try:
        fmt = sniff_format(paths[0])
        for path in paths[1:]:   # a file of another format among them would be read as this one's
            try:
                other = f"{sniff_format(path)} data"
            except ValueError:
                other = "not a data file of a known format"
            if other != f"{fmt} data":
                raise UsageError("PATH", f"{path} is {other} but {paths[0]} is {fmt} data; give the files of "
                                         f"one dataset (contact files with --pairs, a .restart with --restart)")
        return fmt
    except ValueError as exc:
        raise UsageError("--format", str(exc)) from None


def check_flags_apply(args, fmt):
    for name, formats in FLAG_FORMATS.items():
        if getattr(args, name) is not None and fmt not in formats:
            flag = "--" + name.replace("_", "-")
            raise UsageError(flag, f"applies to {', '.join(formats)} input, not to {fmt} input")


def contact_files(args, paths, fmt):
    """The contact files: --pairs (a file or a pattern), or for MercuryDPM the .fstat next to each .data."""
    if args.pairs is not None:
        return args.pairs
    if fmt == "mercury":
        from ..readers.files import companion
        found = [companion(p, ".data", ".fstat") for p in paths]
        if any(found) and not all(found):
            # some frames without their contacts would be coarse-grained as if no particle touched
            lost = [os.path.basename(p) for p, f in zip(paths, found) if f is None]
            raise UsageError("--pairs", f"{len(lost)} of the {len(paths)} .data files have no .fstat beside them "
                                        f"({', '.join(lost[:3])}{' ...' if len(lost) > 3 else ''}) while the others "
                                        f"have: a contact file is missing; restore it, or name the .data files that "
                                        f"have one")
        if all(found):
            print(f"cgbound: contacts from {', '.join(os.path.basename(f) for f in found[:3])}"
                  f"{' ...' if len(found) > 3 else ''}", file=sys.stderr)
            return found
    return None


def mercury_dimension(path):
    from ..readers.files import open_input
    with open_input(path) as f:
        words = f.readline().split()
    return 2 if len(words) == 6 else 3


def lammps_dimension(args):
    """A LAMMPS/LIGGGHTS run's dimension: --dimension, else the input script's (--input), else 3."""
    if args.dimension is not None:
        return args.dimension
    if getattr(args, "input", None) is not None:
        from ..readers.lammps_input import read_input
        return read_input(args.input, args.var or None).dimension
    return 3


def check_gravity(args, fmt, paths):
    if args.gravity is None:
        return None
    dim = mercury_dimension(paths[0]) if fmt == "mercury" else lammps_dimension(args)
    allowed = (2, 3) if dim == 2 else (3,)
    if len(args.gravity) not in allowed:
        text = ",".join(f"{g:g}" for g in args.gravity)
        raise UsageError("--gravity", f"expected {dim} comma-separated numbers for {dim}-D data, got {text!r}")
    return args.gravity


def reader_options(args, fmt, paths):
    """The reader keywords of the flags given."""
    options = {}
    gravity = check_gravity(args, fmt, paths)
    if gravity is not None:
        options["body_force"] = gravity
    if args.gravity_override:
        options["body_force_override"] = True
    if fmt in ("lammps", "liggghts"):
        for name in ("pair_compute", "pair_values", "fixed_types", "fixed_ids", "masses", "dt", "dimension"):
            if getattr(args, name) is not None:
                options[name] = getattr(args, name)
        if args.no_check_forces:
            options["check_forces"] = False
        if args.input is not None:
            options["input"] = args.input
            options["variables"] = args.var or None
        if fmt == "lammps":
            if args.pair_style is not None:
                options["pair_style"] = args.pair_style
            if args.walls is not None:
                options["walls"] = args.walls
        else:
            for name in ("wall_contacts", "wall_compute", "wall_values"):
                if getattr(args, name) is not None:
                    options[name] = getattr(args, name)
    elif fmt == "yade":
        if args.fixed_ids is not None:
            options["fixed_ids"] = args.fixed_ids
        if args.no_check_forces:
            options["check_forces"] = False
    elif fmt == "mercury":
        if args.fixed_ids is not None:
            options["fixed"] = args.fixed_ids
        if args.density is not None:
            options["density"] = args.density
    return options


def read_files(paths, contacts, restart, script):
    """Every file the run reads (the files of a directory of exports, the files a --pairs pattern names)."""
    import glob
    out = []
    for p in paths:
        out.extend(os.path.join(p, name) for name in sorted(os.listdir(p))) if os.path.isdir(p) else out.append(p)
    for item in [contacts] if isinstance(contacts, str) else (contacts or []):
        out.extend(glob.glob(item) or [item])
    return out + [p for p in (restart, script) if p]


def open_data(args):
    """The dataset as one frame sequence, with every reader flag checked against the format."""
    from ..readers import open_dataset
    paths = input_files(args)
    fmt = data_format(args, paths)
    check_flags_apply(args, fmt)
    if fmt == "mdanalysis":
        output_not_input(args.output, paths, "--output")
        replaceable_output(args.output, "--output")
        with as_usage("PATH"):
            return open_dataset(tuple(paths) if len(paths) > 1 else paths[0], format=fmt), fmt, paths
    options = reader_options(args, fmt, paths)
    contacts = contact_files(args, paths, fmt) if fmt != "hdf5" else None
    if contacts is not None:
        options["fstat_path" if fmt == "mercury" else "pairs"] = contacts
    if fmt == "mercury":
        from ..readers.files import companion
        restart = args.restart or companion(paths[0], ".data", ".restart")
        if restart and args.restart is None:
            print(f"cgbound: fixed particles, densities, periodic axes and gravity from {os.path.basename(restart)}",
                  file=sys.stderr)
        options["restart_path"] = restart
    output_not_input(args.output, read_files(paths, contacts, options.get("restart_path"), args.input)
                     + ([args.wall_contacts] if getattr(args, "wall_contacts", None) else []), "--output")
    replaceable_output(args.output, "--output")
    with as_usage("PATH"):
        try:
            data = open_dataset(paths, format=fmt, **options)
        except OSError as exc:     # a missing file named by a pattern or option: an argument error too
            raise ValueError(str(exc)) from None
    if len(data) == 0:
        raise UsageError("PATH", f"{', '.join(paths[:3])}: no frames")
    return data, fmt, paths


# --- checks that need the first frame ----------------------------------------------------------------

def make_grid(args, first):
    from ..box import Box
    from ..grid import Grid
    dim, box = first.dim, first.box
    with as_usage("--average"):
        names = box.axis_names
        for a in args.average:
            if a not in names:
                raise UsageError("--average", f"expected axis names of {dim}-D data ({', '.join(names)}), got {a!r}")
    if len(args.grid) not in (1, dim):
        raise UsageError("--grid", f"expected {dim} comma-separated node counts for {dim}-D data (or one for every "
                                   f"resolved axis), got {','.join(map(str, args.grid))!r}")
    shape = args.grid[0] if len(args.grid) == 1 else tuple(args.grid)
    lower, upper = box.lower.copy(), box.upper.copy()
    for flag, given, corner in (("--lower", args.lower, lower), ("--upper", args.upper, upper)):
        if given is None:
            continue
        if len(given) != dim:
            raise UsageError(flag, f"expected {dim} comma-separated numbers for {dim}-D data "
                                   f"(empty entries keep the box), got {len(given)}")
        for d, value in enumerate(given):
            if value is None:
                continue
            if names[d] in args.average and value != corner[d]:
                raise UsageError(flag, f"axis {names[d]} is averaged over the data's box "
                                       f"[{box.lower[d]:g}, {box.upper[d]:g}]; leave its entry empty")
            corner[d] = value
    if np.any(upper <= lower):
        raise UsageError("--lower" if args.lower is not None else "--upper",
                         f"expected lower < upper on every axis, got lower {lower.tolist()} and upper {upper.tolist()}")
    with as_usage("--grid"):
        grid_box = box if args.lower is None and args.upper is None else Box(lower, upper)
        return Grid(grid_box, shape, average=args.average)


def make_kernel(args):
    from ..kernels import Gaussian, Heaviside, Lucy
    flag = "--cutoff" if args.cutoff is not None else "--width"
    with as_usage(flag):
        if args.kernel == "gaussian":
            return Gaussian(args.width, cutoff=args.cutoff, normalize=args.normalize,
                            averaged_axes=args.averaged_kernel)
    kernel, per_width = (Lucy, 3.0) if args.kernel == "lucy" else (Heaviside, 1.0)
    if args.cutoff is not None:
        with as_usage("--cutoff"):
            return kernel(args.cutoff, averaged_axes=args.averaged_kernel)
    # the cutoff made from --width: its errors are --width's (the API names its cutoff argument)
    try:
        return kernel(per_width * args.width, averaged_axes=args.averaged_kernel)
    except (ValueError, TypeError, OverflowError) as exc:
        why = str(exc).split(": ", 1)[-1] if str(exc).startswith("cutoff: ") else str(exc)
        raise UsageError("--width", f"gives a {kernel.__name__} cutoff of {per_width:g} x {args.width:g} = "
                                    f"{per_width * args.width:g}: {why}") from exc


def warn_if_no_particle_reached(args, out):
    """Say so when the density is zero at every node of every frame: no particle came within the kernel's reach of
    the grid (a --lower/--upper outside the data, or a --species absent), so every field is zero (velocity NaN)."""
    for name in ("density", "number_density"):
        if name in args.fields:
            if not np.any(np.asarray(out[name])):
                import warnings
                which = "particle" if args.species is None else f"flowing particle of species {args.species}"
                warnings.warn(f"the {name.replace('_', ' ')} is zero at every node of every frame: no {which} came "
                              f"within the kernel's cutoff of the grid, so every field is zero (velocity NaN); "
                              f"check {'--species, ' if args.species is not None else ''}--lower and --upper "
                              f"against the data's box {out.box.lower.tolist()} .. {out.box.upper.tolist()}",
                              stacklevel=2)
            return


#: --width when neither it nor --cutoff is given: a quarter of a unit diameter (the paper's d/4)
DEFAULT_WIDTH = "0.25"
#: the default width is refused when it is this many times larger, or smaller, than the particles' median diameter
DEFAULT_WIDTH_RANGE = (0.01, 10.0)


def check_flat_3d(args, fmt, first):
    """A LAMMPS/LIGGGHTS dump of a 2-D run (``dimension 2``) read without --dimension 2 is 3-D data with every z and
    vz 0 (LAMMPS keeps a 2-D run's z at 0): its fields would be per volume through the plane z = 0 and its
    profiles along z meaningless. Refuse it, unless the input script says which dimension the run has."""
    if fmt not in ("lammps", "liggghts") or args.dimension is not None or first.dim != 3 or first.n_particles < 2:
        return
    if getattr(args, "input", None) is not None:
        from ..readers.lammps_input import read_input
        if read_input(args.input, args.var or None).dimension_given:
            return
    z = first.positions[:, 2]
    flat = not np.any(z) and (first.velocities is None or not np.any(first.velocities[:, 2]))
    if flat:
        raise UsageError("--dimension", "not given, so the data are read as 3-D, but every particle of the first "
                                        "frame has z = 0 and vz = 0: a 2-D run (LAMMPS 'dimension 2')? Pass "
                                        "--dimension 2 (the fields are then per unit area of the run's plane), or "
                                        "--dimension 3 if the run is 3-D (a layer at z = 0)")


def check_default_width(args, first):
    """The default width assumes particles of diameter about 1: on data in other units (SI grains of a millimetre)
    it smooths over the whole system, or resolves nothing, and the fields are meaningless though finite. Refuse it
    before the work when the first frame's radii say so."""
    if args.width_given or args.cutoff is not None or first.radii is None:
        return
    flowing = first.radii[~first.fixed] if np.any(~first.fixed) else first.radii
    diameter = 2.0 * float(np.median(flowing)) if flowing.size else 0.0
    if not diameter > 0:
        return
    ratio = args.width / diameter
    if DEFAULT_WIDTH_RANGE[0] <= ratio <= DEFAULT_WIDTH_RANGE[1]:
        return
    raise UsageError("--width", f"not given, and the default {args.width:g} is {ratio:.3g} times the particles' "
                                f"median diameter d = {diameter:.3g} (the data's units): the fields would be "
                                f"{'smoothed over the whole system' if ratio > 1 else 'spikes at the particles'}; "
                                f"give --width (or --cutoff) in the data's units, e.g. --width {diameter / 4:.3g} "
                                f"(d/4)")


def check_figure(args, grid):
    if args.figure and len(grid.resolved) not in (1, 2):
        raise UsageError("--figure", f"a figure shows profiles (one resolved axis) or maps (two); the grid "
                                     f"{grid!r} resolves {len(grid.resolved)}: average over more axes (--average)")


# --- the command ----------------------------------------------------------------------------------------

def run(args):
    from ..coarse import CoarseGrain
    from ..units import check_fields as check_units_fields
    data, fmt, paths = open_data(args)
    if args.units is not None:
        data.units = args.units
    with as_usage(args=args):        # the reader checks the first frame: a selection of nothing names its flag
        first = data[0]
    check_flat_3d(args, fmt, first)
    if os.path.splitext(args.output)[1].lower() == ".stat" and first.dim != 3:
        # (refused by the writer after the work otherwise)
        raise UsageError("--output", f"MercuryCG's .stat files are 3-D, the data are {first.dim}-D: write .h5, .npz "
                                     f"or .vtk")
    with as_usage("--fields"):
        check_units_fields(first.units, args.fields)
    grid = make_grid(args, first)
    kernel = make_kernel(args)
    check_default_width(args, first)
    check_figure(args, grid)
    with as_usage("--fields"):
        analysis = CoarseGrain(data, grid, kernel, fields=args.fields, convention=args.convention,
                               species=args.species, time_average=args.time_average,
                               couple_stress_form=args.couple_stress_form)
    start = time.perf_counter()
    analysis.run(args.start, args.stop, args.step, verbose=not args.quiet)
    elapsed = time.perf_counter() - start
    out = analysis.results
    warn_if_no_particle_reached(args, out)
    ext = os.path.splitext(args.output)[1].lower()
    if ext in (".h5", ".hdf5"):
        out.to_hdf5(args.output, provenance={"input": ", ".join(os.path.abspath(p) for p in paths),
                                             "command": "cgbound run"})
    elif ext == ".npz":
        out.to_npz(args.output)
    elif ext == ".stat":
        from ..mercurycg import write_stat
        write_stat(args.output, out)
    else:
        out.to_vtk(args.output, frame=None if args.time_average == "mean" else 0)
    print(f"cgbound: {analysis.n_frames} frames -> {', '.join(args.fields)} on "
          f"{grid!r} with {kernel!r} in {elapsed:.2f} s; wrote {args.output}")
    if args.figure:
        from .figures import fields_figure
        fig = fields_figure(out, args.figure_fields)
        save_figure(fig, args.figure, args.figure_format)
        print(f"cgbound: wrote {args.figure}")
    return 0
