"""Exact ring averages on θ-averaged CylindricalGrids: the moments against 32-digit quadrature, the fields
of point sources against adaptive quadrature of the rotated Cartesian sum, mass, rigid rotation."""
import math
import warnings

import mpmath as mp
import numpy as np
import pytest
from scipy.integrate import IntegrationWarning, quad, quad_vec

import cgbound as cg
from cgbound.cylindrical_ring import ring_moments
from helpers import random_snapshot
from oracle import oracle_kernel_of

KERNELS = [cg.Gaussian(0.4), cg.Gaussian(0.4, normalize="truncated"), cg.Gaussian(0.3, cutoff=3.0), cg.Lucy(1.2),
           cg.Heaviside(1.0)]
IDS = ["gauss5w", "gauss5w-truncated", "gauss10w", "lucy", "heaviside"]


def mp_kernel(kernel):
    """W(d) in 3-D at 32 digits, from the textbook definitions."""
    c = mp.mpf(kernel.radius)
    if isinstance(kernel, cg.Gaussian):
        w = mp.mpf(kernel.width)
        norm = (2 * mp.pi * w * w) ** mp.mpf(1.5)
        if kernel.truncated:
            norm = 4 * mp.pi * mp.quad(lambda x: mp.exp(-x * x / (2 * w * w)) * x * x, [0, c])
        return lambda d: mp.exp(-d * d / (2 * w * w)) / norm if d < c else mp.mpf(0)
    if isinstance(kernel, cg.Lucy):
        return lambda d: 105 / (16 * mp.pi * c ** 3) * (1 + 3 * d / c) * (1 - d / c) ** 3 if d < c else mp.mpf(0)
    return lambda d: 3 / (4 * mp.pi * c ** 3) if d < c else mp.mpf(0)


def mp_moments(kernel, r, h, rho):
    """(1/2π) ∫ W(|x(θ) - q|) cos(m θ) dθ over the full circle (q at angle 0), adaptive tanh-sinh at 32 digits
    with breakpoints at the support's edges and the closest approach."""
    with mp.workdps(32):
        W = mp_kernel(kernel)
        r, h, rho = mp.mpf(r), mp.mpf(h), mp.mpf(rho)
        c = mp.mpf(kernel.radius)

        def d(t):
            return mp.sqrt(r * r + rho * rho + h * h - 2 * r * rho * mp.cos(t))
        edges = [mp.mpf(0), mp.pi]
        if r * rho > 0:
            s2 = (c * c - (r - rho) ** 2 - h * h) / (4 * r * rho)
            if 0 < s2 < 1:
                edges.insert(1, 2 * mp.asin(mp.sqrt(s2)))
        out = []
        for m in range(3):
            total = mp.mpf(0)
            for a, b in zip(edges[:-1], edges[1:]):
                # graded towards the closest approach, where Lucy's d³ is nearly singular
                pts = [a] + [a + (b - a) * mp.mpf(10) ** -k for k in (9, 6, 3, 1)] + [b] if a == 0 else [a, b]
                total += mp.quad(lambda t: W(d(t)) * mp.cos(m * t), pts)
            out.append(float(total / mp.pi))
    return np.array(out)


CASES = [(2.0, 0.0, 2.0),             # the ring passes through the source
         (2.0, 0.0, 2.0 + 1e-7),      # ... nearly
         (2.0, 3e-4, 2.0),
         (1e-6, 0.1, 0.3),            # a ring of radius -> 0
         (0.05, 0.01, 0.02),
         (0.7, 0.2, 0.0),             # the source on the axis
         (3.0, 0.2, 2.5),
         (0.8, 0.3, 1e-9)]


@pytest.mark.parametrize("kernel", KERNELS, ids=IDS)
def test_ring_moments_against_32_digit_quadrature(kernel):
    rng = np.random.default_rng(3)
    c = kernel.radius
    cases = list(CASES) + [(5.0, 0.0, 5.0 + 0.999 * c), (5.0, 0.0, 5.0 + 0.999 * c * math.sqrt(2) / 2)]
    for _ in range(4):
        r = rng.uniform(0, 4)
        rho = rng.uniform(max(0.0, r - c), r + c)
        h = rng.uniform(-1, 1) * math.sqrt(max(c * c - (r - rho) ** 2, 0.0))
        cases.append((r, h, rho))
    for r, h, rho in cases:
        want = mp_moments(kernel, r, h, rho)
        got = ring_moments(kernel, r, h, rho)
        assert want[0] > 0
        np.testing.assert_allclose(got, want, rtol=0, atol=1e-12 * want[0], err_msg=str((r, h, rho)))


def test_heaviside_on_axis_and_outside():
    k = cg.Heaviside(1.0)
    m = ring_moments(k, np.array([0.5, 0.5, 3.0]), np.array([0.2, 0.2, 0.0]), np.array([0.0, 2.0, 0.5]))
    np.testing.assert_allclose(m[:, 0], [3 / (4 * math.pi), 0, 0], rtol=1e-15)
    assert np.all(m[:, 2] == 0)      # out of reach: (3 - 0.5) > 1


# ---- fields against the rotated Cartesian sum integrated over θ by QUADPACK ----

def basis(theta):
    c, s = math.cos(theta), math.sin(theta)
    return np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]])


def scalar_kernel(kernel):
    """W(d) of the full 3-D kernel for one distance d (the oracle's, for scalar quadrature)."""
    ok = oracle_kernel_of(kernel, 3)
    if isinstance(kernel, cg.Gaussian):
        return lambda d: math.exp(-d * d / (2 * kernel.width ** 2)) / ok.gaussian_norm(3) if d < kernel.radius else 0.0
    return lambda d: float(ok.full(np.array(d)))


def oracle_ring(kernel, sources, r, zs, wz):
    """θ (and z) averages of sum_i values_i W(x - q_i) with x on the ring, values rotated into (e_r, e_θ, e_z)
    (axis z through the origin). sources: [(q (3,), value (scalar, 3 or 3x3 Cartesian))]."""
    W = scalar_kernel(kernel)
    c = kernel.radius
    shape = np.shape(sources[0][1])
    total = np.zeros(shape)
    for z, wzq in zip(zs, wz):
        breaks = set()
        for q, _ in sources:
            rho, phi = math.hypot(q[0], q[1]), math.atan2(q[1], q[0])
            if r * rho > 0:
                s2 = (c * c - (r - rho) ** 2 - (z - q[2]) ** 2) / (4 * r * rho)
                if 0 < s2 < 1:
                    D = 2 * math.asin(math.sqrt(s2))
                    breaks.update(((phi + D) % (2 * math.pi), (phi - D) % (2 * math.pi)))
                breaks.add(phi % (2 * math.pi))
        breaks = sorted(b for b in breaks if 1e-12 < b < 2 * math.pi - 1e-12)
        for idx in np.ndindex(shape):
            def f(theta):
                x = np.array([r * math.cos(theta), r * math.sin(theta), z])
                R = basis(theta)
                acc = 0.0
                for q, v in sources:
                    w = W(float(np.linalg.norm(x - q)))
                    if w == 0.0:
                        continue
                    v = np.asarray(v, float)
                    local = v if v.ndim == 0 else (R @ v if v.ndim == 1 else R @ v @ R.T)
                    acc += w * local[idx]
                return acc
            with warnings.catch_warnings():
                # QUADPACK reports that 1e-14 is beyond its round-off; the comparison at 1e-12 is the check
                warnings.simplefilter("ignore", IntegrationWarning)
                val, _ = quad(f, 0.0, 2 * math.pi, points=breaks or None, limit=2000, epsabs=1e-17, epsrel=1e-14)
            total[idx] += wzq * val / (2 * math.pi)
    return total


def particles(n=7, seed=2):
    """Particles around the z axis; one on the axis, one on the ring r = 1.1, z = 0.3 of the test grid."""
    rng = np.random.default_rng(seed)
    pos = np.c_[rng.uniform(-1.5, 1.5, (n, 2)), rng.uniform(-0.5, 0.8, n)]
    pos[0] = [0.0, 0.0, 0.1]
    pos[1] = [1.1 * math.cos(0.4), 1.1 * math.sin(0.4), 0.3]
    box = cg.Box([-3, -3, -2], [3, 3, 2], periodic=False)
    return cg.Snapshot(pos, rng.normal(size=(n, 3)), rng.uniform(0.5, 2, n), box=box)


@pytest.mark.parametrize("kernel", KERNELS[:2] + KERNELS[3:], ids=IDS[:2] + IDS[3:])
def test_point_fields_equal_adaptive_quadrature_of_the_rotated_sum(kernel):
    snap = particles()
    grid = cg.CylindricalGrid(snap.box, (0, 0, 0), "z", r=(1.1 - 1e-3, 1.1 + 1e-3, 1), z=(0.3 - 1e-3, 0.3 + 1e-3, 1))
    small = cg.CylindricalGrid(snap.box, (0, 0, 0), "z", r=(0.0, 2e-6, 1), z=(-0.2, 0.0, 1))
    fields = ("density", "momentum", "momentum_flux")
    for g in (grid, small):
        out = cg.coarse_grain(snap, g, kernel, fields=fields)
        r, z = float(g.r[0]), float(g.z[0])
        for name, value in (("density", lambda i: snap.masses[i]),
                            ("momentum", lambda i: snap.masses[i] * snap.velocities[i]),
                            ("momentum_flux", lambda i: snap.masses[i] * np.outer(snap.velocities[i], snap.velocities[i]))):
            want = oracle_ring(kernel, [(snap.positions[i], value(i)) for i in range(len(snap.masses))], r, [z], [1.0])
            got = getattr(out, name)[0, 0, 0]
            scale = np.abs(want).max()
            assert scale > 0
            np.testing.assert_allclose(got, want, rtol=0, atol=1e-12 * scale, err_msg=f"{name} r={r}")


# ---- z-averaged grids: the exact axial average against nested adaptive quadrature, and the mass identity ----

def float_kernel(kernel):
    """W(d) in 3-D in double precision from the textbook definitions (the truncated Gaussian's norm by mpmath)."""
    c = float(kernel.radius)
    if isinstance(kernel, cg.Gaussian):
        w = float(kernel.width)
        norm = (2 * math.pi * w * w) ** 1.5
        if kernel.truncated:
            norm = float(4 * mp.pi * mp.quad(lambda x: mp.exp(-x * x / (2 * w * w)) * x * x, [0, c]))
        return lambda d: math.exp(-d * d / (2 * w * w)) / norm if d < c else 0.0
    if isinstance(kernel, cg.Lucy):
        return lambda d: 105 / (16 * math.pi * c ** 3) * (1 + 3 * d / c) * (1 - d / c) ** 3 if d < c else 0.0
    return lambda d: 3 / (4 * math.pi * c ** 3) if d < c else 0.0


def axial_angular_moments(kernel, r, q, lo, hi):
    """(1/2π (hi - lo)) ∫_lo^hi dz ∫ dθ W(|x(θ, z) - q|) (1, cos θ, sin θ, cos² θ, cos θ sin θ, sin² θ) by nested
    adaptive quadrature (scipy's quad_vec): θ = φ + t over the arc ``|t|`` < Δ(z) split at t = 0, z split where
    the arc appears (``|z - ζ|`` = H), becomes the whole ring and at the closest approach z = ζ, each z piece
    mapped by z = a + (b - a) sin²(π u / 2)."""
    W = float_kernel(kernel)
    c = float(kernel.radius)
    rho, phi, zeta = math.hypot(q[0], q[1]), math.atan2(q[1], q[0]), float(q[2])

    def ring(z):
        d2 = (r - rho) ** 2 + (z - zeta) ** 2
        if d2 >= c * c:
            return np.zeros(6)
        s2 = (c * c - d2) / (4 * r * rho) if r * rho > 0 else 2.0
        D = math.pi if s2 >= 1 else 2 * math.asin(math.sqrt(s2))

        def f(t):
            th = phi + t
            w = W(math.sqrt(r * r + rho * rho + (z - zeta) ** 2 - 2 * r * rho * math.cos(t)))
            cs, sn = math.cos(th), math.sin(th)
            return w * np.array([1.0, cs, sn, cs * cs, cs * sn, sn * sn])
        return quad_vec(f, -D, D, points=[0.0], epsabs=1e-15 * W(0.0), epsrel=1e-14, limit=400)[0]
    H = math.sqrt(max(c * c - (r - rho) ** 2, 0.0))
    whole = math.sqrt(max(c * c - (r + rho) ** 2, 0.0))
    cuts = sorted({min(max(zeta + e, lo), hi) for e in (-H, -whole, 0.0, whole, H)})
    if H == 0.0 or len(cuts) < 2:
        return np.zeros(6)
    total = np.zeros(6)
    for a, b in zip(cuts[:-1], cuts[1:]):
        # z = a + (b - a) sin²(π u / 2) makes the square roots at the ends smooth for the adaptive rule
        def mapped(u):
            return ring(a + (b - a) * math.sin(0.5 * math.pi * u) ** 2) * (0.5 * math.pi * (b - a) * math.sin(math.pi * u))
        total += quad_vec(mapped, 0.0, 1.0, epsabs=1e-15 * W(0.0), epsrel=1e-13, limit=400)[0]
    return total / (2 * math.pi * (hi - lo))


def oracle_axial_fields(kernel, positions, velocities, masses, r, lo, hi):
    """density, momentum and momentum flux (local components) on the ring of radius r about the z axis through
    the origin, averaged over z in [lo, hi]: the Cartesian values projected on e_r = (cos θ, sin θ, 0),
    e_θ = (-sin θ, cos θ, 0), e_z, whose products are combinations of the angular moments."""
    rho = 0.0
    p = np.zeros(3)
    k = np.zeros((3, 3))
    for q, v, m in zip(positions, velocities, masses):
        one, C, S, CC, CS, SS = axial_angular_moments(kernel, r, q, lo, hi)
        rho += m * one
        # the local components as (coefficient of cos θ, of sin θ, constant)
        coef = [(v[0], v[1], 0.0), (v[1], -v[0], 0.0), (0.0, 0.0, v[2])]
        for i, (ci, si, zi) in enumerate(coef):
            p[i] += m * (ci * C + si * S + zi * one)
            for j, (cj, sj, zj) in enumerate(coef):
                k[i, j] += m * (ci * cj * CC + (ci * sj + si * cj) * CS + si * sj * SS
                                + (ci * zj + zi * cj) * C + (si * zj + zi * sj) * S + zi * zj * one)
    return rho, p, k


AXIAL_KERNELS = [cg.Gaussian(0.25), cg.Gaussian(0.25, normalize="truncated"), cg.Lucy(1.2), cg.Heaviside(1.0)]
AXIAL_IDS = ["gauss5w", "gauss5w-truncated", "lucy", "heaviside"]


@pytest.mark.parametrize("kernel", AXIAL_KERNELS, ids=AXIAL_IDS)
def test_z_averaged_fields_equal_nested_adaptive_quadrature(kernel):
    """Rings through a particle, around particles near the axis (whole rings), a particle whose support crosses
    the periodic end of the box (seen with its image): density, momentum and momentum flux at 1e-12."""
    box = cg.Box([-3, -3, -2], [3, 3, 2], periodic=[False, False, True])
    pos = np.array([[1.1 * math.cos(0.4), 1.1 * math.sin(0.4), 0.3],      # on the ring r = 1.1
                    [0.1, -0.15, -0.5],                                        # near the axis
                    [-0.6, 0.5, 1.85],                                         # its support wraps around z
                    [0.0, 0.0, 0.2]])                                          # on the axis
    rng = np.random.default_rng(8)
    vel, m = rng.normal(size=(4, 3)), rng.uniform(0.5, 2.0, 4)
    snap = cg.Snapshot(pos, vel, m, box=box)
    images = np.concatenate([pos + [0, 0, dz] for dz in (-4.0, 0.0, 4.0)])
    for r in (0.3, 1.1):
        grid = cg.CylindricalGrid(box, (0, 0, 0), "z", r=(r - 1e-3, r + 1e-3, 1))
        out = cg.coarse_grain(snap, grid, kernel, fields=("density", "momentum", "momentum_flux"))
        want = oracle_axial_fields(kernel, images, np.tile(vel, (3, 1)), np.tile(m, 3), float(grid.r[0]), -2.0, 2.0)
        got = (out.density[0, 0, 0], out.momentum[0, 0, 0], out.momentum_flux[0, 0, 0])
        for name, g, w in zip(("density", "momentum", "momentum_flux"), got, want):
            scale = np.abs(w).max()
            assert scale > 0
            np.testing.assert_allclose(g, w, rtol=0, atol=1e-12 * scale, err_msg=f"{name} r={r}")


def end_clustered(n):
    """Gauss-Legendre in u mapped by x = (3u - u³)/2 onto [0, 1] (square-root ends made analytic)."""
    u, w = np.polynomial.legendre.leggauss(n)
    return 0.25 * (3 * u - u ** 3) + 0.5, 0.75 * w * (1 - u * u)


def ball_mass(kernel):
    """The kernel's integral over its support: 1, or for a Gaussian normalised over all space its mass inside the
    cutoff (mpmath)."""
    if not isinstance(kernel, cg.Gaussian) or kernel.truncated:
        return 1.0
    w, c = mp.mpf(kernel.width), mp.mpf(kernel.radius)
    return float(4 * mp.pi * mp.quad(lambda x: mp.exp(-x * x / (2 * w * w)) * x * x, [0, c])
                 / (2 * mp.pi * w * w) ** mp.mpf(1.5))


MASS_KERNELS = AXIAL_KERNELS + [cg.Gaussian(0.3, cutoff=3.0)]
MASS_IDS = AXIAL_IDS + ["gauss10w"]


@pytest.mark.parametrize("kernel", MASS_KERNELS, ids=MASS_IDS)
@pytest.mark.parametrize("where", ["inside", "periodic-end", "near-axis"])
def test_z_averaged_mass_per_unit_length(kernel, where):
    """∫ ρ̄ 2π r dr = m (ball mass) / L for the z-averaged density ρ̄ of one particle: r by the end-clustered rule
    on pieces split where ρ̄ is not analytic in r (ρ, ρ ± c, c - ρ), one single-node grid per point. Main's
    Gauss-Legendre rule in z missed this by 2e-5 for Lucy."""
    c = float(kernel.radius)
    rho_p, zeta_p, periodic = {"inside": (1.7, 0.3, False), "periodic-end": (1.0, 1.8, True),
                               "near-axis": (0.35, -1.9, True)}[where]
    lo, hi = (-5.0, 5.0) if where == "inside" else (-2.0, 2.0)
    box = cg.Box([-6, -6, lo], [6, 6, hi], periodic=[False, False, periodic])
    m = 1.3
    snap = cg.Snapshot([[rho_p * math.cos(0.7), rho_p * math.sin(0.7), zeta_p]], [[0.0, 0.0, 0.0]], [m], box=box)
    cuts = sorted({max(rho_p - c, 0.0), rho_p, rho_p + c} | ({c - rho_p} if c > rho_p else set()))
    x, w = end_clustered(48)
    total = 0.0
    for a, b in zip(cuts[:-1], cuts[1:]):
        for xi, wi in zip(x, w):
            r = a + (b - a) * xi
            grid = cg.CylindricalGrid(box, (0, 0, 0), "z", r=(r - 1e-9, r + 1e-9, 1))
            density = cg.coarse_grain(snap, grid, kernel, fields=("density",)).density[0, 0, 0]
            total += (b - a) * wi * density * 2 * math.pi * grid.r[0]
    want = m * ball_mass(kernel) / (hi - lo)
    assert abs(total / want - 1) < 1e-12, total / want - 1


def test_interaction_force_density_on_rings():
    snap = random_snapshot(11, n=30, n_bulk=20, lengths=[6.0, 6.0, 5.0], periodic=(False, False, False))
    a = 0.5 * (snap.box.lower + snap.box.upper)
    kernel = cg.Lucy(1.0)
    grid = cg.CylindricalGrid(snap.box, a, "z", r=(0.2, 2.2, 3), z=(-0.6, 0.6, 2))
    out = cg.coarse_grain(snap, grid, kernel, fields=("interaction_force_density",))
    boundary = snap.split_contacts()[1]
    assert boundary["i"].size
    sources = [(p - a, f) for p, f in zip(boundary["point"], boundary["force"])]
    scale = np.abs(out.interaction_force_density).max()
    assert scale > 0
    for k, r in enumerate(grid.r):
        for j, z in enumerate(grid.z):
            want = oracle_ring(kernel, sources, r, [z], [1.0])
            np.testing.assert_allclose(out.interaction_force_density[k, 0, j], want, rtol=0, atol=1e-12 * scale)


def test_mass_integral_to_round_off():
    """∫ρ 2πr dr dz = M: z averaged (Gauss-Legendre, exact for a Gaussian cut off below round-off), r by
    Gauss-Legendre nodes (one single-node grid each)."""
    rng = np.random.default_rng(5)
    box = cg.Box([-6, -6, 0], [6, 6, 8], periodic=False)
    n = 20
    pos = np.c_[rng.uniform(-1.5, 1.5, (n, 2)), rng.uniform(3, 5, n)]
    m = rng.uniform(0.5, 2, n)
    snap = cg.Snapshot(pos, np.zeros((n, 3)), m, box=box)
    kernel = cg.Gaussian(0.3, cutoff=3.0)
    R = 1.5 * math.sqrt(2) + 3.0
    x, w = np.polynomial.legendre.leggauss(80)
    rs, wr = 0.5 * R * (x + 1), 0.5 * R * w
    mass = 0.0
    for r, wq in zip(rs, wr):
        g = cg.CylindricalGrid(box, (0, 0, 0), "z", r=(r - 1e-4, r + 1e-4, 1))
        rho = cg.coarse_grain(snap, g, kernel, fields=("density",)).density[0, 0, 0]
        mass += wq * 2 * math.pi * float(g.r[0]) * rho * 8.0
    assert abs(mass / m.sum() - 1) < 1e-11


@pytest.mark.parametrize("kernel", [cg.Gaussian(0.4), cg.Lucy(1.2), cg.Heaviside(1.0)], ids=["gauss", "lucy", "heaviside"])
def test_rigid_rotation_on_rings(kernel):
    """v = ω e_z × (x - a): on the θ-average p_θ = ω m_r (m the ring average of sum m_i (q_i - a)_⊥ W), p_r = p_z = 0;
    a particle on the node's ring and alone in its reach moves at v_θ = ω r exactly when the kernel is constant
    on its arc (Heaviside) and the velocity's projection averages over the arc."""
    snap0 = particles(n=12, seed=4)
    omega = 0.7
    d = snap0.positions.copy()
    rot = np.c_[-omega * d[:, 1], omega * d[:, 0], np.zeros(len(d))]
    mk = lambda v: cg.Snapshot(snap0.positions, v, snap0.masses, box=snap0.box)
    grid = cg.CylindricalGrid(snap0.box, (0, 0, 0), "z", r=(0.0, 2.0, 5), z=(-0.5, 0.5, 2))
    p = cg.coarse_grain(mk(rot), grid, kernel, fields=("momentum",)).momentum
    moment = cg.coarse_grain(mk(np.c_[d[:, :2], np.zeros(len(d))]), grid, kernel, fields=("momentum",)).momentum
    scale = np.abs(p).max()
    np.testing.assert_allclose(p[..., 1], omega * moment[..., 0], rtol=0, atol=1e-14 * scale)
    assert np.abs(p[..., 0]).max() < 1e-14 * scale and np.abs(p[..., 2]).max() == 0
    assert np.abs(moment[..., 1]).max() < 1e-14 * scale


def test_uniform_ring_of_particles_rotates_rigidly():
    """Particles spread evenly on a circle of radius R (many, so the ring average sees a continuum in θ), all on the
    rigid rotation: the ring average at r = R gives v_θ = ω R · M₁/M₀ per particle = the same for each, and the
    node's v_θ equals that of the single-particle ring average (linearity), v_r = v_z = 0."""
    R, omega, n = 1.3, 0.9, 64
    phi = 2 * np.pi * np.arange(n) / n + 0.1
    pos = np.c_[R * np.cos(phi), R * np.sin(phi), np.zeros(n)]
    vel = omega * np.c_[-pos[:, 1], pos[:, 0], np.zeros(n)]
    box = cg.Box([-3, -3, -2], [3, 3, 2])
    snap = cg.Snapshot(pos, vel, np.ones(n), box=box)
    grid = cg.CylindricalGrid(box, (0, 0, 0), "z", r=(1.0, 1.6, 3), z=(-0.1, 0.1, 1))
    kernel = cg.Lucy(0.8)
    v = cg.coarse_grain(snap, grid, kernel, fields=("velocity",)).velocity[:, 0, 0]
    one = cg.coarse_grain(cg.Snapshot(pos[:1], vel[:1], [1.0], box=box), grid, kernel, fields=("velocity",)).velocity
    np.testing.assert_allclose(v, one[:, 0, 0], rtol=0, atol=1e-14)
    assert np.abs(v[:, 0]).max() < 1e-15 and np.abs(v[:, 2]).max() == 0
    M = ring_moments(kernel, grid.r, 0.0, R)
    np.testing.assert_allclose(v[:, 1], omega * R * M[1] / M[0], rtol=1e-14)


def segment_oracle(kernel, start, vector, value, g, r, z):
    """(1/2π) ∫_0^1 ds ∫ dθ W(|x(θ) - start - s vector|) Σ_ab g_ab (R(θ) value R(θ)ᵀ)_ab by nested QUADPACK
    (θ with breakpoints at the support's edges; s adaptive, which finds the square-root ends)."""
    W = scalar_kernel(kernel)
    c = kernel.radius

    def inner(s):
        q = start + s * vector
        rho, phi = math.hypot(q[0], q[1]), math.atan2(q[1], q[0])
        breaks = []
        if r * rho > 0:
            s2 = (c * c - (r - rho) ** 2 - (z - q[2]) ** 2) / (4 * r * rho)
            if s2 <= 0:
                return 0.0
            if s2 < 1:
                D = 2 * math.asin(math.sqrt(s2))
                breaks = [phi - D, phi + D]

        def f(theta):
            x = np.array([r * math.cos(theta), r * math.sin(theta), z])
            R = basis(theta)
            return W(float(np.linalg.norm(x - q))) * float(np.sum(g * (R @ value @ R.T)))
        if breaks:
            val = quad(f, breaks[0], breaks[1], points=[phi], limit=200, epsabs=1e-17, epsrel=1e-14)[0]
        else:
            val = quad(f, 0.0, 2 * math.pi, limit=200, epsabs=1e-17, epsrel=1e-14)[0]
        return val / (2 * math.pi)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", IntegrationWarning)
        return quad(inner, 0.0, 1.0, limit=400, epsabs=1e-17, epsrel=1e-13)[0]


@pytest.mark.parametrize("kernel", [cg.Gaussian(0.4), cg.Lucy(1.2), cg.Heaviside(1.0)], ids=["gauss5w", "lucy", "heaviside"])
def test_contact_stress_line_integrals_equal_nested_quadrature(kernel):
    """One contact whose branch crosses the ring's support (and passes near the axis); the ring average of the
    contact stress against nested adaptive quadrature (σ_rθ and σ_rz; tests/test_cylindrical.py
    checks every component against a brute-force rule for a Gaussian cut off below round-off)."""
    pos = np.array([[-0.9, 0.3, 0.1], [1.2, 0.5, 0.4]])
    box = cg.Box([-3, -3, -3], [3, 3, 3])
    force = np.array([[0.3, -1.1, 0.7]])
    contacts = cg.Contacts([0], [1], force, point=pos[:1] + 0.5 * (pos[1] - pos[0]))
    snap = cg.Snapshot(pos, np.zeros((2, 3)), np.ones(2), box=box, contacts=contacts)
    grid = cg.CylindricalGrid(box, (0, 0, 0), "z", r=(0.6, 1.0, 1), z=(0.1, 0.3, 1))
    out = cg.coarse_grain(snap, grid, kernel, fields=("contact_stress",)).contact_stress
    branch = pos[0] - pos[1]                 # r_ij = r_i - r_j; the segment runs from r_i along -r_ij
    value = -np.outer(force[0], branch)
    for k, r in enumerate(grid.r):
        for a, b in ((0, 1), (0, 2)):     # (the nested quadrature is slow) the rθ mixture and an M₁ component
            g = np.zeros((3, 3))
            g[a, b] = 1.0
            want = segment_oracle(kernel, pos[0], -branch, value, g, float(r), float(grid.z[0]))
            scale = np.abs(out).max()
            assert abs(out[k, 0, 0, a, b] - want) < 1e-12 * scale, (r, a, b)


def test_heaviside_arc_near_the_support_edges_within_its_inputs_conditioning():
    """Heaviside's closed-form arc, sin²(Δ/2) = (c² - d₀²) / 4 r ρ, next to the support's edge (d₀ → c), where
    the whole ring enters it (s → 1), and next to the axis (ρ → 0, 4 r ρ tiny): each moment within twice what a
    change of one ulp in r, h or ρ does to the exact value (mpmath at 40 digits), plus 2 ulp of the peak (the
    moments' own rounding: M₀ = W₀ Δ / π is 1 ulp off W₀ for the whole ring). Measured: at most 1.18 times that
    (e.g. 3.7e-14 of the peak against 5.7e-14 for h alone at d₀ = c (1 - 1e-14)); a factored numerator
    (c - r + ρ)(c + r - ρ) - h² gains little: the inputs' rounding is what the numerator loses."""
    kernel = cg.Heaviside(1.0)
    peak = 3 / (4 * math.pi)

    def exact(r, h, rho):
        with mp.workdps(40):
            r, h, rho = mp.mpf(r), mp.mpf(h), mp.mpf(rho)
            s2 = (1 - (r - rho) ** 2 - h * h) / (4 * r * rho)
            if s2 <= 0:
                return [mp.mpf(0)] * 3
            delta = mp.pi if s2 >= 1 else 2 * mp.asin(mp.sqrt(s2))
            return [peak * delta / mp.pi] + [peak * mp.sin(m * delta) / (m * mp.pi) for m in (1, 2)]
    rng = np.random.default_rng(18)
    ratios = []
    for case in range(150):
        r, rho = rng.uniform(0.05, 1.5), rng.uniform(0.0, 1.5) * [1.0, 1e-4, 1e-7][case % 3]
        delta = 10.0 ** rng.uniform(-14, -2)
        t2 = (1 - delta) ** 2 - (r - rho) ** 2 if case % 2 else 1 + delta * rng.choice([-1, 1]) - (r + rho) ** 2
        if t2 <= 0 or rho <= 0:
            continue
        h = math.sqrt(t2)
        got = ring_moments(kernel, r, h, rho)
        want = exact(r, h, rho)
        spread = max(float(abs(a - b)) for k in (0.0, 2.0)
                     for near in ((np.nextafter(r, k), h, rho), (r, np.nextafter(h, k), rho), (r, h, np.nextafter(rho, k)))
                     for a, b in zip(exact(*near), want))
        err = max(float(abs(g - w)) for g, w in zip(got, want))
        ratios.append(err / (spread + 2 * np.finfo(float).eps * peak))
    assert max(ratios) <= 2.0
