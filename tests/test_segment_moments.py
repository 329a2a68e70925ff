"""The kernel's first moment along segments, chi(r) = int_0^1 s W(r - a - s b) ds (csrc/cg_moment.c,
_core.scatter_segment_moments), against its NumPy twin (oracle_scatter_segment_moments) at 1e-12, hard cases
included: near-zero segments, nodes on the line, far nodes, the support clipping the segment; then the
branch-line couple stress (docs/theory.md, "Rotation and couple stress"): the angular momentum balance holds
pointwise at round-off with it, and clearly not when a term is dropped; its torque densities are eps : sigma
of the contact and boundary stresses."""
import numpy as np
import pytest

import cgbound
import cgbound as cg
from cgbound._engine import core_kernel, core_target, scatter_segment_moments, scatter_segments
from helpers import ForbiddenCore, random_snapshot
from oracle import oracle_kernel_of, oracle_scatter_segment_moments, oracle_target
from test_rotation import BALANCE_KERNELS, random_points, spinning

KERNELS = {"gaussian": cg.Gaussian(0.4, cutoff=1.6), "gaussian-wide-cutoff": cg.Gaussian(0.3, cutoff=2.4),
           "gaussian-truncated": cg.Gaussian(0.45, cutoff=1.35, normalize="truncated"), "lucy": cg.Lucy(1.3),
           "heaviside": cg.Heaviside(1.1)}
RTOL = 1e-12


def hard_segments(dim, seed):
    """Starts, vectors and nodes: ordinary, short (1e-3), near-zero (1e-9, 1e-14), zero, long segments; nodes on
    each line (inside and beyond the ends), next to it (1e-12 off), at the kernel's edge, far away."""
    rng = np.random.default_rng(seed)
    lengths = np.array([1.0, 1e-3, 1e-9, 0.3, 3.0, 1e-14, 0.0, 2.0])
    starts = rng.uniform(1.5, 2.5, (lengths.size, dim))
    vecs = rng.normal(size=(lengths.size, dim))
    vecs *= (lengths / np.linalg.norm(vecs, axis=1))[:, None]
    nodes = [rng.uniform(0.0, 4.0, (12, dim))]
    for a, b in zip(starts, vecs):
        s = np.array([-0.3, 0.0, 0.25, 0.5, 1.0, 1.4])
        on = a + s[:, None] * b
        nodes += [on, on + 1e-12 * rng.normal(size=on.shape), a + rng.normal(size=(2, dim)) * 0.6]
    nodes.append(starts[:3] + 1.29 * np.eye(dim)[0])       # just inside Lucy's and the Gaussians' supports
    nodes.append(starts[:2] + 50.0)                          # far away: zero
    return starts, vecs, np.concatenate(nodes)


def close(got, want, what):
    """|got - want| <= RTOL x the largest |want| (the field's scale; zero where want is zero)."""
    scale = np.abs(want).max()
    err = np.abs(got - want).max()
    assert err <= RTOL * scale, f"{what}: error {err:.3e} > {RTOL:g} x {scale:.3e}"
    assert scale > 0, what


@pytest.mark.parametrize("kname", sorted(KERNELS))
@pytest.mark.parametrize("dim", [2, 3])
def test_first_moment_at_points_matches_the_oracle(kname, dim):
    kernel = KERNELS[kname]
    starts, vecs, nodes = hard_segments(dim, 3 + dim)
    box = cg.Box([-60.0] * dim, [60.0] * dim)
    pts = cg.Points(nodes)
    values = np.random.default_rng(1).normal(size=(starts.shape[0], 2))
    oracle = oracle_kernel_of(kernel, dim)
    tgt = oracle_target(pts, box)
    ck = core_kernel(kernel, 1.0)
    # segment by segment, so that a hard one cannot hide behind a large neighbour
    for o in range(starts.shape[0]):
        sl = slice(o, o + 1)
        got = scatter_segment_moments(core_target(pts, box), ck, starts[sl], vecs[sl], values[sl])
        want = oracle_scatter_segment_moments(oracle, tgt, starts[sl], vecs[sl], values[sl])
        close(got, want, f"{kname} {dim}D segment {o} (length {np.linalg.norm(vecs[o]):.0e})")
        if kernel.differentiable:
            got = scatter_segment_moments(core_target(pts, box), ck, starts[sl], vecs[sl], values[sl], gradient=True)
            want = oracle_scatter_segment_moments(oracle, tgt, starts[sl], vecs[sl], values[sl], gradient=True)
            close(got, want, f"{kname} {dim}D segment {o} gradient")


@pytest.mark.parametrize("kname", ["gaussian", "lucy", "heaviside"])
def test_first_moment_on_grids_and_periodic_boxes(kname):
    """Grids without and with averaged axes (the marginals' moments), periodic images (segments crossing the
    boundary, started outside the box)."""
    kernel = KERNELS[kname]
    rng = np.random.default_rng(8)
    box = cg.Box([0.0, 0.0, 0.0], [3.0, 2.5, 4.0], periodic=(True, True, False))
    starts = rng.uniform(-3.0, 6.0, (6, 3))
    starts[:, 2] = rng.uniform(0.5, 3.5, 6)
    vecs = rng.normal(size=(6, 3)) * 0.7
    values = rng.normal(size=(6, 1))
    oracle = oracle_kernel_of(kernel, 3)
    grids = [cg.Grid(box, (5, 4, 6)), cg.Grid(box, (1, 4, 6), average=("x",)),
             cg.Grid(box, (1, 1, 9), average=("x", "y"))]
    for grid in grids:
        ck = core_kernel(kernel, grid.avg_extent)
        got = scatter_segment_moments(core_target(grid, box), ck, starts, vecs, values)
        want = oracle_scatter_segment_moments(oracle, oracle_target(grid, box), starts, vecs, values)
        close(got, want, f"{kname} {grid}")


MARGINAL_LAYOUTS = [(2, ("x",)), (3, ("x",)), (3, ("z",)), (3, ("x", "y"))]


def marginal_lines(grid, kernel, seed):
    """Segments in the resolved subspace that pass through nodes (nodes on the line and at its ends), short
    (1e-3, 1e-9, 1e-14), zero, long ones clipped by the support at both ends, one ending exactly at the support's
    edge seen from a node, and random ones; the averaged coordinates random (they must not matter)."""
    rng = np.random.default_rng(seed)
    dim, res = grid.dim, list(grid.resolved)
    node = np.array([grid.axis_coordinates[a][grid.shape[a] // 2] for a in range(dim)])
    starts, vecs = [], []
    for length in (1.0, 1e-3, 1e-9, 1e-14, 0.37, 3.0):
        for axis_aligned in (True, False):
            d = np.zeros(dim)
            if axis_aligned:
                d[res[0]] = 1.0
            else:
                d[res] = rng.normal(size=len(res))
            d[[a for a in range(dim) if a not in res]] = rng.normal(size=dim - len(res))
            d *= length / max(np.linalg.norm(d[res]), 1e-300)
            start = node.copy()
            start[res] -= rng.uniform(0.2, 0.8) * d[res]      # the node lies on the segment
            starts.append(start)
            vecs.append(d)
    edge = np.zeros(dim)
    edge[res[0]] = kernel.radius
    starts.append(node + edge)                      # from the support's edge inward
    vecs.append(-0.6 * edge)
    starts += list(node + rng.normal(size=(3, dim)))
    vecs += list(rng.normal(size=(3, dim)))
    return np.array(starts), np.array(vecs)


@pytest.mark.parametrize("kname", ["lucy", "heaviside"])
@pytest.mark.parametrize("dim, average", MARGINAL_LAYOUTS)
def test_first_moment_of_the_marginals_against_the_oracle(kname, dim, average):
    """Lucy's and Heaviside's marginals over averaged axes (Lucy over one axis: its x^4 log x kink where the line
    meets a node and its (R - rho)^(7/2) edge; Heaviside over one axis: its square-root edge where the support
    clips the line), segment by segment at 1e-12 of each segment's own scale, with the identities psi = chi + the
    reversed segment's chi and chi = half the point value at zero length."""
    kernel = KERNELS[kname]
    box = cg.Box([0.0] * dim, [4.0] * dim)
    grid = cg.Grid(box, 11, average=average)
    starts, vecs = marginal_lines(grid, kernel, 40 + dim)
    ck, tgt = core_kernel(kernel, grid.avg_extent), core_target(grid, box)
    oracle, otgt = oracle_kernel_of(kernel, dim), oracle_target(grid, box)
    values = np.ones((1, 1))
    for o in range(starts.shape[0]):
        sl = slice(o, o + 1)
        got = scatter_segment_moments(tgt, ck, starts[sl], vecs[sl], values)
        want = oracle_scatter_segment_moments(oracle, otgt, starts[sl], vecs[sl], values)
        close(got, want, f"{kname} {average} segment {o} (length {np.linalg.norm(vecs[o]):.0e})")
        if np.linalg.norm(vecs[o][list(grid.resolved)]) < 1e-6:
            # Heaviside's chord line integral psi is a difference of closed-form end values, which cancels on
            # segments this short (1e-2 at 1e-14): the identity checks the moment where psi is accurate
            continue
        back = scatter_segment_moments(tgt, ck, starts[sl] + vecs[sl], -vecs[sl], values)
        psi = scatter_segments(tgt, ck, starts[sl], vecs[sl], values)
        np.testing.assert_allclose(got + back, psi, rtol=0, atol=RTOL * np.abs(psi).max())
    zero = scatter_segment_moments(tgt, ck, starts, 0.0 * vecs, np.ones((len(starts), 1)))
    point = cgbound._engine.scatter_points(tgt, ck, starts, np.ones((len(starts), 1)))
    np.testing.assert_array_equal(zero, 0.5 * point)


def test_first_moment_identities():
    """psi - chi is the moment about the far end (the reversed segment's chi), and for a zero-length segment chi is
    half the point value: identities between the core's line integral and its first moment."""
    rng = np.random.default_rng(2)
    box = cg.Box([-5.0] * 3, [5.0] * 3)
    starts, vecs = rng.normal(size=(5, 3)), rng.normal(size=(5, 3))
    pts = cg.Points(rng.normal(size=(40, 3)))
    for kernel in (cg.Lucy(1.7), cg.Gaussian(0.5, cutoff=2.0)):
        ck, tgt = core_kernel(kernel, 1.0), core_target(pts, box)
        ones = np.ones((5, 1))
        psi = scatter_segments(tgt, ck, starts, vecs, ones)
        chi = scatter_segment_moments(tgt, ck, starts, vecs, ones)
        back = scatter_segment_moments(tgt, ck, starts + vecs, -vecs, ones)
        # three evaluations, each exact to a few eps of the field's scale (their documented absolute accuracy); at
        # the worst node here (Lucy, a tail value 0.002 of a field peaking at 0.37) psi is 1.7e-16 and chi + back
        # -4.1e-16 off a 40-digit quadrature: their sum of errors, not a wrong identity, sets the bound
        np.testing.assert_allclose(chi + back, psi, rtol=1e-13, atol=4e-15 * np.abs(psi).max())
        zero = scatter_segment_moments(tgt, ck, starts, 0.0 * vecs, ones)
        point = cgbound._engine.scatter_points(tgt, ck, starts, ones)
        np.testing.assert_array_equal(zero, 0.5 * point)


def test_gauss_legendre_rule_applies_to_the_moment_too():
    """line_quadrature=n: the moment with the kernel's own n-point rule, as its line integral."""
    kernel = cg.Gaussian(0.4, cutoff=1.6, line_quadrature=4)
    starts, vecs, nodes = hard_segments(3, 5)
    box = cg.Box([-60.0] * 3, [60.0] * 3)
    pts = cg.Points(nodes)
    ck = core_kernel(kernel, 1.0, longest_branch=1.0)
    values = np.ones((starts.shape[0], 1))
    got = scatter_segment_moments(core_target(pts, box), ck, starts, vecs, values)
    want = oracle_scatter_segment_moments(oracle_kernel_of(kernel, 3), oracle_target(pts, box), starts, vecs, values)
    close(got, want, "4-point rule")


def test_unsupported_moments_are_refused():
    box = cg.Box([0.0] * 3, [2.0] * 3)
    grid = cg.Grid(box, (1, 1, 4), average=("x", "y"))
    one = np.ones((1, 3))
    for kernel in (cg.Lucy(1.0), cg.Heaviside(1.0)):    # the marginals' moments have no gradient
        with pytest.raises(NotImplementedError, match="first moments along segments"):
            scatter_segment_moments(core_target(grid, box), core_kernel(kernel, grid.avg_extent), one, one,
                                    np.ones((1, 1)), gradient=True)
    pts = cg.Points(np.ones((2, 3)))
    with pytest.raises(NotImplementedError, match="first moments along segments"):
        scatter_segment_moments(core_target(pts, box), core_kernel(cg.Heaviside(1.0), 1.0), one, one, np.ones((1, 1)),
                                gradient=True)


# ---------------------------------------------------------------------------------------------------------
# the branch-line couple stress

@pytest.mark.parametrize("seed", range(3))
@pytest.mark.parametrize("kname", sorted(BALANCE_KERNELS))
@pytest.mark.parametrize("dim", [2, 3])
def test_branch_line_balance_is_round_off_and_needs_every_term(dim, kname, seed):
    snap = spinning(random_snapshot(seed, dim=dim), seed)
    bal = cg.angular_momentum_balance_residual(snap, random_points(snap, seed), BALANCE_KERNELS[kname],
                                               couple_stress_form="branch_line")
    assert bal.relative.max() <= 1e-10, bal
    for name in ("div_couple_stress", "stress_torque_density", "boundary_couple_density"):
        without = bal.residual + getattr(bal, name)
        assert (np.linalg.norm(without, axis=1) / bal.scale).max() > 1e-2, name
    # the two forms differ (by a divergence), so both checks are of something
    other = cg.angular_momentum_balance_residual(snap, random_points(snap, seed), BALANCE_KERNELS[kname])
    assert np.abs(other.stress_torque_density - bal.stress_torque_density).max() > 1e-3 * bal.scale


def antisymmetric(sigma, dim):
    """eps_cba sigma_ab: (sigma_zy - sigma_yz, sigma_xz - sigma_zx, sigma_yx - sigma_xy) in 3D, sigma_10 - sigma_01
    in 2D."""
    if dim == 2:
        return sigma[..., 1, 0] - sigma[..., 0, 1]
    return np.stack([sigma[..., 2, 1] - sigma[..., 1, 2], sigma[..., 0, 2] - sigma[..., 2, 0],
                     sigma[..., 1, 0] - sigma[..., 0, 1]], axis=-1)


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("kname", ["lucy", "gaussian", "heaviside"])
def test_branch_line_torque_densities_are_the_antisymmetric_stresses(dim, kname):
    snap = spinning(random_snapshot(17, dim=dim), 17)
    where = cg.Grid(snap.box, (4, 3, 5) if dim == 3 else (4, 5))
    fields = ("couple_stress", "stress_torque_density", "boundary_couple_density", "contact_stress",
              "boundary_stress", "stress")
    out = cg.coarse_grain(snap, where, KERNELS[kname], fields=fields, couple_stress_form="branch_line")
    for name, sigma in (("stress_torque_density", "contact_stress"), ("boundary_couple_density", "boundary_stress")):
        want = antisymmetric(out[sigma], dim)
        np.testing.assert_allclose(out[name], want, rtol=0, atol=1e-13 * np.abs(want).max(), err_msg=name)
        assert np.abs(want).max() > 0
    total = antisymmetric(out.stress, dim)
    np.testing.assert_allclose(out.stress_torque_density + out.boundary_couple_density, total, rtol=0,
                               atol=1e-13 * np.abs(total).max())
    rot = cg.rotation_fields(snap, where, KERNELS[kname], ("couple_stress",), couple_stress_form="branch_line")
    np.testing.assert_array_equal(rot["couple_stress"], out.couple_stress)


@pytest.mark.parametrize("dim, kname, average", [(2, "lucy", None), (3, "lucy", None), (3, "lucy", ("x",)),
                                                 (2, "lucy", ("x",)), (3, "heaviside", ("x", "y")),
                                                 (3, "heaviside", ("y",))])
def test_branch_line_couple_stress_against_the_oracle(dim, kname, average):
    """m = -sum_c (f x a) (x) b psi_c + sum_c (f x b) (x) b chi_c, contact by contact with the oracle's line
    integral and first moment; at points, and on grids with averaged axes (the marginals' first moments)."""
    from oracle import OracleKernel, _object_weights
    snap = spinning(random_snapshot(23, dim=dim), 23)
    if average is None:
        where = cg.Points(random_points(snap, 23, 15))
    else:
        shape = [4, 3, 5][:dim] if dim == 3 else [4, 5]
        where = cg.Grid(snap.box, tuple(1 if "xyz"[a] in average else n for a, n in enumerate(shape)),
                        average=average)
    kernel = {"lucy": cg.Lucy(1.3), "heaviside": cg.Heaviside(1.3)}[kname]
    got = cg.coarse_grain(snap, where, kernel, fields=("couple_stress",), couple_stress_form="branch_line")
    oracle = OracleKernel(kname, dim, 1.3, 1.3)
    tgt = oracle_target(where, snap.box)
    T = 3 if dim == 3 else 1
    want = np.zeros((where.size, T, dim))
    X, c, L = snap.positions, snap.contacts, np.asarray(snap.box.lengths)
    per = np.asarray(snap.box.periodic)

    def image(v):
        return np.where(per, v - L * np.round(v / L), v)

    def cross(a, b):
        return np.cross(a, b) if dim == 3 else np.array([a[0] * b[1] - a[1] * b[0]])

    for k in range(len(c)):
        i, j, f, p = int(c.i[k]), int(c.j[k]), c.force[k], c.point[k]
        fi, fj = snap.fixed[i], (j < 0 or snap.fixed[j])
        if fi and fj:
            continue
        if fi:
            i, f = j, -f
        a = image(X[i] - p)
        b = image(X[i] - X[j]) if not (fi or fj) else a
        psi = _object_weights(oracle, tgt, X[i], -b)
        chi = _object_weights(oracle, tgt, X[i], -b, moment=True)
        want += (-psi[:, None, None] * np.outer(cross(f, a), b) + chi[:, None, None] * np.outer(cross(f, b), b))
    np.testing.assert_allclose(got.couple_stress.reshape(want.shape), want, rtol=0, atol=1e-12 * np.abs(want).max())
    assert np.abs(want).max() > 0


def test_branch_line_time_average_and_refusals(monkeypatch):
    snaps = [spinning(random_snapshot(k, dim=3), k) for k in range(3)]
    where = cg.Points(random_points(snaps[0], 4, 10))
    fields = ("couple_stress", "stress_torque_density")
    mean = cg.CoarseGrain(snaps, where, cg.Lucy(1.3), fields=fields, couple_stress_form="branch_line").run().results
    each = [cg.coarse_grain(s, where, cg.Lucy(1.3), fields=fields, couple_stress_form="branch_line") for s in snaps]
    for name in fields:
        want = np.mean([r[name] for r in each], axis=0)
        np.testing.assert_allclose(mean[name], want, rtol=1e-13, atol=1e-14 * np.abs(want).max())
    monkeypatch.setattr(cgbound._engine, "_core", ForbiddenCore(cgbound._engine._core))
    with pytest.raises(ValueError, match="couple_stress_form: 'branch_line' .*needs exact line integrals"):
        cg.CoarseGrain(snaps, cg.Grid(snaps[0].box, (1, 1, 4), average=("x", "y")),
                       cg.Gaussian(0.4, line_quadrature="mercurycg"), fields=fields,
                       couple_stress_form="branch_line").run()
    with pytest.raises(ValueError, match="couple_stress_form: expected"):
        cg.angular_momentum_balance_residual(snaps[0], where, cg.Lucy(1.3), couple_stress_form="branch")
