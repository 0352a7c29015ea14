#!/usr/bin/env python3
"""The FEniCSx peer's Hertz scene solved by ngcontact with its default options; one JSON line.

The peer is ``nitsche_contact.py --scene hertz --control disp`` of ``../shared/peers/fenicsx``;
this is its scene written as an ngcontact user writes it, with nothing tuned:

* mesh: the peer's gmsh mesh (``hertz_gmsh.py``, unchanged from the turn-3 race), curved at
  P2/P3 by a VectorH1 deformation of the arc edges; ``--hierarchy netgen`` builds the same
  vertices and triangles by Netgen's uniform refinement of level 0 (new arc vertices projected
  on the circle), so that the mesh also carries NGSolve's hierarchy of levels;
* ``Body(supports={"top": "all"})``, ``Loads(displacement={"top": (0, -d t)})``: the flat top
  moved down by d, one quasi-static step ``sim.step(1.0)`` from u = 0;
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
+ factorisation + solve of ``StepRecord.timings``. Works with any ngcontact checkout on
``PYTHONPATH``; record fields a checkout lacks are written as null.
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
from ngcontact.obstacles import Plane  # noqa: E402

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


def netgen_hierarchy(hc0, refine, order, R):
    """The peer's level ``refine`` built by Netgen's uniform refinement of gmsh's level 0, the new
    vertices of the arc projected radially on the circle after each split (gmsh puts them at the
    arc's parametric midpoint: the same point). (ngsolve.Mesh with its levels, deformation)."""
    pts, tri, segs = hertz_gmsh.gmsh_hertz(hc0, R, 0)
    ngmesh = hertz_gmsh.netgen_mesh(pts, tri, segs)
    contact_index = 1                                   # netgen_mesh: boundary 1 is "contact"
    for _ in range(refine):
        ngmesh.Refine()
        on_arc = sorted({v.nr - 1 for el in ngmesh.Elements1D() if el.index == contact_index
                         for v in el.vertices})
        xy = ngmesh.Coordinates()                       # a view: writing moves the points
        d = xy[on_arc] - (0.0, R)
        xy[on_arc] = (0.0, R) + R * d / np.linalg.norm(d, axis=1)[:, None]
    mesh = ngs.Mesh(ngmesh)
    return mesh, hertz_gmsh.curve(mesh, order, R)


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
    ap.add_argument("--hierarchy", choices=("gmsh", "netgen"), default="gmsh",
                    help="levels split by gmsh (the peer's) or by Netgen (same mesh, with NGSolve's levels)")
    ap.add_argument("--hc0", type=positive(float), default=0.02, help="level-0 mesh size at the contact")
    ap.add_argument("--disp", type=positive(float), default=0.0171, help="downward motion d of the top")
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
    k, R, E, nu = args.order, args.R, args.E, args.nu

    t0 = time.perf_counter()
    if args.hierarchy == "netgen":
        mesh, _defo = netgen_hierarchy(args.hc0, args.refine, k, R)
    else:
        mesh, _defo = hertz_gmsh.hertz(args.hc0, args.refine, k, R)
    t_mesh = time.perf_counter() - t0

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
    body = ngc.Body(mesh, material, supports={"top": "all"}, contact_side="contact", order=k)
    if args.threads == "auto":
        from ngcontact.studies.bench import THREADS_FROM
        if body.ndof >= THREADS_FROM:
            tm = ngs.TaskManager()
            tm.__enter__()
    t = ngs.Parameter(0.0)
    loads = ngc.Loads(displacement={"top": (0.0, -args.disp * t)})
    contact = ngc.Contact(obstacle=Plane((0.0, 0.0), (0.0, 1.0)), theta=args.theta, gamma0=gamma0)
    sim = ngc.Simulation(body, loads, contact=contact, time=t, **options)
    t_setup = time.perf_counter() - t0

    # ------------------------------------------------------------------ the solve
    t0 = time.perf_counter()
    try:
        rec = sim.step(1.0)
    except ngc.NewtonError as err:
        print(json.dumps({"code": "ngcontact", "order": k, "refine": args.refine, "ndofs": body.V.ndof,
                          "converged": False, "error": str(err)[:500], "options": options,
                          "t_setup": t_setup, "t_step": time.perf_counter() - t0}, default=str), flush=True)
        return 1
    t_step = time.perf_counter() - t0
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
    Es = E / (1.0 - nu ** 2)
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
        "code": "ngcontact", "scene": "hertz", "control": "disp", "order": k, "refine": args.refine,
        "hierarchy": args.hierarchy, "mesh_levels": getattr(mesh, "levels", None),
        "h_contact": args.hc0 * 2.0 ** (-args.refine), "theta": args.theta,
        "gamma0_ngcontact": gamma0, "gamma0_peer_matched": None if args.gamma0 is not None else args.match_gamma0,
        "h_ratio_mean_min_max": ratio, "lambda_max_F": lam_max, "disp": args.disp,
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
        "applied_force": F_h, "resultant_vertical": F_h, "resultant_horizontal": float(rec.contact.force[0]),
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
