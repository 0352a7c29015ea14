#!/usr/bin/env python3
"""The race runs of docs/race_reference.md: the FEniCSx peer and ngcontact on the 2D Hertz race
problem (top moved down by d = 0.0171 m), process wall times and errors against the reference
(``ngcontact.studies.hertz_reference``).

    python docs/race/runs.py peer [--reps 3]        -> docs/data/race_peer.jsonl
    python docs/race/runs.py ngcontact [--reps 3]   -> docs/data/race_ngcontact.jsonl
    python docs/race/runs.py goals [--reps 3]       -> docs/data/race_goals.jsonl (the peer's P2 L1 and
                                                       P3 L1 interleaved with adapt.solve(goal=...))
    python docs/race/runs.py recompute docs/data/race_peer.jsonl   (errors again, from the kept samples)

Peer: ``nitsche_contact.py --scene hertz --control disp --disp 0.0171`` (its uniform gmsh levels
P1–P3 × refine 0–3) from a writable copy with the ``--profile`` option of ``peer_profile.patch``
(``cp -r peers /tmp/peers && patch -p0 -d /tmp < docs/race/peer_profile.patch``; PEER, default
/tmp/peers/fenicsx/nitsche_contact.py; interpreter PEER_PY, default /tmp/fenicsx-venv/bin/python).
ngcontact: this script's ``child`` mode in a process of its own: the uniform defaults
``scenes.hertz.simulation(order, dim=2, depth=d, refine=k)`` P1–P3 and ``adapt.solve`` (P2, P3 at
tol 1e-1 … 1e-4, the relative energy estimate) on ``hertz.mesh(2, h_contact=0.1)``.

Each configuration runs once untimed for its errors (the peer with ``--profile``, ngcontact with
``--errors``; the samples kept in RACE_SAMPLES, default /tmp/race_samples; ``recompute`` measures
them again), then ``--reps`` timed runs without the measurement, the repetitions interleaved
(round 1 of every configuration, then round 2, ...). ``proc_wall_s``: the process's wall time
measured by this runner (interpreter start, imports, mesh, solve, its own output), with its CPU
time and the 1-minute load average before and after. A configuration whose first timed run took
more than ``--case-limit`` s (default 180) is not repeated, and the higher levels of its order are
skipped from a level whose first run took a quarter of it (the next would take about 4 times as
long). A study stopped half-way goes on from the runs already in its file; ``--errors-from FILE``
takes each configuration's errors from the runs in FILE (no untimed run: timings only).
"""
import argparse
import json
import os
import pathlib
import resource
import subprocess
import sys
import tempfile
import time

HERE = pathlib.Path(__file__).resolve().parent
ROOT = HERE.parents[1]
PEER = os.environ.get("PEER", "/tmp/peers/fenicsx/nitsche_contact.py")
PEER_PY = os.environ.get("PEER_PY", "/tmp/fenicsx-venv/bin/python")
DISP = "0.0171"
ENV = dict(os.environ, PYTHONPATH=str(ROOT))
CACHE = pathlib.Path(os.environ.get("RACE_SAMPLES", "/tmp/race_samples"))
"""Where the error runs keep their samples (x, y, q, force_h; ``recompute`` measures them again)."""


def peer_configs():
    return [dict(code="peer", kind="uniform", order=p, refine=k) for p in (1, 2, 3) for k in range(4)]


def ngcontact_configs():
    uniform = [dict(code="ngcontact", kind="uniform", order=p, refine=k) for p in (1, 2, 3) for k in range(4)]
    adaptive = [dict(code="ngcontact", kind="adapt", order=p, tol=t) for p in (2, 3) for t in (1e-1, 1e-2, 1e-3, 1e-4)]
    return uniform + adaptive


GOAL_MESH = {"pressure": 0.02, "force": 0.05}
"""h_contact of the first mesh of the goal runs (``hertz.mesh``)."""


def goal_configs():
    """The goal runs (``adapt.solve(goal=...)``) and the peer's levels they are timed against,
    interleaved in one study: the peer's first level below 1e-2 in pressure and its best (P3 L1),
    its P2 L1."""
    peer = [dict(code="peer", kind="uniform", order=p, refine=1) for p in (2, 3)]
    pressure = [dict(code="ngcontact", kind="goal-pressure", order=p, tol=t) for p in (2, 3) for t in (1e-2, 1e-3)]
    force = [dict(code="ngcontact", kind="goal-force", order=p, tol=t) for p, t in ((3, 1e-5), (3, 1e-6), (4, 1e-6))]
    return peer + pressure + force


def command(config, measure=None):
    """The command of one run; ``measure``: the .npz path of the peer's profile / ngcontact's --errors."""
    if config["code"] == "peer":
        cmd = [PEER_PY, PEER, "--scene", "hertz", "--order", str(config["order"]), "--refine",
               str(config["refine"]), "--control", "disp", "--disp", DISP]
        return cmd + (["--profile", measure] if measure else [])
    cmd = [sys.executable, str(pathlib.Path(__file__).resolve()), "child", "--kind", config["kind"], "--order",
           str(config["order"])]
    cmd += ["--refine", str(config["refine"])] if config["kind"] == "uniform" else ["--tol", str(config["tol"])]
    return cmd + (["--errors", measure] if measure else [])


def cached(config):
    """The samples file of ``config``."""
    name = "_".join(f"{k}{config[k]}" for k in sorted(config))
    return CACHE / f"{name}.npz"


def measured(path):
    """The errors of the samples at ``path`` against the package's reference."""
    sys.path.insert(0, str(ROOT))
    import numpy as np
    from ngcontact.studies import hertz_reference
    data = np.load(path)
    e = hertz_reference.errors(data["x"], data["y"], data["q"], force=float(data["force_h"]))
    return dict(force_error=e["force"], a_error=e["a"], pressure_L2=e["pressure_L2"], force_h=e["force_h"],
                a_h=e["a_h"], force_integrated=e["force_integrated"])


def execute(cmd, timeout):
    load = os.getloadavg()[0]
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    try:
        p = subprocess.run(cmd, env=ENV, capture_output=True, text=True, timeout=timeout)
    except subprocess.TimeoutExpired:
        return dict(timeout=timeout, proc_wall_s=time.perf_counter() - t0)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    lines = p.stdout.strip().splitlines()
    try:
        out = json.loads(lines[-1])
    except (IndexError, json.JSONDecodeError):
        out = dict(stderr_tail=p.stderr[-600:])
    out.update(rc=p.returncode, proc_wall_s=wall, loadavg_before=load, loadavg=os.getloadavg()[0],
               proc_cpu_s=(after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime))
    return out


def errors_of(config, timeout):
    """The untimed run of ``config``: its samples kept in ``cached(config)``, its errors."""
    CACHE.mkdir(parents=True, exist_ok=True)
    path = cached(config)
    if config["code"] == "peer":
        with tempfile.TemporaryDirectory() as folder:
            profile = os.path.join(folder, "profile.npz")
            out = execute(command(config, profile), timeout)
            if out.get("rc") != 0 or not os.path.exists(profile):
                return dict(error=out.get("stderr_tail", "no profile"))
            import numpy as np
            data = dict(np.load(profile))
            np.savez(path, force_h=out["resultant_nitsche"], **data)
        return dict(measured(path), ndof=out["ndofs"], newton=out["newton_its"])
    out = execute(command(config, str(path)), timeout)
    if out.get("rc") != 0:
        return dict(error=out.get("stderr_tail", "failed"))
    return dict(measured(path), **{k: out[k] for k in ("ndof", "newton", "reached", "levels", "goal_estimate") if k in out})


def recompute(out):
    """Measure the kept samples of every run in ``out`` again (against the package's reference as
    it is now) and rewrite the file."""
    runs = [json.loads(line) for line in pathlib.Path(out).read_text().splitlines()]
    keys = ("code", "kind", "order", "refine", "tol")
    for run in runs:
        path = cached({k: run[k] for k in keys if k in run})
        if path.exists():
            run.update(measured(path))
    pathlib.Path(out).write_text("".join(json.dumps(run) + "\n" for run in runs))


def study(configs, out, reps, case_limit, errors_from=None):
    """The runs of ``configs`` appended to ``out``: (config, rep) pairs already there are kept
    (a study stopped half-way goes on); a configuration is not run when the level below it of
    the same (code, kind, order) took more than a quarter of ``case_limit`` at its first run (the
    level's time grows about 4 times), nor repeated when its own first run took more."""
    out = pathlib.Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    keys = ("code", "kind", "order", "refine", "tol")
    kept = [json.loads(line) for line in out.read_text().splitlines()] if out.exists() else []
    have = {(json.dumps({k: r[k] for k in keys if k in r}, sort_keys=True), r["rep"]): r for r in kept}
    done, skipped, first = {}, set(), {}
    if errors_from:                         # the errors (and DOFs) of another file's runs: no untimed run
        fields = ("force_error", "a_error", "pressure_L2", "force_h", "a_h", "force_integrated", "ndof", "newton",
                  "reached", "levels")
        for line in pathlib.Path(errors_from).read_text().splitlines():
            r = json.loads(line)
            if "pressure_L2" in r:
                done[json.dumps({k: r[k] for k in keys if k in r}, sort_keys=True)] = {f: r[f] for f in fields if f in r}
    for rep in range(1, reps + 1):
        for config in configs:
            key = json.dumps(config, sort_keys=True)
            group = (config["code"], config["kind"], config["order"])
            if key in skipped or (rep == 1 and group in skipped) or (rep > 1 and key not in first):
                continue
            if (key, rep) in have:
                record = have[key, rep]
            else:
                if key not in done:
                    done[key] = errors_of(config, 3 * case_limit)
                run = execute(command(config), 3 * case_limit)
                record = dict(config, rep=rep, **done[key], proc_wall_s=run["proc_wall_s"],
                              proc_cpu_s=run.get("proc_cpu_s"), loadavg_before=run.get("loadavg_before"),
                              loadavg=run.get("loadavg"), rc=run.get("rc"),
                              t_total=run.get("t_total"), timeout=run.get("timeout"))
                with open(out, "a") as f:
                    f.write(json.dumps(record) + "\n")
                print(f"{config} rep {rep}: {run['proc_wall_s']:.1f} s, errors F "
                      f"{record.get('force_error', float('nan')):.2e} a {record.get('a_error', float('nan')):.2e} "
                      f"p {record.get('pressure_L2', float('nan')):.2e}", flush=True)
            if rep == 1:
                first[key] = record["proc_wall_s"]
                if record["proc_wall_s"] > case_limit:
                    skipped.update((key, group))
                elif record["proc_wall_s"] > case_limit / 4 and config["kind"] == "uniform":
                    skipped.add(group)          # the next level would take more than case_limit


def child(args):
    """One ngcontact run in this process: prints one JSON line."""
    from ngcontact.scenes import hertz
    from ngcontact.studies import hertz_reference
    depth = float(DISP)
    if args.kind == "uniform":
        sim = hertz.simulation(args.order, dim=2, depth=depth, refine=args.refine, keep_states=False)
        sim.step(1.0)
        result = dict(ndof=sim.X.ndof, newton=sim.history[-1].newton_iterations)
    elif args.kind == "adapt":
        import ngcontact as ngc
        adaptation = ngc.adapt.solve(
            lambda mesh: hertz.simulation(args.order, dim=2, depth=depth, mesh=mesh, keep_states=False),
            hertz.mesh(2, h_contact=0.1, curve=args.order), args.tol)
        sim = adaptation.levels[-1].sim
        result = dict(ndof=sim.X.ndof, newton=sum(level.newton for level in adaptation.levels),
                      reached=adaptation.reached, levels=len(adaptation.levels))
    else:
        import ngcontact as ngc
        goal = args.kind[len("goal-"):]
        adaptation = ngc.adapt.solve(
            lambda mesh: hertz.simulation(args.order, dim=2, depth=depth, mesh=mesh, keep_states=False),
            hertz.mesh(2, h_contact=GOAL_MESH[goal], curve=args.order), args.tol, goal=goal)
        sim = adaptation.levels[-1].sim
        result = dict(ndof=sim.X.ndof, newton=sum(level.newton for level in adaptation.levels),
                      reached=adaptation.reached, levels=len(adaptation.levels),
                      goal_estimate=adaptation.levels[-1].goal_estimate)
    result["force_h"] = float(sim.history[-1].contact.force[-1])
    if args.errors:
        import numpy as np
        x, y, q = hertz_reference.facet_samples(sim)
        np.savez(args.errors, x=x, y=y, q=q, force_h=result["force_h"])
    print(json.dumps(result), flush=True)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    sub = parser.add_subparsers(dest="what", required=True)
    for name in ("peer", "ngcontact", "goals"):
        p = sub.add_parser(name)
        p.add_argument("--reps", type=int, default=3)
        p.add_argument("--case-limit", type=float, default=180.0)
        p.add_argument("--only", default=None, help="e.g. uniform:1:0,adapt:2:0.1 (kind:order:refine|tol)")
        p.add_argument("--out", default=str(ROOT / "docs" / "data" / f"race_{name}.jsonl"))
        p.add_argument("--errors-from", default=None, help="take the errors from this runs file")
    c = sub.add_parser("child")
    c.add_argument("--kind", choices=("uniform", "adapt", "goal-pressure", "goal-force"), required=True)
    c.add_argument("--order", type=int, required=True)
    c.add_argument("--refine", type=int, default=0)
    c.add_argument("--tol", type=float, default=None)
    c.add_argument("--errors", metavar="NPZ", default=None, help="keep the samples of the solution there")
    r = sub.add_parser("recompute", help="measure the kept samples of a runs file again")
    r.add_argument("out")
    args = parser.parse_args()
    if args.what == "child":
        return child(args)
    if args.what == "recompute":
        return recompute(args.out)
    configs = dict(peer=peer_configs, ngcontact=ngcontact_configs, goals=goal_configs)[args.what]()
    if args.only:
        wanted = {tuple(item.split(":")) for item in args.only.split(",")}
        configs = [c for c in configs if (c["kind"], str(c["order"]), str(c.get("refine", c.get("tol")))) in wanted]
    study(configs, args.out, args.reps, args.case_limit, args.errors_from)


if __name__ == "__main__":
    sys.exit(main())
