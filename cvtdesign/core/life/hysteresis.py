"""Rolling resistance of a viscoelastic contact from its hysteresis loss fraction; units SI.

K. L. Johnson, *Contact Mechanics* (1985), ch. 9, "Hysteresis losses": a rigid body rolling on a viscoelastic
one does work on the leading half of the contact, of which a fraction α (the hysteresis loss fraction) is
not returned on the trailing half. Per unit distance rolled the work on the leading half is the moment of
the Hertz pressure about the contact's centre over the rolling radius, ∫_{x>0} p x dA / R:
 * a sphere (circular patch of radius a): 3Wa/16, so F_R = α·3Wa/(16R);
 * an elliptical patch, a along the rolling direction: the same, 3Wa/16 (the substitution x = a u, y = b v
   maps it onto the circle), so the crowned roller on the sphere rolls against F_R = α·3Wa/(16 R_x) with
   R_x the relative radius of curvature in the rolling direction, 1/R_x = 1/R_sphere + 1/r_roller.
"""
from __future__ import annotations


def rolling_resistance(alpha, W, a, R_x):
    """Johnson's rolling resistance [N] of a point contact: α·3Wa/(16 R_x) (module docstring); α the loss
    fraction [-], W the normal force [N], a the patch semi-axis along rolling [m], R_x [m]."""
    return alpha * 3.0 * W * a / (16.0 * R_x)


def rolling_radius(R_sphere, r_roller):
    """The relative radius of curvature R_x [m] of a roller on a sphere in the rolling direction (both convex)."""
    return 1.0 / (1.0 / R_sphere + 1.0 / r_roller)


def energy_shares(E1, nu1, E2, nu2):
    """How the elastic energy of a Hertz contact divides between its two bodies [-, -]: each body's share of
    the compliance (1 − ν²)/E (Johnson, ch. 4: the two approach in that proportion)."""
    c1, c2 = (1 - nu1 ** 2) / E1, (1 - nu2 ** 2) / E2
    return c1 / (c1 + c2), c2 / (c1 + c2)


def contact_loss_fraction(alpha1, share1, alpha2, share2):
    """The loss fraction of a contact of two viscoelastic bodies [-]: each body's α weighted by its share of
    the elastic energy (energy_shares)."""
    return alpha1 * share1 + alpha2 * share2
