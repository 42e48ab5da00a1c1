"""How well ``taptune cut`` hears chatter and finds the next speed, on simulated cuts.

``python -m benchmarks.cut.bench_cut [--per-config N] [--seed S]``

Cuts come from the time-domain milling simulation with the regenerative delay
(:mod:`taptune.machine.simulate`) on three tools (a 2-mode end mill, a 1-mode light radial
cut, a 4-tooth slotting cutter), at random speeds and at depths from well below to well
above the critical depth, turned into shop sound (:mod:`benchmarks.cut.sounds`: noise,
fans, run-out, mains hum, AAC on a third, speed overrides of a few %). The truth of
"stable" is the growth of the linear delay equation (< 1), simulated.

Printed: verdicts right on clear cases (stable, or chatter ≥ 10 dB above the forced
vibration), `stable` said of a chatter ≥ 20 dB, the chatter frequency's error, and the
share of chatter cases whose first suggested speed is truly stable at the cut's depth
(by the rule, and from the lobes of the true tool-point FRF: SDM, or ZOA with --method zoa).
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from benchmarks.cut.sounds import render_cuts, simulate_batch
from taptune.machine.lobes import stability_lobes
from taptune.machine.next_speed import lobe_advice
from taptune.machine.simulate import ModalSet, simulate_milling
from taptune.signal.cut import analyse_cut, smith_tlusty_speeds

CONFIGS = [
    dict(name="2-mode end mill, Z3, ae/D 0.5 down", teeth=3, diameter=16e-3, ae=8e-3, milling="down",
         mx=ModalSet((900.0, 2100.0), (0.02, 0.03), (8e6, 3e7)), my=ModalSet((950.0, 2200.0), (0.02, 0.03), (9e6, 3e7)),
         rpm=(5000, 14000)),
    dict(name="1-mode tool, Z2, ae/D 0.25 up", teeth=2, diameter=12e-3, ae=3e-3, milling="up",
         mx=ModalSet((1500.0,), (0.015,), (6e6,)), my=ModalSet((1500.0,), (0.015,), (6e6,)), rpm=(6000, 20000)),
    dict(name="4-tooth slotting, modes 2.4/2.6 kHz", teeth=4, diameter=12e-3, ae=12e-3, milling="down",
         mx=ModalSet((2400.0,), (0.025,), (1.5e7,)), my=ModalSet((2600.0,), (0.025,), (1.8e7,)), rpm=(6000, 18000)),
]
KTC, KRC = 800e6, 200e6
DEPTH_FACTORS = (0.5, 1.0, 1.6, 2.5)
MAX_RPM = 24000.0


def _cached(folder, key: str, make):
    """``make()`` (picklable), kept in ``folder`` under ``key`` when a folder is given."""
    if not folder:
        return make()
    import hashlib
    import pickle
    from pathlib import Path

    path = Path(folder) / (hashlib.sha1(key.encode()).hexdigest()[:16] + ".pkl")
    if path.is_file():
        return pickle.loads(path.read_bytes())
    out = make()
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_bytes(pickle.dumps(out))
    return out


def linear_growth(cfg, rpm: float, depths) -> np.ndarray:
    """Growth per tooth period of the linear delay equation at ``rpm`` for each depth [m] (see truly_stable)."""
    run = simulate_milling(cfg["mx"], cfg["my"], teeth=cfg["teeth"], ktc=KTC, krc=KRC, diameter=cfg["diameter"],
                           ae=cfg["ae"], milling=cfg["milling"], rpm=rpm, depth=list(depths), duration_s=0.4, fs=8000,
                           feed_per_tooth=0.0, steps=48, rng=np.random.default_rng(5), contact_loss=False)
    return np.atleast_1d(run.growth).astype(float)


def truly_stable(cfg, rpm: float, depth: float) -> bool:
    """Growth of the linear delay equation < 1 at (rpm, depth).

    Without feed: only the free vibration from a random start, so that the growth per tooth
    period is the critical multiplier's even where a tooth-passing harmonic sits on a mode
    (with feed the forced vibration, repeating every period, leaves the estimate at 1.000).
    """
    run = simulate_milling(cfg["mx"], cfg["my"], teeth=cfg["teeth"], ktc=KTC, krc=KRC, diameter=cfg["diameter"],
                           ae=cfg["ae"], milling=cfg["milling"], rpm=rpm, depth=[depth], duration_s=0.4, fs=8000,
                           feed_per_tooth=0.0, steps=48, rng=np.random.default_rng(5), contact_loss=False)
    return bool(np.atleast_1d(run.growth)[0] < 1.0)


def main(argv=None) -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--per-config", type=int, default=4, help="speeds per tool (each with 4 depths)")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--method", choices=("zoa", "sdm"), default="sdm",
                   help="the lobes the holder+machine suggestion uses (of the true tool-point FRF)")
    p.add_argument("--dump", metavar="JSON", help="write every cut's truth and verdict")
    p.add_argument("--cache", metavar="DIR", help="keep the simulated cuts here (re-runs only listen again)")
    args = p.parse_args(argv)
    rng = np.random.default_rng(args.seed)
    rows, diverged = [], []
    t0 = time.time()
    for cfg in CONFIGS:
        f = np.linspace(100, 6000, 5901)
        gx, gy = cfg["mx"].frf(f), cfg["my"].frf(f)
        grid = np.arange(2000.0, MAX_RPM + 1, 5.0 if args.method == "zoa" else 40.0)
        lobes = stability_lobes(f, gx, gy, teeth=cfg["teeth"], ktc=KTC, krc=KRC, diameter=cfg["diameter"],
                                ae=cfg["ae"], milling=cfg["milling"], rpm=grid, method=args.method,
                                modes=(cfg["mx"], cfg["my"]))
        # The depths are sized on the zero-order critical depth (the same cuts whatever --method).
        size = stability_lobes(f, gx, gy, teeth=cfg["teeth"], ktc=KTC, krc=KRC, diameter=cfg["diameter"],
                               ae=cfg["ae"], milling=cfg["milling"], rpm=np.arange(500.0, MAX_RPM + 1, 5.0))
        print(f"  {cfg['name']}: {args.method} lobes, critical depth {lobes.a_crit * 1e3:.2f} mm", flush=True)
        for _ in range(args.per_config):
            rpm = float(rng.uniform(*cfg["rpm"]))
            depths = [size.a_crit * k * rng.uniform(0.85, 1.15) for k in DEPTH_FACTORS]
            seed = int(rng.integers(1 << 30))
            codec = "aac" if rng.random() < 1 / 3 else None
            shop = dict(noise_db=float(rng.uniform(-35, -20)), hum_hz=float(rng.choice([50.0, 60.0])),
                        fans=int(rng.integers(0, 4)))
            override = float(rng.choice([1.0, 1.0, rng.uniform(0.96, 1.05)]))
            batch = _cached(args.cache, f"{cfg['name']}-{rpm * override:.3f}-{seed}", lambda: simulate_batch(
                cfg["mx"], cfg["my"], teeth=cfg["teeth"], ktc=KTC, krc=KRC, diameter=cfg["diameter"], ae=cfg["ae"],
                milling=cfg["milling"], rpm=rpm * override, depths=depths, seed=seed))
            # The truth from the free vibration (kept batches may hold the growth with feed).
            batch = batch | {"growth": linear_growth(cfg, rpm * override, depths)}
            cuts = render_cuts(batch, commanded_rpm=rpm, seed=seed, codec=codec, **shop)
            for depth, (rec, truth, growth), vib in zip(depths, cuts, batch["vibration"]):
                if not np.all(np.isfinite(vib)) or np.max(np.abs(vib)) > 1e-3:
                    diverged.append((cfg["name"], rpm, depth))  # the simulation, not the cut: left out
                    continue
                try:
                    a = analyse_cut(rec, rpm, cfg["teeth"])
                except Exception as err:  # a refusal is a miss, counted
                    rows.append(dict(cfg=cfg["name"], truth=truth, verdict=f"refused: {err}", a=None))
                    continue
                row = dict(cfg=cfg["name"], truth=truth, verdict=a.verdict, a=a, depth=depth)
                if truth.kind == "chatter" and a.chatter_hz is not None:
                    rule = smith_tlusty_speeds(a.chatter_hz, cfg["teeth"], a.spindle_rpm, min_rpm=500, max_rpm=MAX_RPM)
                    adv = lobe_advice(grid, lobes.a_lim, depth, a.spindle_rpm, max_rpm=MAX_RPM)
                    row["rule_ok"] = truly_stable(cfg, rule[0], depth) if rule else False
                    row["lobes_ok"] = truly_stable(cfg, adv.suggested_rpm[0], depth) if adv.depth_to is None else None
                rows.append(row)
            print(f"  {cfg['name']}: {rpm:.0f} rpm done ({time.time() - t0:.0f} s)", flush=True)
    if args.dump:
        import json

        def plain(r):
            a, t = r["a"], r["truth"]
            return {"config": r["cfg"], "kind": t.kind, "truth_hz": t.chatter_hz, "truth_db": t.chatter_db,
                    "rpm": t.rpm, "depth_mm": r.get("depth", 0) * 1e3, "verdict": r["verdict"],
                    "chatter_hz": a and a.chatter_hz, "level_db": a and a.chatter_level_db,
                    "family_hz": a and list(a.family_hz), "family_db": a and list(a.family_level_db),
                    "rule_ok": r.get("rule_ok"), "lobes_ok": r.get("lobes_ok")}

        with open(args.dump, "w") as fh:
            json.dump([plain(r) for r in rows], fh, indent=1)
    clear = [r for r in rows if r["truth"].kind == "stable" or (r["truth"].chatter_db or -99) >= 10]
    right = [r for r in clear if r["verdict"] == r["truth"].kind]
    loud = [r for r in rows if r["truth"].kind == "chatter" and (r["truth"].chatter_db or -99) >= 20]
    missed_loud = [r for r in loud if r["verdict"] == "stable"]
    errs = [abs(r["a"].chatter_hz / r["truth"].chatter_hz - 1) for r in rows
            if r["truth"].kind == "chatter" and r["a"] is not None and r["a"].chatter_hz and r["verdict"] == "chatter"]
    rule = [r["rule_ok"] for r in rows if "rule_ok" in r]
    lob = [r["lobes_ok"] for r in rows if r.get("lobes_ok") is not None]
    n_chatter = sum(r["truth"].kind == "chatter" for r in rows)
    print(f"\n{len(rows)} cuts ({n_chatter} chatter by the linear growth), {time.time() - t0:.0f} s; "
          f"{len(diverged)} left out (the simulation with loss of contact diverged: > 1 mm)")
    print(f"verdicts right on clear cases: {len(right)}/{len(clear)} = {100 * len(right) / max(len(clear), 1):.0f} %")
    for cfg in CONFIGS:
        mine = [r for r in clear if r["cfg"] == cfg["name"]]
        print(f"   {cfg['name']}: {sum(r in right for r in mine)}/{len(mine)}")
    for r in clear:
        if r["verdict"] != r["truth"].kind:
            a = r["a"]
            print(f"   wrong: {r['cfg']}: truth {r['truth'].kind} ({r['truth'].chatter_hz}, {r['truth'].chatter_db}) "
                  f"said {r['verdict']} {None if a is None else (a.chatter_hz, a.chatter_level_db)}")
    print(f"'stable' said of chatter >= 20 dB: {len(missed_loud)}/{len(loud)}")
    if errs:
        print(f"chatter frequency error (chatter verdicts): median {100 * np.median(errs):.2f} %, "
              f"within 1 %: {sum(e <= 0.01 for e in errs)}/{len(errs)}")
    print(f"first suggested speed truly stable, rule: {sum(rule)}/{len(rule)} = {100 * np.mean(rule or [0]):.0f} %")
    print(f"first suggested speed truly stable, {args.method.upper()} lobes of the true FRF: {sum(lob)}/{len(lob)} = "
          f"{100 * np.mean(lob or [0]):.0f} %")


if __name__ == "__main__":
    main()
