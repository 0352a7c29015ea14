import numpy as np
import pytest

import ngcontact as ngc
from ngcontact.model.materials import transversely_isotropic_piezo, transversely_isotropic_stiffness

C33, E33, EPS33 = 111e9, 15.8, 830 * ngc.EPS0


@pytest.fixture
def uniaxial():
    """A PZT-like material with c13 = e31 = 0 (and c12 = 0): a column along the poling
    axis y is then in an exactly uniaxial state, so the closed forms are exact for P1."""
    def make(relaxation_time=0.0):
        c = transversely_isotropic_stiffness(121e9, 0.0, 0.0, C33, 21.1e9, 22.6e9)
        return ngc.Material(c, transversely_isotropic_piezo(0.0, E33, 12.3),
                            np.diag([916.0, 916.0, 830.0]) * ngc.EPS0,
                            relaxation_time * c, name="uniaxial")
    return make

