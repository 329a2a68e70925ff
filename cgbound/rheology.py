"""Ratios of stress components of a coarse-grained Result, and the mu(I) friction law fitted to (I, mu)
(docs/theory.md, "Gradients, kinematics and rheology").

The rheology fields themselves (shear rate, shear stress, friction, inertial number, ...) are in
:data:`cgbound.fields.FIELDS`; this module reads components of a Result's stress and fits the
Jop-Forterre-Pouliquen law to friction against inertial number (notebook 05).
"""
import numpy as np

from .fields import STRESS_FIELDS


def _component(name, axis_names, argument):
    if not isinstance(name, str) or len(name) != 2 or any(c not in axis_names for c in name):
        raise ValueError(f"{argument}: expected a component as two axis names from {''.join(axis_names)!r} "
                         f"(e.g. 'xz'), got {name!r}")
    return axis_names.index(name[0]), axis_names.index(name[1])


def stress_ratio(result, numerator="xz", denominator="zz", field="stress"):
    """sigma_numerator / sigma_denominator of a stress field of ``result``, node by node.

    The ratio is the same in the tension and the compression conventions (both components change
    sign). NaN where the denominator is zero. On a chute inclined at theta, with x down the slope
    and z normal to the base, steady uniform flow has sigma_xz / sigma_zz = -tan(theta): the
    macroscopic friction is ``-stress_ratio(result, "xz", "zz")``.

    Parameters
    ----------
    result : cgbound.Result
        With ``field`` among its fields.
    numerator, denominator : str
        Components as two axis names ("xz"; in 2D the axes are x and z).
    field : str
        One of the stress fields (``stress``, ``extended_stress``, ``contact_stress``, ...).
    """
    if not isinstance(field, str) or field not in STRESS_FIELDS:
        raise ValueError(f"field: expected one of {', '.join(STRESS_FIELDS)}, got {field!r}")
    if not (hasattr(result, "fields") and hasattr(result, "box")):
        raise TypeError(f"result: expected a cgbound.Result, got {type(result).__name__}")
    if field not in result.fields:
        raise ValueError(f"result: expected the field {field!r} among its fields, got {', '.join(result.fields)}")
    names = tuple(result.box.axis_names)
    a, b = _component(numerator, names, "numerator")
    c, d = _component(denominator, names, "denominator")
    sigma = result[field]
    num, den = sigma[..., a, b], sigma[..., c, d]
    out = np.full(num.shape, np.nan)
    np.divide(num, den, out=out, where=den != 0)
    return out


class MuOfIFit:
    """The Jop-Forterre-Pouliquen friction law mu(I) = mu_s + (mu_2 - mu_s) / (1 + I_0 / I) fitted to (I, mu).

    Attributes: ``mu_s``, ``mu_2``, ``i_0``; ``errors`` (their standard errors, the square roots of the
    diagonal of ``covariance``, ordered mu_s, mu_2, I_0); ``chi2`` (the weighted sum of squared residuals),
    ``dof`` (points minus 3). Call the fit on I to evaluate the law.
    """

    def __init__(self, mu_s, mu_2, i_0, covariance, chi2, dof):
        self.mu_s, self.mu_2, self.i_0 = float(mu_s), float(mu_2), float(i_0)
        self.covariance, self.chi2, self.dof = covariance, float(chi2), int(dof)
        self.errors = np.sqrt(np.diag(covariance))

    def __call__(self, inertial_number):
        return mu_of_i(inertial_number, self.mu_s, self.mu_2, self.i_0)

    def __repr__(self):
        e = self.errors
        return (f"<MuOfIFit mu_s = {self.mu_s:.4f} ± {e[0]:.4f}, mu_2 = {self.mu_2:.4f} ± {e[1]:.4f}, "
                f"I_0 = {self.i_0:.4f} ± {e[2]:.4f}; chi2 = {self.chi2:.3g} for {self.dof} degrees of freedom>")


def mu_of_i(inertial_number, mu_s, mu_2, i_0):
    """mu_s + (mu_2 - mu_s) / (1 + i_0 / I) (Jop, Forterre & Pouliquen, Nature 441, 727 (2006))."""
    i = np.asarray(inertial_number, float)
    return mu_s + (mu_2 - mu_s) * i / (i + i_0)


def _linear_part(i, mu, weight, i_0):
    """For a fixed I_0 the law is linear in (mu_s, mu_2): their weighted least squares and the chi2."""
    g = i / (i + i_0)
    design = np.stack([1.0 - g, g], axis=1) * weight[:, None]
    coef, *_ = np.linalg.lstsq(design, mu * weight, rcond=None)
    residual = design @ coef - mu * weight
    return coef, float(residual @ residual)


def fit_mu_of_i(inertial_number, friction, sigma=None, i_0_range=(1e-4, 1e2)):
    """Fit mu(I) = mu_s + (mu_2 - mu_s) / (1 + I_0 / I) by least squares; returns a :class:`MuOfIFit`.

    The law is linear in mu_s and mu_2 for a given I_0, so those are solved exactly and only I_0 is
    searched (a log-spaced scan of ``i_0_range`` refined by golden sections; variable projection).
    The covariance is the inverse of J^T W J at the minimum (J the Jacobian of the law): with
    ``sigma`` (standard errors of ``friction``) it is taken as absolute, without it scaled by
    chi2 / dof, like scipy.optimize.curve_fit.

    Parameters
    ----------
    inertial_number, friction : (n,) arrays, n >= 4 (three parameters and one degree of freedom)
    sigma : (n,) array, optional
        Standard errors of ``friction`` (positive).
    i_0_range : (float, float)
        Where I_0 is searched (0 < low < high).
    """
    i = np.asarray(inertial_number, float).reshape(-1)
    mu = np.asarray(friction, float).reshape(-1)
    if i.size != mu.size:
        raise ValueError(f"friction: expected as many values as inertial_number ({i.size}), got {mu.size}")
    if i.size < 4:
        raise ValueError(f"inertial_number: expected at least 4 points for 3 parameters, got {i.size}")
    if not (np.all(np.isfinite(i)) and np.all(i > 0)):
        raise ValueError("inertial_number: expected finite positive values")
    if not np.all(np.isfinite(mu)):
        raise ValueError("friction: expected finite values")
    if np.unique(i).size < 3:
        raise ValueError("inertial_number: expected at least 3 distinct values")
    if sigma is None:
        weight = np.ones_like(mu)
    else:
        sigma = np.asarray(sigma, float).reshape(-1)
        if sigma.shape != mu.shape or not (np.all(np.isfinite(sigma)) and np.all(sigma > 0)):
            raise ValueError(f"sigma: expected {mu.size} finite positive standard errors, got {sigma!r}")
        weight = 1.0 / sigma
    low, high = (float(v) for v in i_0_range)
    if not (np.isfinite(low) and np.isfinite(high) and 0 < low < high):
        raise ValueError(f"i_0_range: expected (low, high) with 0 < low < high, got {i_0_range!r}")

    def chi2(log_i0):
        return _linear_part(i, mu, weight, np.exp(log_i0))[1]
    grid = np.linspace(np.log(low), np.log(high), 400)
    values = np.array([chi2(x) for x in grid])
    k = int(np.argmin(values))
    a, b = grid[max(k - 1, 0)], grid[min(k + 1, grid.size - 1)]
    ratio = (np.sqrt(5.0) - 1.0) / 2.0
    c, d = b - ratio * (b - a), a + ratio * (b - a)
    for _ in range(200):
        if chi2(c) < chi2(d):
            b = d
        else:
            a = c
        c, d = b - ratio * (b - a), a + ratio * (b - a)
        if b - a < 1e-12:
            break
    i_0 = float(np.exp(0.5 * (a + b)))
    (mu_s, mu_2), best = _linear_part(i, mu, weight, i_0)
    g = i / (i + i_0)
    jacobian = np.stack([1.0 - g, g, -(mu_2 - mu_s) * i / (i + i_0) ** 2], axis=1) * weight[:, None]
    covariance = np.linalg.pinv(jacobian.T @ jacobian)
    dof = i.size - 3
    if sigma is None:
        covariance = covariance * (best / dof if dof > 0 else np.inf)
    return MuOfIFit(mu_s, mu_2, i_0, covariance, best, dof)
