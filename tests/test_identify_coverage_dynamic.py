"""Coverage by simulation of method 'dynamic' (issue 46, "Intervals that hold"), per
parameter, the contact stiffness included: the loaded slider-crank plant of
tests/test_identify_driven.py (clearance 420 um, friction 0.13) with the contact stiffness
3e10 N/m^1.5 (nominal 6.6e10 from its radii) is run once by rrr4.simulate; each noise seed
(1 um on the slider's x, 1 % of the crank torque's RMS, the levels given) is fitted from the
nominal scene by identify's default (staged: straight to 'dynamic' on a driven scene). The
errors are judged in the coordinate each parameter is fitted in (log for the stiffness: its
interval is symmetric there)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.stats import binom, chi2, norm, t

import rrr4
from rrr4.identify import identify
from rrr4.identify.least_squares import Z95
from tests.test_identify_driven import LOADED, PLANT, TRUTH, _noisy  # the same plant and noise

CLEARANCE, FRICTION, STIFFNESS = "joints.radial_clearance", "effects.friction.coefficient", "effects.contact.stiffness"
KEYS = [CLEARANCE, FRICTION, STIFFNESS]
STIFF = 3e10  # N/m^1.5, the plant's contact stiffness
ALPHA = 0.01  # the level at which a rule below calls a coverage or a spread shown wrong
Z90, Z99 = norm.ppf([0.95, 0.995])  # the half-widths of 90 and 99 % intervals [standard errors]


def _coverage(t_end: float, seeds: range):
    """The plant over t_end s (the nominal scene's path made as long), fitted once per seed:
    (inside (seeds, 3): each 95 % interval holds the truth, z (seeds, 3): the errors in
    standard errors in the fitted coordinate, wall times (seeds,))."""
    nominal = rrr4.load_scene(LOADED).with_values({"path.duration": t_end})
    sim = rrr4.simulate(nominal.with_values({**PLANT, STIFFNESS: STIFF}), t_end=t_end, output_rate=1000)
    assert sim.contact_loss_events["B"] == 0  # the journal stays seated: a run smooth in its parameters
    truth = np.r_[TRUTH, STIFF]
    inside, z, walls = [], [], []
    for seed in seeds:
        m, noise = _noisy(sim, seed)
        res = identify(nominal, m, KEYS, noise=noise)
        assert not res.at_bound, (seed, res.estimate, res.at_bound)
        walls.append(res.fit["wall_time_s"])
        if not res.fit["converged"]:  # what identify returns is judged; it is said
            print(f"seed {seed}: not converged in {res.fit['iterations']} iterations, at {res.estimate}")
        lo, hi = res.interval.T
        assert np.all(lo <= res.estimate) and np.all(res.estimate <= hi)
        inside.append((lo <= truth) & (truth <= hi))
        u = np.array([q.coordinate(v) for q, v in zip(res.parameters, res.estimate, strict=True)])
        u_true = np.array([q.coordinate(v) for q, v in zip(res.parameters, truth, strict=True)])
        se_u = res.standard_error / np.array([q.derivative(v) for q, v in zip(res.parameters, u, strict=True)])
        z.append((u - u_true) / se_u)
        print(f"seed {seed}: errors {np.round(z[-1], 2)} standard errors (clearance {res.standard_error[0]:.3g} m, "
              f"friction {res.standard_error[1]:.3g}, stiffness {se_u[2]:.3g} in log), inside {inside[-1]}, "
              f"{walls[-1]:.1f} s")
    return np.array(inside), np.array(z), np.array(walls)


def test_95_percent_dynamic_intervals_cover_the_truth_per_parameter_stiffness_included_fast(monkeypatch):
    # 10 seeds of one revolution (0.1 s; the stiffness poorly determined there, standard error
    # 0.28 to 0.74 in log K). Per parameter (the seeds are independent, the parameters of one
    # seed are not: the clearance and the stiffness correlate 0.98): at most 3 misses of 10 (a
    # correct 95 % interval misses 4 or more with probability 0.1 %), and the errors' sum of
    # squares within chi^2's 0.1 and 99.9 % points (10 degrees of freedom: standard errors too
    # small by 1.7 times or too large by 2.6 times fail it)
    monkeypatch.setenv("RRR4_JIT", "1")  # compiled, as a user runs it: a fit 6 times as fast as in the virtual machine
    seeds = 10
    inside, z, _ = _coverage(0.1, range(1, seeds + 1))
    misses = seeds - inside.sum(axis=0)
    assert binom.sf(3, seeds, 0.05) < 0.002
    assert np.all(misses <= 3), dict(zip(KEYS, misses.tolist(), strict=True))
    lo, hi = chi2.ppf([0.001, 0.999], seeds)
    ss = np.sum(z ** 2, axis=0)
    assert np.all((lo < ss) & (ss < hi)), (dict(zip(KEYS, ss.tolist(), strict=True)), lo, hi)


@pytest.mark.slow
def test_95_percent_dynamic_intervals_cover_the_truth_per_parameter_stiffness_included_100_seeds(monkeypatch):
    # 1 s (ten revolutions): the stiffness determined (standard error about 0.14 in log K, its
    # interval within a factor 2; on 0.1 and 0.2 s it is not, and 3 seeds of 50 end in a
    # spurious minimum near 100 times the plant's stiffness, docs/identification.md). The
    # intervals pass unless the seeds show, at ALPHA, a coverage outside 90 to 99 %: too many
    # misses for 90 % (binomial), or errors whose spread is too large for 90 % (1.96 / 1.645
    # standard errors) or too small for 99 % (1.96 / 2.576) (chi^2); and no bias the seeds
    # show (t test at ALPHA). With -s it prints every seed and the coverage per parameter.
    monkeypatch.setenv("RRR4_JIT", "1")
    n = 100
    inside, z, walls = _coverage(1.0, range(1, n + 1))
    misses = n - inside.sum(axis=0)
    report = {k: (1 - m / n, float(np.mean(zz)), float(np.std(zz))) for k, m, zz in zip(KEYS, misses, z.T, strict=True)}
    print(f"coverage, mean and spread of the errors [se]: {report}; wall time median {np.median(walls):.1f} s")
    fail = int(np.argmax(binom.sf(np.arange(n + 1) - 1, n, 0.10) < ALPHA))  # the fewest misses that fail (19)
    assert binom.sf(fail - 1, n, 0.05) < 1e-5  # a correct 95 % interval does not
    assert np.all(binom.sf(misses - 1, n, 0.10) >= ALPHA), report
    ss = np.sum(z ** 2, axis=0)
    assert np.all(chi2.sf(ss / (Z95 / Z90) ** 2, n) >= ALPHA), report
    assert np.all(chi2.cdf(ss / (Z95 / Z99) ** 2, n) >= ALPHA), report
    tstat = np.mean(z, axis=0) / (np.std(z, axis=0, ddof=1) / np.sqrt(n))
    assert np.all(np.abs(tstat) < t.ppf(1 - ALPHA / 2, n - 1)), report

