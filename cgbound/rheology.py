"""Ratios of stress components of a coarse-grained Result (docs/theory.md, "Gradients, kinematics and rheology").

The rheology fields themselves (shear rate, shear stress, friction, inertial number, ...) are in
:data:`cgbound.fields.FIELDS`; this module reads components of a Result's stress.
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
