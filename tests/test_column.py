"""Piezoelectric columns against closed forms: creep, applied voltage, open vs short circuit.

Column [0, W] × [0, H] poled along y, clamped at the bottom, plane strain. With c13 = e31 = 0
the exact state is uniaxial: u = (0, ε(t) y), φ linear in y, so P1 is exact in space.
"""
import numpy as np
import ngsolve as ngs
import pytest

import ngcontact as ngc
from conftest import C33, E33, EPS33
from ngcontact.geometries import plate

W, H, P = 0.01, 0.03, 2e6   # m, m, Pa


def column(material, grounded, loads, order=1, **kw):
    body = ngc.Body(plate(L1=W, L2=H, maxh=0.01), material, clamped="bottom", grounded=grounded,
                    order=order)
    return ngc.Simulation(body, loads, **kw)


def top_strain(sim):
    return sim.u(sim.body.mesh(W / 2, H))[1] / H


def test_short_circuit_creep_follows_kelvin_voigt(uniaxial):
    """σ = c33 (ε + τ ε̇) = -P: backward Euler gives ε_n = -P/c33 (1 - (1 + k/τ)^-n)."""
    tau, T = 0.1, 0.2
    errors = []
    for nsteps in (10, 20, 40):
        sim = column(uniaxial(tau), "bottom|top", ngc.Loads(f2={"top": (0, -P)}))
        k = T / nsteps
        h = sim.run(dt=k, T=T)
        strains = np.array([sim.state(n).components[0](sim.body.mesh(W / 2, H))[1] / H
                            for n in range(len(h))])
        n = np.arange(len(h))
        discrete = -P / C33 * (1 - (1 + k / tau) ** -n)
        assert np.allclose(strains, discrete, rtol=1e-9, atol=1e-9 * P / C33)
        errors.append(abs(strains[-1] - (-P / C33 * (1 - np.exp(-T / tau)))))
    rates = np.log2(np.array(errors[:-1]) / errors[1:])
    assert np.all(rates > 0.9) and np.all(rates < 1.1)       # O(k) towards the creep law


@pytest.mark.parametrize("order", [1, 2])
def test_open_circuit_is_stiffer_by_the_coupling(uniaxial, order):
    """Elastic column: short circuit ε = -P/c33, open circuit (top charge-free, D = 0)
    ε = -P/(c33 + e33²/ε33)."""
    short = column(uniaxial(), "bottom|top", ngc.Loads(f2={"top": (0, -P)}), order=order)
    short.run(dt=1, T=1)
    opened = column(uniaxial(), "bottom", ngc.Loads(f2={"top": (0, -P)}), order=order)
    opened.run(dt=1, T=1)
    assert top_strain(short) == pytest.approx(-P / C33, rel=1e-9)
    assert top_strain(opened) == pytest.approx(-P / (C33 + E33 ** 2 / EPS33), rel=1e-9)
    # the open-circuit voltage builds up as ∂φ/∂y = e33 ε / ε33
    assert opened.phi(opened.body.mesh(W / 2, H)) == pytest.approx(E33 * top_strain(opened) / EPS33 * H, rel=1e-9)


def test_applied_voltage_column(uniaxial):
    """Top electrode at V, bottom grounded, no load: u_y(H) = -e33 V / c33 and the top
    electrode carries the charge Q = −∫ D·ν = (ε33 + e33²/c33) V W / H (a capacitor, the
    coupling adding to the permittivity); the bottom one carries −Q."""
    V = 100.0
    t = ngs.Parameter(0)
    sim = column(uniaxial(), "bottom|top", ngc.Loads(potential={"top": V * t}), time=t)
    h = sim.run(dt=0.5, T=1)
    assert sim.u(sim.body.mesh(W / 2, H))[1] == pytest.approx(-E33 * V / C33, rel=1e-9)
    charge = h[-1].electrode_charge
    assert charge["top"] == pytest.approx((EPS33 + E33 ** 2 / C33) * V * W / H, rel=1e-9)
    assert charge["bottom"] == pytest.approx(-charge["top"], rel=1e-9)
    assert h.electrode_charges("top")[1] == pytest.approx(charge["top"] / 2, rel=1e-9)
    assert np.allclose(h.reactions[-1], 0, atol=1e-9 * P * W)


def test_pzt5a_column_open_circuit_stiffer():
    """The real PZT-5A (c13, e31 ≠ 0, not uniaxial): still stiffer open-circuit."""
    deflection = {}
    for grounded in ("bottom|top", "bottom"):
        sim = column(ngc.pzt5a(), grounded, ngc.Loads(f2={"top": (0, -P)}), order=2)
        sim.run(dt=1, T=1)
        deflection[grounded] = -sim.u(sim.body.mesh(W / 2, H))[1]
    assert deflection["bottom"] < 0.9 * deflection["bottom|top"]


def test_force_balance(uniaxial):
    """Reaction on Γ1 balances the applied traction, for any material and order."""
    sim = column(ngc.pzt5a(1e-3), "bottom", ngc.Loads(f2={"top": (3e5, -P)}, f0=(1e4, 2e4)), order=3)
    h = sim.run(dt=1e-3, T=2e-3)
    applied = np.array([3e5 * W + 1e4 * W * H, -P * W + 2e4 * W * H])
    assert np.allclose(h.reactions[-1], -applied, rtol=1e-9)


def test_vtk_output_per_step(uniaxial, tmp_path):
    """run(vtk=...) writes one VTU file per step (initial state included) with both fields."""
    sim = column(uniaxial(), "bottom|top", ngc.Loads(f2={"top": (0, -P)}))
    sim.run(dt=0.5, T=1, vtk=tmp_path / "column")
    files = sorted(tmp_path.glob("column*.vtu"))
    assert len(files) == 3
    text = files[-1].read_text(errors="ignore")
    assert 'Name="displacement"' in text and 'Name="potential"' in text


def test_a_vtk_file_that_cannot_be_written_stops_the_run(uniaxial, tmp_path):
    """A directory where step 1's VTU file goes: NGSolve's VTKOutput would skip it without a
    word; run(vtk=...) stops with an OSError naming the time and the file, step 1 kept."""
    (tmp_path / "column_step00001.vtu").mkdir()
    sim = column(uniaxial(), "bottom|top", ngc.Loads(f2={"top": (0, -P)}))
    with pytest.raises(IsADirectoryError, match=r"^vtk: the fields at t = 0\.5 s could not be written \(\[Errno 21\] "
                                                r"Is a directory: '.*column_step00001\.vtu'\)$"):
        sim.run(dt=0.5, T=1, vtk=tmp_path / "column")
    assert len(sim.history) == 2 and (tmp_path / "column.vtu").is_file()
