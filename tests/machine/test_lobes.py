"""Zero-order stability lobes (Altintas & Budak 1995)."""

from __future__ import annotations

import numpy as np
import pytest

from taptune.errors import InputError
from taptune.machine import MATERIALS, stability_lobes
from taptune.machine.lobes import _eigenvalues, directional_factors, engagement_angles
from taptune.machine.materials import cutting_coefficients

MM = 1e-3


def sdof(freq_hz, k, zeta, fn):
    """Viscous single mode 1/(k − mω² + icω) [m/N]."""
    w, wn = 2 * np.pi * np.nan_to_num(np.asarray(freq_hz)), 2 * np.pi * fn
    m = k / wn**2
    return 1.0 / (k - m * w**2 + 2j * zeta * wn * m * w)


def test_closed_form_slotting_single_mode():
    """Closed form (Altintas & Budak 1995), slotting with one flexible mode: a_lim,min = 8kζ(1+ζ)/(N K_rc) = 1.6790 mm (k = 1e7, ζ = 0.02, N = 4, K_rc = 243 MPa)."""
    k, zeta, n, krc = 1e7, 0.02, 4, 243e6
    f = np.arange(500.0, 1500.0, 1.0)
    phi = sdof(f, k, zeta, 1000.0)
    rpm = np.arange(2000.0, 14000.0, 5.0)
    lobes = stability_lobes(f, phi, np.zeros_like(phi), teeth=n, ktc=902e6, krc=krc, diameter=12 * MM, ae=12 * MM,
                            milling="down", rpm=rpm)
    exact = 8 * k * zeta * (1 + zeta) / (n * krc)
    assert exact == pytest.approx(1.6790e-3, abs=5e-8)
    assert lobes.a_crit == pytest.approx(exact, rel=1e-5)
    # Every lobe sweeps the whole scan, so the boundary's valleys touch a_crit.
    assert lobes.a_lim.min() == pytest.approx(exact, rel=2e-3)
    # On the boundary a_lim = −2/(N K_rc Re Φ(ω_c)) with the chatter frequency it reports
    # (both interpolated between scan points, so exact only between the lobes' cusps).
    re = np.real(sdof(lobes.chatter_hz, k, zeta, 1000.0))
    assert np.median(np.abs(lobes.a_lim * (-n * krc * re / 2) - 1)) < 1e-4
    assert np.all(np.isfinite(lobes.a_lim)) and np.all(lobes.chatter_hz > 1000.0)  # chatter above f_n
    assert lobes.warnings == ()
    # Above ≈ 14,800 rpm the k = 0 lobe needs chatter frequencies beyond the 1,500 Hz band.
    fast = stability_lobes(f, phi, np.zeros_like(phi), teeth=n, ktc=902e6, krc=krc, diameter=12 * MM, ae=12 * MM,
                           milling="down", rpm=np.arange(14000.0, 16000.0, 10.0))
    assert not np.all(np.isfinite(fast.a_lim)) and "outside the FRF's band" in fast.warnings[0]
    assert None in fast.to_dict()["a_lim_mm"]


def test_directional_factors():
    kr = 0.3
    axx, axy, ayx, ayy = directional_factors(10 * MM, 10 * MM, "up", kr)  # slotting
    assert (axx, axy, ayx, ayy) == pytest.approx((-np.pi * kr, -np.pi, np.pi, -np.pi * kr))
    assert engagement_angles(2.5 * MM, 10 * MM, "up") == pytest.approx((0.0, np.pi / 3))
    assert engagement_angles(2.5 * MM, 10 * MM, "down") == pytest.approx((2 * np.pi / 3, np.pi))
    with pytest.raises(InputError, match="exceeds the tool diameter"):
        engagement_angles(11 * MM, 10 * MM, "up")
    with pytest.raises(InputError, match="'up' or 'down'"):
        engagement_angles(5 * MM, 10 * MM, "climb")


def two_mode_frf(f):
    """x and y with two modes each, slightly different (a realistic tool point)."""
    xx = sdof(f, 2.0e7, 0.012, 2900.0) + sdof(f, 6.0e7, 0.02, 4300.0)
    yy = sdof(f, 1.8e7, 0.012, 2880.0) + sdof(f, 6.5e7, 0.02, 4350.0)
    return xx, yy


@pytest.mark.parametrize("milling, ae", [("down", 4 * MM), ("up", 4 * MM), ("down", 12 * MM)])
def test_finer_chatter_scan_moves_the_boundary_by_less_than_0_2_percent(milling, ae):
    """Convergence of the adaptive scan: refine 8 (default) vs 16 on a 2 Hz FRF grid."""
    f = np.arange(200.0, 10000.0, 2.0)
    xx, yy = two_mode_frf(f)
    rpm = np.arange(3000.0, 30000.0, 10.0)
    args = dict(teeth=3, ktc=902e6, krc=243e6, diameter=12 * MM, ae=ae, milling=milling, rpm=rpm)
    coarse = stability_lobes(f, xx, yy, **args)
    fine = stability_lobes(f, xx, yy, refine=16, **args)
    assert np.max(np.abs(coarse.a_lim / fine.a_lim - 1)) < 0.002
    assert abs(coarse.a_crit / fine.a_crit - 1) < 0.002


def test_boundary_pockets_and_json():
    f = np.arange(200.0, 10000.0, 2.0)
    xx, yy = two_mode_frf(f)
    rpm = np.arange(3000.0, 30001.0, 10.0)
    lobes = stability_lobes(f, xx, yy, teeth=3, ktc=902e6, krc=243e6, diameter=12 * MM, ae=6 * MM, milling="down",
                            rpm=rpm)
    assert np.all(np.isfinite(lobes.a_lim)) and np.all(lobes.a_lim >= lobes.a_crit * (1 - 1e-9))
    assert all(np.any(np.isfinite(a)) for _, _, a in lobes.curves)
    heights = [a for _, a in lobes.pockets]
    assert heights == sorted(heights, reverse=True) and len(heights) >= 3
    best_rpm, best_a = lobes.pockets[0]
    assert best_a == pytest.approx(lobes.a_lim.max(), rel=1e-9) or best_a < lobes.a_lim.max()
    d = lobes.to_dict()
    assert set(d) == {"rpm", "a_lim_mm", "a_crit_mm", "pockets", "chatter_hz", "method", "instability", "depth_cap_mm"}
    assert d["a_crit_mm"] == pytest.approx(lobes.a_crit / MM) and len(d["rpm"]) == len(rpm)
    assert d["pockets"][0] == {"rpm": best_rpm, "a_lim_mm": pytest.approx(best_a / MM)}


def lobe_by_lobe(f, xx, yy, rpm, teeth, ktc, krc, diameter, ae, milling):
    """The boundary the plain way: every lobe k and root, each monotonic run of valid scan
    points interpolated onto the speeds with np.interp; also which lobes reach the speeds."""
    lam = _eigenvalues(xx, yy, directional_factors(ae, diameter, milling, krc / ktc))
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        kappa = lam.imag / lam.real
        a = -2 * np.pi * lam.real * (1 + kappa**2) / (teeth * ktc)
        eps = np.pi - 2 * np.arctan(kappa)
    valid = np.isfinite(a) & (a > 0)
    best, chatter, reached = np.full(len(rpm), np.inf), np.full(len(rpm), np.nan), []
    k_max = int(np.ceil(60 * f[-1] / (teeth * rpm.min()))) + 1
    for k in range(k_max + 1):
        for r in range(2):
            n = 60 * 2 * np.pi * f / (teeth * (eps[r] + 2 * k * np.pi))
            ok = valid[r]
            pair = ok[:-1] & ok[1:]
            inside = np.any(ok & (n >= rpm[0]) & (n <= rpm[-1]))
            across = np.any(pair & (np.minimum(n[:-1], n[1:]) < rpm[0]) & (np.maximum(n[:-1], n[1:]) > rpm[-1]))
            if pair.any() and (inside or across):
                reached.append((k, np.where(ok, n, np.nan)))
            # runs of valid segments going the same way
            step = np.sign(np.diff(n))
            cut = np.flatnonzero(~pair | np.r_[False, step[1:] != step[:-1]])
            for seg in np.split(np.arange(len(f) - 1), cut):
                seg = seg[pair[seg]]
                if seg.size == 0:
                    continue
                i = np.r_[seg, seg[-1] + 1]
                o = np.argsort(n[i])
                x = n[i][o]
                on = (rpm >= x[0]) & (rpm <= x[-1])
                val = np.interp(rpm[on], x, a[r, i][o])
                lower = val < best[on]
                best[on] = np.minimum(best[on], val)
                chatter[np.flatnonzero(on)[lower]] = np.interp(rpm[on], x, f[i][o])[lower]
    return best, chatter, reached


@pytest.mark.parametrize("milling, ae, y", [("down", 4 * MM, True), ("up", 3 * MM, True), ("down", 12 * MM, False)])
def test_envelope_matches_a_lobe_by_lobe_route(milling, ae, y):
    """The vectorised, pruned envelope against the plain per-lobe np.interp over a wide speed range
    (about 150 lobes per root reach 800 rpm); the lobes listed in ``curves`` too."""
    f = np.arange(200.0, 6000.0, 4.0)
    xx, yy = two_mode_frf(f)
    yy = yy if y else np.zeros_like(yy)
    rpm = np.linspace(800.0, 24000.0, 700)
    args = dict(teeth=3, ktc=902e6, krc=243e6, diameter=12 * MM, ae=ae, milling=milling)
    lobes = stability_lobes(f, xx, yy, rpm=rpm, refine=1, **args)
    best, chatter, reached = lobe_by_lobe(f, xx, yy, rpm, **args)
    assert np.all(np.isfinite(best))
    assert np.max(np.abs(lobes.a_lim / best - 1)) < 1e-12
    # the chatter frequency is ambiguous only where two lobes meet exactly at a speed
    assert np.mean(np.abs(lobes.chatter_hz - chatter) < 1e-6) > 0.99
    assert [k for k, _, _ in lobes.curves] == [k for k, _ in reached]
    assert all(np.allclose(n, m, rtol=1e-14, equal_nan=True) for (_, n, _), (_, m) in zip(lobes.curves, reached))


def test_y_defaults_to_x_and_bad_inputs():
    f = np.arange(500.0, 1500.0, 1.0)
    phi = sdof(f, 1e7, 0.02, 1000.0)
    args = dict(teeth=2, ktc=700e6, krc=200e6, diameter=10 * MM, ae=3 * MM, milling="up", rpm=np.arange(5000.0, 9000.0, 10.0))
    a = stability_lobes(f, phi, None, **args)
    b = stability_lobes(f, phi, phi, **args)
    assert np.array_equal(a.a_lim, b.a_lim)
    with pytest.raises(InputError, match="strictly ascending"):
        stability_lobes(f[::-1], phi, None, **args)
    with pytest.raises(InputError, match="teeth"):
        stability_lobes(f, phi, None, **{**args, "teeth": 0})
    with pytest.raises(InputError, match="spindle speeds"):
        stability_lobes(f, phi, None, **{**args, "rpm": np.array([0.0, 100.0])})


def test_materials_table():
    al = cutting_coefficients("AL-6082")
    assert (al.ktc, al.krc) == (902e6, 243e6)
    assert all(m.source for m in MATERIALS.values())
    # the names users type: aliases of the same published values
    assert cutting_coefficients("aluminium-6082") is al
    assert cutting_coefficients("Al7075-T6").ktc == 767e6
    with pytest.raises(InputError, match="unknown work material"):
        cutting_coefficients("unobtainium")
