"""A converged reference for the 2D Hertz race problem, and the errors of a solution against it.

The race problem (``scenes.hertz`` in 2D, displacement control): the elastic half-disk
{|x − (0, R)| <= R, y <= R}, R = 1 m, E = 1 Pa, ν = 0.3, plane strain, its flat top moved down
by d = ``DEPTH`` = 0.0171 m, frictionless unilateral contact of the curved side Γ3 with the rigid
plane y = 0 (obstacle normal n_o = (0, −1), gap g = y). Its solution has a contact force F
(N/m), a contact zone |x| < a (m) and a pressure p(x) (Pa: force per metre of Γ3, per metre of
depth) that vanishes like a square root at x = ±a. Hertz's half-plane formula
(``scenes.hertz.closed_form``) is for a half-plane, not this finite half-disk: the reference is its own.

How it is made (``build``): ngcontact at P3 and P4 on meshes graded geometrically toward the
contact edges (two families: Netgen's mesh-size restriction at (±a, y(±a)) with Netgen's
grading, and bisection of the elements at the edges, ``meshes.refined``), the edge located anew
on each level; the levels of a family converge, Richardson's extrapolation is used where they
converge at a rate, and the families, orders and two γ0 are compared (the agreement stored with
the reference). The profile is stored as p(x) = sqrt(max(a² − x², 0)) s(x) with s an even
Chebyshev series in x/a (``Reference.pressure``), plus a table of p dense near ±a.

How a solution is evaluated (``measure``): on each facet of Γ3 the unclipped Nitsche pressure
q = −P (λ_h = max(q, 0), P = σ_ν − γ(u_ν − g), Chouly–Hild) and the facet's points are sampled at
``SAMPLES`` Gauss points and interpolated (a polynomial in the facet's parameter s ∈ [0, 1],
exact for the straight and isoparametric facets up to round-off); each facet is split at the
roots of q and at x = ±a, and each piece integrated by a Gauss rule under a map whose derivative
vanishes at both ends (the square root of p at ±a and the kink of λ_h become smooth). Then
F_h = ∫_Γ3 λ_h ds, a_h = (x_max − x_min)/2 of the contact set {q > 0} and
‖λ_h − p‖_L2(Γ3)/‖p‖_L2(Γ3), ds the arc length. The same measure takes the peer's samples
(``peer_errors``), so both codes are evaluated alike.
"""
import json
import math
import os
import pathlib
import time

import ngsolve as ngs
import numpy as np
from numpy.polynomial import chebyshev, legendre

import ngcontact as ngc
from ngcontact.scenes import hertz

DEPTH = 0.0171
"""d (m): the top's downward motion of the race problem (the peer's ``--disp 0.0171``)."""
R = hertz.R
DATA = pathlib.Path(__file__).with_name("data") / "hertz_race_reference.json"
SAMPLES = 24
"""Gauss points per facet of Γ3 at which a solution is sampled (``facet_samples``)."""
PIECE_POINTS = 20
"""Gauss points per piece of a facet in ``measure``."""


# ---------------------------------------------------------------------- sampling a solution
def gauss_parameters(points=SAMPLES):
    """The Gauss–Legendre points in s ∈ [0, 1] at which each facet is sampled."""
    nodes, _ = legendre.leggauss(points)
    return (nodes + 1) / 2


def facet_samples(sim, points=SAMPLES):
    """(x, y, q) of a solved ngcontact simulation of the race problem: arrays (facets of Γ3 ×
    ``points``) at the Gauss points s of ``gauss_parameters`` mapped onto each (curved) facet:
    the coordinates (m) and the unclipped Nitsche pressure q = −P (Pa; λ_h = max(q, 0)), P of
    ``enforcement.P`` with the stresses of the volume element. Nitsche's method only."""
    enforcement = sim.enforcement
    if not hasattr(enforcement, "P"):
        raise ValueError(f"sim: the race problem is measured on Nitsche's P (λ_h = −[P]_-); this simulation "
                         f"enforces contact by {type(enforcement).__name__}")
    mesh = sim.body.mesh
    names = set(sim.body.boundaries["contact_side"])
    rule = ngs.IntegrationRule([(float(s),) for s in gauss_parameters(points)], [1.0] * points)
    facets = [el.nr for el in mesh.Elements(ngs.BND) if el.mat in names]
    index = (np.array(facets)[:, None] * points + np.arange(points)).ravel()
    mapped = mesh.MapToAllElements(rule, ngs.BND)[index]
    q = ngs.BoundaryFromVolumeCF(-enforcement.P(sim.u, sim.phi, ngs.CF(0.0)))
    shape = (len(facets), points)
    return tuple(np.asarray(cf(mapped)).reshape(shape) for cf in (ngs.x, ngs.y, q))


# ---------------------------------------------------------------------- the reference profile
class Reference:
    """The stored reference: ``force`` F (N/m), ``a`` (m), the coefficients of s (Pa/m) and
    the agreement; ``pressure(x)`` p (Pa) at x (m), 0 for |x| >= a."""

    def __init__(self, data):
        self.data = data
        self.force, self.a = float(data["force"]), float(data["a"])
        self.coefficients = np.asarray(data["s_chebyshev_even"], dtype=float)
        self.norm = float(data["pressure_norm"])

    @classmethod
    def load(cls, path=DATA):
        """The reference stored at ``path`` (default: the package's)."""
        return cls(json.loads(pathlib.Path(path).read_text()))

    def pressure(self, x):
        """p(x) = sqrt(max(a² − x², 0)) s(x), s(x) = Σ_k c_k T_2k(x/a) (Pa)."""
        return profile(self.a, self.coefficients, x)


def profile(a, coefficients, x):
    """sqrt(max(a² − x², 0)) Σ_k c_k T_2k(x/a) at x (m)."""
    x = np.asarray(x, dtype=float)
    even = np.zeros(2 * len(coefficients) - 1)
    even[::2] = coefficients
    return np.sqrt(np.maximum(a * a - x * x, 0.0)) * chebyshev.chebval(np.clip(x / a, -1, 1), even)


def fit_profile(x, q, weights, a, terms):
    """The coefficients c_k (k < ``terms``) of s that fit λ ≈ sqrt(a² − x²) Σ c_k T_2k(x/a) in the
    weighted least squares sense on the points |x| < a (m, Pa, quadrature weights m)."""
    inside = np.abs(x) < a
    root = np.sqrt(a * a - x[inside] ** 2)
    basis = np.stack([root * np.cos(2 * k * np.arccos(x[inside] / a)) for k in range(terms)], axis=1)
    w = np.sqrt(weights[inside])
    coefficients, *_ = np.linalg.lstsq(basis * w[:, None], np.maximum(q[inside], 0.0) * w, rcond=None)
    return coefficients


def arc_weight(x):
    """ds/dx (dimensionless) on the circle of radius R about (0, R), below its centre."""
    return R / np.sqrt(R * R - x * x)


def profile_force_and_norm(a, coefficients, points=400):
    """(∫ p ds, ‖p‖_L2(Γ3)) of the profile on the circle (N/m, Pa m^½): x = a cos t turns the
    square root into sin t, then Gauss–Legendre in t."""
    nodes, w = legendre.leggauss(points)
    t = (nodes + 1) * math.pi / 2
    x = a * np.cos(t)
    dx = a * np.sin(t) * math.pi / 2 * w
    p = profile(a, coefficients, x)
    return float(np.sum(p * arc_weight(x) * dx)), math.sqrt(float(np.sum(p * p * arc_weight(x) * dx)))


def reference_samples(reference, layers=40, ratio=0.5, half_angle=0.3):
    """Samples (x, y, q) of the reference profile itself on arcs of the circle, |θ| <= ``half_angle``,
    with facet ends at ±a and facets shrinking geometrically (``ratio``, ``layers``) toward them,
    q = p(x) inside and a negative linear continuation outside: ``measure`` of these against the
    reference is its own accuracy (the square root at ±a lies in facets of < 1e-12 m)."""
    edge = math.asin(reference.a / R)
    steps = edge * ratio ** np.arange(1, layers + 1)
    inner = np.concatenate([np.linspace(-edge, edge, 41)[1:-1], -edge + steps, edge - steps])
    outer = np.concatenate([np.linspace(edge, half_angle, 30)[1:], edge + steps])
    cuts = np.unique(np.concatenate([inner, outer, -outer, [-edge, edge]]))
    theta = cuts[:-1, None] + np.diff(cuts)[:, None] * gauss_parameters()[None, :]
    x, y = R * np.sin(theta), R - R * np.cos(theta)
    slope = reference.pressure(0.0) / reference.a
    q = np.where(np.abs(x) < reference.a, reference.pressure(x), -slope * (np.abs(x) - reference.a))
    return x, y, q


# ---------------------------------------------------------------------- the measure
def _smoothstep(points):
    """Nodes and weights on [0, 1] of Gauss–Legendre under s = 3t² − 2t³ (ds/dt = 6t(1 − t) vanishes
    at both ends)."""
    nodes, w = legendre.leggauss(points)
    t = (nodes + 1) / 2
    return 3 * t * t - 2 * t ** 3, w / 2 * 6 * t * (1 - t)


DENSE = np.linspace(0, 1, 257)
"""Where a facet's interpolant is scanned for sign changes (``_roots``)."""


def _roots(coefficients, scanned):
    """The roots in (0, 1) of the Legendre series in 2·s − 1 whose values at ``DENSE`` are
    ``scanned``: its sign changes there, refined by Brent's method to round-off."""
    from scipy.optimize import brentq
    changes = np.flatnonzero(np.sign(scanned[:-1]) * np.sign(scanned[1:]) < 0)
    return [brentq(lambda t: legendre.legval(2 * t - 1, coefficients), DENSE[i], DENSE[i + 1], xtol=1e-16,
                   rtol=8.9e-16) for i in changes]


def measure(x, y, q, reference=None, piece_points=PIECE_POINTS):
    """Measure samples (x, y, q) (facets × ``SAMPLES``, ``facet_samples``): a dict of F_h =
    ∫_Γ3 λ_h ds (N/m), a_h and the centre of the contact set (m), ``fit_residual`` (the largest
    misfit of the facet interpolants at their samples), with a ``Reference`` ``squared`` =
    ‖λ_h − p‖²_L2(Γ3) (Pa² m), and ``points``, the quadrature's (x, λ_h, weight) in the contact
    set (for ``fit_profile``)."""
    points = x.shape[1]
    if x.shape != q.shape or y.shape != q.shape or points != SAMPLES:
        raise ValueError(f"x, y, q: arrays of facets × {SAMPLES} samples, got {x.shape}, {y.shape}, {q.shape}")
    s = gauss_parameters(points)
    vander = legendre.legvander(2 * s - 1, points - 1)
    cx, cy, cq = (np.linalg.solve(vander, v.T) for v in (x, y, q))      # (points, facets)
    dx, dy = (np.vstack([legendre.legder(c) * 2, np.zeros((1, c.shape[1]))]) for c in (cx, cy))    # d/ds
    residual = max(float(np.max(np.abs(vander @ c - v.T))) for c, v in ((cx, x), (cy, y), (cq, q)))
    nodes, weights = _smoothstep(piece_points)
    scan = legendre.legvander(2 * DENSE - 1, points - 1)
    scanned_q, scanned_x = scan @ cq, scan @ cx                          # (DENSE, facets)
    force = squared = 0.0
    low, high = math.inf, -math.inf
    kept = []
    for f in range(x.shape[0]):
        cuts = [0.0, 1.0] + _roots(cq[:, f], scanned_q[:, f])
        if reference is not None:
            for edge in (-reference.a, reference.a):
                if min(x[f]) - 1e-3 < edge < max(x[f]) + 1e-3:
                    cuts += _roots(cx[:, f] - np.eye(points)[0] * edge, scanned_x[:, f] - edge)
        cuts = np.unique(cuts)
        series = np.stack([cq[:, f], cx[:, f], dx[:, f], dy[:, f]], axis=1)       # (points, 4)
        for s0, s1 in zip(cuts[:-1], cuts[1:]):
            if s1 - s0 < 1e-15:
                continue
            t = np.concatenate([2 * (s0 + (s1 - s0) * nodes) - 1, [s0 + s1 - 1, 2 * s0 - 1, 2 * s1 - 1]])
            values, xs, ddx, ddy = legendre.legval(t, series)
            middle, ends = values[-3], xs[-2:]
            lam, xs = np.maximum(values[:-3], 0.0), xs[:-3]
            w = (s1 - s0) * weights * np.hypot(ddx[:-3], ddy[:-3])
            force += float(np.sum(lam * w))
            if middle > 0:                                       # the piece is in the contact set
                low, high = min(low, *ends), max(high, *ends)
                kept.append((xs, lam, w))
            if reference is not None:
                squared += float(np.sum((lam - reference.pressure(xs)) ** 2 * w))
    result = dict(force=force, a=(high - low) / 2 if high > low else 0.0, center=(high + low) / 2,
                  fit_residual=residual)
    if reference is not None:
        result["squared"] = squared
    result["points"] = tuple(np.concatenate(c) for c in zip(*kept)) if kept else (np.zeros(0),) * 3
    return result


def errors(x, y, q, reference=None, force=None, piece_points=PIECE_POINTS):
    """The race errors of samples (x, y, q) (``facet_samples``): dict(force, a, pressure_L2)
    = |F_h − F|/F, |a_h − a|/a, ‖λ_h − p‖_L2(Γ3)/‖p‖_L2(Γ3), with F_h = ``force`` if given (the
    code's own record, N/m) else ∫_Γ3 λ_h ds, and the evaluated F_h, a_h; ``piece_points``: the
    Gauss points per piece of a facet (``measure``)."""
    reference = Reference.load() if reference is None else reference
    m = measure(x, y, q, reference, piece_points)
    force_h = m["force"] if force is None else float(force)
    return dict(force=abs(force_h - reference.force) / reference.force, a=abs(m["a"] - reference.a) / reference.a,
                pressure_L2=math.sqrt(m["squared"]) / reference.norm, force_h=force_h, a_h=m["a"],
                force_integrated=m["force"])


def race_errors(sim, reference=None):
    """The relative errors of a solved ngcontact simulation of the race problem (Nitsche, 2D)
    against the stored reference (or ``reference``): dict(force, a, pressure_L2) =
    |F_h − F|/F, |a_h − a|/a, ‖λ_h − p‖_L2(Γ3)/‖p‖ (``measure``), F_h the recorded contact force
    (``ContactRecord.force``, N/m: λ_h integrated by the residual's rule, the force the discrete
    body exerts); also F_h, a_h and ``force_integrated`` = ∫_Γ3 λ_h ds integrated exactly."""
    if sim.body.dim != 2 or sim.body.axisymmetric:
        raise ValueError(f"sim: the race problem is the 2D half-disk, got a body of dim {sim.body.dim}"
                         f"{' (axisymmetric)' if sim.body.axisymmetric else ''}")
    if not sim.history or sim.history[-1].contact is None or sim.history[-1].time <= 0:
        raise ValueError("sim: solve the simulation first (no step recorded)")
    return errors(*facet_samples(sim), reference, force=float(sim.history[-1].contact.force[-1]))


def peer_errors(path, force, reference=None):
    """The race errors of the FEniCSx peer's output, as ``race_errors``: ``path`` the .npz of its
    ``--profile`` option (x, y, q of facets × ``SAMPLES`` at the points of ``gauss_parameters``),
    ``force`` its ``resultant_nitsche`` (N/m, λ_h by its residual's rule)."""
    data = np.load(path)
    return errors(data["x"], data["y"], data["q"], reference, force=force)


# ---------------------------------------------------------------------- the graded meshes
CORNERS = ((-R, R), (R, R))
"""Where the clamped top meets the free arc: a stress singularity that holds F back to an
algebraic rate unless the mesh is graded there too."""
H_MIN = 1e-6
"""The mesh size (m) at the contact edges and the corners of the graded meshes."""


def _arc(x):
    """The point of the arc Γ3 above x (m)."""
    return (x, R - math.sqrt(R * R - x * x))


def _geometry():
    from netgen.occ import Circle, OCCGeometry, Pnt, Rectangle, Y
    shape = Circle(Pnt(0, R), R).Face() * Rectangle(2 * R, R).Face().Move((-R, 0, 0))
    shape.edges.Max(Y).name = "top"
    for edge in shape.edges:
        if edge.name != "top":
            edge.name = "contact"
    return OCCGeometry(shape, dim=2)


def _base(maxh, h_contact, restrictions=()):
    """The half-disk meshed at ``maxh`` (m), ``h_contact`` on |x| < R/4 and (x, y, h) restrictions."""
    from netgen.meshing import MeshingParameters
    parameters = MeshingParameters(maxh=maxh, grading=0.3)
    for x in np.linspace(-0.25 * R, 0.25 * R, 26):
        parameters.RestrictH(*_arc(x), 0, h_contact)
    for x, y, h in restrictions:
        parameters.RestrictH(x, y, 0, h)
    return ngs.Mesh(_geometry().GenerateMesh(mp=parameters))


def restricted_mesh(a, level, order, h_min=H_MIN):
    """Family "restrict": Netgen's mesh with the size ``h_min`` (m) at the contact edges (±a, y(±a))
    and the corners, grown away from them by Netgen's grading 0.3 (geometric), maxh = 0.2 R
    2^-level, 0.02 R 2^-level on |x| < R/4; curved to ``order``."""
    points = [_arc(-a), _arc(a), *CORNERS]
    m = _base(0.2 * R / 2 ** level, 0.02 * R / 2 ** level, [(x, y, h_min) for x, y in points])
    m.Curve(order)
    return m


def bisected_mesh(a, level, order, h_min=H_MIN, reach=0.5):
    """Family "bisect": Netgen's mesh at maxh = 0.2 R 2^-level (0.02 R 2^-level on |x| < R/4),
    then bisected (``meshes.refined``) where an element of diameter > ``h_min`` (m) lies within
    ``reach`` diameters of a contact edge (±a, y(±a)) or a corner, until none does: sizes
    growing geometrically with the distance; curved to ``order``."""
    points = np.array([_arc(-a), _arc(a), *CORNERS])
    m = _base(0.2 * R / 2 ** level, 0.02 * R / 2 ** level)
    while True:
        vertices = np.array([v.point for v in m.vertices])
        cells = np.array([[v.nr for v in el.vertices] for el in m.Elements(ngs.VOL)])
        corners = vertices[cells]                                            # elements × 3 × 2
        centroid = corners.mean(axis=1)
        diameter = np.max(np.linalg.norm(corners - np.roll(corners, 1, axis=1), axis=2), axis=1)
        distance = np.min(np.linalg.norm(centroid[:, None, :] - points[None], axis=2), axis=1)
        marked = (diameter > h_min) & (distance < (reach + 1) * diameter)
        if not marked.any():
            break
        m = ngc.meshes.refined(m, marked)
    m.Curve(order)
    return m


MESHES = dict(restrict=restricted_mesh, bisect=bisected_mesh)
"""The two families of graded meshes."""


# ---------------------------------------------------------------------- the reference build
def solve(mesh, order, gamma0=10.0, maxit=200):
    """The race problem solved by ngcontact on ``mesh`` at ``order`` with Nitsche's ``gamma0``
    (Newton to its default tolerance in at most ``maxit`` iterations: on the facets of 1e-6 m at
    the edge the contact set settles slowly)."""
    sim = hertz.simulation(order, dim=2, depth=DEPTH, mesh=mesh, gamma0=gamma0, keep_states=False, maxit=maxit)
    with ngs.TaskManager():
        sim.step(1.0)
    return sim


def richardson(values):
    """The limit of the last three ``values`` of a sequence converging at a rate (successive
    differences shrinking by a factor r >= 1.5: v3 + (v3 − v2)/(r − 1)), else None."""
    if len(values) < 3:
        return None
    v1, v2, v3 = values[-3:]
    if v3 == v2 or v2 == v1:
        return None
    r = (v2 - v1) / (v3 - v2)
    return v3 + (v3 - v2) / (r - 1) if r >= 1.5 else None


def _case(family, order, level, a, gamma0):
    t0 = time.perf_counter()
    mesh = MESHES[family](a, level, order)
    sim = solve(mesh, order, gamma0)
    samples = facet_samples(sim)
    m = measure(*samples)
    row = dict(family=family, order=order, level=level, gamma0=gamma0, ndof=sim.X.ndof, elements=mesh.ne,
               newton=sim.history[-1].newton_iterations, force=m["force"],
               force_recorded=float(sim.history[-1].contact.force[-1]), a=m["a"], center=m["center"],
               graded_at=a, seconds=time.perf_counter() - t0)
    return row, samples


def locate(family, order, a, gamma0=10.0, tol=1e-7, rounds=4, progress=print):
    """The contact edge a (m) on the family's coarsest mesh: solve, locate the edge, grade the
    mesh there, again, until a moves by less than ``tol`` (m) or ``rounds`` solves."""
    for _ in range(rounds):
        row, _ = _case(family, order, 0, a, gamma0)
        progress(f"{family} P{order} level 0 graded at {a:.10g} m: a_h = {row['a']:.10g} m")
        moved, a = abs(row["a"] - a), row["a"]
        if moved < tol:
            break
    return a


def build(out=DATA, levels=4, orders=(3, 4), gamma0s=(10.0, 100.0), terms=12, a0=0.107, progress=print):
    """Solve the levels of both mesh families at ``orders`` (with the first γ0 given), each
    level graded at the contact edge of the level before (the first at the edge ``locate``d from
    ``a0``, m), the finest "restrict" level of the highest order at the other γ0; take F and a of
    the finest "restrict" level of the highest order (Richardson's limit where its levels
    converge at a rate), fit the profile there (``terms`` even Chebyshev terms), measure every
    finest solution against it (the agreement) and write the reference to ``out`` (JSON);
    returns the data. Minutes on 2 cores."""
    levels = ngc.checks.integer("levels", levels, 1, 6)
    rows, finest = [], {}
    for family in MESHES:
        a = locate(family, min(orders), a0, gamma0s[0], progress=progress)
        for order in orders:
            graded = a
            for level in range(levels):
                row, samples = _case(family, order, level, graded, gamma0s[0])
                rows.append(row)
                graded = row["a"]
                finest[f"{family} P{order} level {level}"] = (row, samples)
                progress(f"{family} P{order} level {level}: ndof {row['ndof']}, Newton {row['newton']}, "
                         f"F = {row['force']:.12g} N/m, a = {row['a']:.10g} m ({row['seconds']:.0f} s)")
            for level in range(levels - 1):
                del finest[f"{family} P{order} level {level}"]
    top = max(orders)
    best = [r for r in rows if r["family"] == "restrict" and r["order"] == top and r["gamma0"] == gamma0s[0]]
    key = f"restrict P{top} level {levels - 1}"
    for gamma0 in gamma0s[1:]:
        row, samples = _case("restrict", top, levels - 1, best[-1]["graded_at"], gamma0)
        rows.append(row)
        finest[f"{key} γ0 = {gamma0:g}"] = (row, samples)
        progress(f"{key} γ0 = {gamma0:g}: F = {row['force']:.12g} N/m, a = {row['a']:.10g} m ({row['seconds']:.0f} s)")
    extrapolated = dict(force=richardson([r["force"] for r in best]), a=richardson([r["a"] for r in best]))
    force = extrapolated["force"] if extrapolated["force"] is not None else best[-1]["force"]
    a = extrapolated["a"] if extrapolated["a"] is not None else best[-1]["a"]
    x, lam, w = measure(*finest[key][1])["points"]
    coefficients = fit_profile(x, lam, w, a, terms)
    data = dict(problem=dict(R=R, E=hertz.E, nu=hertz.NU, depth=DEPTH, plane_strain=True, gamma0=gamma0s[0]),
                force=force, a=a, s_chebyshev_even=coefficients.tolist(), reference_case=key,
                extrapolated={k: v is not None for k, v in extrapolated.items()})
    data["profile_force"], data["pressure_norm"] = profile_force_and_norm(a, coefficients)
    reference = Reference(data)
    agreement = []
    for case, (row, samples) in finest.items():
        e = errors(*samples, reference)
        agreement.append(dict(case=case, ndof=row["ndof"], force_h=e["force_h"], a_h=e["a_h"], force=e["force"],
                              a_abs=abs(e["a_h"] - a), pressure_L2=e["pressure_L2"],
                              force_recorded=row["force_recorded"]))
    data["fit_L2"] = next(r["pressure_L2"] for r in agreement if r["case"] == key)
    others = [r for r in agreement if r["case"] != key]
    data["agreement_max"] = dict(force=max(r["force"] for r in others), a_abs=max(r["a_abs"] for r in others),
                                 pressure_L2=max(r["pressure_L2"] for r in others),
                                 profile_force=abs(data["profile_force"] - force) / force)
    edge = a * (1 - np.geomspace(1e-6, 0.1, 30))
    xs = np.unique(np.concatenate([np.linspace(-a, a, 41), edge, -edge]))
    data.update(agreement=agreement, levels=rows, table=dict(x=xs.tolist(), p=reference.pressure(xs).tolist()))
    out = pathlib.Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps(data, indent=1) + "\n")
    return data


def agreement_table(data):
    """The agreement of a built reference as markdown: each family's finest level and each γ0
    compared with the reference (``errors``; the reference's own row is its fit)."""
    lines = ["| case | ndof | F_h (N/m) | a_h (m) | abs(F_h − F)/F | abs(a_h − a) (m) | ‖λ_h − p‖/‖p‖ |",
             "|---|---|---|---|---|---|---|"]
    for row in data["agreement"]:
        lines.append(f"| {row['case']} | {row['ndof']} | {row['force_h']:.12g} | {row['a_h']:.10g} | "
                     f"{row['force']:.1e} | {row['a_abs']:.1e} | {row['pressure_L2']:.1e} |")
    return "\n".join(lines)


def command(out, levels=4):
    """``python -m ngcontact hertz-reference``: ``build`` into ``out`` (a JSON file; its folder
    must exist and be writable, checked first) and print F, a and the agreement table."""
    out = pathlib.Path(out)
    folder = out.parent if str(out.parent) else pathlib.Path(".")
    if not folder.is_dir() or not os.access(folder, os.W_OK):
        raise ValueError(f"out: the folder {str(folder)!r} of {str(out)!r} does not exist or cannot be written")
    data = build(out, levels)
    print(f"F = {data['force']:.12g} N/m, a = {data['a']:.10g} m, ‖p‖ = {data['pressure_norm']:.10g} Pa m^½, "
          f"profile fit {data['fit_L2']:.1e} (relative L2); written to {out}")
    print(agreement_table(data))
