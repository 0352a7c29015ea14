"""Scene geometries: named boundaries and nested refinement; the 3D block in a closed-form check."""
import pytest

import ngcontact as ngc
from conftest import C33, E33, EPS33
from ngcontact.geometries import block, plate


def test_plate_names_and_nested_refinement():
    coarse = plate(L1=0.1, L2=0.02, maxh=0.01)
    assert set(coarse.GetBoundaries()) == {"left", "right", "top", "bottom"}
    fine = plate(L1=0.1, L2=0.02, maxh=0.01, refine=2)
    assert fine.ne == 16 * coarse.ne                       # h halves per refinement
    graded = plate(L1=0.1, L2=0.02, maxh=0.01, maxh_contact=0.002)
    assert graded.ne > 2 * coarse.ne


def test_block_names_and_refinement():
    coarse = block(maxh=0.02)
    assert set(coarse.GetBoundaries()) == {"left", "right", "front", "back", "bottom", "top"}
    assert block(maxh=0.02, refine=1).ne == 8 * coarse.ne


@pytest.mark.parametrize("grounded, stiffness", [("bottom|top", C33), ("bottom", C33 + E33**2 / EPS33)])
def test_block_column_open_and_short_circuit(uniaxial, grounded, stiffness):
    """3D block poled along z, clamped at the bottom, pressed on top: ε_zz = -P / stiffness."""
    L3, P = 0.02, 1e6
    body = ngc.Body(block(L1=0.01, L2=0.01, L3=L3, maxh=0.01), uniaxial(), clamped="bottom",
                    grounded=grounded)
    sim = ngc.Simulation(body, ngc.Loads(f2={"top": (0, 0, -P)}))
    h = sim.run(dt=1, T=1)
    assert sim.u(body.mesh(0.005, 0.005, L3))[2] / L3 == pytest.approx(-P / stiffness, rel=1e-9)
    assert h.reactions[-1][2] == pytest.approx(P * 1e-4, rel=1e-9)
