"""Slow pure-NumPy twins ("oracles") of the C core and of the pipeline, written from the formulas.

Each twin is named after what it mirrors: ``oracle_scatter_points``,
``oracle_scatter_segments``, ``oracle_scatter_fluctuation`` and
``oracle_minimum_image`` mirror the ``_core`` entry points of the same name (and
``oracle_scatter_segment_moments`` ``_core.scatter_segment_moments``);
``oracle_split_contacts`` mirrors ``Snapshot.split_contacts``;
``oracle_coarse_grain`` mirrors ``cgbound.coarse_grain`` (the whole pipeline);
``oracle_rheology`` mirrors its gradient, kinematics and rheology fields;
``OracleKernel`` mirrors the core's kernels (cg_kernel_value, cg_kernel_line,
cg_kernel_gradient; with ``lower_dimensional``, MercuryCG's kernel over averaged axes; with
``line_points="mercurycg"``, MercuryCG's approximate Gauss line integral, its normalisation by quadrature;
``oracle_kernel_of`` builds it from a cgbound kernel) and ``oracle_target`` the nodes of a Grid or Points target.

It shares no numerics with the C core: marginals over averaged axes are
integrated numerically from the D-dimensional kernel, line integrals use the
substitution t = b sin(theta) with graded Gauss-Legendre panels (no erf), the
Gaussian's truncated normalisation is a numerical ball integral, periodic
images are summed by brute force over a generous range, and contacts are
classified with plain Python loops.
"""
import math

import numpy as np

GL_X, GL_W = np.polynomial.legendre.leggauss(12)
GL40_X, GL40_W = np.polynomial.legendre.leggauss(40)


def _gl(f, a, b, x=GL_X, w=GL_W):
    """Gauss-Legendre of f over [a, b]; a, b arrays (broadcast), f vectorised over a trailing node axis."""
    a = np.asarray(a, float)[..., None]
    b = np.asarray(b, float)[..., None]
    half = 0.5 * (b - a)
    nodes = a + half + half * x
    return (f(nodes) * w).sum(axis=-1) * half[..., 0]


def _graded_panels(lo, hi, scale):
    """Panel edges on [lo, hi]: split at 0 and graded geometrically toward 0 down to
    ``scale`` (where the integrand has a near-singularity of that width)."""
    edges = {lo, hi}
    span = max(abs(lo), abs(hi))
    if lo < 0.0 < hi:
        edges.add(0.0)
    levels = int(math.ceil(math.log2(span / scale))) + 2 if span > scale else 1
    for k in range(0, min(levels, 60)):
        for sgn in (-1.0, 1.0):
            x = sgn * span * 2.0**-k
            if lo < x < hi:
                edges.add(x)
    edges = sorted(edges)
    fine = []
    for a, b in zip(edges[:-1], edges[1:]):
        fine += [a, 0.5 * (a + b)]
    fine.append(edges[-1])
    return fine


class OracleKernel:
    """Kernel from its textbook definition in D dimensions (twin of the core's cg_kernel_*)."""

    def __init__(self, kind, dim, width, radius, truncated=False, line_points=0, lower_dimensional=False):
        self.kind, self.dim, self.w, self.R, self.truncated = kind, dim, width, radius, truncated
        # "mercurycg": MercuryCG's approximate Gauss line integral along one resolved axis (mercurycg_line)
        self.mercurycg = kind == "gaussian" and line_points == "mercurycg"
        line_points = 0 if self.mercurycg else line_points
        self.line_points = line_points if kind == "gaussian" else 0   # n-point Gauss-Legendre along segments
        # MercuryCG's convention over averaged axes: the n_res-dimensional kernel itself, not the marginal
        self.lower_dimensional = lower_dimensional
        self._norms = {}

    # full D-dimensional kernel (for Lucy/Heaviside), as a function of r
    def full(self, r, dim=None):
        dim = dim or self.dim
        R = self.R
        x = r / R
        if self.kind == "lucy":
            C = {1: 5 / (4 * R), 2: 5 / (math.pi * R**2), 3: 105 / (16 * math.pi * R**3)}[dim]
            return np.where(x < 1, C * (1 + 3 * x) * (1 - x) ** 3, 0.0)
        if self.kind == "heaviside":
            V = {1: 2 * R, 2: math.pi * R**2, 3: 4 / 3 * math.pi * R**3}[dim]
            return np.where(x < 1, 1.0 / V, 0.0)
        raise ValueError(self.kind)

    def gaussian_norm(self, n_res):
        if n_res not in self._norms:
            self._norms[n_res] = self._gaussian_norm(n_res)
        return self._norms[n_res]

    def _gaussian_norm(self, n_res):
        w, R = self.w, self.R
        if not self.truncated:
            return (2 * math.pi * w * w) ** (n_res / 2)
        # numerical radial integral over the ball in n_res dimensions
        surface = {1: 2.0, 2: 2 * math.pi, 3: 4 * math.pi}[n_res]
        val = sum(_gl(lambda r: np.exp(-r**2 / (2 * w * w)) * r ** (n_res - 1), a, b, GL40_X, GL40_W)
                  for a, b in zip(np.linspace(0, R, 9)[:-1], np.linspace(0, R, 9)[1:]))
        return surface * val

    def marginal(self, rho2, n_res, avg_extent):
        """Kernel in the resolved subspace (n_res dims) at squared distance rho2."""
        rho2 = np.asarray(rho2, float)
        n_avg = self.dim - n_res
        if n_res == 0:
            return np.full(rho2.shape, 1.0 / avg_extent)
        R = self.R
        inside = rho2 < R * R
        if self.kind == "gaussian":
            val = np.exp(-rho2 / (2 * self.w**2)) / self.gaussian_norm(n_res)
            return np.where(inside, val, 0.0) / avg_extent
        rho = np.sqrt(np.minimum(rho2, R * R))
        if self.lower_dimensional:
            # the textbook kernel of the resolved dimension (normalised in n_res dimensions)
            val = self.full(rho, dim=n_res)
        elif n_avg == 0:
            val = self.full(rho)
        elif n_avg == 1:
            # int over y in [-h, h] of W(sqrt(rho^2 + y^2)); y = rho sinh(tau) smooths small rho
            h = np.sqrt(np.maximum(R * R - rho2, 0.0))
            safe = np.maximum(rho, 1e-300)
            tau_max = np.arcsinh(h / safe)
            f = lambda tau: self.full(safe[..., None] * np.cosh(tau)) * safe[..., None] * np.cosh(tau)
            val = np.zeros_like(rho)
            for a, b in [(0.0, 0.25), (0.25, 0.5), (0.5, 0.75), (0.75, 1.0)]:
                val += 2 * _gl(f, a * tau_max, b * tau_max, GL40_X, GL40_W)
            # rho = 0: the integrand is the 1-D profile W(|y|)
            zero = rho < 1e-300
            if np.any(zero):
                g = lambda y: self.full(y)
                val = np.where(zero, 2 * _gl(g, np.zeros_like(h), h, GL40_X, GL40_W), val)
        else:
            # int over the plane = 2 pi int_{|z|}^{R} W(r) r dr
            f = lambda r: self.full(r) * r
            val = 2 * math.pi * _gl(f, rho, np.full_like(rho, R), GL40_X, GL40_W)
        return np.where(inside, val, 0.0) / avg_extent

    def line(self, q, e, n_res, avg_extent, ray=False):
        """psi(q) = int_0^S M(|q - s e|^2) ds for nodes q (P x n_res), one segment e."""
        q = np.atleast_2d(q)
        if n_res == 0:
            if ray:
                raise ValueError("ray with no resolved axis")
            return np.full(q.shape[0], 1.0 / avg_extent)
        if self.mercurycg and not ray:
            return self.mercurycg_line(q[:, 0], float(np.asarray(e, float)[0]), avg_extent)
        if self.line_points and not ray:
            # the rule applied to the cut-off kernel: sum_g w_g M(|q - s_g e|^2), s_g, w_g on [0, 1]
            x, w = np.polynomial.legendre.leggauss(self.line_points)
            total = np.zeros(q.shape[0])
            for s, wg in zip(0.5 * (x + 1.0), 0.5 * w):
                d = q - s * np.asarray(e, float)
                total += wg * self.marginal((d * d).sum(axis=1), n_res, avg_extent)
            return total
        L = float(np.linalg.norm(e))
        if L == 0.0:
            return self.marginal((q * q).sum(axis=1), n_res, avg_extent)
        n = e / L
        u = q @ n
        a2 = np.maximum((q * q).sum(axis=1) - u * u, 0.0)
        b2 = self.R**2 - a2
        out = np.zeros(q.shape[0])
        for p in np.flatnonzero(b2 > 0):
            b = math.sqrt(b2[p])
            t_hi = min(u[p], b)
            t_lo = -b if ray else max(u[p] - L, -b)
            if t_lo >= t_hi:
                continue
            th_lo, th_hi = math.asin(max(-1.0, t_lo / b)), math.asin(min(1.0, t_hi / b))
            f = lambda th, a2p=a2[p], b=b: self.marginal(a2p + (b * np.sin(th)) ** 2, n_res, avg_extent) * b * np.cos(th)
            edges = _graded_panels(th_lo, th_hi, max(math.sqrt(a2[p]) / b, 1e-6))
            total = 0.0
            for x0, x1 in zip(edges[:-1], edges[1:]):
                total += float(_gl(f, x0, x1))
            out[p] = total / L
        return out

    def mercurycg_line(self, q, e, avg_extent):
        """MercuryCG's Gauss "line integral" along one axis (Gauss::evaluateCGIntegral1D): psi = P(d) [erf(hi/s)
        - erf(lo/s)] for the branch's ends at lo <= hi from the node (d = hi - lo, s = sqrt(2) w), 0 beyond the
        cutoff c; P(d) normalises psi to 1 over the nodes it reaches: 1 / (2 int_{-c}^{c+d} erf(x/s) dx), here by
        quadrature (MercuryCG has the antiderivative)."""
        s, c = math.sqrt(2) * self.w, self.R
        ends = np.stack([-q, e - q], axis=1)
        lo, hi = ends.min(axis=1), ends.max(axis=1)
        d = abs(e)
        if not d > 1e-10 * c:
            return self.marginal(q * q, 1, avg_extent)
        verf = np.vectorize(math.erf)
        edges = np.linspace(-c, c + d, 17)
        area = sum(float(_gl(lambda x: verf(x / s), a, b, GL40_X, GL40_W)) for a, b in zip(edges[:-1], edges[1:]))
        psi = (verf(hi / s) - verf(lo / s)) / (2 * area)
        return np.where((hi < -c) | (lo > c), 0.0, psi) / avg_extent

    def radial_derivative(self, r, dim=None):
        """dW/dr of the full-dimensional kernel (or of the ``dim``-dimensional one), from its textbook form."""
        R = self.R
        dim = dim or self.dim
        if self.kind == "gaussian":
            return np.where(r < R, -r / self.w**2 * np.exp(-r**2 / (2 * self.w**2)) / self.gaussian_norm(dim), 0.0)
        if self.kind == "lucy":
            C = {1: 5 / (4 * R), 2: 5 / (math.pi * R**2), 3: 105 / (16 * math.pi * R**3)}[dim]
            x = r / R
            # d/dr [C (1 + 3x)(1 - x)^3] = C [3 (1 - x)^3 - 3 (1 + 3x)(1 - x)^2] / R
            return np.where(x < 1, C * (3 * (1 - x) ** 3 - 3 * (1 + 3 * x) * (1 - x) ** 2) / R, 0.0)
        return np.zeros_like(r)

    def gradient(self, x):
        """Gradient of W at offsets x (P x D; with fewer columns, of the kernel of that dimension)."""
        r = np.sqrt((x * x).sum(axis=1))
        safe = np.where(r > 0, r, 1.0)
        return (self.radial_derivative(r, dim=x.shape[1]) / safe)[:, None] * x

    def marginal_gradient(self, q, n_res=None, avg_extent=1.0):
        """grad_q M(|q|^2) at offsets q (P x n_res), as cg_kernel_gradient: the full kernel's gradient when
        nothing is averaged; the Gaussian's marginal is Gaussian in the resolved axes."""
        q = np.atleast_2d(q)
        n_res = self.dim if n_res is None else n_res
        if n_res == self.dim or (self.lower_dimensional and self.kind != "gaussian"):
            return self.gradient(q) / avg_extent
        if self.kind == "gaussian":
            return -q / self.w**2 * self.marginal((q * q).sum(axis=1), n_res, avg_extent)[:, None]
        if self.kind == "lucy":
            return self.lucy_marginal_gradient(q, n_res, avg_extent)
        raise ValueError("no gradient of an averaged Heaviside kernel")

    def lucy_marginal_gradient(self, q, n_res, avg_extent):
        """grad_q of Lucy's marginal over the averaged axes, integrated numerically from the full
        kernel's radial derivative: grad M = q int W'(r) / r over the averaged coordinates (y, with
        r^2 = |q|^2 + |y|^2); one averaged axis: 2 int_0^h dy (W'(r)/r is smooth in y for Lucy);
        two: polar coordinates (s ds = r dr), 2 pi int W'(r) / r s ds = 2 pi int_rho^R W'(r) dr."""
        R = self.R
        rho2 = (q * q).sum(axis=1)
        rho = np.sqrt(np.minimum(rho2, R * R))
        inside = rho2 < R * R
        if self.dim - n_res == 1:
            h = np.sqrt(np.maximum(R * R - rho2, 0.0))
            def f(y):
                r = np.sqrt(rho[:, None] ** 2 + y * y)
                safe = np.where(r > 0, r, 1.0)
                return self.radial_derivative(r) / safe
            integral = np.zeros_like(rho)
            for a, b in [(0.0, 0.25), (0.25, 0.5), (0.5, 0.75), (0.75, 1.0)]:
                integral += 2 * _gl(f, a * h, b * h, GL40_X, GL40_W)
        else:
            integral = 2 * math.pi * _gl(self.radial_derivative, rho, np.full_like(rho, R), GL40_X, GL40_W)
        return np.where(inside, integral, 0.0)[:, None] * q / avg_extent

    def line_gradient(self, q, e, n_res=None, avg_extent=1.0, ray=False):
        """grad_r psi for nodes q (P x n_res) of int_0^S M(q - s e) ds (S = 1, or infinity for a ray):
        quadrature of grad M along the segment (the kernel's n-point rule if it has one, as cg_kernel_line)."""
        q = np.atleast_2d(q)
        n_res = self.dim if n_res is None else n_res
        if self.line_points and not ray:
            x, w = np.polynomial.legendre.leggauss(self.line_points)
            total = np.zeros_like(q, dtype=float)
            for s, wg in zip(0.5 * (x + 1.0), 0.5 * w):
                total += wg * self.marginal_gradient(q - s * np.asarray(e, float), n_res, avg_extent)
            return total
        L = float(np.linalg.norm(e))
        if L == 0.0:
            return self.marginal_gradient(q, n_res, avg_extent)
        n = e / L
        u = q @ n
        qperp = q - u[:, None] * n
        a2 = (qperp * qperp).sum(axis=1)
        out = np.zeros_like(q)
        for p in np.flatnonzero(a2 < self.R**2):
            b = math.sqrt(self.R**2 - a2[p])
            t_hi, t_lo = min(u[p], b), (-b if ray else max(u[p] - L, -b))
            if t_lo >= t_hi:
                continue
            th_lo, th_hi = math.asin(max(-1.0, t_lo / b)), math.asin(min(1.0, t_hi / b))
            for comp in range(q.shape[1]):
                def f(th, p=p, b=b, comp=comp):
                    t = b * np.sin(th)
                    x = qperp[p][None, None, :] + t[..., None] * n
                    shape = t.shape
                    g = self.marginal_gradient(x.reshape(-1, q.shape[1]), n_res, avg_extent)[:, comp].reshape(shape)
                    return g * b * np.cos(th)
                edges = _graded_panels(th_lo, th_hi, max(math.sqrt(a2[p]) / b, 1e-6))
                out[p, comp] = sum(float(_gl(f, x0, x1)) for x0, x1 in zip(edges[:-1], edges[1:])) / L
        return out

    def line_moment(self, q, e, n_res=None, avg_extent=1.0, gradient=False):
        """chi(q) = int_0^1 s M(|q - s e|^2) ds for nodes q (P x n_res), or its gradient with respect to the node
        ((P, n_res)): quadrature in s of s M (s grad M) at the offsets q - s e themselves, panels graded toward
        the closest approach (Lucy's kink where the line meets the node) and split where the support clips."""
        q = np.atleast_2d(np.asarray(q, float))
        e = np.asarray(e, float)
        n_res = self.dim if n_res is None else n_res

        def value(y):
            if gradient:
                return self.marginal_gradient(y, n_res, avg_extent)
            return self.marginal((y * y).sum(axis=1), n_res, avg_extent)

        if n_res == 0:
            return np.zeros((q.shape[0], 0)) if gradient else np.full(q.shape[0], 0.5 / avg_extent)
        if self.line_points:
            x, w = np.polynomial.legendre.leggauss(self.line_points)
            return sum(wg * s * value(q - s * e) for s, wg in zip(0.5 * (x + 1.0), 0.5 * w))
        L = float(np.linalg.norm(e))
        if L == 0.0:
            return 0.5 * value(q)
        n = e / L
        out = np.zeros(q.shape if gradient else q.shape[0])
        for p in range(q.shape[0]):
            u = float(q[p] @ n)
            a = float(np.linalg.norm(q[p] - u * n))
            if a >= self.R:
                continue
            b = math.sqrt(self.R**2 - a * a)
            lo, hi = max(0.0, (u - b) / L), min(1.0, (u + b) / L)
            if lo >= hi:
                continue
            star = min(max(u / L, lo), hi)
            scale = max(a, abs(u / L - star) * L, 1e-9 * self.R) / L
            edges = {lo, hi, star}
            for side in (star - lo, hi - star):
                d = side
                while d > scale and len(edges) < 400:
                    d *= 0.5
                    edges.update(x for x in (star - d, star + d) if lo < x < hi)
            # the marginals over averaged axes have an algebraic edge where the support ends (Heaviside's chord
            # sqrt(b^2 - t^2), Lucy's (R - rho)^(7/2)): panels graded toward an end that is on the edge (clipped)
            # or nearer to it than the segment is long, 2^-45 of the length at the finest (for the full kernels the
            # edge is smooth or a jump, and the panels are harmless)
            for end, inward in ((lo, 1.0), (hi, -1.0)):
                near_edge = b - abs(u - end * L) < (hi - lo) * L
                if near_edge and self.kind != "gaussian":
                    edges.update(end + inward * (hi - lo) * 2.0**-k for k in range(1, 46))
            edges = sorted(x for x in edges if lo <= x <= hi)
            total = 0.0
            for x0, x1 in zip(edges[:-1], edges[1:]):
                half = 0.5 * (x1 - x0)
                if half <= 0:
                    continue
                ss = x0 + half + half * GL40_X
                vals = value(q[p][None, :] - ss[:, None] * e[None, :])
                total = total + (((ss * GL40_W)[:, None] if gradient else ss * GL40_W) * vals).sum(axis=0) * half
            out[p] = total
        return out


# ----------------------------------------------------------------------
# evaluation targets


def oracle_target(grid_or_points, box):
    """(nodes (P x n_res), resolved axes, periodic flags, periods, avg_extent) computed independently:
    the twin of the core target a Grid or Points describes."""
    from cgbound import Grid

    dim = box.dim
    if isinstance(grid_or_points, Grid):
        g = grid_or_points
        lo, hi = np.asarray(box.lower, float), np.asarray(box.upper, float)
        resolved = [d for d in range(dim) if d not in g.averaged]
        axes = []
        for d in resolved:
            h = (hi[d] - lo[d]) / g.shape[d]
            axes.append(np.array([lo[d] + (k + 0.5) * h for k in range(g.shape[d])]))
        if resolved:
            mesh = np.meshgrid(*axes, indexing="ij")
            nodes = np.stack([m.ravel() for m in mesh], axis=1)
        else:
            nodes = np.zeros((1, 0))
        avg = float(np.prod([hi[d] - lo[d] for d in g.averaged])) if g.averaged else 1.0
    else:
        nodes = np.asarray(grid_or_points.positions, float)
        resolved = list(range(dim))
        avg = 1.0
    periodic = [box.periodic[d] for d in resolved]
    periods = [float(box.upper[d] - box.lower[d]) for d in resolved]
    return nodes, resolved, periodic, periods, avg


def _shell(periodic, periods, k):
    """Image shifts whose largest index along the periodic axes is exactly k."""
    ranges = [range(-k, k + 1) if p else range(0, 1) for p in periodic]
    out = []
    for combo in np.ndindex(*[len(r) for r in ranges]):
        idx = [ranges[a][c] for a, c in enumerate(combo)]
        if max((abs(i) for i in idx), default=0) == k:
            out.append([i * periods[a] for a, i in enumerate(idx)])
    return np.array(out, float).reshape(-1, len(periodic))


def _sum_images(weight_of_shift, periodic, periods, P):
    """Sum weights over periodic images, shell by shell, until two shells add nothing
    (contributing images form a contiguous block once the object is wrapped next to the nodes)."""
    total = np.zeros(P)
    empty = 0
    first = True
    k = 0
    while True:
        shifts = _shell(periodic, periods, k)
        if shifts.shape[0] == 0:
            break
        added = sum(weight_of_shift(s) for s in shifts)
        if first:  # weights may have a trailing axis (gradients)
            total, first = np.zeros(np.shape(added)), False
        total += added
        if not any(periodic):
            break
        empty = empty + 1 if not np.any(added) else 0
        if empty >= 2 or k > 2000:
            break
        k += 1
    return total


def _wrap(x, tgt):
    """Bring an object's resolved start into the node range along periodic axes."""
    nodes, resolved, periodic, periods, _ = tgt
    x = np.array(x, float)
    for a, (p, L) in enumerate(zip(periodic, periods)):
        if p:
            lo = nodes[:, a].min()
            x[a] -= L * math.floor((x[a] - lo) / L)
    return x


def _object_weights(kernel, tgt, x, e=None, ray=False, gradient=False, moment=False):
    """Kernel weight (e is None) or line integral of one object at every node, summed over images
    ((P,), or (P, n_res) with gradient: the gradient with respect to the node)."""
    nodes, resolved, periodic, periods, avg = tgt
    n_res = len(resolved)
    if n_res == 0:
        return np.zeros((nodes.shape[0], 0)) if gradient else np.full(nodes.shape[0], 1.0 / avg)
    xr = _wrap(x[resolved], tgt)
    if e is None and gradient:
        def weight(s):
            return kernel.marginal_gradient(nodes - (xr + s), n_res, avg)
    elif e is None:
        def weight(s):
            d = nodes - (xr + s)
            return kernel.marginal((d * d).sum(axis=1), n_res, avg)
    elif moment:
        def weight(s):
            return kernel.line_moment(nodes - (xr + s), e[resolved], n_res, avg, gradient=gradient)
    elif gradient:
        def weight(s):
            return kernel.line_gradient(nodes - (xr + s), e[resolved], n_res, avg, ray=ray)
    else:
        def weight(s):
            return kernel.line(nodes - (xr + s), e[resolved], n_res, avg, ray=ray)
    return _sum_images(weight, periodic, periods, nodes.shape[0])


def _scatter(kernel, tgt, values, objects, ray=False, gradient=False, moment=False):
    P, n_res = tgt[0].shape[0], len(tgt[1])
    out = np.zeros((P, values.shape[1], n_res) if gradient else (P, values.shape[1]))
    for (x, e), v in zip(objects, values):
        w = _object_weights(kernel, tgt, x, e, ray, gradient, moment)
        out += w[:, None, :] * v[None, :, None] if gradient else w[:, None] * v[None, :]
    return out


def oracle_scatter_points(kernel, tgt, positions, values, gradient=False):
    """Twin of _core.scatter_points: (P, K), or (P, K, n_res) with gradient."""
    return _scatter(kernel, tgt, values, [(x, None) for x in positions], gradient=gradient)


def oracle_scatter_segments(kernel, tgt, starts, vecs, values, ray=False, gradient=False):
    """Twin of _core.scatter_segments: (P, K), or (P, K, n_res) with gradient."""
    return _scatter(kernel, tgt, values, list(zip(starts, vecs)), ray=ray, gradient=gradient)


def oracle_scatter_segment_moments(kernel, tgt, starts, vecs, values, gradient=False):
    """Twin of _core.scatter_segment_moments (the kernel's first moment along segments): (P, K), or (P, K, n_res)
    with gradient."""
    return _scatter(kernel, tgt, values, list(zip(starts, vecs)), gradient=gradient, moment=True)


def oracle_scatter_fluctuation(kernel, tgt, positions, masses, velocities, node_velocity):
    """Twin of _core.scatter_fluctuation: (P, D, D)."""
    D = node_velocity.shape[1]
    out = np.zeros((tgt[0].shape[0], D, D))
    for x, m, v in zip(positions, masses, velocities):
        w = _object_weights(kernel, tgt, x)
        dv = v[None, :] - node_velocity
        out -= (m * w)[:, None, None] * dv[:, :, None] * dv[:, None, :]
    return out


# ----------------------------------------------------------------------
# fields


def oracle_minimum_image(vectors, periodic, period):
    """Twin of _core.minimum_image (and Box.minimum_image): each periodic column to its nearest image."""
    vec = np.array(vectors, float)
    for d, (p, L) in enumerate(zip(periodic, period)):
        if p:
            vec[..., d] -= L * np.round(vec[..., d] / L)
    return vec


def oracle_split_contacts(snap):
    """Twin of Snapshot.split_contacts: bulk and boundary contacts by plain loops (docs/theory.md, "The snapshot
    model")."""
    bulk, boundary = [], []
    c = snap.contacts
    for k in range(len(c)):
        i, j = int(c.i[k]), int(c.j[k])
        f, pt = np.array(c.force[k]), np.array(c.point[k])
        fi = bool(snap.fixed[i])
        fj = True if j < 0 else bool(snap.fixed[j])
        if not fi and not fj:
            bulk.append((i, j, f))
        elif not fi and fj:
            boundary.append((i, f, pt))
        elif fi and not fj:
            boundary.append((j, -f, pt))
    return bulk, boundary


def oracle_kernel_of(kernel_obj, dim):
    """The OracleKernel twin of a cgbound kernel object."""
    import cgbound as cg

    kind = {cg.Gaussian: "gaussian", cg.Lucy: "lucy", cg.Heaviside: "heaviside"}[type(kernel_obj)]
    line = getattr(kernel_obj, "line_quadrature", "exact")
    return OracleKernel(kind, dim, getattr(kernel_obj, "width", None) or kernel_obj.radius, kernel_obj.radius,
                        truncated=getattr(kernel_obj, "truncated", False), line_points=0 if line == "exact" else line,
                        lower_dimensional=getattr(kernel_obj, "averaged_axes", "marginal") == "lower-dimensional")


def oracle_coarse_grain(snap, where, kernel_obj, fields, convention="tension"):
    """Twin of cgbound.coarse_grain: all requested fields, flat over nodes (P, ...), from the formulas of
    docs/theory.md, "Fields"."""
    rheology = [name for name in fields if name in RHEOLOGY_NAMES]
    if rheology:        # their own twin (which asks this one for density, momentum and stress)
        out = oracle_coarse_grain(snap, where, kernel_obj, [f for f in fields if f not in rheology], convention)
        out.update(oracle_rheology(snap, where, kernel_obj, rheology))
        return {name: out[name] for name in fields}
    kernel = oracle_kernel_of(kernel_obj, snap.dim)
    box = snap.box
    tgt = oracle_target(where, box)
    D = snap.dim
    P = tgt[0].shape[0]
    flow = ~np.asarray(snap.fixed)
    pos = np.asarray(snap.positions)[flow]
    m = np.asarray(snap.masses)[flow]
    vel = np.zeros_like(pos) if snap.velocities is None else np.asarray(snap.velocities)[flow]

    rho = oracle_scatter_points(kernel, tgt, pos, m[:, None])[:, 0]
    p = oracle_scatter_points(kernel, tgt, pos, m[:, None] * vel)
    with np.errstate(invalid="ignore", divide="ignore"):
        V = np.where(rho[:, None] > 0, p / rho[:, None], np.nan)
    k = oracle_scatter_points(kernel, tgt, pos, (m[:, None, None] * vel[:, :, None] * vel[:, None, :]).reshape(-1, D * D)).reshape(P, D, D)
    sk = oracle_scatter_fluctuation(kernel, tgt, pos, m, vel, np.nan_to_num(V))

    bulk, boundary = oracle_split_contacts(snap)
    lengths = [box.upper[d] - box.lower[d] for d in range(D)]
    X = np.asarray(snap.positions)
    sb = np.zeros((P, D * D))
    for i, j, f in bulk:
        r_ij = oracle_minimum_image(X[i] - X[j], box.periodic, lengths)
        sb += oracle_scatter_segments(kernel, tgt, X[i][None], -r_ij[None], -np.outer(f, r_ij).reshape(1, -1), False)
    sw = np.zeros((P, D * D))
    sx = np.zeros((P, D * D))
    t = np.zeros((P, D))
    for i, f, c in boundary:
        a = oracle_minimum_image(X[i] - c, box.periodic, lengths)
        vals = -np.outer(f, a).reshape(1, -1)
        if "boundary_stress" in fields or "stress" in fields or "pressure" in fields:
            sw += oracle_scatter_segments(kernel, tgt, X[i][None], -a[None], vals, False)
        if "extended_stress" in fields:
            sx += oracle_scatter_segments(kernel, tgt, X[i][None], -a[None], vals, True)
        t += oracle_scatter_points(kernel, tgt, (X[i] - a)[None], f[None])
    sb, sw, sx = (x.reshape(P, D, D) for x in (sb, sw, sx))
    if snap.body_force is not None:
        b = oracle_scatter_points(kernel, tgt, pos, m[:, None] * np.asarray(snap.body_force)[flow])
    else:
        b = np.zeros((P, D))
    sign = -1.0 if convention == "compression" else 1.0
    structure = [name for name in fields if name in STRUCTURE_FIELD_NAMES]
    out = oracle_structure(snap, where, kernel_obj, structure) if structure else {}
    for name in fields:
        if name in structure:
            continue
        out[name] = {
            "density": lambda: rho,
            "momentum": lambda: p,
            "velocity": lambda: V,
            "momentum_flux": lambda: k,
            "kinetic_stress": lambda: sign * sk,
            "contact_stress": lambda: sign * sb,
            "boundary_stress": lambda: sign * sw,
            "interaction_force_density": lambda: t,
            "body_force_density": lambda: b,
            "stress": lambda: sign * (sk + sb + sw),
            "extended_stress": lambda: sign * (sk + sb + sx),
            "volume_fraction": lambda: oracle_scatter_points(kernel, tgt, pos, (
                (math.pi * np.asarray(snap.radii)[flow] ** 2) if D == 2 else
                (4 / 3 * math.pi * np.asarray(snap.radii)[flow] ** 3))[:, None])[:, 0],
            "pressure": lambda: -np.trace(sk + sb + sw, axis1=1, axis2=2) / D,
            "temperature": lambda: np.where(rho > 0, -np.trace(sk, axis1=1, axis2=2) / (D * np.where(rho > 0, rho, 1)), np.nan),
        }[name]()
    return out


# ----------------------------------------------------------------------
# structure (docs/theory.md, "Structure")


STRUCTURE_FIELD_NAMES = ("number_density", "fabric", "coordination_number", "mean_radius", "radius_spread",
                         "radius_skewness") + tuple(f"size_moment_{k}" for k in range(6))


def oracle_structure(snap, where, kernel_obj, fields):
    """Twin of the structure fields of cgbound.coarse_grain (fabric, coordination number, number density,
    size moments and the local radius statistics), flat over nodes, by plain loops over particles and contacts."""
    import cgbound as cg

    kind = {cg.Gaussian: "gaussian", cg.Lucy: "lucy", cg.Heaviside: "heaviside"}[type(kernel_obj)]
    kernel = OracleKernel(kind, snap.dim, getattr(kernel_obj, "width", None) or kernel_obj.radius, kernel_obj.radius,
                          truncated=getattr(kernel_obj, "truncated", False))
    box = snap.box
    tgt = oracle_target(where, box)
    D = snap.dim
    P = tgt[0].shape[0]
    lengths = [box.upper[d] - box.lower[d] for d in range(D)]
    X = np.asarray(snap.positions)
    fixed = np.asarray(snap.fixed)
    radii = None if snap.radii is None else np.asarray(snap.radii)
    moments = np.zeros((6, P))
    for k in range(snap.n_particles):
        if fixed[k]:
            continue
        w = oracle_scatter_points(kernel, tgt, X[k][None], np.ones((1, 1)))[:, 0]
        for power in range(6):
            if power == 0 or radii is not None:
                moments[power] += w * (radii[k] ** power if power else 1.0)
    fabric_bulk = np.zeros((P, D, D))
    fabric_wall = np.zeros((P, D, D))
    c = snap.contacts
    for k in range(len(c)):
        i, j, point = int(c.i[k]), int(c.j[k]), np.array(c.point[k])
        wall_j = j < 0 or bool(fixed[j])
        if fixed[i] and wall_j:
            continue                                   # between boundary objects: ignored
        if not fixed[i] and not wall_j:
            normal = oracle_minimum_image(X[i] - X[j], box.periodic, lengths)
            into = fabric_bulk
        else:
            flowing = j if fixed[i] else i
            normal = oracle_minimum_image(X[flowing] - point, box.periodic, lengths)
            into = fabric_wall
        normal = normal / math.sqrt(float(normal @ normal))
        w = oracle_scatter_points(kernel, tgt, point[None], np.ones((1, 1)))[:, 0]
        into += w[:, None, None] * np.outer(normal, normal)[None]
    n = moments[0]
    with np.errstate(invalid="ignore", divide="ignore"):
        mean = np.where(n > 0, moments[1] / n, np.nan)
        var = np.where(n > 0, moments[2] / n, np.nan) - mean ** 2
        third = np.where(n > 0, moments[3] / n, np.nan) - 3 * mean * var - mean ** 3
        spread = np.sqrt(np.maximum(var, 0))
        out = {"number_density": n, "fabric": fabric_bulk + fabric_wall,
               "coordination_number": np.where(n > 0, (2 * np.trace(fabric_bulk, axis1=1, axis2=2)
                                                      + np.trace(fabric_wall, axis1=1, axis2=2)) / n, np.nan),
               "mean_radius": mean, "radius_spread": spread,
               "radius_skewness": np.where(spread > 0, third / spread ** 3, np.nan)}
    out.update({f"size_moment_{k}": moments[k] for k in range(6)})
    return {name: out[name] for name in fields}
#: the fields oracle_rheology mirrors
RHEOLOGY_NAMES = ("density_gradient", "momentum_gradient", "velocity_gradient", "strain_rate", "spin", "shear_rate",
                  "shear_stress", "friction", "inertial_number")


def _shear_invariant(tensors):
    """sqrt(J2) of the symmetric part of each tensor from its eigenvalues: J2 = (1/6) sum over pairs
    (l_i - l_j)^2 in 3D, (l_1 - l_2)^2 / 4 in 2D (no deviator formed)."""
    lam = np.linalg.eigvalsh(0.5 * (tensors + np.swapaxes(tensors, 1, 2)))
    if lam.shape[1] == 2:
        return np.abs(lam[:, 0] - lam[:, 1]) / 2
    return np.sqrt(((lam[:, 0] - lam[:, 1]) ** 2 + (lam[:, 1] - lam[:, 2]) ** 2 + (lam[:, 2] - lam[:, 0]) ** 2) / 6)


def oracle_rheology(snap, where, kernel_obj, fields):
    """Twin of the gradient, kinematics and rheology fields of cgbound.coarse_grain, from the formulas of
    docs/theory.md, "Gradients, kinematics and rheology": gradients by oracle_scatter_points (gradient=True)
    of the absolute momentum, node by node, invariants from eigenvalues."""
    kernel = oracle_kernel_of(kernel_obj, snap.dim)
    tgt = oracle_target(where, snap.box)
    resolved = tgt[1]
    D = snap.dim
    P = tgt[0].shape[0]
    flow = ~np.asarray(snap.fixed)
    pos = np.asarray(snap.positions)[flow]
    m = np.asarray(snap.masses)[flow]
    vel = np.zeros_like(pos) if snap.velocities is None else np.asarray(snap.velocities)[flow]
    base = oracle_coarse_grain(snap, where, kernel_obj, ["density", "momentum", "stress"])
    rho, p, sigma = base["density"], base["momentum"], base["stress"]
    grad_rho = np.zeros((P, D))
    grad_p = np.zeros((P, D, D))
    L = np.full((P, D, D), np.nan)
    gamma = np.full(P, np.nan)
    if set(fields) - {"shear_stress", "friction"}:          # fields with gradients
        grad_rho[:, resolved] = oracle_scatter_points(kernel, tgt, pos, m[:, None], gradient=True)[:, 0, :]
        grad_p[:, :, resolved] = oracle_scatter_points(kernel, tgt, pos, m[:, None] * vel, gradient=True)
        for n in range(P):
            if rho[n] > 0:
                V = p[n] / rho[n]
                L[n] = (grad_p[n] - np.outer(V, grad_rho[n])) / rho[n]
        ok = rho > 0
        gamma[ok] = 2 * _shear_invariant(0.5 * (L + np.swapaxes(L, 1, 2))[ok])   # sqrt(2 D':D') = 2 sqrt(J2(D))
    strain = 0.5 * (L + np.swapaxes(L, 1, 2))
    tau = _shear_invariant(sigma)
    pressure = -np.trace(sigma, axis1=1, axis2=2) / D
    radii = np.asarray(snap.radii)[flow] if snap.radii is not None else None
    out = {}
    for name in fields:
        if name == "density_gradient":
            out[name] = grad_rho
        elif name == "momentum_gradient":
            out[name] = grad_p
        elif name == "velocity_gradient":
            out[name] = L
        elif name == "strain_rate":
            out[name] = strain
        elif name == "spin":
            out[name] = 0.5 * (L - np.swapaxes(L, 1, 2))
        elif name == "shear_rate":
            out[name] = gamma
        elif name == "shear_stress":
            out[name] = tau
        elif name == "friction":
            out[name] = np.array([tau[n] / pressure[n] if pressure[n] > 0 else np.nan for n in range(P)])
        elif name == "inertial_number":
            volume = math.pi * radii**2 if D == 2 else 4 / 3 * math.pi * radii**3
            phi = oracle_scatter_points(kernel, tgt, pos, volume[:, None])[:, 0]
            phi_d = oracle_scatter_points(kernel, tgt, pos, (volume * 2 * radii)[:, None])[:, 0]
            value = np.full(P, np.nan)
            for n in range(P):
                if phi[n] > 0 and pressure[n] > 0 and rho[n] > 0:
                    d_mean, rho_p = phi_d[n] / phi[n], rho[n] / phi[n]
                    value[n] = gamma[n] * d_mean / math.sqrt(pressure[n] / rho_p)
            out[name] = value
        else:
            raise ValueError(name)
    return out


# ----------------------------------------------------------------------
# rotation (docs/theory.md, "Rotation and couple stress")


def _oracle_cross(a, b):
    """a x b: the 3-vector in 3D; in 2D the out-of-plane scalar a_0 b_1 - a_1 b_0 as a 1-vector."""
    if len(a) == 3:
        return np.array([a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]])
    return np.array([a[0] * b[1] - a[1] * b[0]])


def oracle_rotation(snap, where, kernel_obj, fields, inertia=None):
    """Twin of cgbound.rotation_fields, flat over nodes with the pseudo-vector index always present
    (length 3 in 3D, 1 in 2D): spin_density (P, T), spin_flux (P, T, D), couple_stress (P, T, D),
    stress_torque_density and boundary_couple_density (P, T). Contacts are walked one by one."""
    kernel = oracle_kernel_of(kernel_obj, snap.dim)
    box = snap.box
    tgt = oracle_target(where, box)
    D = snap.dim
    T = 3 if D == 3 else 1
    P = tgt[0].shape[0]
    lengths = [box.upper[d] - box.lower[d] for d in range(D)]
    X = np.asarray(snap.positions)
    fixed = np.asarray(snap.fixed)
    out = {}
    if set(fields) & {"spin_density", "angular_momentum_density", "spin_flux", "kinetic_spin_flux"}:
        if inertia is None:
            r = np.asarray(snap.radii)
            inertia = (0.4 if D == 3 else 0.5) * np.asarray(snap.masses) * r * r
        w = np.asarray(snap.angular_velocities, float).reshape(len(X), T)
        s = np.zeros((P, T))
        J = np.zeros((P, T * D))
        for i in range(len(X)):
            if fixed[i]:
                continue
            s += oracle_scatter_points(kernel, tgt, X[i][None], (inertia[i] * w[i])[None])
            if "spin_flux" in fields:
                J += oracle_scatter_points(kernel, tgt, X[i][None],
                                           np.outer(inertia[i] * w[i], snap.velocities[i]).reshape(1, -1))
        out["spin_density"] = out["angular_momentum_density"] = s
        out["spin_flux"] = J.reshape(P, T, D)
        if "kinetic_spin_flux" in fields:       # about each node's own velocity, particle by particle
            flow = ~fixed
            m = np.asarray(snap.masses)[flow]
            rho = oracle_scatter_points(kernel, tgt, X[flow], m[:, None])[:, 0]
            p = oracle_scatter_points(kernel, tgt, X[flow], m[:, None] * np.asarray(snap.velocities)[flow])
            V = np.where(rho[:, None] > 0, p / np.where(rho > 0, rho, 1.0)[:, None], 0.0)
            K = np.zeros((P, T, D))
            for i in np.flatnonzero(flow):
                wi = oracle_scatter_points(kernel, tgt, X[i][None], np.ones((1, 1)))[:, 0]
                dv = snap.velocities[i][None, :] - V
                K += (wi[:, None, None] * (inertia[i] * w[i])[None, :, None]) * dv[:, None, :]
            out["kinetic_spin_flux"] = K
    m = np.zeros((P, T * D))
    pair = np.zeros((P, T))
    wall = np.zeros((P, T))
    c = snap.contacts
    for k in range(len(c)):
        i, j = int(c.i[k]), int(c.j[k])
        f, pt = np.array(c.force[k]), np.array(c.point[k])
        fi = bool(fixed[i])
        fj = True if j < 0 else bool(fixed[j])
        if fi and fj:
            continue
        if fi:                       # seen from the flowing particle j
            i, f = j, -f
        halves = []
        a_i = oracle_minimum_image(X[i] - pt, box.periodic, lengths)
        halves.append((i, f, a_i))
        if not fi and not fj:
            point = X[i] - a_i
            a_j = oracle_minimum_image(X[j] - point, box.periodic, lengths)
            halves.append((j, -f, a_j))
            r_ij = oracle_minimum_image(X[i] - X[j], box.periodic, lengths)
            pair += oracle_scatter_points(kernel, tgt, point[None], _oracle_cross(f, r_ij)[None])
        else:
            wall += oracle_scatter_points(kernel, tgt, (X[i] - a_i)[None], _oracle_cross(X[i] - a_i - X[i], f)[None])
        for p, fp, a in halves:
            tau = _oracle_cross(-a, fp)               # (c - r_p) x f
            m += oracle_scatter_segments(kernel, tgt, X[p][None], -a[None], -np.outer(tau, a).reshape(1, -1))
    out["couple_stress"] = m.reshape(P, T, D)
    out["stress_torque_density"] = pair
    out["boundary_couple_density"] = wall
    return {name: out[name] for name in fields}


# ---------------------------------------------------------------------------
# rings (csrc/cg_ring.c): the angular moments of the 3-D kernel over a ring's arc

_RING_X, _RING_W = np.polynomial.legendre.leggauss(20)


def _oracle_ring_rule(panels=8, ratio=0.25):
    """Points and weights on [0, 1]: ``panels`` Gauss-Legendre panels graded by ``ratio`` towards 0."""
    edges = np.concatenate([[0.0], ratio ** np.arange(panels - 1, -1, -1)])
    xs = [a + (b - a) * 0.5 * (_RING_X + 1.0) for a, b in zip(edges[:-1], edges[1:])]
    ws = [0.5 * (b - a) * _RING_W for a, b in zip(edges[:-1], edges[1:])]
    return np.concatenate(xs), np.concatenate(ws)


def _oracle_kernel_3d(kernel):
    """W(d²) of the full 3-D kernel (OracleKernel's)."""
    twin = oracle_kernel_of(kernel, 3)
    return lambda d2: twin.marginal(d2, 3, 1.0)


def _oracle_kernel_gradient_factor_3d(kernel):
    """G(d²) = W'(d) / d of the full 3-D kernel (grad W(x) = G x), from the textbook derivatives: the Gaussian's
    -W / w², Lucy's d/dd [C (1 + 3x)(1 - x)³] / d = -12 C (1 - x)² / R² (x = d / R), factored so that it
    stays exact at d = 0."""
    twin = oracle_kernel_of(kernel, 3)
    if twin.kind == "gaussian":
        return lambda d2: -twin.marginal(d2, 3, 1.0) / twin.w**2
    if twin.kind == "lucy":
        R = twin.R
        C = 105 / (16 * math.pi * R**3)
        return lambda d2: np.where(d2 < R * R, -12 * C * (1 - np.sqrt(np.minimum(d2, R * R)) / R) ** 2 / R**2, 0.0)
    raise ValueError("no gradient of the Heaviside kernel")


def oracle_ring_moments(kernel, r, h, rho, gradient=False, n_moments=3):
    """Twin of cg_ring_moments: (n_moments, n) moments M_m = (1/π) ∫_0^Δ W(d(t)) cos(m t) dt by a graded composite
    Gauss-Legendre rule (8 panels x 20 points for every kernel; Heaviside's closed form); with ``gradient``
    those of G = W'(d) / d."""
    h, rho = np.asarray(h, dtype=float), np.asarray(rho, dtype=float)
    c = float(kernel.radius)
    W = _oracle_kernel_gradient_factor_3d(kernel) if gradient else _oracle_kernel_3d(kernel)
    d0sq = (r - rho) ** 2 + h * h
    rr = r * rho
    inside = d0sq < c * c
    with np.errstate(divide="ignore", invalid="ignore"):
        s2 = np.where(rr > 0, (c * c - d0sq) / np.where(rr > 0, 4.0 * rr, 1.0), 1.0)
    half = 2.0 * np.arcsin(np.sqrt(np.clip(s2, 0.0, 1.0)))
    if kernel.kind == 2:
        w0 = W(d0sq)
        M = np.stack([w0 * half] + [w0 * np.sin(m * half) / m for m in range(1, n_moments)]) / math.pi
    else:
        x, w = _oracle_ring_rule()
        t = half[:, None] * x
        s = np.sin(0.5 * t)
        values = W(np.minimum(d0sq[:, None] + 4.0 * rr[:, None] * s * s, c * c)) * (half[:, None] * w)
        M = np.stack([(values * np.cos(m * t)).sum(axis=1) for m in range(n_moments)]) / math.pi
    M[:, ~inside] = 0.0
    M[1:, rr == 0] = 0.0
    return M


def oracle_ring_tensor_sum(kernel, r, h, rho, cos_phi, sin_phi, weight, which, tensors, gradient=False):
    """Twin of cg_ring_tensor_sum by the θ-average itself: (1/2π) ∫_{-Δ}^{Δ} W(d(t)) B(φ + t) T B(φ + t)ᵀ dt per
    source (B the rows e_r, e_θ, e_z at the node's angle), the graded rule at ±t; (3, 3). With ``gradient`` the
    θ-average of B T Bᵀ ⊗ B ∇W(x - q), ∇W = G(d) (x - q) with x - q = (r cos θ - ρ cos φ, r sin θ - ρ sin φ, h)
    in Cartesian components: (3, 3, 3), the derivative's index last."""
    c = float(kernel.radius)
    W = _oracle_kernel_gradient_factor_3d(kernel) if gradient else _oracle_kernel_3d(kernel)
    x, w = _oracle_ring_rule()
    out = np.zeros((3, 3, 3) if gradient else (3, 3))
    for i in range(len(h)):
        d0sq = (r - rho[i]) ** 2 + h[i] ** 2
        if not d0sq < c * c:
            continue
        rr = r * rho[i]
        half = math.pi if rr == 0 or (c * c - d0sq) >= 4 * rr else 2 * math.asin(math.sqrt((c * c - d0sq) / (4 * rr)))
        phi = math.atan2(sin_phi[i], cos_phi[i])
        T = tensors[which[i]].reshape(3, 3)
        for sign in (1.0, -1.0):
            t = sign * half * x
            theta = phi + t
            B = np.zeros((len(t), 3, 3))
            B[:, 0, 0], B[:, 0, 1] = np.cos(theta), np.sin(theta)
            B[:, 1, 0], B[:, 1, 1] = -np.sin(theta), np.cos(theta)
            B[:, 2, 2] = 1.0
            values = W(np.minimum(d0sq + 4.0 * rr * np.sin(0.5 * t) ** 2, c * c)) * half * w / (2 * math.pi)
            if not gradient:
                out += weight[i] * np.einsum("q,qia,ab,qjb->ij", values, B, T, B)
                continue
            apart = np.stack([r * np.cos(theta) - rho[i] * cos_phi[i], r * np.sin(theta) - rho[i] * sin_phi[i],
                              np.full(len(t), h[i])], axis=1)
            out += weight[i] * np.einsum("q,qia,ab,qjb,qkc,qc->ijk", values, B, T, B, B, apart)
    return out


def _oracle_segment_points(z, segment, lo, hi, panels, geometry, weight):
    """The s-points of cg_ring_segment_sum's pieces (20-point Gauss-Legendre in u on each piece's panels,
    s = lo + (hi - lo) sin²(π u / 2)): their (h, ρ, cos φ, sin φ, weight, segment)."""
    x, w = np.polynomial.legendre.leggauss(20)
    x, w = 0.5 * (x + 1.0), 0.5 * w
    h, rho, cphi, sphi, wt, which = [], [], [], [], [], []
    for q in range(len(lo)):
        g = geometry[segment[q]]
        P = panels[q]
        for jp in range(P):
            u = (jp + x) / P
            s = lo[q] + (hi[q] - lo[q]) * np.sin(0.5 * math.pi * u) ** 2
            p1, p2 = g[0] + s * g[3], g[1] + s * g[4]
            rr = np.hypot(p1, p2)
            rho.append(rr)
            cphi.append(np.where(rr > 0, p1 / np.where(rr > 0, rr, 1.0), 1.0))
            sphi.append(np.where(rr > 0, p2 / np.where(rr > 0, rr, 1.0), 0.0))
            h.append(z - g[2] - s * g[5])
            wt.append((hi[q] - lo[q]) * w * 0.5 * math.pi * np.sin(math.pi * u) / P * weight)
            which.append(np.full(len(u), segment[q]))
    cat = [np.concatenate(a) if a else np.zeros(0) for a in (h, rho, cphi, sphi, wt, which)]
    return cat[:5] + [cat[5].astype(int)]


def oracle_ring_segment_sum(kernel, r, z, segment, lo, hi, panels, geometry, tensors, weight, gradient=False):
    """Twin of cg_ring_segment_sum (with ``gradient``, of cg_ring_segment_gradient_sum): the s-points of each piece
    and their θ-averages by oracle_ring_tensor_sum; (3, 3), with ``gradient`` (3, 3, 3)."""
    points = _oracle_segment_points(z, segment, lo, hi, panels, geometry, weight)
    return oracle_ring_tensor_sum(kernel, r, *points, tensors, gradient=gradient)


def oracle_outer_values(factors, vectors):
    """Twin of the values _core.scatter_segments_outer forms per segment: factors_r * vectors_c, flat (n, F*D),
    each as NumPy's einsum "ni,nj->nij" gives it (0.0 + the product: a zero is +0)."""
    factors, vectors = np.asarray(factors, float), np.asarray(vectors, float)
    return (0.0 + factors[:, :, None] * vectors[:, None, :]).reshape(factors.shape[0], -1)


def oracle_kinetic_values(masses, velocities, u_ref, parts):
    """Twin of the values _core.scatter_points_kinetic forms per particle: the parts (1 m, 2 m (v - u_ref), 4
    m (v_r v_c) for r <= c, row by row) side by side, flat (n, K), each product as NumPy rounds it."""
    m, v, u = np.asarray(masses, float), np.asarray(velocities, float), np.asarray(u_ref, float)
    cols = []
    if parts & 1:
        cols.append(m[:, None])
    if parts & 2:
        cols.append(m[:, None] * (v - u))
    if parts & 4:
        rows, columns = np.triu_indices(v.shape[1])
        cols.append(m[:, None] * (v[:, :, None] * v[:, None, :])[:, rows, columns])
    return np.hstack(cols)


def oracle_one_listing_per_pair(i, jraw, force, point, radii, fixed, rtol):
    """Twin of MercuryReader's .fstat pairing (cgbound/readers/mercury.py): which lines to keep (N bools; wall
    lines False), or the ValueError's kind ("too many", "inconsistent", "once") for the pair whose first line
    comes first. A plain loop: the pair lines grouped in a dict by their pair, in file order."""
    keep = np.zeros(i.shape, bool)
    scale = float(np.max(np.linalg.norm(force, axis=1))) if len(force) else 0.0
    lscale = 2.0 * float(np.max(radii)) if radii.size else 1.0
    groups = {}
    for k in np.flatnonzero(jraw >= 0):
        groups.setdefault((min(i[k], jraw[k]), max(i[k], jraw[k])), []).append(int(k))
    pairs = sorted(groups.values(), key=lambda ks: ks[0])          # by the pair's first line
    for ks in pairs:
        if len(ks) > 2 or (len(ks) == 2 and i[ks[0]] == i[ks[1]]):
            return "too many"
        if len(ks) == 2:
            p, q = ks
            if (np.linalg.norm(force[p] + force[q]) > rtol * max(scale, 1e-300)
                    or np.linalg.norm(point[p] - point[q]) > rtol * lscale):
                return "inconsistent"
    for ks in pairs:
        if len(ks) == 1 and not fixed[i[ks[0]]] and not fixed[jraw[ks[0]]]:
            return "once"
    for ks in pairs:
        keep[ks[0] if len(ks) == 1 or i[ks[0]] < i[ks[1]] else ks[1]] = True
    return keep


def oracle_axial_segment_sum(kernel, bottoms, column, first, segment, lo, hi, panels, starts, vectors, values):
    """Twin of cg_axial_segment_sum: per column, the s-points of each of its pieces (20-point Gauss-Legendre in u on
    its panels, s = lo + (hi - lo) sin²(π u / 2)), at each the kernel's line integral along ``column`` from the
    column's bottom (OracleKernel.line), times the piece's segment's values; (n_columns, 9)."""
    k = oracle_kernel_of(kernel, 3)
    x, w = np.polynomial.legendre.leggauss(20)
    x, w = 0.5 * (x + 1.0), 0.5 * w
    out = np.zeros((len(bottoms), 9))
    for c in range(len(bottoms)):
        for q in range(first[c], first[c + 1]):
            a, b, P = starts[segment[q]], vectors[segment[q]], panels[q]
            total = 0.0
            for jp in range(P):
                u = (jp + x) / P
                s = lo[q] + (hi[q] - lo[q]) * np.sin(0.5 * math.pi * u) ** 2
                weight = (hi[q] - lo[q]) * 0.5 * math.pi * np.sin(math.pi * u) * w / P
                psi = k.line(bottoms[c][None, :] - (a[None, :] + s[:, None] * b[None, :]), column, 3, 1.0)
                total += float(np.sum(weight * psi))
            out[c] += total * values[segment[q]]
    return out


# the problems of oracle_fstat_contacts, numbered as cg_fstat.h numbers them
FSTAT_PROBLEMS = {"time": 1, "particle": 2, "ghost": 3, "self": 4, "flat": 5, "repeated": 6, "inconsistent": 7,
                  "once": 8}


def oracle_fstat_contacts(rows, partners, time, time_tolerance, positions, radii, fixed, periodic, period, rtol):
    """Twin of _core.fstat_contacts (cg_fstat_contacts): MercuryReader's NumPy per-contact work on a .fstat
    frame as it was before the C pass (the time check, the partners' checks, the forces on i with their
    orientation, the pairing with its in-turn fast path and its general path by a sort, the walls).

    Returns what the core returns: (0, (), (i, j, wall, force, point, overlap)), or (problem, (row, other_row,
    pair_lo, pair_hi, count, df, dc, force_row, force_other), None) with the entries the problem has (others
    -1 or 0.0)."""
    rows, partners = np.asarray(rows, float), np.asarray(partners, np.int64)
    positions = np.asarray(positions, float)
    n, d = positions.shape
    fixed = np.asarray(fixed, bool)

    def problem(kind, row, other_row=-1, lo=-1, hi=-1, count=0, df=0.0, dc=0.0, f1=(0.0,) * 3, f2=(0.0,) * 3):
        return FSTAT_PROBLEMS[kind], (int(row), int(other_row), int(lo), int(hi), int(count), float(df), float(dc),
                                      tuple(f1) + (0.0,) * (3 - len(f1)), tuple(f2) + (0.0,) * (3 - len(f2))), None

    off = np.abs(rows[:, 0] - time) > time_tolerance
    if np.any(off):
        return problem("time", np.flatnonzero(off)[0])
    i, jraw = partners[:, 0].copy(), partners[:, 1].copy()
    for kind, bad in (("particle", (i < 0) | (i >= n)), ("ghost", jraw >= n), ("self", jraw == i)):
        if np.any(bad):
            return problem(kind, np.flatnonzero(bad)[0])
    point = rows[:, 3:3 + d]
    overlap = rows[:, 6]
    arm = positions[i] - point
    if any(periodic):
        arm = oracle_minimum_image(arm, periodic, period)
    # the forces on i: s (fn n + ft t), s = sign(n . arm)
    fn, ft = rows[:, 8], rows[:, 9]
    normal, tang = rows[:, 10:10 + d], rows[:, 13:13 + d]
    proj = np.einsum("ij,ij->i", normal, arm)
    bound = 2.0 * math.sqrt(d) * float(np.abs(arm).max(initial=0.0))
    near = np.flatnonzero(np.abs(proj) <= 1e-12 * max(bound, 1e-300))
    arm_near = arm[near]
    flat = near[(np.abs(proj[near]) <= 1e-12 * np.maximum(np.linalg.norm(arm_near, axis=1), 1e-300))
                & ((fn[near] != 0) | (ft[near] != 0))]
    if flat.size:
        return problem("flat", flat[0])
    force = fn[:, None] * normal
    force += ft[:, None] * tang
    np.negative(force, out=force, where=(proj < 0)[:, None])
    # the pairing
    wall = jraw < 0
    keep = np.zeros(i.shape, bool)
    lines = np.flatnonzero(jraw >= 0)
    if lines.size:
        scale = math.sqrt(float(np.max(_squared_norms(force))))
        lscale = 2.0 * float(np.max(radii)) if np.size(radii) else 1.0
        tol_force, tol_point = rtol * max(scale, 1e-300), rtol * lscale
        first = oracle_lines_in_turn(i, jraw, force, point, lines, tol_force, tol_point)
        if first is not None:
            keep[first] = True
        else:
            lo, hi = np.minimum(i, jraw)[lines], np.maximum(i, jraw)[lines]
            order = np.lexsort((lines, hi, lo))         # by pair, then line
            slo, shi, sline = lo[order], hi[order], lines[order]
            first = np.flatnonzero(np.r_[True, (slo[1:] != slo[:-1]) | (shi[1:] != shi[:-1])])
            count = np.diff(np.r_[first, slo.size])
            k1 = sline[first]
            two = count == 2
            k2 = np.where(two, sline[np.minimum(first + 1, slo.size - 1)], k1)
            too_many = (count > 2) | (two & (i[k1] == i[k2]))
            df = np.linalg.norm(force[k1] + force[k2], axis=1)
            dc = np.linalg.norm(point[k1] - point[k2], axis=1)
            inconsistent = two & ~too_many & ((df > tol_force) | (dc > tol_point))
            bad = np.flatnonzero(too_many | inconsistent)
            if bad.size:
                g = int(bad[np.argmin(k1[bad])])
                a, b = slo[first[g]], shi[first[g]]
                if too_many[g]:
                    return problem("repeated", k1[g], lo=a, hi=b, count=count[g])
                p, q = int(k1[g]), int(k2[g])
                return problem("inconsistent", p, q, a, b, 2, df[g], dc[g], force[p].tolist(), force[q].tolist())
            lonely = (count == 1) & ~fixed[i[k1]] & ~fixed[jraw[k1]]
            if np.any(lonely):
                return problem("once", np.min(k1[lonely]))
            keep[k1[count == 1]] = True
            p, q = k1[two], k2[two]
            keep[np.where(i[p] < i[q], p, q)] = True
    sel = np.flatnonzero(wall | keep)
    return 0, (), (i[sel], np.where(wall, -1, jraw)[sel], np.where(wall, -1 - jraw, -1)[sel],
                   np.ascontiguousarray(force[sel]), np.ascontiguousarray(point[sel]), overlap[sel].copy())


def oracle_lines_in_turn(i, jraw, force, point, lines, tol_force, tol_point):
    """The in-turn fast path of oracle_fstat_contacts (MercuryReader's NumPy lines_in_turn as it was): the kept
    line of each pair when the pair lines come in turn (each pair from both sides on consecutive pair lines, no
    pair twice, opposite forces and the same contact point within the tolerances); None otherwise."""
    if lines.size % 2:
        return None
    a, b = lines[0::2], lines[1::2]
    ia, ja, ib, jb = i[a], jraw[a], i[b], jraw[b]
    if not (np.array_equal(ia, jb) and np.array_equal(ja, ib)):
        return None
    lo, hi = np.minimum(ia, ja), np.maximum(ia, ja)
    key = np.sort(lo * (int(hi.max()) + 1) + hi)
    if np.any(key[1:] == key[:-1]):
        return None
    df = math.sqrt(float(np.fmax.reduce(_squared_norms(force[a] + force[b]))))
    dc = math.sqrt(float(np.fmax.reduce(_squared_norms(point[a] - point[b]))))
    if df > tol_force or dc > tol_point:
        return None
    return np.where(ia < ib, a, b)


def _squared_norms(vectors):
    """x . x of each row, summed as np.linalg.norm sums them."""
    return np.add.reduce(vectors * vectors, axis=1)


def oracle_ring_segment_columns(kernel, rings, first, segment, lo, hi, panels, geometry, tensors, gradient=False):
    """Twin of cg_ring_segment_columns: per ring (r, z, weight) of ``rings``, oracle_ring_segment_sum over its pieces
    first[c]:first[c + 1]; (C, 9), with ``gradient`` (C, 27)."""
    rings, first = np.asarray(rings, float), np.asarray(first)
    out = np.zeros((len(rings), 27 if gradient else 9))
    for c, (r, z, weight) in enumerate(rings):
        part = slice(int(first[c]), int(first[c + 1]))
        if first[c + 1] > first[c]:
            out[c] = oracle_ring_segment_sum(kernel, r, z, segment[part], lo[part], hi[part], panels[part], geometry,
                                             tensors, weight, gradient=gradient).ravel()
    return out


def oracle_ring_axial_point_sum(kernel, r, lo, hi, xy, zeta, tensors, weights):
    """Twin of cg_ring_axial_point_sum, source by source: z cut at ζ ± (0, H, w) (the support's edge
    H = √(c² - (r - ρ)²), the whole ring's w = √(c² - (r + ρ)²)) and graded by 1/4 (26 levels) towards branch points
    just off the cuts (±i √((r + ρ)² - c²) when the ring just misses holding the support, Lucy's ±i ``|r - ρ|``, the
    mirror -w); per piece 24-point Gauss-Legendre in u through x = (3u - u³)/2, the Gaussian's in panels of at
    most 5 widths, a box end inside a piece clipped in u (the root of the cubic by numpy.roots); the moments by
    oracle_ring_moments; the θ-average of B T Bᵀ from M₀, M₁, M₂ written out per component. (3, 3)."""
    c = float(kernel.radius)
    G, GW = np.polynomial.legendre.leggauss(24)
    panels = 1
    if kernel.kind == 0:
        panels = max(1, math.ceil(c / (5.0 * float(kernel.width)) - 1e-9))
    grades = 0.25 ** np.arange(1, 27)
    out = np.zeros((3, 3))
    tensors = np.asarray(tensors, float).reshape(-1, 3, 3)

    def inverse(x):                                 # the u in [-1, 1] with (3u - u³)/2 = x
        roots = np.roots([-0.5, 0.0, 1.5, -x])
        roots = roots[np.abs(roots.imag) < 1e-9].real
        return float(roots[np.argmin(np.abs(np.clip(roots, -1, 1) - roots))])

    for j in range(len(zeta)):
        rho = math.hypot(xy[j][0], xy[j][1])
        H = math.sqrt(max(c * c - (r - rho) ** 2, 0.0))
        whole = math.sqrt(max(c * c - (r + rho) ** 2, 0.0))
        near = math.inf if whole > 0 else math.sqrt(max((r + rho) ** 2 - c * c, 0.0))
        if kernel.kind == 1:
            near = min(near, abs(r - rho))
        cuts = [0.0, H, whole]
        inner = whole if whole > 0 else H
        if near < 0.25 * inner:
            cuts += [max(inner * g, near) for g in grades]
        if whole > 0 and 2 * whole < 0.25 * (H - whole):
            cuts += [whole + max((H - whole) * g, 2 * whole) for g in grades]
        edges = sorted(set([zeta[j] - x for x in cuts] + [zeta[j] + x for x in cuts]))
        hs, ws = [], []
        for a, b in zip(edges[:-1], edges[1:]):
            if not (b > lo and a < hi):
                continue
            u_lo = -1.0 if a >= lo else inverse(2 * (lo - a) / (b - a) - 1)
            u_hi = 1.0 if b <= hi else inverse(2 * (hi - a) / (b - a) - 1)
            for p in range(panels):
                u = u_lo + (u_hi - u_lo) * (p + 0.5 * (G + 1)) / panels
                x, dx = 0.5 * (3 * u - u ** 3), 1.5 * (1 - u * u)
                hs.append(a + (b - a) * 0.5 * (x + 1) - zeta[j])
                ws.append(0.25 * (b - a) * (u_hi - u_lo) * dx * GW / panels / (hi - lo))
        if not hs:
            continue
        h, w = np.concatenate(hs), np.concatenate(ws)
        M0, M1, M2 = (oracle_ring_moments(kernel, r, h, np.full(h.size, rho)) * w).sum(axis=1)
        cphi, sphi = (xy[j][0] / rho, xy[j][1] / rho) if rho > 0 else (1.0, 0.0)
        B = np.array([[cphi, sphi, 0.0], [-sphi, cphi, 0.0], [0.0, 0.0, 1.0]])
        T = B @ tensors[j] @ B.T * weights[j]            # in the source's own basis at θ = φ
        cc, ss = 0.5 * (M0 + M2), 0.5 * (M0 - M2)         # E[cos² t], E[sin² t]; E[cos t] = M₁
        out += np.array([[cc * T[0, 0] + ss * T[1, 1], cc * T[0, 1] - ss * T[1, 0], M1 * T[0, 2]],
                         [cc * T[1, 0] - ss * T[0, 1], ss * T[0, 0] + cc * T[1, 1], M1 * T[1, 2]],
                         [M1 * T[2, 0], M1 * T[2, 1], M0 * T[2, 2]]])
    return out


_QUARTIC_COS = (0.92106099400288510, -0.38941834230865050, -0.92106099400288510, 0.38941834230865050)
_QUARTIC_SIN = (0.38941834230865050, 0.92106099400288510, -0.38941834230865050, -0.92106099400288510)


def oracle_quartic_roots(coef):
    """Twin of cg_quartic_roots, row by row in Python floats (the same operations in the same order, so the same
    bits): Aberth-Ehrlich sweeps on the monic quartic from four points on the Fujiwara circle at angles
    π k / 2 + 0.4, each root updated in turn, until every step is at most 2⁻⁵² of its root (at most 200 sweeps).
    (n, 4) complex."""
    coef = np.asarray(coef, float)
    out = np.zeros((len(coef), 4), complex)
    tol = 2.220446049250313e-16
    for i, a in enumerate(coef):
        b = [float(a[1]) / float(a[0]), float(a[2]) / float(a[0]), float(a[3]) / float(a[0]), float(a[4]) / float(a[0])]
        R = max(abs(b[0]), math.sqrt(abs(b[1])), math.cbrt(abs(b[2])), math.sqrt(math.sqrt(abs(b[3]) * 0.5)))
        R = 2.0 * R if R > 0.0 else 1.0
        re = [R * cc for cc in _QUARTIC_COS]
        im = [R * ss for ss in _QUARTIC_SIN]
        for _ in range(200):
            done = True
            for k in range(4):
                x, y = re[k], im[k]
                pr, pi, dr, di = 1.0, 0.0, 0.0, 0.0
                for j in range(4):
                    dr, di = dr * x - di * y + pr, dr * y + di * x + pi
                    pr, pi = pr * x - pi * y + b[j], pr * y + pi * x
                if pr == 0.0 and pi == 0.0:
                    continue
                dd = dr * dr + di * di
                nr, ni = ((pr * dr + pi * di) / dd, (pi * dr - pr * di) / dd) if dd > 0.0 else (pr, pi)
                sr = si = 0.0
                for j in range(4):
                    if j == k:
                        continue
                    ur, ui = x - re[j], y - im[j]
                    uu = ur * ur + ui * ui
                    if uu > 0.0:
                        sr += ur / uu
                        si -= ui / uu
                qr, qi = 1.0 - (nr * sr - ni * si), -(nr * si + ni * sr)
                qq = qr * qr + qi * qi
                wr, wi = ((nr * qr + ni * qi) / qq, (ni * qr - nr * qi) / qq) if qq > 0.0 else (nr, ni)
                re[k], im[k] = x - wr, y - wi
                if wr * wr + wi * wi > tol * tol * (re[k] * re[k] + im[k] * im[k]):
                    done = False
            if done:
                break
        out[i] = np.array(re) + 1j * np.array(im)
    return out
