"""One snapshot too big for one process: coarse graining in tiles of the grid, stitched exactly.

The grid's nodes are split into ``tiles`` (a block of consecutive nodes along each resolved
axis). A tile needs only the flowing particles within the kernel's support (``kernel.radius``) of
its nodes and the contacts whose line from the particle to the contact (at most the longest branch
vector long) can reach them, so each worker gets those (a halo of ``radius`` around the tile for
particles, ``radius`` plus the longest branch for contacts, measured with periodic images along
periodic axes, not at all along averaged axes, which every node integrates over; when a field sums
over contact points or the lines from a particle to its contact point (fabric, the rotational contact
fields) the contact halo is ``radius`` plus the longest of the branches and of the particle-to-contact-
point levers, which bounds every such point and line). The extended stress is the exception: its rays
run from a boundary contact out of the region, so with ``extended_stress`` every tile gets every
boundary contact (usually few). Each node's sums
then hold exactly the same non-zero terms as in one process, so the stitched fields agree with
:func:`cgbound.coarse_grain` to rounding.
"""
import numpy as np

from ._validate import counts_per_axis, flag
from .executors import check_backend, executor
from .fields import DEFAULT_COUPLE_STRESS_FORM
from .grid import Grid
from .pipeline import DEFAULT_FIELDS, prepare, run_snapshot
from .primaries import (CONTACT_PRIMARIES, ROTATION_CONTACT_PRIMARIES, SPIN_PRIMARIES, compute_primaries,
                        flowing_rows, longest_branch)
from .progress import progress
from .snapshot import Snapshot

#: tiles in flight per worker thread: keeps workers busy without sending every tile's particles at once
TILES_IN_FLIGHT_PER_THREAD = 2

#: the halo is widened by this fraction so that a particle exactly at the support radius is never lost
#: to rounding (an extra particle outside the support adds only zeros)
HALO_SLACK = 1e-9


def coarse_grain_tiled(snapshot, grid, kernel, fields=DEFAULT_FIELDS, convention="tension", species=None, *,
                       tiles, backend="dask", client=None, n_workers=None, verbose=False,
                       couple_stress_form=DEFAULT_COUPLE_STRESS_FORM):
    """Coarse-grained fields of one (large) snapshot, computed tile by tile (on Dask workers by default).

    Parameters
    ----------
    snapshot, grid, kernel, fields, convention, species, couple_stress_form : as for
        :func:`cgbound.coarse_grain` (every field, the rotational ones too); ``grid`` must be a
        :class:`cgbound.Grid`.
    tiles : sequence of D positive ints
        Tiles along each axis (1 along averaged axes; at most the grid's nodes along each axis).
    backend : "dask" or "serial"
        "dask": tiles run on a dask.distributed cluster; "serial": one after another in this
        process (each tile's scratch memory instead of the whole grid's, no cluster).
    client : dask.distributed.Client, optional
        The cluster to use (left open). None: a LocalCluster of ``n_workers`` processes (default 2),
        closed afterwards.
    n_workers : int, optional
    verbose : bool
        Progress bar over tiles.

    Returns
    -------
    Result
        The same as ``coarse_grain(snapshot, grid, kernel, fields, convention, species, couple_stress_form)``
        to rounding.

    Notes
    -----
    This process holds the snapshot and the whole grid's fields; it cuts the tiles one by one and keeps
    at most two per worker thread on the cluster, so a worker holds about two tiles' particles and one
    tile's sums at a time. Use more tiles to lower the memory per worker.
    """
    if not isinstance(grid, Grid):
        raise TypeError(f"grid: expected a cg.Grid for tiling (tiles split its nodes), got {type(grid).__name__}")
    if not isinstance(snapshot, Snapshot):
        raise TypeError(f"snapshot: expected a cg.Snapshot, got {type(snapshot).__name__}")
    backend, n_workers = check_backend(backend, client, n_workers)
    verbose = flag(verbose, "verbose")
    job = prepare(snapshot, grid, kernel, fields, convention, species, couple_stress_form)
    tiles = check_tiles(tiles, grid)
    job = job._replace(kernel=resolve_auto_line_quadrature(job.kernel, job.split))

    def tiled_sums(job, u_ref):
        cutter = _Cutter(job.snapshot, grid, job.kernel, job.split, job.needed)
        boxes = tile_ranges(grid, tiles)
        stitched = _Stitched(grid, job.snapshot.dim)
        jobs = ((ranges, (cutter.tile(ranges), TileTarget(grid, ranges), job.kernel, job.needed, u_ref))
                for ranges in boxes)
        bar = progress(verbose, len(boxes), "tile")
        try:
            with executor(backend, client, n_workers) as run:
                run.stream(tile_primaries, jobs, stitched.put, bar, TILES_IN_FLIGHT_PER_THREAD)
        finally:
            bar.close()
        return stitched.primaries

    return run_snapshot(job, tiled_sums)


def check_tiles(tiles, grid):
    """Tiles per axis as a tuple of D ints, checked against the grid."""
    dim = grid.dim
    names = grid.box.axis_names
    tiles = counts_per_axis(tiles, "tiles", dim, "tile", hint=" (tiles along each axis)")
    for d, t in enumerate(tiles):
        if d in grid.averaged and t != 1:
            raise ValueError(f"tiles: expected 1 tile along the averaged axis {names[d]}, got {t}")
        if t > grid.shape[d]:
            raise ValueError(f"tiles: expected at most {grid.shape[d]} tiles along {names[d]} (the grid's nodes), "
                             f"got {t}")
    return tiles


def tile_ranges(grid, tiles):
    """Each tile as a tuple of D (first, stop) node ranges, in C order of the tiles."""
    per_axis = []
    for d in range(grid.dim):
        edges = np.linspace(0, grid.shape[d], tiles[d] + 1).round().astype(int)
        per_axis.append([(int(a), int(b)) for a, b in zip(edges[:-1], edges[1:])])
    return [tuple(per_axis[d][k] for d, k in enumerate(combo)) for combo in np.ndindex(*tiles)]


class TileTarget:
    """The nodes of one tile, with the grid's own coordinates (bitwise) and averaging extent."""

    def __init__(self, grid, ranges):
        self.dim, self.resolved, self.avg_extent = grid.dim, grid.resolved, grid.avg_extent
        self.axis_coordinates = [np.ascontiguousarray(grid.axis_coordinates[d][a:b])
                                 for d, (a, b) in enumerate(ranges)]
        self.size = int(np.prod([b - a for a, b in ranges]))


class _TileData:
    """The particles and contacts one tile needs (one object, so Dask scatters it as a whole).

    ``points``: flowing particles near the tile; ``owners``: the positions of the particles the selected
    contacts' lines start from (contact primaries start their line there; the second particle of each
    bulk contact too when its half-line from that particle is summed); bulk/boundary: the selected
    contacts of ``Snapshot.split_contacts``, with ``i`` (and ``j``) indexing ``owners``.
    """

    def __init__(self, box, points, owners, bulk, boundary):
        self.box, self.points, self.owners, self.bulk, self.boundary = box, points, owners, bulk, boundary


def resolve_auto_line_quadrature(kernel, split):
    """line_quadrature="auto" picks n from the longest branch; fix it from the whole snapshot so that
    every tile uses the rule the single-process run would."""
    if split is None:  # no contact primary needed: no branch, and nothing to resolve
        return kernel
    return kernel.with_resolved_line_quadrature(longest_branch(*split))


def tile_primaries(data, target, kernel, needed, u_ref):
    """Task: primary sums (flat over the tile's nodes) of one tile."""
    pts = data.points
    n, m = pts["positions"].shape[0], data.owners.shape[0]

    def rows(value, fill):
        return None if value is None else np.concatenate([value, np.full((m,) + value.shape[1:], fill)])

    snap = Snapshot(np.concatenate([pts["positions"], data.owners]), rows(pts["velocities"], 0.0),
                    rows(pts["masses"], 1.0), box=data.box, fixed=np.arange(n + m) >= n,
                    body_force=rows(pts["body_force"], 0.0), radii=rows(pts["radii"], 0.0),
                    angular_velocities=rows(pts["angular_velocities"], 0.0),
                    moments_of_inertia=rows(pts["inertia"], 1.0))
    # the contact owners follow the particles, as fixed rows: they only anchor the contact lines
    bulk = dict(data.bulk, i=data.bulk["i"] + n)
    if "j" in bulk:
        bulk["j"] = bulk["j"] + n
    boundary = dict(data.boundary, i=data.boundary["i"] + n)
    return compute_primaries(snap, target, kernel, needed, u_ref, (bulk, boundary))


def longest_lever(snapshot, bulk):
    """The longest distance from a bulk contact's first particle to its contact point (minimum image), 0
    without bulk contacts: contact points and the half-lines r_j -> c lie within it or the branch of r_i."""
    if not bulk["i"].size:
        return 0.0
    lever = snapshot.box.minimum_image(np.take(snapshot.positions, bulk["i"], axis=0) - bulk["point"])
    return float(np.sqrt(np.einsum("ij,ij->i", lever, lever).max()))


class _Cutter:
    """Selects, for a tile, the particles and contacts that reach its nodes."""

    def __init__(self, snapshot, grid, kernel, split, needed):
        self.snapshot, self.grid = snapshot, grid
        flow = snapshot.flowing
        self.flow_idx = np.flatnonzero(flow)
        self.flow_pos = snapshot.positions[flow]
        empty = (np.zeros(0, np.int64), np.zeros((0, snapshot.dim)))
        if split is None:
            split = ({"i": empty[0], "j": empty[0], "force": empty[1], "branch": empty[1], "point": empty[1]},
                     {"i": empty[0], "force": empty[1], "branch": empty[1], "point": empty[1]})
        self.bulk, self.boundary = split
        branches = np.concatenate([self.bulk["branch"], self.boundary["branch"]])
        longest = float(np.sqrt((branches**2).sum(axis=1)).max()) if branches.shape[0] else 0.0
        # the rotational contact primaries sum the half-lines from both particles of a bulk contact to its
        # contact point (so need the second particle's position too)
        self.with_halves = bool(needed & ROTATION_CONTACT_PRIMARIES)
        if self.with_halves or "fb" in needed:
            # fabric and torque densities sit at the bulk contact points, the half-lines end there
            longest = max(longest, longest_lever(snapshot, self.bulk))
        self.point_halo = kernel.radius * (1 + HALO_SLACK)
        self.contact_halo = (kernel.radius + longest) * (1 + HALO_SLACK)
        self.bulk_owner = snapshot.positions[self.bulk["i"]]
        self.bulk_partner = snapshot.positions[self.bulk["j"]] if self.with_halves else None
        self.boundary_owner = snapshot.positions[self.boundary["i"]]
        self.with_contacts = bool(needed & CONTACT_PRIMARIES)
        # the extended stress integrates along rays from the particle through the contact point and
        # beyond, out of the region: no halo bounds them, so every tile gets every boundary contact
        self.all_boundary = "sx" in needed
        self.with_spin = bool(needed & SPIN_PRIMARIES)
        self.inertia = flowing_rows(snapshot, snapshot.inertia("the rotational fields")) if self.with_spin else None

    def _near(self, positions, ranges, halo):
        """Rows of ``positions`` within ``halo`` of the tile's node span on every resolved axis."""
        keep = np.ones(positions.shape[0], bool)
        box = self.snapshot.box
        for d in self.grid.resolved:
            a, b = ranges[d]
            lo, hi = self.grid.axis_coordinates[d][a], self.grid.axis_coordinates[d][b - 1]
            x = positions[:, d]
            if box.periodic[d]:
                length = float(box.lengths[d])
                if (hi - lo) + 2 * halo >= length:
                    continue
                u = np.mod(x - lo, length)  # position past the tile's first node, on the circle
                keep &= (u <= (hi - lo) + halo) | (u >= length - halo)
            else:
                keep &= (x >= lo - halo) & (x <= hi + halo)
        return keep

    def tile(self, ranges):
        snap = self.snapshot
        near = self._near(self.flow_pos, ranges, self.point_halo)
        rows = self.flow_idx[near]
        points = {"positions": snap.positions[rows], "masses": snap.masses[rows],
                  "velocities": None if snap.velocities is None else snap.velocities[rows],
                  "body_force": None if snap.body_force is None else np.ascontiguousarray(snap.body_force[rows]),
                  "radii": None if snap.radii is None else snap.radii[rows],
                  "angular_velocities": snap.angular_velocities[rows] if self.with_spin else None,
                  "inertia": self.inertia[near] if self.with_spin else None}
        if self.with_contacts:
            b_keep = np.flatnonzero(self._near(self.bulk_owner, ranges, self.contact_halo))
            if self.all_boundary:
                w_keep = np.arange(self.boundary_owner.shape[0])
            else:
                w_keep = np.flatnonzero(self._near(self.boundary_owner, ranges, self.contact_halo))
        else:
            b_keep = w_keep = np.zeros(0, np.int64)
        owners = [self.bulk_owner[b_keep], self.boundary_owner[w_keep]]
        bulk = {"i": np.arange(b_keep.size), "force": self.bulk["force"][b_keep], "branch": self.bulk["branch"][b_keep],
                "point": self.bulk["point"][b_keep]}
        boundary = {"i": b_keep.size + np.arange(w_keep.size), "force": self.boundary["force"][w_keep],
                    "branch": self.boundary["branch"][w_keep], "point": self.boundary["point"][w_keep]}
        if self.with_halves:
            owners.append(self.bulk_partner[b_keep])
            bulk["j"] = b_keep.size + w_keep.size + np.arange(b_keep.size)
        return _TileData(snap.box, points, np.concatenate(owners), bulk, boundary)


class _Stitched:
    """The whole grid's primary sums, filled tile by tile."""

    def __init__(self, grid, dim):
        self.grid, self.dim = grid, dim
        self.primaries = {}

    def put(self, ranges, tile):
        shape = self.grid.shape
        where = tuple(slice(a, b) for a, b in ranges)
        for name, value in tile.items():
            extra = value.shape[1:]
            if name not in self.primaries:
                self.primaries[name] = np.zeros((self.grid.size,) + extra)
            full = self.primaries[name].reshape(shape + extra)
            full[where] = value.reshape(tuple(b - a for a, b in ranges) + extra)
