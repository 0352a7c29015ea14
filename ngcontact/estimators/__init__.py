"""A posteriori error estimators: ``equilibration`` builds equilibrated fluxes on
vertex patches; ``equilibrated`` turns them into element indicators of the step problem
(``EquilibratedEstimator(sim)()`` -> ``Estimate``)."""
from .equilibrated import EquilibratedEstimator, Estimate

__all__ = ["EquilibratedEstimator", "Estimate"]
