#!/usr/bin/env python3
"""The Hertz race: ngcontact (default options) against the FEniCSx peer, interleaved; tables.

For each (order, level) and each repetition the codes run one after the other (A, B, C, A, B,
C, ...), so that a burst of load from other jobs on this shared machine hits all of them:

* ``ngc``: ``ngc_hertz.py`` (next to this file) with the ngcontact checkout ``--ngc`` on
  ``PYTHONPATH`` and ``--ngc-args`` (default: none, i.e. ngcontact's defaults); or, with
  ``--variant LABEL=ARGS`` (repeatable), one ngcontact runner per variant, labelled LABEL, with
  ``--ngc-args`` and then ARGS (e.g. ``--variant "ngc-force-informed=--control force --start
  informed"``), all in the same interleaved sequence;
* ``peer-disp``: ``nitsche_contact.py --scene hertz --control disp --disp 0.0171`` (the same
  problem: the top moved down, Newton from the rigid shift);
* ``peer-force``: ``nitsche_contact.py --scene hertz`` (its own force control, informed start).

``--ngc-only`` races two ngcontact checkouts instead: ``ngc-A`` (``--ngc``, ``--ngc-args``)
against ``ngc-B`` (``--ngc-b``, ``--ngc-b-args``), interleaved; ratios are B ÷ A.

Every run appends one JSON line to ``--out`` (the code's own line plus the runner's label,
repetition, exit code, process wall and CPU time and the 1-minute load average before and
after). The tables (``--tables FILE ...`` prints them again from such files):

1. time to ≤ 3 % and ≤ 1.5 % pressure error (the peer's metric, λ_h in L2 against Hertz):
   the configuration with the smallest setup + solve that reaches it, minimum and median over
   the repetitions, Newton iterations, and the ratios;
2. cost per Newton iteration per u-DOF (µs; Newton time: ngcontact's residual + assembly +
   factorisation + solve, the peer's SNES) with the ratios, and setup + solve;
3. the phase split of each ngcontact label (medians): setup, the ``StepRecord.timings``
   phases, factorisations, GMRES iterations, and for a nested start the coarse levels.

Every ngcontact label is compared with every peer label (ratios ngcontact ÷ peer).

"setup + solve" is from the mesh to the converged state (ngcontact: Body + Loads + Contact +
Simulation + ``sim.step``; the peer: forms from the JIT cache + SNES); imports and meshing are
apart. Interpreters: ``--ngc-py`` / ``NGC_PY`` (default: this Python), ``--peer-py`` /
``PEER_PY`` (default /tmp/peer-venv/bin/python); the peer's script: ``--peer-script`` /
``PEER_SCRIPT`` (default /tmp/peers/fenicsx/nitsche_contact.py); the checkout: ``--ngc`` /
``NGC_PATH`` (default /work/main); extra ngcontact options: ``--ngc-args`` / ``NGC_ARGS``.
Nothing here asserts a time.
"""
import argparse
import json
import os
import pathlib
import platform
import resource
import shlex
import statistics
import subprocess
import sys
import time
from collections import defaultdict

HERE = pathlib.Path(__file__).resolve().parent
DISP = "0.0171"          # top motion: the peer's resultant is 0.0099985 at P2 level 2 (turn-3 race)
THRESHOLDS = (0.03, 0.015)
PEERS = ("peer-disp", "peer-force")


# ------------------------------------------------------------------------------- running
def contestants(args):
    """{label: (command without order/level, env)} in the order they run."""
    def ngc(checkout, extra, settings):
        env = dict(os.environ, PYTHONPATH=str(checkout),
                   PATH=str(pathlib.Path(args.ngc_py).parent) + os.pathsep + os.environ.get("PATH", ""))
        env.update(settings)
        return [args.ngc_py, str(HERE / "ngc_hertz.py"), "--disp", DISP] + shlex.split(extra), env

    if args.ngc_only:
        return {"ngc-A": ngc(args.ngc, args.ngc_args, args.ngc_env),
                "ngc-B": ngc(args.ngc_b, args.ngc_b_args, args.ngc_b_env)}
    peer = [args.peer_py, args.peer_script, "--scene", "hertz"]
    runners = {label: ngc(args.ngc, args.ngc_args + " " + extra, args.ngc_env) for label, extra in args.variant} \
        or {"ngc": ngc(args.ngc, args.ngc_args, args.ngc_env)}
    runners.update({"peer-disp": (peer + ["--control", "disp", "--disp", DISP], None), "peer-force": (peer, None)})
    return runners


def run(label, cmd, env, rep, out):
    """Run one command, append its JSON line (with the runner's measurements) to ``out``."""
    load_before = os.getloadavg()[0]
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    p = subprocess.run(cmd, env=env, capture_output=True, text=True, cwd=HERE)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    lines = p.stdout.strip().splitlines()
    try:
        rec = json.loads(lines[-1]) if lines else {"parse_error": "no output"}
    except json.JSONDecodeError:
        rec = {"parse_error": lines[-1][:300]}
    rec.update(label=label, rep=rep, rc=p.returncode, proc_wall_s=wall,
               proc_cpu_s=(after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime),
               loadavg_before=load_before, loadavg=os.getloadavg()[0],
               cmd=" ".join(pathlib.Path(c).name if "/" in c else c for c in cmd))
    if p.returncode != 0:
        rec["stderr_tail"] = p.stderr[-800:]
    with open(out, "a") as f:
        f.write(json.dumps(rec) + "\n")
    err = rec.get("p_l2_rel_err")
    print(f"{label:18s} P{rec.get('order')} L{rec.get('refine')} rep {rep} rc {p.returncode} "
          f"its {rec.get('newton_its')} wall {wall:6.1f} s setup+solve {solve_time(rec):7.3f} s "
          f"err {err if err is not None else float('nan'):.4f} load {rec['loadavg']:.2f}", flush=True)
    return wall


def race(args):
    cs = contestants(args)
    configs = [(p, lv) for p in args.orders for lv in args.levels]
    print(f"# {len(configs)} configurations x {args.reps} repetitions x {list(cs)}; out {args.out}")
    for label, (cmd, env) in cs.items():
        extra = {k: v for k, v in (env or {}).items() if os.environ.get(k) != v and k != "PATH"}
        print(f"#   {label}: {' '.join(cmd)}" + (f"  {extra}" if extra else ""))
    print(f"# machine: {platform.node()}, {os.cpu_count()} cores, load average {os.getloadavg()}", flush=True)
    if not args.no_warmup:      # the peer's FFCx/CFFI JIT cache; the file cache of both
        for order in args.orders:
            for label, (cmd, env) in cs.items():
                subprocess.run(cmd + ["--order", str(order), "--refine", "0"], env=env, capture_output=True,
                               cwd=HERE)
    stopped = set()
    for order, level in configs:
        if order in stopped:
            print(f"P{order} L{level}: skipped (a lower level took more than {args.case_limit:g} s)", flush=True)
            continue
        longest = 0.0
        for rep in range(1, args.reps + 1):
            for label, (cmd, env) in cs.items():
                longest = max(longest, run(label, cmd + ["--order", str(order), "--refine", str(level)],
                                           env, rep, args.out))
        if args.case_limit and longest > args.case_limit:
            stopped.add(order)


# ------------------------------------------------------------------------------- tables
def solve_time(r):
    """Setup + solve (s): from the mesh to the converged state; NaN for a failed run."""
    if r.get("code") == "ngcontact":
        return r.get("t_setup", float("nan")) + r.get("t_step", float("nan"))
    if "t_snes" in r:
        return r["t_setup_jit"] + r["t_snes"]
    return float("nan")


def newton_time(r):
    return r["t_newton"] if r.get("code") == "ngcontact" else r["t_snes"]


def load(paths):
    rows = []
    for p in paths:
        rows += [json.loads(line) for line in pathlib.Path(p).read_text().splitlines() if line.strip()]
    return rows


def summarize(rows):
    """{(label, order, level): summary} over the converged runs."""
    groups = defaultdict(list)
    for r in rows:
        if r.get("rc") == 0 and r.get("converged", False):
            groups[(r["label"], r["order"], r["refine"])].append(r)
    out = {}
    for key, rs in groups.items():
        r = rs[0]
        solve = [solve_time(x) for x in rs]
        newton = [newton_time(x) for x in rs]
        its = r["newton_its"]
        s = dict(label=key[0], order=key[1], level=key[2], reps=len(rs), ndofs=r["ndofs"], its=its,
                 err=r["p_l2_rel_err"], err_spread=max(x["p_l2_rel_err"] for x in rs) - min(x["p_l2_rel_err"] for x in rs),
                 its_set=sorted({x["newton_its"] for x in rs}),
                 solve_min=min(solve), solve_med=statistics.median(solve),
                 newton_min=min(newton), newton_med=statistics.median(newton),
                 impmesh_med=statistics.median(x["t_import"] + x["t_mesh"] for x in rs),
                 us_min=1e6 * min(newton) / r["ndofs"] / max(its, 1),
                 us_med=1e6 * statistics.median(newton) / r["ndofs"] / max(its, 1))
        if r.get("code") == "ngcontact":
            def med(f):
                values = [f(x) for x in rs]
                return None if any(v is None for v in values) else statistics.median(values)
            s.update(setup_med=med(lambda x: x["t_setup"]), step_med=med(lambda x: x["t_step"]),
                     **{f"phase_{ph}": med(lambda x, ph=ph: x.get("timings", {}).get(ph))
                        for ph in ("residual", "assembly", "factorization", "solve", "other")},
                     coarse_its=r.get("coarse_its"), coarse_ndofs=r.get("coarse_ndofs"),
                     coarse_med=med(lambda x: x.get("t_coarse")), before_med=med(lambda x: x.get("t_before_step")),
                     start=r.get("start"), start_used=r.get("start_used"), hierarchy=r.get("hierarchy"),
                     factorizations=r.get("factorizations"), krylov=r.get("krylov_iterations"),
                     realcompile=r.get("realcompile"), condense=r.get("condense"), threads=r.get("threads"),
                     solver=r.get("solver"), commit=r.get("ngcontact_commit"), dirty=r.get("ngcontact_dirty"))
        out[key] = s
    return out


def cheapest(summary, label, threshold):
    ok = [s for (lab, _, _), s in summary.items() if lab == label and s["err"] <= threshold]
    return min(ok, key=lambda s: s["solve_min"]) if ok else None


def ratio(a, b, key):
    return a[key] / b[key] if a is not None and b is not None and b[key] > 0 else None


def its_text(s):
    """Newton iterations on the finest level, the coarse levels' (coarsest first) after a +."""
    return f"{s['its']}" + (f" (+{'/'.join(map(str, s['coarse_its']))} coarse)" if s.get("coarse_its") else "")


def fmt_ratio(a, b):
    if a is None or b is None:
        return "–"
    return (f"**{a['solve_min'] / b['solve_min']:.2f}** ({a['solve_med'] / b['solve_med']:.2f}; "
            f"Newton {a['newton_min'] / b['newton_min']:.2f})")


def time_to_accuracy(summary, labels, pairs):
    """One row per (threshold, label): the cheapest configuration that reaches it and the
    ratios of an ngcontact label to each peer's cheapest (``pairs``)."""
    peers = [b for b in PEERS if b in labels]
    lines = ["| error | label | setup+solve s min (med) | configuration | Newton its | error | "
             + " | ".join(f"÷ {b}" for b in peers) + " |", "|---" * (6 + len(peers)) + "|"]
    for th in THRESHOLDS:
        best = {lab: cheapest(summary, lab, th) for lab in labels}
        for lab in labels:
            b = best[lab]
            if b is None:
                lines.append(f"| ≤ {100 * th:g} % | {lab} | not reached | | | | " + " | ".join("" for _ in peers) + " |")
                continue
            cells = [f"≤ {100 * th:g} %", lab, f"{b['solve_min']:.3f} ({b['solve_med']:.3f})",
                     f"P{b['order']} L{b['level']}, {b['ndofs']:,} u-DOFs", its_text(b), f"{b['err']:.4f}"]
            cells += [fmt_ratio(b, best[peer]) if (lab, peer) in pairs else "" for peer in peers]
            lines.append("| " + " | ".join(cells) + " |")
    lines.append("")
    lines.append("Setup + solve, minimum over the repetitions (median); ratios: of minima (of medians; "
                 "of Newton-only minima) at each runner's own cheapest configuration.")
    return "\n".join(lines)


def per_iteration(summary, labels, pairs):
    """One row per (order, level, label): iterations, µs per u-DOF per Newton iteration and
    setup + solve, with the ratios of each ngcontact label to each peer at the same (P, L)."""
    peers = [b for b in PEERS if b in labels]
    head = ("| P | L | label | u-DOFs | its | µs/DOF/it (min) | " + " | ".join(f"÷ {b} per it (min; med)" for b in peers)
            + " | setup+solve s min (med) | " + " | ".join(f"÷ {b} setup+solve (min; med)" for b in peers) + " |")
    lines = [head, "|---" * (7 + 2 * len(peers)) + "|"]
    for o, lv in sorted({(o, lv) for (_, o, lv) in summary}):
        for lab in labels:
            s = summary.get((lab, o, lv))
            if s is None:
                continue
            cells = [str(o), str(lv), lab, f"{s['ndofs']:,}", its_text(s), f"{s['us_min']:.2f}"]
            for b in peers:
                t = summary.get((b, o, lv))
                cells.append("" if t is None or lab in peers else
                             f"{s['us_min'] / t['us_min']:.2f}; {s['us_med'] / t['us_med']:.2f}")
            cells.append(f"{s['solve_min']:.3f} ({s['solve_med']:.3f})")
            for b in peers:
                t = summary.get((b, o, lv))
                cells.append("" if t is None or lab in peers else
                             f"{s['solve_min'] / t['solve_min']:.2f}; {s['solve_med'] / t['solve_med']:.2f}")
            lines.append("| " + " | ".join(cells) + " |")
    lines.append("")
    lines.append("µs per u-DOF per Newton iteration of the finest level's Newton time (ngcontact: residual + "
                 "assembly + factorisation + solve of StepRecord.timings; the peer: SNES), minimum over the "
                 "repetitions; a nested start's coarse levels are not in it (they are in setup + solve). "
                 "Setup + solve: minimum (median).")
    return "\n".join(lines)


def phase_split(summary, labels):
    lines = ["| label | P | L | u-DOFs | setup+solve s | setup | before step | residual | assembly | factorization "
             "| solve | other | of it coarse levels | its | factorizations | GMRES its | realcompile | solver |",
             "|---" * 18 + "|"]
    solvers = []
    for (lab, o, lv), s in sorted(summary.items(), key=lambda kv: (kv[0][0], kv[0][1], kv[0][2])):
        if lab not in labels or "setup_med" not in s:
            continue
        def f(key):
            return "–" if s.get(key) is None else f"{s[key]:.3f}"
        lines.append(f"| {lab} | {o} | {lv} | {s['ndofs']:,} | {s['solve_med']:.3f} | {f('setup_med')} | "
                     f"{f('before_med')} | {f('phase_residual')} | {f('phase_assembly')} | {f('phase_factorization')} | "
                     f"{f('phase_solve')} | {f('phase_other')} | {f('coarse_med')} | {its_text(s)} | "
                     f"{s['factorizations']} | {s['krylov']} | {s['realcompile']} | "
                     f"{solvers.index(s['solver']) + 1 if s['solver'] in solvers else solvers.append(s['solver']) or len(solvers)} |")
    lines.append("")
    lines.append("Medians over the repetitions, s; setup = Body + Loads + Contact + Simulation; the other phases "
                 "are sim.step's StepRecord.timings (other: step length, norms, records, and Newton's start: the "
                 "coarse levels' steps of a nested start, the touch of a force-controlled warm start); before step: "
                 "sim.step's time before its record's clock starts (a nested start's levels built at the first "
                 "use). Solvers: "
                 + "; ".join(f"{i + 1}: {name}" for i, name in enumerate(solvers)) + ".")
    return "\n".join(lines)


def noise(rows, labels):
    ok = [r for r in rows if r.get("rc") == 0]
    loads = [r["loadavg"] for r in ok] + [r["loadavg_before"] for r in ok]
    lines = [f"runs: {len(rows)}, {len(ok)} with exit code 0"
             + (f"; failed: {sorted({(r['label'], r.get('order'), r.get('refine')) for r in rows if r.get('rc') != 0})}"
                if len(ok) < len(rows) else "")]
    if loads:
        lines.append(f"1-minute load average before/after the runs: min {min(loads):.2f}, "
                     f"median {statistics.median(loads):.2f}, max {max(loads):.2f}")
    for lab in labels:
        rs = [r for r in ok if r["label"] == lab]
        if rs:
            lines.append(f"{lab}: CPU/wall of the process, median {statistics.median(r['proc_cpu_s'] / r['proc_wall_s'] for r in rs):.2f}")
    commits = sorted({(r["label"], r.get("ngcontact_commit"), r.get("ngcontact_dirty"), r.get("ngcontact_dir"))
                      for r in ok if r.get("code") == "ngcontact"})
    for lab, commit, dirty, root in commits:
        lines.append(f"{lab}: ngcontact {commit}{' (uncommitted changes)' if dirty else ''} from {root}")
    return "\n".join(lines)


def tables(rows):
    labels = list(dict.fromkeys(r["label"] for r in rows if "label" in r))      # in the order they ran
    ngc_labels = [lab for lab in labels if lab not in PEERS]
    labels = ngc_labels + [p for p in PEERS if p in labels]
    pairs = [(a, p) for a in ngc_labels for p in PEERS if p in labels and a not in ("ngc-A", "ngc-B")]
    if "ngc-A" in labels and "ngc-B" in labels:
        pairs.append(("ngc-B", "ngc-A"))
    summary = summarize(rows)
    bad = [(k, s["err_spread"]) for k, s in summary.items() if s["err_spread"] > 1e-9]
    out = ["## Time to accuracy (pressure error ‖λ_h − p_Hertz‖/‖p_Hertz‖)", "", time_to_accuracy(summary, labels, pairs),
           "", "## Cost per Newton iteration", "", per_iteration(summary, labels, pairs),
           "", "## Where ngcontact's time goes", "", phase_split(summary, labels), "", "## Runs", "", noise(rows, labels)]
    if bad:
        out.append(f"warning: the error differs between repetitions in {bad}")
    return "\n".join(out)


# ------------------------------------------------------------------------------- main
def levels(text):
    value = int(text)
    if not 0 <= value <= 5:
        raise argparse.ArgumentTypeError(f"a level is in 0..5, got {value}")
    return value


def setting(text):
    name, sep, value = text.partition("=")
    if not sep or not name:
        raise argparse.ArgumentTypeError(f"wants NAME=VALUE, got {text!r}")
    return name, value


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0],
                                 formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    ap.add_argument("--orders", type=int, nargs="+", choices=(1, 2, 3), default=[1, 2, 3])
    ap.add_argument("--levels", type=levels, nargs="+", default=[0, 1, 2])
    ap.add_argument("--level3", action="store_true", help="add level 3 (minutes per run)")
    ap.add_argument("--reps", type=int, default=3)
    ap.add_argument("--out", default="race.jsonl", help="JSON lines, appended")
    ap.add_argument("--ngc", default=os.environ.get("NGC_PATH", "/work/main"), help="ngcontact checkout (A)")
    ap.add_argument("--ngc-args", default=os.environ.get("NGC_ARGS", ""), help="extra ngc_hertz.py arguments (A)")
    ap.add_argument("--ngc-only", action="store_true", help="race checkout A against checkout B")
    ap.add_argument("--ngc-b", default=os.environ.get("NGC_PATH_B"), help="ngcontact checkout B (--ngc-only)")
    ap.add_argument("--ngc-b-args", default=os.environ.get("NGC_ARGS_B", ""), help="extra ngc_hertz.py arguments (B)")
    ap.add_argument("--variant", type=setting, action="append", default=[], metavar="LABEL=ARGS",
                    help="an ngcontact runner LABEL with these extra ngc_hertz.py arguments (repeatable; "
                         "replaces the single 'ngc')")
    ap.add_argument("--ngc-env", type=setting, action="append", default=[], metavar="NAME=VALUE",
                    help="environment of A's runs (e.g. OPENBLAS_NUM_THREADS=1; repeatable)")
    ap.add_argument("--ngc-b-env", type=setting, action="append", default=[], metavar="NAME=VALUE",
                    help="environment of B's runs (--ngc-only)")
    ap.add_argument("--ngc-py", default=os.environ.get("NGC_PY", sys.executable))
    ap.add_argument("--peer-py", default=os.environ.get("PEER_PY", "/tmp/peer-venv/bin/python"))
    ap.add_argument("--peer-script", default=os.environ.get("PEER_SCRIPT", "/tmp/peers/fenicsx/nitsche_contact.py"))
    ap.add_argument("--no-warmup", action="store_true", help="skip one L0 run of each code per order first")
    ap.add_argument("--case-limit", type=float, default=0.0,
                    help="skip the higher levels of an order once a run took longer (s); 0: never")
    ap.add_argument("--tables", nargs="+", metavar="JSONL", help="only print the tables of these files")
    args = ap.parse_args(argv)
    if args.tables:
        for p in args.tables:
            if not pathlib.Path(p).is_file():
                ap.error(f"--tables: no file {p}")
        print(tables(load(args.tables)))
        return 0
    if args.reps < 1:
        ap.error(f"--reps must be >= 1, got {args.reps}")
    if args.level3 and 3 not in args.levels:
        args.levels.append(3)
    args.levels = sorted(set(args.levels))
    checkouts = [("--ngc", args.ngc)] + ([("--ngc-b", args.ngc_b)] if args.ngc_only else [])
    for flag, path in checkouts:
        if path is None or not (pathlib.Path(path) / "ngcontact" / "__init__.py").is_file():
            ap.error(f"{flag} must be an ngcontact checkout (a directory with ngcontact/__init__.py), got {path!r}")
    interpreters = [("--ngc-py", args.ngc_py)] + ([] if args.ngc_only else [("--peer-py", args.peer_py)])
    for flag, path in interpreters:
        if not os.access(path, os.X_OK):
            ap.error(f"{flag}: no executable {path!r}")
    if not args.ngc_only and not pathlib.Path(args.peer_script).is_file():
        ap.error(f"--peer-script: no file {args.peer_script!r} (cp -r /work/shared/peers /tmp/peers)")
    args.out = str(pathlib.Path(args.out).resolve())
    args.ngc_env, args.ngc_b_env = dict(args.ngc_env), dict(args.ngc_b_env)
    names = [label for label, _ in args.variant]
    if args.variant and args.ngc_only:
        ap.error("--variant races ngcontact runners against the peer; --ngc-only races two checkouts")
    if len(set(names)) < len(names) or set(names) & set(PEERS):
        ap.error(f"--variant labels must be distinct and not a peer's ({', '.join(PEERS)}), got {names}")
    race(args)
    print()
    print(tables(load([args.out])))
    return 0


if __name__ == "__main__":
    sys.exit(main())
