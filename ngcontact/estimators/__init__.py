"""A posteriori error estimators: ``equilibration`` builds equilibrated fluxes on vertex
patches (``block_diagonal`` solves all patch problems at once); ``equilibrated`` turns them into
a bound of the step's energy error with element indicators (``EquilibratedEstimator(sim)()`` ->
``Estimate``); ``averaging`` is a cheap indicator for marking, not a bound
(``AveragingIndicator(sim)()``)."""
from .averaging import AveragingIndicator
from .equilibrated import EquilibratedEstimator, Estimate

__all__ = ["AveragingIndicator", "EquilibratedEstimator", "Estimate"]
