"""The conformal layer (rrr4.contact.conformal) against the dry point law on an unworn bore,
where it must be the same contact (independent integrations of a journal under each law's
force): a journal thrown radially into its bore rebounds with the point law's restitution; a
lightly loaded journal whose load turns round the bore loses contact as often as with the
point law; and the deepest overlap, the joint's penetration and in-contact flag, is |e| - c0
in every direction, between the quadrature's points too. (Points fixed on the bore 2.5 deg
apart read it up to c0 (pi / 144)^2 / 2 = 24 nm shallow between them: a washboard under a
journal pressed a few tens of nm deep that made the layer count six times the point law's
contact losses on the reference scene without preload.)"""

import math

import numpy as np
import pytest

from rrr4.contact.conformal import ARC_NUMBERS, FRICTION_NUMBERS, arc_function, arc_points, foundation_modulus
from rrr4.contact.normal import V_MIN, hysteresis_factor, normal_force

K, C0, R_J, L, NODES = 7.66e10, 1.0e-4, 5.0e-3, 0.01, 36   # the reference scene's steel joint [N/m^1.5, m, m, m]
R_B, MASS, C_R = R_J + C0, 0.3, 0.9                        # [m], the journal's mass [kg], restitution
CHI = hysteresis_factor("lankarani-nikravesh", C_R)


def _layer(e, v, v0):
    """The conformal layer's force on the journal (2,) [N] and its deepest overlap [m] at the
    eccentricity e (2,) [m] and its rate v (2,) [m/s], approach velocity v0 [m/s]."""
    f = arc_function(NODES, False, 1.5, "none")
    numbers = {"clearance": C0, "modulus": float(foundation_modulus(K, 1.5, L, R_B, C0)),
               "area": L * R_B * 2 * math.pi / len(arc_points(NODES)),
               "damping_rate": CHI / max(v0, V_MIN), "slip_offset": 0.0}  # the equations floor v0 at V_MIN
    friction = [0.0] * len(FRICTION_NUMBERS)
    out = f.call({"e": e, "e_rate": v, "e_dot": v, "turn": np.zeros(2), "first": np.zeros(NODES),
                  "other": np.zeros(NODES), "numbers": [numbers[k] for k in ARC_NUMBERS] + friction})
    return np.array(out["normal"]).ravel(), float(out["deepest"])


def _point(e, v, v0):
    n = e / np.linalg.norm(e)
    return -n * float(normal_force("lankarani-nikravesh", np.linalg.norm(e) - C0, v @ n, v0, K, 1.5, C_R)), \
        float(np.linalg.norm(e) - C0)


def _rk4(force, e, v, v0, h, load=None):
    def acc(e, v):
        return (force(e, v, v0)[0] + (0.0 if load is None else load)) / MASS
    k1 = (v, acc(e, v))
    k2 = (v + 0.5 * h * k1[1], acc(e + 0.5 * h * k1[0], v + 0.5 * h * k1[1]))
    k3 = (v + 0.5 * h * k2[1], acc(e + 0.5 * h * k2[0], v + 0.5 * h * k2[1]))
    k4 = (v + h * k3[1], acc(e + h * k3[0], v + h * k3[1]))
    return e + h / 6 * (k1[0] + 2 * k2[0] + 2 * k3[0] + k4[0]), v + h / 6 * (k1[1] + 2 * k2[1] + 2 * k3[1] + k4[1])


def _restitution(force, v0, direction):
    """v_out / v_in of a journal of MASS thrown at v0 [m/s] from the bore's wall into it."""
    u = np.array([math.cos(direction), math.sin(direction)])
    h = 3.0 * (1.25 * MASS * v0**2 / K) ** 0.4 / v0 / 600  # a few times delta_max / v0, in 600 steps
    e, v = C0 * u, v0 * u
    while e @ u >= C0:
        e, v = _rk4(force, e, v, v0, h)
    return -(v @ u) / v0


@pytest.mark.parametrize("v0", [1e-3, 3e-2])  # delta_max 0.11 um and 1.3 um
def test_an_impact_into_an_unworn_bore_rebounds_as_with_the_point_law(v0):
    point = _restitution(_point, v0, 0.0)
    assert 0.85 < point < 0.95  # Lankarani-Nikravesh's c_r = 0.9, to its own approximation
    for direction in (0.0, 0.5 * 2 * math.pi / 144, 1.234):  # on a point, half-way between two, anywhere
        assert _restitution(_layer, v0, direction) == pytest.approx(point, rel=0.02)


def _seat(force, load):
    """The penetration [m] at which `force` carries `load` [N] at rest (bisection)."""
    low, high = 0.0, 1e-6
    for _ in range(50):
        mid = 0.5 * (low + high)
        low, high = (mid, high) if np.linalg.norm(force(np.array([C0 + mid, 0.0]), np.zeros(2), V_MIN)[0]) < load \
            else (low, mid)
    return low


def _losses(force, load, omega, steps=1500, h=2e-5):
    """Contact losses of a journal of MASS seated under `load` [N] at rest whose direction turns
    at omega [rad/s] for `steps` steps of h [s], the approach velocity captured at each onset
    (the equations' rule), and the run's smallest deepest overlap [m]."""
    e, v, v0, inside, losses, deepest = np.array([C0 + _seat(force, load), 0.0]), np.zeros(2), V_MIN, True, 0, 1.0
    for k in range(steps):
        a = omega * k * h
        e, v = _rk4(force, e, v, v0, h, load * np.array([math.cos(a), math.sin(a)]))
        d = force(e, v, v0)[1]
        if d > 0 and not inside:
            v0 = max(v @ e / np.linalg.norm(e), V_MIN)
        losses += inside and not d > 0
        inside, deepest = d > 0, min(deepest, d)
    return losses, deepest


def test_a_light_journal_sliding_round_its_bore_loses_contact_as_with_the_point_law():
    """0.2 N (18 nm deep) turning at 100 rad/s: the journal slides over 3 rad of its bore; fixed
    points lifted it off 18 times, the point law never."""
    point, _ = _losses(_point, 0.2, 100.0)
    layer, deepest = _losses(_layer, 0.2, 100.0)
    assert abs(layer - point) <= 0.2 * point
    assert point > 0 or deepest > 0


def test_the_deepest_overlap_is_the_point_laws_penetration_in_every_direction():
    for delta in (5e-9, 3e-8, 1e-6):
        for direction in np.linspace(0.0, 2 * math.pi / 144, 7):
            e = (C0 + delta) * np.array([math.cos(direction), math.sin(direction)])
            assert _layer(e, np.zeros(2), 1e-3)[1] == pytest.approx(delta, rel=1e-6, abs=1e-12)
