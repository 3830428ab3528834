"""Conformal contact of a journal in its (worn) bore: an elastic foundation over the arc.

A journal in a bore of small clearance touches it over an arc, tens of degrees wide once the
bore has worn to the journal's shape. The pressure over that arc is modelled as a Winkler
(elastic-foundation) layer: at each angle psi of the bore the local overlap of the journal's
circle with the worn profile,

    d(psi) = e . u(psi) - c0 - w_B(psi - theta_B) - w_J(psi - theta_J),   u = (cos psi, sin psi),

(e the eccentricity, c0 = R_B - R_J, w_s the surfaces' wear profiles, :mod:`.wear`; e . u is
the journal's surface along u to O(e^2 / R)) presses with p = K_w max(d, 0)^m, the layer's
exponent m = n - 1/2 for the scene's exponent n (m = 1, the linear Winkler layer, for Hertz's
1.5) (Bei & Fregly 2004, Med. Eng. Phys. 26; Flores 2009, Mech. Mach. Theory 44, for
revolute joints). The normal force on the journal is the integral -L R_B int p u dpsi, its
direction and point of action follow from that integral.

Stiffness. On an unworn bore with delta = |e| - c0 << c0 the overlap is
d = delta - c0 a^2 / 2 (a = psi - phi from the line of centres), positive over
|a| < a0 = sqrt(2 delta / c0), and the integral is

    F = K_w L R_B sqrt(2 / c0) B(m) delta^(m + 1/2),   B(m) = int_-1^1 (1 - s^2)^m ds
      = sqrt(pi) Gamma(m + 1) / Gamma(m + 3/2)     (4/3 for m = 1),

the scene's dry law K delta^n exactly when m = n - 1/2 and
K_w = K / (L R_B sqrt(2 / c0) B(m)) (:func:`foundation_modulus`): the unworn joint's
force-penetration curve is the scene's wherever delta << c0.

Damping follows each point: p = K_w d^m (1 + chi d_dot / delta_dot0) >= 0 with the scene's
hysteresis factor chi (:func:`rrr4.contact.normal.hysteresis_factor`; 0 for Hertz) and the
joint's captured approach velocity delta_dot0; friction too, f_t(v_slip(psi), dF(psi)) with
the slip of each point. The layer's energy is L R_B int K_w d^(m+1) / (m+1) dpsi.

Quadrature: points that follow the line of centres, psi_k = phi + 2 pi k / N (phi the
direction of e, in the first wearing surface's frame), at a spacing of at most 2.5 deg
(:data:`MIN_POINTS` a revolution, a whole number per profile node, :func:`arc_points`), so the
arc is resolved whatever the profile's node count (an unworn contact under the reference
loads is several degrees wide) and e . u_k = |e| cos(2 pi k / N) exactly: on an unworn bore the
deepest overlap is |e| - c0 in every direction, as the point law's penetration (points fixed
on the surface read it up to c0 (pi / N)^2 / 2 shallow between them, 24 nm at 144 points and
0.1 mm: a washboard under a lightly loaded journal that lifted it off and flipped its
in-contact flag). Each profile is known at its own points 2 pi k / N as constant combinations
of its coefficients (:func:`sampling_matrix`, :func:`slope_matrix`) and read at the moving
points (the other surface, where both wear, turned under them too) by :func:`turned_samples`:
a circular shift by a symbolic whole number of points (a gather in an MX Function the arc
calls, O(N)) and a cubic Hermite interpolation, continuous with a continuous slope, so that the force and its
direction are continuous in the motion; the wear at the points is shared back onto each
surface's own points (:func:`turned_deposit`). The normal force is -sum_k dF_k d d_k / d e,
the gradient of the layer's energy (its tangential share where the profile slopes).

The whole arc is one CasADi Function per (nodes, surfaces, exponent, friction law)
(:func:`arc_function`, and :func:`arc_energy` for the energy) that the equations call rather
than inline: their derivatives (the implicit methods' Newton Jacobian) then differentiate it
once in its few inputs instead of once per coordinate, and neither the equations nor the
generated code grow with the profile's nodes beyond the sparse sampling matrix.
"""

from __future__ import annotations

import functools
import math

import casadi as ca
import numpy as np

from ..scene import FrictionEffect
from .friction import friction_force
from .normal import power
from .wear import depth_at

__all__ = ["MIN_POINTS", "arc_points", "sampling_matrix", "slope_matrix", "layer_exponent", "arc_factor",
           "foundation_modulus", "turned_samples", "turned_deposit", "arc_function", "arc_energy", "ARC_NUMBERS",
           "FRICTION_NUMBERS", "front_points"]

# the scalar inputs ``numbers`` of :func:`arc_function`, in order
ARC_NUMBERS = ("clearance", "modulus", "area", "damping_rate", "slip_offset")
# the friction law's numbers among them (after ARC_NUMBERS)
FRICTION_NUMBERS = ("coefficient", "static_coefficient", "v0", "v1", "stribeck_velocity")

# the arc's quadrature points a revolution, at least (2.5 deg apart)
MIN_POINTS = 144


def arc_points(nodes: int) -> np.ndarray:
    """The quadrature angles [rad] over a surface of a profile of M nodes: N = r M points evenly
    spaced, r = ceil(MIN_POINTS / M) (so N >= MIN_POINTS and each node interval holds r)."""
    n = nodes * math.ceil(MIN_POINTS / nodes)
    return 2.0 * math.pi * np.arange(n) / n


def sampling_matrix(nodes: int) -> ca.DM:
    """S (N, M), sparse: the profile's depths at :func:`arc_points` are S c (c its M coefficients)."""
    psi = arc_points(nodes)
    s = np.column_stack([depth_at(np.eye(nodes)[i], psi) for i in range(nodes)])
    s[np.abs(s) < 1e-15] = 0.0
    return ca.sparsify(ca.DM(s))


def slope_matrix(nodes: int) -> ca.DM:
    """D (N, M): the profile's slopes d w / d psi [m/rad] at :func:`arc_points` are D c (central
    differences of the cubic spline, exact to 1e-10 of its scale)."""
    psi, h = arc_points(nodes), 1e-6
    d = np.column_stack([(depth_at(np.eye(nodes)[i], psi + h) - depth_at(np.eye(nodes)[i], psi - h)) / (2 * h)
                         for i in range(nodes)])
    d[np.abs(d) < 1e-12] = 0.0
    return ca.sparsify(ca.DM(d))


def layer_exponent(exponent):
    """m = n - 1/2: the layer's pressure exponent for the joint's exponent n."""
    return exponent - 0.5


def arc_factor(m: float) -> float:
    """B(m) = int_-1^1 (1 - s^2)^m ds = sqrt(pi) Gamma(m + 1) / Gamma(m + 3/2)."""
    return math.sqrt(math.pi) * math.gamma(m + 1.0) / math.gamma(m + 1.5)


def foundation_modulus(stiffness, exponent: float, length, bearing_radius, clearance):
    """K_w [Pa / m^m] of the layer whose unworn force is K delta^n (K [N/m^n], n the exponent)
    for delta << c0: K / (L R_B sqrt(2 / c0) B(m)), L the bearing length [m], R_B [m], c0 [m]."""
    m = layer_exponent(exponent)
    return stiffness / (length * bearing_radius * ca.sqrt(2.0 / clearance) * arc_factor(m))


def _split(angle, n: int):
    """The angle [rad] in steps of 2 pi / n: its whole steps modulo n and the fraction of the next."""
    u = angle * (n / (2.0 * math.pi))
    whole = ca.floor(u)
    return whole - n * ca.floor(whole / n), u - whole


def _wrapped(k, n: int):
    """Indices k in [0, 2n) brought into [0, n) (no fmod: it dominated the arc's cost)."""
    return k - n * (k >= n)


@functools.cache
def _reader(n: int, at: tuple) -> ca.Function:
    """(values, slopes, angle) -> values read at the points `at` turned by angle
    (:func:`turned_samples`): an MX Function whose symbolic gathers cost O(len(at)) whatever the
    angle, called from the arc."""
    values, slopes, angle = ca.MX.sym("values", n), ca.MX.sym("slopes", n), ca.MX.sym("angle")
    shift, f = _split(angle, n)
    k0 = _wrapped(shift + ca.DM(at), n)
    k1 = _wrapped(k0 + 1.0, n)
    h, f2 = 2.0 * math.pi / n, f * f
    f3 = f2 * f
    v0, s0, v1, s1 = values[k0], slopes[k0], values[k1], slopes[k1]
    out = (2 * f3 - 3 * f2 + 1) * v0 + (f3 - 2 * f2 + f) * h * s0 + (-2 * f3 + 3 * f2) * v1 + (f3 - f2) * h * s1
    rate = (6 * f2 - 6 * f) / h * (v0 - v1) + (3 * f2 - 4 * f + 1) * s0 + (3 * f2 - 2 * f) * s1
    return ca.Function(f"turned_samples_{n}_{len(at)}", [values, slopes, angle], [out, rate],
                       ["values", "slopes", "angle"], ["samples", "rates"], {"never_inline": True})


@functools.cache
def _depositor(n: int, at: tuple) -> ca.Function:
    """(values at the points `at`, angle) -> values shared back onto the surface's own points
    (:func:`turned_deposit`)."""
    given, angle = ca.MX.sym("values", len(at)), ca.MX.sym("angle")
    values = ca.MX.zeros(n)
    values[list(at)] = given
    shift, f = _split(angle, n)
    shared = (1.0 - f) * values + f * ca.vertcat(values[n - 1], values[:n - 1])
    back = _wrapped(n - shift + ca.DM(np.arange(n)), n)
    return ca.Function(f"turned_deposit_{n}_{len(at)}", [given, angle], [shared[back]], ["values", "angle"],
                       ["deposit"], {"never_inline": True})


def turned_samples(values, slopes, angle, n: int, at=None):
    """A surface's values (N,) and their slopes d / d psi (N,) at its own points 2 pi k / N, read
    at the points 2 pi k / N + angle [rad] (k in `at`, default all) (a symbol: points that move over the surface) by
    cubic Hermite interpolation: continuous with a continuous slope in the angle, so that a
    force that follows the slope does not jump as the points pass the samples. The shift by a
    symbolic whole number of points is a gather (an MX Function called here), O(N). Returns the
    samples and their rates d / d angle (the interpolant's slope, continuous)."""
    return _reader(n, tuple(range(n)) if at is None else tuple(at))(values, slopes, angle)


def turned_deposit(values, angle, n: int, at=None):
    """The transpose of :func:`turned_samples`: quantities at the points 2 pi k / N + angle
    (k in `at`, default all) of a surface, shared onto its own points with the same weights
    (their sum is kept)."""
    return _depositor(n, tuple(range(n)) if at is None else tuple(at))(values, angle)


def front_points(nodes: int) -> np.ndarray:
    """The indices k of the :func:`arc_points` a_k with cos a_k > 0: the half of the bore ahead of
    the line of centres, the only one that can touch (behind it e . u <= 0 and the overlap is
    below -c0 - w, negative for any profile deeper than -c0)."""
    return np.flatnonzero(np.cos(arc_points(nodes)) > 1e-9)


def _overlap(nodes: int, turned: bool, e, turn, first, other, clearance):
    """The overlaps d_k (N,) [m] at the points psi_k = phi + 2 pi k / N that follow the line of
    centres phi (the direction of e), phi [rad] and the points' tangents t_k (2, N).
    e . u_k = |e| cos(2 pi k / N) is exact, so an unworn bore's deepest overlap is |e| - c0
    wherever the journal points (points fixed on the surface read it c0 (pi / N)^2 / 2 = 24 nm
    too shallow between them at 144 points and 0.1 mm, a washboard under a sliding journal);
    each profile is read at the points by :func:`turned_samples`. Only the points ahead of the
    line of centres (:func:`front_points`) are kept: the others cannot touch. Also the
    gradients d d_k / d e (N, 2) and d d_k / d angle (N,) (the other surface's angle under the
    points; zeros unless `turned`), written out: r = |e| and phi move with e as
    d r / d e = e / r and d phi / d e = t / r (t the unit tangent)."""
    n, front = len(arc_points(nodes)), front_points(nodes)
    a = arc_points(nodes)[front]
    r = ca.sqrt(ca.dot(e, e) + 1e-30)
    phi = ca.if_else(r > 1e-12, ca.atan2(e[1], e[0]), 0.0)
    normal, tangent = e / r, ca.vertcat(-e[1], e[0]) / r
    t = tangent @ ca.DM(np.cos(a)).T - normal @ ca.DM(np.sin(a)).T
    sampled = sampling_matrix(nodes)
    slopes = slope_matrix(nodes)
    depth, slope = turned_samples(sampled @ first, slopes @ first, phi, n, front)
    turning = ca.SX.zeros(len(front))
    if turned:
        depth_other, turning = turned_samples(sampled @ other, slopes @ other, phi + turn[0], n, front)
        depth, slope = depth + depth_other, slope + turning
    overlap = r * ca.DM(np.cos(a)) - clearance - depth
    gradient = ca.DM(np.cos(a)) @ normal.T - slope @ tangent.T / r
    return overlap, phi, t, gradient, -turning


@functools.cache
def arc_energy(nodes: int, turned: bool, exponent: float) -> ca.Function:
    """The layer's energy L R_B h sum_k K_w d_k^(m+1) / (m+1) [J] over the arc, called like
    :func:`arc_function` (inputs e, turn, first, other and numbers = (c0, K_w, area))."""
    e, turn = ca.SX.sym("e", 2), ca.SX.sym("turn", 2)
    first, other, numbers = ca.SX.sym("first", nodes), ca.SX.sym("other", nodes), ca.SX.sym("numbers", 3)
    overlap = _overlap(nodes, turned, e, turn, first, other, numbers[0])[0]
    m = layer_exponent(exponent)
    energy = numbers[2] * ca.sum1(numbers[1] * power(ca.fmax(overlap, 0.0), m + 1.0) / (m + 1.0))
    name = f"conformal_energy_{nodes}{'_turned' if turned else ''}_n{exponent:g}".replace(".", "p")
    return ca.Function(name, [e, turn, first, other, numbers], [energy], ["e", "turn", "first", "other", "numbers"],
                       ["potential"], {"never_inline": True})


@functools.cache
def arc_function(nodes: int, turned: bool, exponent: float, friction: str) -> ca.Function:
    """The conformal contact over the arc of one worn joint as one Function, called (not
    inlined) from the equations, so that their derivatives differentiate it once, in its few
    inputs, instead of once per coordinate. Points that follow the line of centres
    (:func:`arc_points` turned by phi); everything in the first wearing surface's frame.

    Inputs: ``e`` (2,) the eccentricity [m]; ``e_rate`` (2,) its rate in the turning frame
    [m/s]; ``e_dot`` (2,) the world rate seen in the frame [m/s]; ``turn`` (2,) the other
    surface's angle under the points and its rate [rad, rad/s] (`turned`); ``first``,
    ``other`` (M,) the profiles' coefficients [m] (``other`` zeros unless `turned`);
    ``numbers``: :data:`ARC_NUMBERS` (c0 [m], K_w, a point's area L R_B h [m^2],
    chi / delta_dot0 [s/m], R_J omega_J - R_B omega_B [m/s]) then :data:`FRICTION_NUMBERS`.
    Outputs: ``normal`` (2,) the normal force on the journal [N]; ``friction`` (2,) its
    friction force [N] and ``friction_sum`` the points' sum of f_t [N]; ``turn_load``
    -sum dF_k d d_k / d angle [N m] (the other profile's share of the generalised force);
    ``power_damping``, ``power_friction`` [W]; ``deepest`` max_k d_k [m];
    ``wear_first``, ``wear_other`` (M,): sampling^T (dF |v|) on each profile [W]
    (:func:`rrr4.contact.wear.point_depth_rates`)."""
    n, front = len(arc_points(nodes)), front_points(nodes)
    e, e_rate, e_dot, turn = (ca.SX.sym(k, 2) for k in ("e", "e_rate", "e_dot", "turn"))
    first, other = ca.SX.sym("first", nodes), ca.SX.sym("other", nodes)
    numbers = ca.SX.sym("numbers", len(ARC_NUMBERS) + len(FRICTION_NUMBERS))
    clearance, modulus, area, damping_rate, slip_offset = ca.vertsplit(numbers[:len(ARC_NUMBERS)])
    sampled = sampling_matrix(nodes)
    overlap, phi, t, gradient, turning = _overlap(nodes, turned, e, turn, first, other, clearance)
    rate = gradient @ e_rate + turning * turn[1]
    m = layer_exponent(exponent)
    elastic = modulus * power(ca.fmax(overlap, 0.0), m)
    loads = ca.fmax(elastic * (1.0 + damping_rate * rate), 0.0) * area
    slips = t.T @ e_dot + slip_offset
    if friction == "none":
        ft = ca.SX.zeros(len(front))
    else:
        fe = FrictionEffect(friction, *ca.vertsplit(numbers[len(ARC_NUMBERS):]))
        ft = friction_force(fe, slips, loads)
    worn = loads * ca.fabs(slips)
    outputs = {
        "normal": -gradient.T @ loads, "friction": t @ ft, "friction_sum": ca.sum1(ft),
        "turn_load": -ca.dot(turning, loads),
        "power_damping": ca.dot(loads - elastic * area, rate), "power_friction": -ca.dot(ft, slips),
        "deepest": ca.mmax(overlap),
        "wear_first": sampled.T @ turned_deposit(worn, phi, n, front),
        "wear_other": sampled.T @ turned_deposit(worn, phi + turn[0], n, front) if turned else ca.SX.zeros(nodes)}
    inputs = {"e": e, "e_rate": e_rate, "e_dot": e_dot, "turn": turn, "first": first, "other": other,
              "numbers": numbers}
    name = f"conformal_arc_{nodes}{'_turned' if turned else ''}_{friction}_n{exponent:g}"
    return ca.Function(name.replace("-", "_").replace(".", "p"),
                       list(inputs.values()), list(outputs.values()), list(inputs), list(outputs),
                       {"never_inline": True})
