"""Newton's globalisation: a backtracking line search on the scaled residual norm, engaged when
full steps stop making progress.

The merit of an iterate x is m(x) = ‖R(x)‖, the scaled residual norm of ``ResidualNorm`` (J^½).
For the semismooth Newton correction w = R'(x)⁻¹ R(x), −w is a descent direction of m² (its
directional derivative is −2 m² wherever R'(x) is the derivative of the piece of R the step
stays on), so a short enough step decreases m. A full step is what makes Newton fast, and
on the scenes where the contact set settles in a few iterations the residual rises at each
change of the set before it falls: a line search from the first iteration would shorten
exactly those steps. So the full steps are taken as before until they stop making progress:

* the residuals repeat (a cycle between contact, glue or conduction sets, ``cycles.repeating``), or
* ``PATIENCE`` full steps in a row did not halve the residual of the last progress (``PROGRESS``;
  counted from the first correction's residual: the start's is the loads' change alone).

Where the laws that a path through smoother laws (``continuation``) widens change piece between
the iterates since the last progress (ψ or φ_L: ``switches``), the step goes to that path at once
(``budget`` 0): on the electrode contact and the glued plates a search there only spent
iterations before the path took over anyway (docs/stability.md, section 11). Where they do not
(a stiff viscosity law, a cycle of the contact set alone), the search takes over; the path's
widest stage searches too. Searching, every step must decrease the merit (Armijo):
m(x − α w) <= (1 − ``ARMIJO`` α) m(x), α halved from the step length allowed (1, or
``step_length``'s) down to ``SMALLEST``. A step that
finds no decrease there is taken at ``SMALLEST`` (the merit may rise: a kink of the laws lies
within that step) and counted in ``failed``. A search that found no decrease, or made no
progress for twice ``PATIENCE`` steps, or ran ``budget`` × ``PATIENCE``, is ``exhausted``:
``Newton.solve`` then hands the step to its ``continuation`` and, last, to full steps from the
start. Decisions read residuals only (the same on every rank), never the clock.
"""
import math

from ngcontact.solve.cycles import repeating
from ngcontact.gamma3.switches import describe

PATIENCE = 6
"""Full steps in a row without progress after which the line search engages."""
PROGRESS = 0.5
"""Progress: a residual below this fraction of the last residual of progress."""
ARMIJO = 1e-4
"""The sufficient decrease of the merit, per unit step length."""
BUDGET = 3
"""An engaged search is ``exhausted`` after BUDGET × ``PATIENCE`` steps (``LineSearch.budget``)."""
SMALLEST = 2.0 ** -10
"""The shortest step the search tries."""


class LineSearch:
    """Backtracking on the merit, engaged by ``observe`` (module docstring).

    ``engaged``: whether the current solve searches; ``why``: what engaged it; ``trials``:
    the residual evaluations of rejected step lengths in the solve; ``failed``: steps taken at
    ``SMALLEST`` without decrease; ``shortened``: steps accepted with α < 1; ``budget``: the
    search is ``exhausted`` after ``budget`` × ``patience`` steps (0: as soon as it engages,
    where a ``continuation`` takes over; set by ``observe``); ``remedy``: None (the budget is read
    from what flips) or "search" (``BUDGET`` whatever flips: a path's widest stage)."""

    def __init__(self, patience=PATIENCE, armijo=ARMIJO, smallest=SMALLEST):
        if int(patience) != patience or patience < 1:
            raise ValueError(f"patience must be an integer >= 1, got {patience}")
        if not 0 < armijo < 1:
            raise ValueError(f"armijo must lie in (0, 1), got {armijo}")
        if not 0 < smallest < 1:
            raise ValueError(f"smallest must lie in (0, 1), got {smallest}")
        self.patience, self.armijo, self.smallest = int(patience), armijo, smallest
        self.remedy = None               # None: read from what flips; "search": search whatever flips
        self.start()

    def start(self):
        """A Newton solve begins: full steps."""
        self.engaged, self.why, self.budget, self.window = False, None, BUDGET, []
        self.mark, self.stalled = math.inf, 0        # the last residual of progress, iterations since
        self.trials = self.failed = self.shortened = self.searched = 0

    def observe(self, residuals, switches=None, path=None):
        """Read the solve's residual history (after each residual of an accepted iterate);
        engage on a cycle or on a lack of progress. With ``switches`` (``switches.Switches``)
        and a ``path`` (``continuation.Continuation``), record the laws' pieces at the iterates
        since the last progress and, on engaging, leave the step to the path at once
        (``budget`` 0) where the laws it widens flip among them."""
        value = residuals[-1]
        if len(residuals) == 1:     # (the start's residual: the loads' change, often far below the next ones)
            return
        if value < PROGRESS * self.mark:
            self.mark, self.stalled = value, 0
        else:
            self.stalled += 1
        if self.engaged:
            self.searched += 1
            return
        watch = path is not None and switches is not None and self.remedy is None
        if watch:
            self.window = [] if self.stalled == 0 else self.window + [switches()]
        period = repeating(residuals)
        if period is not None:
            self.engaged, self.why = True, f"a cycle of period {period}"
        elif self.stalled >= self.patience:
            self.engaged, self.why = True, f"{self.patience} full steps without progress"
        if self.engaged:
            self.stalled = 0
            flipping = path.widens(switches.flipping(self.window)) if watch else []
            if flipping:
                self.budget, self.why = 0, f"{self.why}; {' and '.join(flipping)} changing piece"

    @property
    def exhausted(self):
        """Whether the search, once engaged, found no decrease along a step, made no progress
        for twice ``patience`` steps, or ran ``budget`` times ``patience`` (a ``continuation``
        may then take over)."""
        return self.engaged and (self.failed > 0 or self.stalled >= 2 * self.patience
                                 or self.searched >= self.budget * self.patience)

    def search(self, x, w, alpha, merit, evaluate):
        """Take the step x ← x − α' w, α' <= ``alpha`` the first of alpha, alpha/2, … that
        decreases the merit (from ``merit``, m(x) before the step) enough; ``evaluate()``
        computes the residual at the new x and returns its merit. Returns (α', m(x − α' w))."""
        x.data -= alpha * w
        value = evaluate()
        while not value <= (1 - self.armijo * alpha) * merit:
            if alpha <= self.smallest:
                self.failed += 1
                break
            self.trials += 1
            x.data += 0.5 * alpha * w
            alpha *= 0.5
            value = evaluate()
        self.shortened += alpha < 1
        return alpha, value

    def explain(self, what, switches=None, pieces=()):
        """(reason, hint) of a solve the search did not bring home (``what`` happened): what engaged
        it and, with ``switches`` (``switches.Switches``), which laws of Γ3 changed piece since
        it began (``pieces``: their state then)."""
        reason = f"{what} ({self.why})" + (f" nor with a line search ({self.shortened} steps shortened)"
                                           if self.budget else "")
        if switches is None or not pieces:
            return reason, "a smaller time step, or a larger maxit"
        where, hint = describe(switches.flipping(list(pieces) + [switches()]), switches.side.dim, "search")
        return f"{reason}; since the search began, {where}", hint
