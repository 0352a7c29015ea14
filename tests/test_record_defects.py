"""Records that must agree with the residual: the pressure of the penalty method where the
gap varies along a facet, and the nodal pressure next to a clamped node (issue 13 defects)."""
import ngsolve as ngs
import numpy as np

import ngcontact as ngc
from ngcontact.scenes import reference


def test_penalty_pressure_integrates_to_the_contact_force():
    """A gap that varies along each facet (a wavy foundation) under the penalty method: the
    recorded facet pressures, integrated over Γ3, give the normal contact force of the
    residual (they are integrated with the residual's own quadrature)."""
    t = ngs.Parameter(0.0)
    gap = 1e-5 * (1 + ngs.sin(2 * np.pi * ngs.x / 0.003))
    sim = ngc.Simulation(reference.body(), reference.loads(t), time=t,
                         contact=ngc.Contact(gap=gap, method="penalty", penalty=100.0))
    sim.run(2.5e-3, 0.05)
    record = sim.history[-1].contact
    assert record.contact_area > 0.003                                # touching over a length
    integrated = float(np.dot(record.pressure, sim.side.measure))
    assert abs(integrated - record.force[1]) < 1e-8 * abs(record.force[1])


def test_active_set_pressure_next_to_a_clamped_node():
    """The plate clamped on the left, lying on the foundation (gap 0) under a uniform
    pressure: the facet of Γ3 at the clamped corner reads the pressure of its neighbour
    (before: half of it, the clamped node having no multiplier)."""
    t = ngs.Parameter(0.0)
    body = reference.body()
    sim = ngc.Simulation(body, ngc.Loads(f2={"top": (0.0, -1e6 * t)}), time=t,
                         contact=ngc.Contact(gap=0.0, method="active_set"))
    sim.run(0.5, 1.0)
    pressure, midpoints = sim.history[-1].contact.pressure, sim.side.midpoints
    order = np.argsort(midpoints[:, 0])
    first, second = pressure[order[0]], pressure[order[1]]
    assert second > 0 and 0.8 < first / second < 1.25


def test_multiplier_at_the_gauss_points_shows_what_the_facet_average_hides():
    """The multiplier recorded at the Gauss points integrates (with their weights) to the
    facet averages; on the curved Hertz side at P1 with the body's normal it swings inside
    facets far more than with the obstacle normal (the sawtooth)."""
    from ngcontact.scenes import hertz
    spreads = {}
    for normal in ("obstacle", "body"):
        sim = hertz.simulation(1, refine=1, normal=normal)
        sim.run(1.0, 1.0)
        c, side = sim.history[-1].contact, sim.side
        assert c.multiplier_points.shape == side.gauss_weights.shape
        integrals = (c.multiplier_points * side.gauss_weights).sum(axis=1)
        assert np.abs(integrals - c.multiplier * side.measure).max() < 1e-10 * np.abs(integrals).max()
        inside = np.abs(side.gauss_points[..., 0]).max(axis=1) < 0.08           # well inside the zone
        points = c.multiplier_points[inside]
        spreads[normal] = np.max((points.max(axis=1) - points.min(axis=1)) / points.mean(axis=1))
    assert spreads["body"] > 0.6 and spreads["body"] > 2.5 * spreads["obstacle"]   # 0.82 and 0.28 measured


def _rigid_mode_cases():
    from ngcontact.scenes import hertz
    yield hertz.simulation(3, dim=2, h_contact=0.05, keep_states=False)                 # curved, P3
    yield hertz.simulation(2, dim=2, h_contact=0.05, axisymmetric=True, keep_states=False)   # a section


def test_the_force_test_vectors_are_the_constant_translations():
    """Γ3's force and charge flux are −R_Γ3(w) for w = (e_i, 0) and (0, 1), written at the vertex
    DOFs: evaluated anywhere in the body they are the constants to round-off, and they equal
    ``Set``'s projection of those constants within its round-off (1e-12); the radial mode of a
    body of revolution, no resultant, is 0."""
    for sim in _rigid_mode_cases():
        X, mesh, dim = sim.X, sim.body.mesh, sim.body.dim
        modes = sim.recorder._rigid_modes
        points = [mesh(*p) for p in sim.side.midpoints[:3]] + [mesh(*np.mean(sim.side.midpoints, axis=0))]
        for i, vec in enumerate(modes):
            w = ngs.GridFunction(X)
            w.vec.data = vec
            expected = ngs.GridFunction(X)
            if i < dim and i not in sim.body.kinematics.resultants:
                assert ngs.Norm(vec) == 0.0
                continue
            if i < dim:
                expected.components[0].Set(ngs.CF(tuple(float(i == j) for j in range(dim))))
                values = [w.components[0](p) for p in points]
                assert np.allclose(values, [[float(i == j) for j in range(dim)]] * len(points), rtol=0, atol=1e-14)
            else:
                expected.components[1].Set(1.0)
                assert np.allclose([w.components[1](p) for p in points], 1.0, rtol=0, atol=1e-14)
            difference = vec.FV().NumPy() - expected.vec.FV().NumPy()
            assert np.abs(difference).max() < 1e-12
            assert np.abs(vec.FV().NumPy()).sum() > 0
