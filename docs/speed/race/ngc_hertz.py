#!/usr/bin/env python3
"""The FEniCSx peer's Hertz scene solved by ngcontact with its default options; one JSON line.

The peer is ``nitsche_contact.py --scene hertz`` of ``../shared/peers/fenicsx`` (``--control
disp`` or its default force control); this is its scene written as an ngcontact user writes it,
with nothing tuned:

* mesh (``--hierarchy``): ``gmsh``, the peer's gmsh mesh (``hertz_gmsh.py``, unchanged from the
  turn-3 race), curved at P2/P3 by a VectorH1 deformation of the arc edges; ``netgen``, made by
  ``multigrid.nested_mesh`` from gmsh's level 0 (the coarse mesh kept), the new arc vertices of
  each split put on the circle as gmsh puts them: the peer's vertices, but not all its
  triangles (NGSolve's ``Mesh.Refine`` bisects where gmsh splits red: 1 956 of the 3 912
  triangles of level 1 are the peer's; P1 L1 error 0.094 against 0.052). That mesh has no
  Netgen geometry, so ``nested.py``'s coarse levels (``nested_mesh(coarse.Copy(), k)``, curved
  by ``mesh.Curve``) would leave the arc vertices on the chords, and ``--start nested`` is
  refused ("the mesh's vertices differ from its kept coarse mesh refined ... times"). ``scene``:
  ngcontact's own ``scenes.hertz.mesh`` (OCC geometry, ``RestrictH`` at the contact) refined
  ``--refine`` + 1 times from a coarse mesh of size ``SCENE_HC`` (hc0/0.02), which gives the
  peer's u-DOFs of the same level to +2.3 … +6.7 % at P1–P3, levels 0–2, and curved by
  ``mesh.Curve(order)``: the mesh of ``--start nested`` (one coarser level more than the level);
* control (``--control``): ``disp``, ``Body(supports={"top": "all"})`` and
  ``Loads(displacement={"top": (0, -d t)})``, the flat top moved down by d; ``force``, the
  peer's force control: ``supports={"top": "x"}`` and ``Loads(f2={"top": (0, -F/w t)})`` with w
  the top's measured length (resultant F, the peer's ``--F``, default 0.01; the peer applies
  −F/(2R) on its top of length 2R), the vertical motion and the rotation held by the contact
  alone. One quasi-static step ``sim.step(1.0, guess=...)``;
* start (``--start``): ``warm`` (no guess: ngcontact's default; under force control the body is
  moved onto the obstacle by ``starts.Starts.touch``), ``nested`` (``guess="nested"``), ``p1`` (``guess="p1"``: P1 on the same mesh first),
  ``informed`` (the peer's start: ``starts.Approach(a²/2R)`` with Hertz's a for F under force
  control, as ``scenes.hertz.informed_start``; ``Approach(d)``, the rigid shift u = (0, −d),
  under displacement control) or ``approach=<depth>`` (``Approach(depth)``, m);
* ``Contact(obstacle=Plane((0, 0), (0, 1)), theta=1, gamma0=...)``: the rigid plane y = 0 with
  its normal n_o = (0, −1); γ0 is matched to the peer's γ = 100 E/h_cell on average over the
  contact facets with |x| < 0.2 (``--match-gamma0``), as in the earlier races;
* no piezoelectric coupling, so ``Simulation`` solves for u alone (``sim.model``).

Everything else is ngcontact's default: no ``reuse_factorization=``, ``realcompile=``,
``limit_steps=``, ``rtol=`` (default 1e-10, the peer's) and no TaskManager. Flags set them for
experiments (``--reuse``, ``--realcompile``, ``--limit-steps``, ``--threads``, and
``--option NAME=VALUE`` for any keyword of ``Simulation``, the value a Python literal).

Metric (the peer's): ‖λ_h − p_Hertz‖/‖p_Hertz‖ in L2 over the whole arc (11-point Gauss rule
per facet), Hertz at the run's own vertical resultant F_h; the peak and the half-width from
λ_h at the Gauss points of degree 2k+4. Times (s, ``time.perf_counter``): ``t_setup`` = Body +
Loads + Contact + Simulation, ``t_step`` = ``sim.step`` (records included), ``t_solve`` =
``t_setup + t_step`` (from the mesh to the converged state), ``t_newton`` = residual + assembly
+ factorisation + solve of ``StepRecord.timings`` (the finest level's Newton); a nested start
adds ``t_coarse`` (the coarse levels' steps, their ``StepRecord.wall_s``, inside the fine
step's "other") and ``t_before_step`` (``t_step`` − the fine step's ``wall_s``: building the
coarse levels and the prolongation on the first use). Newton iterations: ``newton_its`` on the
finest level, ``coarse_its`` per coarse level (``sim.starts.nested.iterations``, coarsest
first). Works with any ngcontact checkout on ``PYTHONPATH`` that has the options asked for;
record fields a checkout lacks are written as null.
"""
import argparse
import ast
import json
import math
import os
import pathlib
import resource
import subprocess
import sys
import time
import warnings

T_START = time.perf_counter()

import ngsolve as ngs  # noqa: E402
import numpy as np  # noqa: E402

import ngcontact as ngc  # noqa: E402
from ngcontact.multigrid import nested_mesh  # noqa: E402
from ngcontact.obstacles import Plane  # noqa: E402
from ngcontact.starts import Approach  # noqa: E402

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))
import hertz_gmsh  # noqa: E402

T_IMPORT = time.perf_counter() - T_START


def checkout():
    """(directory, commit, dirty) of the ngcontact that was imported."""
    root = pathlib.Path(ngc.__file__).resolve().parent.parent
    try:
        commit = subprocess.run(["git", "-C", str(root), "rev-parse", "--short", "HEAD"], capture_output=True,
                                text=True, timeout=10).stdout.strip() or None
        dirty = bool(subprocess.run(["git", "-C", str(root), "status", "--porcelain", "--untracked-files=no"],
                                    capture_output=True, text=True, timeout=10).stdout.strip())
    except (OSError, subprocess.SubprocessError):
        commit, dirty = None, None
    return str(root), commit, dirty


SCENE_HC = 0.019
"""Coarse mesh size of ``scenes.hertz.mesh`` (for hc0 = 0.02) whose refinement k + 1 has the
u-DOFs of the peer's level k: ratios 1.023–1.067 at P1–P3, levels 0–2 (0.018 gives 0.95–1.00)."""


def arc_vertices(ngmesh):
    """0-based numbers of the vertices on "contact" (boundary 1 of ``hertz_gmsh.netgen_mesh``)."""
    return sorted({v.nr - 1 for el in ngmesh.Elements1D() if el.index == 1 for v in el.vertices})


def to_circle(xy, vertices, R):
    """Move ``vertices`` of the coordinate view ``xy`` radially onto the circle about (0, R)."""
    d = xy[vertices] - (0.0, R)
    xy[vertices] = (0.0, R) + R * d / np.linalg.norm(d, axis=1)[:, None]


def netgen_hierarchy(hc0, refine, order, R):
    """The peer's level ``refine`` as ``multigrid.nested_mesh`` of gmsh's level 0 (the coarse
    mesh kept). Netgen's splits of a mesh without geometry leave the new arc vertices on the
    chords; gmsh puts them at the arc's parametric midpoint, i.e. the split of the arc
    projected radially after each split (and the later midpoints of the edges from there).
    Those points are computed on a copy split the same way and written into the mesh.
    (ngsolve.Mesh with its levels, deformation)."""
    pts, tri, segs = hertz_gmsh.gmsh_hertz(hc0, R, 0)
    ngmesh = hertz_gmsh.netgen_mesh(pts, tri, segs)
    peer = ngs.Mesh(ngmesh.Copy())                      # split as nested_mesh splits: the same numbering
    for _ in range(refine):
        peer.Refine()
        to_circle(peer.ngmesh.Coordinates(), arc_vertices(peer.ngmesh), R)
    mesh = nested_mesh(ngmesh, refine)
    xy, target = mesh.ngmesh.Coordinates(), np.asarray(peer.ngmesh.Coordinates())
    assert xy.shape == target.shape and arc_vertices(mesh.ngmesh) == arc_vertices(peer.ngmesh) and \
        np.allclose(xy[:len(pts)], target[:len(pts)], rtol=0, atol=1e-12 * R), \
        "Netgen numbered the split vertices differently"
    xy[:] = target                                      # a view: writing moves the points
    return mesh, hertz_gmsh.curve(mesh, order, R)


def scene_hierarchy(hc0, refine, order):
    """``scenes.hertz.mesh`` with the peer's u-DOFs of level ``refine`` (``SCENE_HC``): refined
    ``refine + 1`` times from its kept coarse mesh, curved by ``mesh.Curve(order)``."""
    from ngcontact.scenes import hertz
    return hertz.mesh(2, h_contact=SCENE_HC * hc0 / 0.02, refine=refine + 1, curve=order), None


def start_of(text):
    """``--start``: warm, nested, p1, informed or approach=<depth> (m, > 0)."""
    if text in ("warm", "nested", "p1", "informed"):
        return text
    name, sep, value = text.partition("=")
    try:
        depth = float(value)
    except ValueError:
        depth = float("nan")
    if name != "approach" or not sep or not depth > 0:
        raise argparse.ArgumentTypeError(f"--start is warm, nested, p1, informed or approach=<depth in m, > 0>, "
                                         f"got {text!r}")
    return depth


def gamma_ratio(mesh):
    """Mean, min, max over the contact facets with |x| < 0.2 of h_facet/h_cell: NGSolve's
    mesh_size at the facet (element height) over the peer's cell diameter (largest edge)."""
    pts = mesh.MapToAllElements(ngs.IntegrationRule(ngs.SEGM, 1), ngs.BND)
    h = ngs.BoundaryFromVolumeCF(ngs.specialcf.mesh_size)(pts).ravel()
    xm = ngs.x(pts).ravel()
    P = np.array([v.point for v in mesh.vertices])
    r = []
    for i, el in enumerate(mesh.Elements(ngs.BND)):
        if el.mat != "contact" or abs(xm[i]) > 0.2:
            continue
        vel = mesh[mesh[el.edges[0]].elements[0]]
        V = P[[v.nr for v in vel.vertices]]
        r.append(h[i] / max(np.linalg.norm(V[a] - V[b]) for a, b in ((0, 1), (1, 2), (0, 2))))
    r = np.array(r)
    return float(r.mean()), float(r.min()), float(r.max())


def option(text):
    """``NAME=VALUE`` with VALUE a Python literal (``True``, ``1e-8``, ``'umfpack'``) or a bare word."""
    name, sep, value = text.partition("=")
    if not sep or not name.isidentifier():
        raise argparse.ArgumentTypeError(f"--option wants NAME=VALUE, got {text!r}")
    try:
        return name, ast.literal_eval(value)
    except (ValueError, SyntaxError):
        return name, value


def positive(kind):
    def check(text):
        value = kind(text)
        if not value > 0:
            raise argparse.ArgumentTypeError(f"must be > 0, got {text}")
        return value
    return check


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0],
                                 formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    ap.add_argument("--order", type=int, choices=(1, 2, 3, 4), default=1)
    ap.add_argument("--refine", type=int, choices=range(0, 6), default=0, metavar="{0..5}")
    ap.add_argument("--hierarchy", choices=("gmsh", "netgen", "scene"), default="gmsh",
                    help="levels split by gmsh (the peer's), by Netgen (same mesh, made by nested_mesh) or "
                         "ngcontact's scenes.hertz.mesh with the peer's DOFs (module docstring)")
    ap.add_argument("--hc0", type=positive(float), default=0.02, help="level-0 mesh size at the contact")
    ap.add_argument("--control", choices=("disp", "force"), default="disp",
                    help="top moved down by --disp, or a traction of resultant --force on a top held in x")
    ap.add_argument("--disp", type=positive(float), default=0.0171, help="downward motion d of the top")
    ap.add_argument("--force", type=positive(float), default=0.01, help="resultant F of the top's traction")
    ap.add_argument("--start", type=start_of, default="warm", metavar="{warm,nested,p1,informed,approach=<m>}",
                    help="Newton's start (module docstring)")
    ap.add_argument("--theta", type=int, choices=(-1, 0, 1), default=1)
    ap.add_argument("--gamma0", type=positive(float), default=None, help="ngcontact's γ0 (overrides matching)")
    ap.add_argument("--match-gamma0", type=positive(float), default=100.0, help="peer's γ0 to match")
    ap.add_argument("--E", type=positive(float), default=1.0)
    ap.add_argument("--nu", type=float, default=0.3)
    ap.add_argument("--R", type=positive(float), default=1.0)
    ap.add_argument("--threads", choices=["no", "yes", "auto"], default="no",
                    help="TaskManager around setup and step; auto: from ngcontact.studies.bench.THREADS_FROM "
                         "DOFs of the Body")
    ap.add_argument("--realcompile", choices=["default", "yes", "no"], default="default")
    ap.add_argument("--reuse", choices=["default", "yes", "no"], default="default",
                    help="Simulation(reuse_factorization=...)")
    ap.add_argument("--limit-steps", choices=["default", "yes", "no"], default="default")
    ap.add_argument("--rtol", type=positive(float), default=None, help="Simulation(rtol=...); default: ngcontact's")
    ap.add_argument("--option", type=option, action="append", default=[], metavar="NAME=VALUE",
                    help="any other Simulation keyword (repeatable)")
    ap.add_argument("--qdeg-err", type=int, default=20)
    ap.add_argument("--cprofile", default=None, help="write a cProfile of setup + step to this file")
    args = ap.parse_args(argv)
    if not -1.0 < args.nu < 0.5:
        ap.error(f"--nu must be in (-1, 0.5), got {args.nu}")
    if args.start == "nested" and args.hierarchy == "gmsh":
        ap.error("--start nested needs a mesh that keeps its coarser levels: --hierarchy netgen or scene")
    k, R, E, nu = args.order, args.R, args.E, args.nu
    Es = E / (1.0 - nu ** 2)

    t0 = time.perf_counter()
    if args.hierarchy == "netgen":
        mesh, _defo = netgen_hierarchy(args.hc0, args.refine, k, R)
    elif args.hierarchy == "scene":
        mesh, _defo = scene_hierarchy(args.hc0, args.refine, k)
    else:
        mesh, _defo = hertz_gmsh.hertz(args.hc0, args.refine, k, R)
    t_mesh = time.perf_counter() - t0
    width = float(ngs.Integrate(ngs.CF(1.0) * ngs.ds(mesh.Boundaries("top")), mesh))
    start_name = args.start if isinstance(args.start, str) else f"approach={args.start:g}"
    if args.start == "warm":
        guess = None
    elif args.start in ("nested", "p1"):
        guess = args.start
    elif args.start == "informed":              # the peer's start: a²/2R for F, or the rigid shift by d
        a_F = math.sqrt(4.0 * args.force * R / (math.pi * Es))
        guess = Approach(a_F * a_F / (2.0 * R) if args.control == "force" else args.disp)
    else:
        guess = Approach(args.start)

    material = ngc.Material.isotropic(E, nu, permittivity=1.0, name="isotropic, no coupling")
    ratio = gamma_ratio(mesh)
    lam_max = float(material.tensors(2).stiffness(0.0))
    gamma0 = args.gamma0 if args.gamma0 is not None else args.match_gamma0 * E * ratio[0] / (k ** 2 * lam_max)

    options = {}
    for key, value in (("realcompile", args.realcompile), ("reuse_factorization", args.reuse),
                       ("limit_steps", args.limit_steps)):
        if value != "default":
            options[key] = value == "yes"
    if args.rtol is not None:
        options["rtol"] = args.rtol
    options.update(args.option)

    profiler = None
    if args.cprofile:
        import cProfile
        profiler = cProfile.Profile()

    # ------------------------------------------------------------------ the scene (setup)
    caught = warnings.catch_warnings(record=True)
    warned = caught.__enter__()
    warnings.simplefilter("always")
    t0 = time.perf_counter()
    if profiler:
        profiler.enable()
    tm = None
    if args.threads == "yes":
        tm = ngs.TaskManager()
        tm.__enter__()
    body = ngc.Body(mesh, material, supports={"top": "all" if args.control == "disp" else "x"},
                    contact_side="contact", order=k)
    if args.threads == "auto":
        from ngcontact.studies.bench import THREADS_FROM
        if body.ndof >= THREADS_FROM:
            tm = ngs.TaskManager()
            tm.__enter__()
    t = ngs.Parameter(0.0)
    if args.control == "disp":
        loads = ngc.Loads(displacement={"top": (0.0, -args.disp * t)})
    else:
        loads = ngc.Loads(f2={"top": (0.0, -args.force / width * t)})
    contact = ngc.Contact(obstacle=Plane((0.0, 0.0), (0.0, 1.0)), theta=args.theta, gamma0=gamma0)
    sim = ngc.Simulation(body, loads, contact=contact, time=t, **options)
    t_setup = time.perf_counter() - t0

    # ------------------------------------------------------------------ the solve
    t0 = time.perf_counter()
    try:
        rec = sim.step(1.0, guess=guess)
    except (ngc.NewtonError, ValueError) as err:
        print(json.dumps({"code": "ngcontact", "order": k, "refine": args.refine, "ndofs": body.V.ndof,
                          "control": args.control, "start": start_name, "hierarchy": args.hierarchy,
                          "converged": False, "error": f"{type(err).__name__}: {str(err)[:500]}",
                          "options": options, "t_setup": t_setup, "t_step": time.perf_counter() - t0},
                         default=str), flush=True)
        return 1
    t_step = time.perf_counter() - t0
    nested = {"nested": sim.starts._nested, "p1": sim.starts._first_order}.get(args.start)
    if profiler:
        profiler.disable()
        profiler.dump_stats(args.cprofile)
    if tm is not None:
        tm.__exit__(None, None, None)
    caught.__exit__(None, None, None)
    tim = dict(rec.timings)
    t_newton = sum(tim.get(p, 0.0) for p in ("residual", "assembly", "factorization", "solve"))

    # ----------------------------------------------------------------- post-processing
    t0 = time.perf_counter()
    u, phi = sim.u, sim.phi
    nit = sim.enforcement
    lam = nit.multiplier(u, phi, ngs.CF(0.0))
    raw = -nit.sigma_n(u, phi)
    x, y = ngs.x, ngs.y
    opening = -u[1] - y                                   # u·n_o − g, n_o = (0, −1), g = y
    C = mesh.Boundaries("contact")
    BFV = ngs.BoundaryFromVolumeCF

    def integral(cf, order):
        return float(ngs.Integrate(BFV(cf), mesh, ngs.BND, order=order, definedon=C))

    F_h = float(rec.contact.force[1])                    # vertical force of the plane on the body
    a = math.sqrt(4.0 * F_h * R / (math.pi * Es))
    p0 = 2.0 * F_h / (math.pi * a)
    p_ex = p0 * ngs.sqrt(ngs.IfPos(1.0 - (x / a) ** 2, 1.0 - (x / a) ** 2, 0.0))
    qe = args.qdeg_err
    nrm = math.sqrt(integral(p_ex ** 2, qe))
    err_nit = math.sqrt(integral((lam - p_ex) ** 2, qe)) / nrm
    err_raw = math.sqrt(integral((raw - p_ex) ** 2, qe)) / nrm

    ir = ngs.IntegrationRule(ngs.SEGM, 2 * k + 4)
    pts = mesh.MapToAllElements(ir, ngs.BND)
    on_c = np.array([el.mat == "contact" for el in mesh.Elements(ngs.BND)])
    mask = np.repeat(on_c, len(ir.points))
    xq = ngs.x(pts).ravel()[mask]
    pq = BFV(lam)(pts).ravel()[mask]
    penq = BFV(opening)(pts).ravel()[mask]
    act = pq > 0.0
    p_max = float(pq.max())
    half = float(np.abs(xq[act]).max()) if act.any() else 0.0
    t_post = time.perf_counter() - t0
    ru = resource.getrusage(resource.RUSAGE_SELF)
    root, commit, dirty = checkout()

    out = {
        "code": "ngcontact", "scene": "hertz", "control": args.control, "order": k, "refine": args.refine,
        "start": start_name, "guess": repr(guess), "start_used": sim.starts.last,
        "coarse_its": None if nested is None else list(nested.iterations),
        "coarse_ndofs": None if nested is None else [c.body.V.ndof for c in nested.levels],
        "t_coarse": None if nested is None else sum(c.history[-1].wall_s for c in nested.levels),
        "t_before_step": t_step - rec.wall_s,
        "hierarchy": args.hierarchy, "mesh_levels": getattr(mesh, "levels", None), "top_width": width,
        "force": args.force if args.control == "force" else None,
        "h_contact": args.hc0 * 2.0 ** (-args.refine), "theta": args.theta,
        "gamma0_ngcontact": gamma0, "gamma0_peer_matched": None if args.gamma0 is not None else args.match_gamma0,
        "h_ratio_mean_min_max": ratio, "lambda_max_F": lam_max,
        "disp": args.disp if args.control == "disp" else None,
        "ngcontact_dir": root, "ngcontact_commit": commit, "ngcontact_dirty": dirty,
        "model": sim.model, "solver": str(sim.solver),
        "ndofs": body.V.ndof, "ndofs_u": body.V.ndof, "ndofs_space": body.ndof,
        "ndofs_free": int(sim.X.FreeDofs().NumSet()), "ncells": mesh.ne,
        "newton_its": int(rec.newton_iterations), "converged": True,
        "residuals": [float(v) for v in rec.residuals],
        "factorizations": getattr(rec, "factorizations", None),
        "krylov_iterations": getattr(rec, "krylov_iterations", None),
        "krylov_failures": getattr(rec, "krylov_failures", None),
        "discarded_iterations": getattr(rec, "discarded_iterations", None),
        "condense": getattr(sim, "condense", None), "realcompile": getattr(sim, "realcompile", None),
        "threads": tm is not None, "options": options,
        "blas_env": {k: os.environ[k] for k in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")
                     if k in os.environ},
        "t_import": T_IMPORT, "t_mesh": t_mesh, "t_setup": t_setup, "t_step": t_step,
        "t_solve": t_setup + t_step, "t_newton": t_newton,
        "t_residual": tim.get("residual"), "t_assembly": tim.get("assembly"),
        "t_factorization": tim.get("factorization"), "t_linear_solve": tim.get("solve"),
        "t_record": tim.get("other"), "t_post": t_post, "timings": tim,
        "applied_force": args.force if args.control == "force" else F_h, "resultant_vertical": F_h, "resultant_horizontal": float(rec.contact.force[0]),
        "resultant_nitsche": integral(lam, 2 * k + 2), "resultant_raw_sigma": integral(raw, 2 * k + 2),
        "active_length": float(rec.contact.contact_area), "contact_half_width": half,
        "contact_x_min": float(xq[act].min()) if act.any() else None,
        "contact_x_max": float(xq[act].max()) if act.any() else None,
        "max_penetration": float(max(0.0, penq.max())), "p_max": p_max,
        "E_star": Es, "F_hertz": F_h, "a_hertz": a, "p0_hertz": p0,
        "p_l2_rel_err": err_nit, "p_raw_l2_rel_err": err_raw,
        "a_rel_err": half / a - 1.0, "p_max_rel_err": p_max / p0 - 1.0,
        "cpu_s": ru.ru_utime + ru.ru_stime, "maxrss_mb": ru.ru_maxrss / 1024.0,
        "flags": [str(f) for f in getattr(sim, "flags", [])],
        "warnings": sorted({f"{w.category.__name__}: {str(w.message)[:200]}" for w in warned}),
    }
    out["t_total"] = time.perf_counter() - T_START
    out["t_per_dof_newton_it_us"] = 1e6 * t_newton / out["ndofs"] / max(out["newton_its"], 1)
    out["ngsolve"] = ngs.__version__
    print(json.dumps(out, default=str), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
