"""Hydrodynamic force of a lubricated journal bearing (a clearance joint full of oil).

Frame: the line of centres n (bearing -> journal centre) and t = n rotated by +90 deg;
the film angle theta runs from n towards t, so the film thickness is
h = c (1 - eps cos theta), eps = |e| / c the eccentricity ratio. In the frame turning with
the line of centres (angle gamma) Reynolds' equation reads (Pinkus & Sternlicht 1961,
Theory of Hydrodynamic Lubrication, ch. 3 and 10)

    div(h^3 / (12 mu) grad p) = (R w / 2) dh/dx + dh/dt,   x = R theta,

with the whirl w = omega_J + omega_B - 2 gamma_dot (the journal's rotation relative to the
bearing minus twice the rate of the line of centres, both relative to the bearing) and
dh/dt = -c eps_dot cos theta. Both solutions depend on eps and on the film's two rates

    A = eps_dot (squeeze),  B = eps w / 2 (wedge),

and the source of the film, A cos theta - B sin theta = rho cos(theta + alpha), is
positive on the half circle theta in (-alpha - pi/2, -alpha + pi/2).

Cavitation: half-Sommerfeld (Guembel) conditions. The oil carries pressure on that half
circle only (the "pi film") and is at ambient pressure (0) at both of its ends; the other
half is cavitated. For the short bearing this is exactly p = max(p_full, 0), with the
ends of the film following the motion (Daniel, Machado, Cavalca 2016, Mech. Mach. Theory
99); for the long bearing it is the classic half-Sommerfeld solution of a rotating journal
(film from theta = -pi to 0) and of a squeezed one (film from -pi/2 to pi/2), and in
between a pi film that turns with (A, B). The classic fixed-film forms (Flores et al. 2006,
Mech. Mach. Theory 41, eq. 8-11) coincide with these for pure rotation.

- long bearing (Sommerfeld; no axial flow, L >> D): h^3 dp/dtheta = 12 mu R^2 c
  (-B cos theta - A sin theta + C), C from p = 0 at both ends of the film; force per
  length times L.
- short bearing (Ocvirk 1952; no circumferential pressure flow, L << D): p = 6 mu /h^3
  (z^2 - L^2/4) c (B sin theta - A cos theta), integrated over z in (-L/2, L/2).

The film integrals of (1, cos, sin) x (cos, sin) / (1 - eps cos theta)^3 are closed forms
after Sommerfeld's substitution cos psi = (cos theta - eps) / (1 - eps cos theta), with
psi = theta + 2 atan(beta sin theta / (1 - beta cos theta)), beta = eps / (1 + sqrt(1 - eps^2))
(continuous in theta: the film may straddle theta = +-pi).

Every function works on floats and on CasADi SX/MX alike. The caller keeps eps < 1 (the
equations evaluate the film at min(eps, threshold) and hand over to the dry laws, see
:func:`film_weight`).
"""

from __future__ import annotations

import math

import casadi as ca
import numpy as np

from ..scene.vocabulary import LUBRICATION_LAWS as LUBRICATION_LAW_NAMES
from ..scene.vocabulary import registry

__all__ = ["LUBRICATION_LAWS", "film_force", "film_weight", "film_rates", "RATE_FLOOR", "min_film_thickness",
           "film_torque"]

# [1/s] added to the squeeze rate where the film's position is taken (see _film_integrals)
RATE_FLOOR = 1e-9


def film_rates(eps, e_dot_n, e_dot_t, omega_journal, omega_bearing, clearance):
    """(A, B) = (eps_dot, eps w / 2) [1/s] of the film from the eccentricity rate e_dot
    resolved on n and t [m/s], the bodies' angular rates [rad/s] and the radial clearance c
    [m]: eps_dot = e_dot.n / c and eps gamma_dot = e_dot.t / c (finite for a centred journal)."""
    return e_dot_n / clearance, 0.5 * (eps * (omega_journal + omega_bearing) - 2.0 * e_dot_t / clearance)


def _psi(theta, eps, beta):
    return theta + 2.0 * ca.atan2(beta * ca.sin(theta), 1.0 - beta * ca.cos(theta))


def _film_integrals(eps, A, B):
    """The integrals I_f = int f(theta) / (1 - eps cos theta)^3 dtheta over the pi film,
    f in (1, cos, sin, cos^2, cos sin, sin^2)."""
    k = 1.0 - eps**2
    s = ca.sqrt(k)
    beta = eps / (1.0 + s)
    # start of the film; RATE_FLOOR keeps the angle's derivative finite at A = B = 0 (there the
    # force, proportional to (A, B), is 0 and its derivative 0, not 0 * NaN)
    a = -ca.atan2(B, A + RATE_FLOOR) - 0.5 * math.pi
    p0, p1 = _psi(a, eps, beta), _psi(a + math.pi, eps, beta)

    def between(F):
        return F(p1) - F(p0)

    k52, k2, k32 = k**2 * s, k**2, k * s
    one = between(lambda p: p + 2 * eps * ca.sin(p) + eps**2 * (0.5 * p + 0.25 * ca.sin(2 * p))) / k52
    cos = between(lambda p: (1 + eps**2) * ca.sin(p) + eps * (1.5 * p + 0.25 * ca.sin(2 * p))) / k52
    sin = between(lambda p: -ca.cos(p) + 0.5 * eps * ca.sin(p) ** 2) / k2
    cc = between(lambda p: (0.5 + eps**2) * p + 0.25 * ca.sin(2 * p) + 2 * eps * ca.sin(p)) / k52
    cs = between(lambda p: 0.5 * ca.sin(p) ** 2 - eps * ca.cos(p)) / k2
    ss = between(lambda p: 0.5 * p - 0.25 * ca.sin(2 * p)) / k32
    return one, cos, sin, cc, cs, ss


def _long_bearing(eps, A, B, radius, length, viscosity, clearance):
    one, cos, sin, cc, cs, ss = _film_integrals(eps, A, B)
    C = (B * cos + A * sin) / one  # p = 0 at both ends of the film
    k = 12.0 * viscosity * radius**3 * length / clearance**2
    return k * (-B * cs - A * ss + C * sin), -k * (-B * cc - A * cs + C * cos)


def _short_bearing(eps, A, B, radius, length, viscosity, clearance):
    _, _, _, cc, cs, ss = _film_integrals(eps, A, B)
    k = viscosity * radius * length**3 / clearance**2
    return -k * (A * cc - B * cs), -k * (A * cs - B * ss)


# the registry, by the names of the scene's vocabulary ('none' has no entry: no film term)
LUBRICATION_LAWS = registry(LUBRICATION_LAW_NAMES, {"long-bearing": _long_bearing, "short-bearing": _short_bearing})


def film_force(law: str, eps, A, B, radius, length, viscosity, clearance):
    """(F_n, F_t) [N]: the film's force on the journal along n and t, for eccentricity ratio
    eps in [0, 1), squeeze rate A = eps_dot and wedge rate B = eps w / 2 [1/s]
    (:func:`film_rates`), journal radius R [m], bearing length L [m], viscosity mu [Pa s] and
    radial clearance c [m]. F_n < 0 pushes the journal back towards the bearing centre."""
    return LUBRICATION_LAWS[law](eps, A, B, radius, length, viscosity, clearance)


def film_torque(eps, relative_rate, radius, length, viscosity, clearance):
    """The film's shear torque [N m] on the journal about its centre (the bearing takes the
    opposite): the viscous (Couette) shear stress mu R w / h of the journal turning at
    w = omega_J - omega_B [rad/s] inside the bore, over the whole film h = c (1 - eps cos theta),

        T = -mu w R^3 L / c  int_0^2pi dtheta / (1 - eps cos theta) = -2 pi mu w R^3 L / (c sqrt(1 - eps^2)),

    Petroff's torque 2 pi mu w R^3 L / c of the concentric bearing at eps = 0, and Ocvirk's
    short-bearing friction torque at eccentricity (Ocvirk 1952; Hamrock, Schmid & Jacobson,
    Fundamentals of Fluid Film Lubrication, ch. 10; the oil fills the cavitated half as
    streamers and shears there too). It dissipates -T w >= 0. The
    pressure's share of the friction (+-e W sin(phi) / 2 on journal and bearing) is the moment
    of the film force about the two centres, which the equations already apply (the force
    acts at each body's own centre). Floats or CasADi; eps < 1."""
    return -2.0 * math.pi * viscosity * relative_rate * radius**3 * length / (clearance * ca.sqrt(1.0 - eps**2))


def film_weight(eps, threshold):
    """The film's share w of the bearing's load, 1 for eps <= threshold, falling as a cubic
    step 1 - s^2 (3 - 2 s), s = (eps - threshold) / (1 - threshold), to 0 at eps = 1 where
    the journal touches the bearing and the dry laws act (penetration > 0). The equations
    apply w(eps) F(min(eps, threshold), A, B): continuous (C1) in eps and finite as eps -> 1."""
    s = ca.fmin(ca.fmax((eps - threshold) / (1.0 - threshold), 0.0), 1.0)
    return 1.0 - s**2 * (3.0 - 2.0 * s)


def min_film_thickness(eccentricity, clearance):
    """h_min = c (1 - eps) = c - |e| [m], the thinnest film between journal and bore, from the
    eccentricities (..., nc, 2) [m] and the radial clearances c (nc,) [m] (numpy); 0 where
    the journal touches its bore (eps >= 1: the dry laws carry the load)."""
    return np.maximum(np.asarray(clearance, float) - np.linalg.norm(np.asarray(eccentricity, float), axis=-1), 0.0)
