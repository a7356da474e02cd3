"""Read a variant and evaluate it at operating points of your own: the contact states that `cvtdesign compare
--points` writes over the envelope (io.points), at any γ and τ⊥."""
from __future__ import annotations

import numpy as np

from cvtdesign.core.inputs import uncertain_model
from cvtdesign.core.layout import Layout
from cvtdesign.core.metrics import at_points
from cvtdesign.errors import InputError
from cvtdesign.io import variant as variant_file
from cvtdesign.io.limits import check_loads, check_points
from cvtdesign.io.points import contact_points, points_frame


def load_variant(path) -> Layout:
    """Read, validate and resolve a variant file.

    Parameters
    ----------
    path : str or Path
        A variant YAML file (docs/variant-reference.md), e.g. ``variants/box.yaml``.

    Returns
    -------
    Layout
        The resolved layout, every value in SI (lengths [m], angles [rad], forces [N], loads [N·m]); its
        ``name``, ``file``, ``contact_law``, ``rollers``, ``gamma_grid`` [rad] and ``load_grid`` [N·m] (the
        envelope) among its fields. Geometry that cannot work (preloads that do not balance, rollers that
        overlap, a linkage that cannot steer) is refused.

    Raises
    ------
    cvtdesign.errors.InputError
        A file or field that is not valid, in one line naming it and what was expected.
    """
    return variant_file.load_variant(path)


def evaluate(variant, gamma_deg, load_Nm, speed_rad_s=None):
    """Every contact's state at operating points of your own (the ``compare --points`` columns).

    Parameters
    ----------
    variant : str, Path or Layout
        A variant file, or a layout from `load_variant`.
    gamma_deg : float or array_like
        Commanded transmission angle γ [°].
    load_Nm : float or array_like
        Lateral load τ⊥ [N·m], broadcast against `gamma_deg` (a scalar load with an array of γ is a sweep).
    speed_rad_s : float or array_like, optional
        Motor (input) shaft speed ω1 [rad/s]; default the variant's ``motor_speed``.

    Returns
    -------
    pandas.DataFrame
        One row per operating point × contact, points in the order given (flattened), contacts in the
        layout's order, with the columns of io.points.COLUMNS: ``variant``, ``gamma_cmd_deg`` [°],
        ``tau_perp_Nm`` [N·m], ``status``, ``roller``, ``role``, ``N_N`` [N], ``xi``, ``eta`` [-],
        ``phi_1_m`` [1/m], ``F_long_N``, ``F_lat_N`` [N], ``M_spin_Nm`` [N·m], ``utilisation`` [-],
        ``a_mm``, ``b_mm`` [mm], ``p0_MPa``, ``G_MPa`` [MPa], ``mu``, ``C11``, ``C22``, ``C23`` [-],
        ``loss_W`` [W], ``T_fork_Nm``, ``T_fork_standstill_Nm`` [N·m] (docs/comparing.md). A point where the
        physics stopped holding keeps its status (``gross_slip``, ``lost_contact``, ``not_converged``,
        ``reversed``, ``multiple_roots``) and carries no numbers (NaN).

    Raises
    ------
    cvtdesign.errors.InputError
        More points than one run may evaluate, a load beyond what the contacts can carry, or a value that is
        not finite.
    """
    layout = variant if isinstance(variant, Layout) else load_variant(variant)
    gamma, load = (np.ravel(a) for a in np.broadcast_arrays(np.asarray(gamma_deg, float), np.asarray(load_Nm, float)))
    for name, values in (("gamma_deg", gamma), ("load_Nm", load)):
        if not np.isfinite(values).all():
            raise InputError(f"evaluate: {name}: expected finite numbers, got {values[~np.isfinite(values)][0]}")
    check_points(gamma.size, len(layout.rollers), "evaluate")
    check_loads([("evaluate: load_Nm", float(np.max(np.abs(load))))] if load.size else [], layout)
    speeds = None if speed_rad_s is None else np.broadcast_to(np.asarray(speed_rad_s, float), gamma.shape)
    res = at_points(uncertain_model(layout), np.radians(gamma), load, speeds)
    states = contact_points(layout.name, layout, res)
    states["gamma_cmd_deg"] = np.repeat(gamma, len(layout.rollers))     # as given, not through radians and back
    return points_frame([states])
