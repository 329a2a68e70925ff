"""One frame of particle data: positions, velocities, masses, contacts, box."""

import numpy as np

from ._engine import minimum_image as core_minimum_image
from ._validate import (abs_max_per_row, bool_array, finite_number, index_array, reader_bool_array,
                        reader_index_array, reader_real_array, real_array)
from .box import Box
from .units import as_units


def _read_only(array):
    """A view of ``array`` that cannot be written through (it shares memory with a snapshot's data)."""
    view = array.view()
    view.flags.writeable = False
    return view


#: the largest product of a snapshot's values (mass x velocity^2, force x branch) accepted: the kernel's
#: peak (at most 3 x 1e180 for the narrowest kernel, kernels.LENGTH_RANGE) times it must stay finite; the
#: pipeline checks the product with the actual kernel
LARGEST_PRODUCT = 1e300


class Contacts:
    """Contact list: ``force[c]`` acts ON particle ``i[c]`` FROM ``j[c]`` at ``point[c]``.

    ``j = -1`` marks a wall (no particle). Each pair appears once; listing a
    contact as (j, i, -force) is equivalent.

    ``branch`` (optional, (M, D)): the branch vector ``r_i - r_j`` of each contact between particles, for a
    periodic box thinner than two particles, where a pair can touch through two periodic images of each other at
    once (LAMMPS then lists it once per image, each listing its own contact). Each row must be the positions'
    difference plus whole box lengths along periodic axes (rows of walls, ``j = -1``, are ignored); a pair may
    then appear once per image. None (the default): the minimum image, each pair once.
    """

    def __init__(self, i, j, force, point, branch=None):
        self._setup(i, j, force, point, index_array, real_array, branch)

    @classmethod
    def from_reader(cls, i, j, force, point, parsed=(), branch=None):
        """The internal path for cgbound's readers (not for user data): arrays the reader has just produced
        (int64 i, j; float64 force, point) are kept without copies (read-only views) and with the constructor's
        checks, except the finiteness pass over the arrays named in ``parsed`` ("contacts.point",
        "contacts.force": values parsed by the C text layer, which refuses nan/inf, and not computed on).
        Other input goes through the constructor's conversions."""
        out = object.__new__(cls)
        out._setup(i, j, force, point, reader_index_array, reader_real_array(parsed), branch)
        return out

    def _setup(self, i, j, force, point, index, real, branch=None):
        self.i = index(i, "contacts.i")
        m = self.i.shape[0]
        self.j = index(j, "contacts.j", length=m)
        if m == 0 and np.size(force) == 0 and np.size(point) == 0:
            force = point = np.zeros((0, np.shape(force)[-1] if np.ndim(force) == 2 else 0))
        self.force = real(force, "contacts.force", ndim=2)
        self.point = real(point, "contacts.point", ndim=2)
        if self.force.shape[0] != m:
            raise ValueError(f"contacts.force: expected {m} rows like contacts.i, got {self.force.shape[0]}")
        if self.point.shape != self.force.shape:
            raise ValueError(f"contacts.point: expected shape {self.force.shape} like contacts.force, got {self.point.shape}")
        self.branch = None if branch is None else real(branch, "contacts.branch", ndim=2, shape=self.force.shape)

    def branch_images(self, positions, box):
        """The image index of each contact between particles (``branch`` given): (M, D) whole numbers, the box
        lengths ``branch`` adds to ``r_lo - r_hi`` (lo, hi: the pair's smaller and larger index, so a listing as
        (j, i, -branch) gives the same), 0 along non-periodic axes and for walls. ValueError where a row is not the
        positions' difference plus whole box lengths (to 1e-9 of the box length and the coordinates)."""
        i, j, b = self.i, self.j, self.branch
        pair = j >= 0
        jj = np.where(pair, j, i)
        flip = np.where(i > jj, -1.0, 1.0)[:, None]
        shift = (b - (np.take(positions, i, axis=0) - np.take(positions, jj, axis=0))) * flip
        lengths = np.asarray(box.lengths, float)
        periodic = np.asarray(box.periodic, bool)
        image = np.where(periodic, np.rint(shift / lengths), 0.0)
        scale = lengths + abs_max_per_row(positions).max(initial=0.0)
        off = abs_max_per_row((shift - image * lengths) / scale) * pair
        if np.any(~(off <= 1e-9)):
            k = int(np.argmax(np.where(np.isnan(off), np.inf, off)))
            raise ValueError(f"contacts.branch: expected r_i - r_j plus whole box lengths along periodic axes, got "
                             f"{b[k].tolist()} at contact {k} (particles {int(i[k])} and {int(j[k])}; "
                             f"r_i - r_j = {(positions[i[k]] - positions[j[k]]).tolist()}, box lengths "
                             f"{lengths.tolist()}, periodic {periodic.tolist()})")
        return np.where(pair[:, None], image, 0.0)

    @classmethod
    def empty(cls, dim):
        return cls(np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros((0, dim)), np.zeros((0, dim)))

    def __len__(self):
        return self.i.shape[0]

    def __repr__(self):
        return f"Contacts({len(self)} contacts)"


def pseudo_vector_array(values, name, n, dim, real=real_array):
    """Angular velocities or torques: (N, 3) in 3D; in 2D the out-of-plane component, given as (N,) or
    (N, 1), stored as (N,). None stays None. real: the conversion of arrays (real_array)."""
    if values is None:
        return None
    if dim == 3:
        return real(values, name, ndim=2, shape=(n, 3))
    array = real(values, name)
    if array.shape == (n, 1):
        return array[:, 0]
    if array.shape != (n,):
        raise ValueError(f"{name}: expected shape ({n},) or ({n}, 1) in 2D (the component perpendicular to the "
                         f"plane), got {array.shape}")
    return array


class Snapshot:
    """Particle data at one instant (docs/theory.md, "The snapshot model").

    Parameters
    ----------
    positions : (N, D) array
        Centres of all particles, flowing and fixed. D = 2 (axes x, z) or 3.
    velocities : (N, D) array or None
        None means a static snapshot: no kinetic contribution is computed.
    masses : (N,) array
        Positive for flowing particles; ignored for fixed ones.
    box : Box, optional
        Defaults to the non-periodic bounding box of the positions.
    contacts : Contacts, optional
    fixed : (N,) bool, optional
        Boundary particles (infinite mass).
    species : (N,) int, optional
    body_force : (D,) or (N, D), optional
        Body force per unit mass (e.g. gravity).
    radii : (N,), optional
        Needed for the volume fraction.
    time : float
    angular_velocities : (N, 3) array in 3D; (N,) or (N, 1) in 2D, optional
        In 2D the component perpendicular to the plane, positive when (axis 0, axis 1, normal) is
        right-handed (docs/theory.md, "Rotation and couple stress"). Needed for the spin density.
    torques : like angular_velocities, optional
        The total torque on each particle (e.g. as dumped), for ``angular_momentum_balance_residual``.
    moments_of_inertia : (N,) array, optional
        Default (when needed): solid spheres 2/5 m r^2 in 3D, discs 1/2 m r^2 in 2D, from masses and radii.
    units : Units, str or mapping, optional
        The units of these numbers (:mod:`cgbound.units`): a system name such as ``"si"`` or ``"lj"``,
        a mapping ``{"length": "m", "mass": "kg", "time": "s"}``, or a :class:`cgbound.Units`. Nothing
        is converted; the fields coarse-grained from the snapshot name their units from it. None: not known.
    """

    _units = None

    @property
    def units(self):
        """The units of the numbers (a :class:`cgbound.Units`), None when not known; settable with anything
        ``units=`` takes."""
        return self._units

    @units.setter
    def units(self, value):
        self._units = as_units(value)

    def __init__(self, positions, velocities=None, masses=None, box=None, contacts=None, fixed=None,
                 species=None, body_force=None, radii=None, time=0.0, units=None, angular_velocities=None,
                 torques=None, moments_of_inertia=None):
        self._setup(positions, velocities, masses, box, contacts, fixed, species, body_force, radii, time, units,
                    angular_velocities, torques, moments_of_inertia)

    @classmethod
    def from_reader(cls, positions, velocities=None, masses=None, box=None, contacts=None, fixed=None,
                    species=None, body_force=None, radii=None, time=0.0, units=None, angular_velocities=None,
                    torques=None, moments_of_inertia=None, parsed=(), contacts_checked=False):
        """The internal path for cgbound's readers (not for user data): the arguments of the constructor, with
        the arrays the reader has just produced (float64, int64 species, bool fixed) kept without copies (read-only
        views; strided ones copied C-contiguous) and every check of the constructor except

        * the finiteness pass over the arrays named in ``parsed`` (constructor argument names, e.g.
          ``"positions"``): values parsed by the C text layer, which refuses nan/inf, and not computed on;
        * with ``contacts_checked``, the checks of the contacts' indices and of one listing per pair, which the
          reader has made (MercuryReader's C pass of the .fstat lines, csrc/cg_fstat.h).

        The value checks (positive masses, radii, the products of masses, velocities, forces and branches) all
        run. Input that is not an array of the expected dtype goes through the constructor's conversions."""
        out = object.__new__(cls)
        out._setup(positions, velocities, masses, box, contacts, fixed, species, body_force, radii, time, units,
                   angular_velocities, torques, moments_of_inertia, real=reader_real_array(parsed),
                   index=reader_index_array, boolean=reader_bool_array, check_contacts=not contacts_checked)
        return out

    def _setup(self, positions, velocities, masses, box, contacts, fixed, species, body_force, radii, time, units,
               angular_velocities, torques, moments_of_inertia, real=real_array, index=index_array,
               boolean=bool_array, check_contacts=True):
        self.units = as_units(units)
        self.positions = real(positions, "positions", ndim=2)
        n, dim = self.positions.shape
        if dim not in (2, 3):
            raise ValueError(f"positions: expected shape (N, 2) or (N, 3), got {self.positions.shape}")
        self.velocities = None if velocities is None else real(velocities, "velocities", ndim=2, shape=(n, dim))
        if masses is None:
            raise TypeError("masses: expected an array of N positive masses, got None")
        self.masses = real(masses, "masses", ndim=1, shape=(n,))
        self.fixed = np.zeros(n, bool) if fixed is None else boolean(fixed, "fixed", n)
        bad = (~self.fixed) & ~(self.masses > 0)
        if np.any(bad):
            k = int(np.flatnonzero(bad)[0])
            raise ValueError(f"masses: expected positive masses for flowing particles, got {self.masses[k]} at index {k}")
        if box is None:
            if n == 0:
                raise ValueError("box: expected a cg.Box when there are no particles, got None")
            lo, hi = self.positions.min(axis=0), self.positions.max(axis=0)
            with np.errstate(over="ignore"):
                pad = np.maximum(hi - lo, 1.0) * 1e-9
                lower, upper = lo - pad, hi + pad
            if not (np.all(np.isfinite(upper - lower)) and np.all(upper > lower)):
                raise ValueError(f"positions: expected positions whose bounding box (the default box) is within the "
                                 f"floating-point range, got a spread from {lo.tolist()} to {hi.tolist()}; "
                                 f"rescale the units or pass box")
            box = Box(lower, upper)
        if not isinstance(box, Box):
            raise TypeError(f"box: expected a cg.Box, got {type(box).__name__}")
        if box.dim != dim:
            raise ValueError(f"box: expected a {dim}D box like positions, got {box.dim}D")
        self.box = box
        self.species = None if species is None else index(species, "species", length=n)
        if body_force is None:
            self.body_force = None
        else:
            g = real(body_force, "body_force")
            if g.shape == (dim,):
                g = np.broadcast_to(g, (n, dim))
            elif g.shape != (n, dim):
                raise ValueError(f"body_force: expected shape ({dim},) or ({n}, {dim}), got {g.shape}")
            self.body_force = g
        self.radii = None
        if radii is not None:
            self.radii = real(radii, "radii", ndim=1, shape=(n,))
            if np.any(self.radii < 0):
                k = int(np.flatnonzero(self.radii < 0)[0])
                raise ValueError(f"radii: expected non-negative radii, got {self.radii[k]} at index {k}")
        self.time = finite_number(time, "time")
        self.angular_velocities = pseudo_vector_array(angular_velocities, "angular_velocities", n, dim, real)
        self.torques = pseudo_vector_array(torques, "torques", n, dim, real)
        self.moments_of_inertia = None
        if moments_of_inertia is not None:
            inertia = real(moments_of_inertia, "moments_of_inertia", ndim=1, shape=(n,))
            bad = (~self.fixed) & ~(inertia > 0)
            if np.any(bad):
                k = int(np.flatnonzero(bad)[0])
                raise ValueError(f"moments_of_inertia: expected positive moments of inertia for flowing particles, "
                                 f"got {inertia[k]} at index {k}")
            self.moments_of_inertia = inertia
        if contacts is None:
            contacts = Contacts.empty(dim)
        if not isinstance(contacts, Contacts):
            raise TypeError(f"contacts: expected a cg.Contacts, got {type(contacts).__name__}")
        self.contacts = contacts
        if check_contacts:
            self._check_contacts()
        self._check_products()

    def _check_products(self):
        """Masses x velocities x velocities (the momentum flux) and forces x branches (the contact stress)
        must be finite doubles; else the fields would be inf or NaN without a word."""
        flow = ~self.fixed
        pick = flow if self.fixed.any() else slice(None)   # every particle flows: views, not copies
        largest = [np.abs(self.masses[pick]).max(initial=0.0)]
        if self.body_force is not None and flow.any():
            with np.errstate(over="ignore"):
                largest.append(float((self.masses[pick] * abs_max_per_row(self.body_force[pick])).max()))
        if self.velocities is not None and flow.any():
            m = self.masses[pick]
            speed = abs_max_per_row(self.velocities[pick])
            with np.errstate(over="ignore"):
                flux = m * speed * speed
            bad = ~(flux <= LARGEST_PRODUCT)
            if np.any(bad):
                k = int(np.flatnonzero(flow)[np.flatnonzero(bad)[0]])
                raise ValueError(f"velocities: expected velocities whose momentum flux (masses x velocity x velocity) "
                                 f"stays below {LARGEST_PRODUCT:g}, got mass {float(self.masses[k])!r} and velocity "
                                 f"{self.velocities[k].tolist()} at index {k} (rescale the units)")
            largest += [float(flux.max()), float((m * speed).max())]
        if self.radii is not None and flow.any():
            with np.errstate(over="ignore"):
                volume = 4.2 * self.radii[pick] ** self.dim      # > the ball's volume in 2D and 3D
            bad = ~(volume <= LARGEST_PRODUCT)
            if np.any(bad):
                k = int(np.flatnonzero(flow)[np.flatnonzero(bad)[0]])
                raise ValueError(f"radii: expected radii whose particle volume stays below {LARGEST_PRODUCT:g}, "
                                 f"got {float(self.radii[k])!r} at index {k} (rescale the units)")
            largest.append(float(volume.max()))
        c = self.contacts
        if len(c):
            force = abs_max_per_row(c.force)
            reach = abs_max_per_row(self.positions)
            # |branch| <= |r_i| + |r_j or the contact point| (before the minimum image, which only shortens it)
            other = np.where(c.j >= 0, reach[np.where(c.j >= 0, c.j, 0)], abs_max_per_row(c.point))
            with np.errstate(over="ignore"):
                branch = reach[c.i] + other
                if c.branch is not None:     # (a listed image's branch: up to a box length longer)
                    np.maximum(branch, np.where(c.j >= 0, abs_max_per_row(c.branch), 0.0), out=branch)
                product = force * branch * 2.0
            far = ~(branch <= LARGEST_PRODUCT)
            if np.any(far):
                k = int(np.flatnonzero(far)[0])
                name = "positions" if c.j[k] >= 0 else "contacts.point"
                raise ValueError(f"{name}: expected coordinates whose differences (the branch vectors of contacts) "
                                 f"stay below {LARGEST_PRODUCT:g}, got a branch of up to {branch[k]:g} at contact {k} "
                                 f"(rescale the units)")
            bad = ~(product <= LARGEST_PRODUCT)
            if np.any(bad):
                k = int(np.flatnonzero(bad)[0])
                raise ValueError(f"contacts.force: expected forces whose product with the branch vectors (contact "
                                 f"stress) stays below {LARGEST_PRODUCT:g}, got force {c.force[k].tolist()} on a "
                                 f"branch of up to {reach[c.i[k]] + other[k]:g} at contact {k} (rescale the units)")
            largest += [float(product.max()), float(force.max())]
        #: a bound of the largest value the kernel's peak multiplies (checked against it before coarse graining)
        self.largest_product = max(largest)

    # ------------------------------------------------------------------
    @property
    def dim(self):
        return self.positions.shape[1]

    @property
    def n_particles(self):
        return self.positions.shape[0]

    @property
    def flowing(self):
        return ~self.fixed

    def _check_contacts(self):
        c, n, dim = self.contacts, self.n_particles, self.dim
        m = len(c)
        if m == 0:
            return
        if c.force.shape[1] != dim:
            raise ValueError(f"contacts.force: expected shape ({m}, {dim}) for a {dim}D snapshot, got {c.force.shape}")
        if np.any((c.i < 0) | (c.i >= n)):
            k = int(np.flatnonzero((c.i < 0) | (c.i >= n))[0])
            raise IndexError(f"contacts.i: expected particle indices in [0, {n}), got {c.i[k]} at contact {k}")
        if np.any((c.j < -1) | (c.j >= n)):
            k = int(np.flatnonzero((c.j < -1) | (c.j >= n))[0])
            raise IndexError(f"contacts.j: expected particle indices in [0, {n}) or -1 for a wall, got {c.j[k]} at contact {k}")
        same = c.i == c.j
        if np.any(same):
            k = int(np.flatnonzero(same)[0])
            raise ValueError(f"contacts.j: expected a particle other than contacts.i (or -1 for a wall), "
                             f"got particle {c.i[k]} joined to itself at contact {k}")
        pairs = c.j >= 0
        image = None
        if c.branch is not None:
            if c.branch.shape[1] != dim:
                raise ValueError(f"contacts.branch: expected shape ({m}, {dim}) for a {dim}D snapshot, got "
                                 f"{c.branch.shape}")
            image = c.branch_images(self.positions, self.box)[pairs]
        if pairs.any():
            ci, cj = c.i[pairs], c.j[pairs]
            lo, hi = np.minimum(ci, cj), np.maximum(ci, cj)
            # one int64 key per pair (lo * n + hi, exact since n * n < 2^63): sorting it orders the pairs as
            # (lo, hi) tuples, so the first repeat found is the lexicographically first repeated pair
            if image is not None:
                # with branches, a pair once per periodic image: the (lo, hi, image) tuples must be distinct
                key = np.unique(np.column_stack([lo, hi, image.astype(np.int64)]), axis=0,
                                return_inverse=True)[1].ravel()
            elif n < 3_000_000_000:
                key = lo.astype(np.int64) * n + hi
            else:  # (never in practice: the positions alone would take 72 GB) sort the pairs as tuples
                key = np.unique(np.stack([lo, hi], axis=1), axis=0, return_inverse=True)[1].ravel()
            if not np.all(key[1:] > key[:-1]):  # readers mostly give pairs in order: then no sort is needed
                order = np.sort(key)
                repeat = np.flatnonzero(order[1:] == order[:-1])
                if len(repeat):
                    first = np.flatnonzero(key == order[repeat[0]])[0]
                    a, b = int(lo[first]), int(hi[first])
                    where = np.flatnonzero((c.j >= 0) & (np.minimum(c.i, c.j) == a) & (np.maximum(c.i, c.j) == b))
                    if image is not None:
                        where = np.flatnonzero(pairs)[np.flatnonzero(key == order[repeat[0]])]
                    once = "each pair once" if image is None else "each pair once per periodic image (contacts.branch)"
                    raise ValueError(f"contacts: expected {once} (as (i, j, f) or (j, i, -f)), got the pair "
                                     f"({a}, {b}) at contacts {', '.join(str(int(k)) for k in where)}")

    # ------------------------------------------------------------------
    def with_fixed(self, fixed):
        """A copy in which ``fixed`` (N bools) marks the boundary particles."""
        out = object.__new__(Snapshot)
        out.__dict__.update(self.__dict__)
        out.fixed = bool_array(fixed, "fixed", self.n_particles)
        out._check_products()
        return out

    def species_view(self, species):
        """The snapshot seen by one species: particles of other species act as boundary.

        Coarse graining this view gives partial fields of that species, and its
        interaction force density is the force density from the other species
        (and from true boundaries), placed at the contact points.
        """
        if self.species is None:
            raise ValueError(f"species: expected None for a snapshot without a species array, got {species!r}")
        return self.with_fixed(self.fixed | (self.species != species))

    def split_contacts(self):
        """Classify contacts (docs/theory.md, "The snapshot model").

        Returns ``(bulk, boundary)`` dicts of arrays: bulk has i, j, force, branch
        (r_i - r_j, minimum image, or ``contacts.branch`` where given), point (the contact point); boundary has i
        (the flowing particle), force
        (on it), branch a = r_i - c (minimum image) and point c = r_i - a. Both have start: r_i, the centres of
        their particles i (the contact segments' starts, gathered once).
        Arrays taken unchanged from the contacts are read-only views of them.
        """
        c = self.contacts
        box = self.box
        dim = self.dim
        if len(c) == 0:
            empty = np.zeros((0, dim))
            idx = np.zeros(0, np.int64)
            return ({"i": idx, "j": idx, "force": empty, "branch": empty, "point": empty, "start": empty},
                    {"i": idx, "force": empty, "branch": empty, "point": empty, "start": empty})
        i, j, f, pt = c.i, c.j, c.force, c.point
        periodic, lengths = list(box.periodic), [float(x) for x in box.lengths]

        def minimum_image(vectors):
            return core_minimum_image(vectors, periodic, lengths) if any(periodic) else vectors

        wall = j < 0
        if not self.fixed.any() and not wall.any():
            # every contact is bulk: read-only views of the contact arrays instead of selected copies
            start = np.take(self.positions, i, axis=0)
            if c.branch is not None:
                r_ij = c.branch.copy()
            else:
                # (in place: one (n, D) array fewer, new memory each frame)
                r_ij = np.take(self.positions, j, axis=0)
                np.subtract(start, r_ij, out=r_ij)
                r_ij = minimum_image(r_ij)
            empty = np.zeros((0, dim))
            return ({"i": _read_only(i), "j": _read_only(j), "force": _read_only(f), "branch": r_ij,
                     "point": _read_only(pt), "start": start},
                    {"i": np.zeros(0, np.int64), "force": empty, "branch": empty, "point": empty, "start": empty})
        fixed_i = self.fixed[i]
        fixed_j = np.where(wall, True, self.fixed[np.where(wall, 0, j)])
        bulk = ~fixed_i & ~fixed_j
        boundary_i = ~fixed_i & fixed_j           # already oriented on the flowing particle
        boundary_j = fixed_i & ~fixed_j & ~wall   # flip: the flowing particle is j

        bi, bj = i[bulk], j[bulk]
        start = self.positions[bi]
        r_ij = c.branch[bulk] if c.branch is not None else minimum_image(start - self.positions[bj])
        bulk_out = {"i": bi, "j": bj, "force": f[bulk], "branch": r_ij, "point": pt[bulk], "start": start}

        k = np.concatenate([i[boundary_i], j[boundary_j]])
        fk = np.concatenate([f[boundary_i], -f[boundary_j]])
        ck = np.concatenate([pt[boundary_i], pt[boundary_j]])
        start_k = self.positions[k]
        a = minimum_image(start_k - ck)
        boundary_out = {"i": k, "force": fk, "branch": a, "point": start_k - a, "start": start_k}
        return bulk_out, boundary_out

    def inertia(self, why="the spin density"):
        """Moments of inertia (N,): as given, else solid spheres 2/5 m r^2 (3D) or discs 1/2 m r^2 (2D)."""
        if self.moments_of_inertia is not None:
            return self.moments_of_inertia
        if self.radii is None:
            raise ValueError(f"moments_of_inertia: expected moments of inertia, or radii to compute them from "
                             f"(spheres 2/5 m r^2, discs 1/2 m r^2), for {why}, got neither")
        return (0.4 if self.dim == 3 else 0.5) * self.masses * self.radii ** 2

    def particle_forces(self):
        """Total force on every particle from its contacts and body force (fixed: contacts only).

        The contact forces on each particle (on i, then minus them on j >= 0) are summed by np.bincount per axis:
        a loop over the contacts in their order, the same additions np.add.at makes (from 0), ten times faster."""
        c = self.contacts
        n, dim = self.n_particles, self.dim
        f = np.zeros((n, dim))
        if len(c):
            m = len(c)
            pair = c.j >= 0
            every = bool(pair.all())    # (no walls: the arrays as they are, not selected copies)
            index = np.concatenate([c.i, c.j if every else c.j[pair]])
            weights = np.empty(index.shape[0])
            for a in range(dim):
                weights[:m] = c.force[:, a]
                np.negative(c.force[:, a] if every else c.force[pair, a], out=weights[m:])
                f[:, a] = np.bincount(index, weights=weights, minlength=n)
        if self.body_force is not None:
            flow = self.flowing
            if flow.all():    # (every particle: the same products on all rows, without selecting them)
                f += self.masses[:, None] * self.body_force
            else:
                f[flow] += self.masses[flow, None] * self.body_force[flow]
        return f

    def __repr__(self):
        nf = int(self.fixed.sum())
        return (f"Snapshot({self.n_particles} particles ({nf} fixed), {len(self.contacts)} contacts, "
                f"{self.dim}D, t={self.time:g})")
