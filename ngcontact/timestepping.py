"""Backward Euler in time for the coupled (u, φ) problem, as in the paper's scheme (4.3)-(4.7).

Step n solves, with δu_n = (u_n − u_{n−1})/k, the mechanical and (negated) electric
equations at t_n together, by Newton on the monolithic (u, φ) system. φ_0 solves the
electric equation with u_0 at t = 0.
"""
import time as wallclock

import ngsolve as ngs
import numpy as np

from . import electric_contact
from .active_set import ActiveSetNewton, NodalContact
from .adhesion import BondingField
from .contact_side import ContactSide
from .loads import Loads, as_cf
from .newton import Newton, NewtonError
from .nitsche import NitscheContact
from .penalty import PenaltyContact
from .results import ContactRecord, History, StepRecord
from .system import StepSystem, has_interior_dofs


class Simulation:
    """Time stepping of a Body under Loads.

    Parameters
    ----------
    body : Body.
    loads : Loads (CoefficientFunctions may depend on ``time``).
    contact : Contact or None; None leaves Γ3 traction-free and charge-free.
    time : ngsolve.Parameter used in the loads (created if not given); set to t_n at step n.
    u0 : initial displacement (number tuple or CoefficientFunction), zero on Γ1; default 0.
    inverse : direct solver; default: "sparsecholesky" where the step Jacobian is symmetric
        (no contact, or ``Contact.symmetric``), "umfpack" otherwise.
    rtol, maxit : Newton tolerance (relative) and iteration limit per step.
    keep_states : keep a copy of (u, φ) of every step in the history.
    predictor : start Newton from the linear extrapolation x_n + (k_{n+1}/k_n)(x_n − x_{n−1})
        instead of x_n (the default warm start). It saves 3-8 % of the iterations of the
        reference run at k = 2.5 ms, but on coarse steps the extrapolated state penetrates deep
        and Newton may fail where the warm start converges (docs/speed.md).
    condense : static condensation of the element-interior DOFs (those of the elements at Γ3
        are kept); default: when the space has such DOFs (order >= 3 in 2D, >= 4 in 3D).
    realcompile : compile the Γ3 integrand to machine code (needs a C++ compiler, takes
        seconds once, assembles the Γ3 terms about 4× faster); default: when ndof >= 50 000
        in 2D, >= 2 000 in 3D.
    """

    def __init__(self, body, loads=None, *, contact=None, time=None, u0=None, inverse=None,
                 rtol=1e-10, maxit=50, keep_states=True, predictor=False, condense=None, realcompile=None):
        self.body = body
        self.loads = loads or Loads()
        self.loads.check(body)
        self.time = time if time is not None else ngs.Parameter(0.0)
        self.inv_dt = ngs.Parameter(1.0)
        self.gfu = ngs.GridFunction(body.X, name="state")
        self.u_old = ngs.GridFunction(body.V, name="u_old")
        self.u, self.phi = self.gfu.components
        if realcompile is None:         # where it paid in docs/speed.md (the 3D Γ3 terms cost far more)
            realcompile = body.ndof >= (2_000 if body.dim == 3 else 50_000)
        self.realcompile = bool(realcompile)
        kept = body.region("contact") if contact is not None else None
        self.condense = has_interior_dofs(body.X) if condense is None else bool(condense)
        if contact is not None and contact.method == "active_set":
            self.condense = False
        self.form = StepSystem(body, self.loads, self.u_old, self.inv_dt, self.time,
                               condense=self.condense, kept=kept)
        self.contact = contact
        if contact is not None:
            self._add_contact(contact)
        symmetric = contact is None or contact.symmetric
        self.inverse = inverse or ("sparsecholesky" if symmetric else "umfpack")
        if contact is not None and contact.method == "active_set":
            self.newton = ActiveSetNewton(self.form, self.gfu, self.side, self.gap,
                                          self.enforcement.pressure, rtol=rtol, maxit=maxit)
        else:
            self.newton = Newton(self.form, self.gfu, inverse=self.inverse, rtol=rtol, maxit=maxit)
        self.keep_states, self.predictor = keep_states, predictor
        self._last = None                                   # (x_{n−1}, k_n) for the predictor
        self.history = History()
        self.cutbacks = []
        self._tests = self._boundary_tests()
        self._set_initial(u0)

    def _add_contact(self, contact):
        """Γ3: B^h, the bonding field, and the Nitsche and conduction terms of the residual."""
        body = self.body
        self.side = side = ContactSide(body)
        self.gap = as_cf(contact.gap, 1, "Contact.gap")
        if side.sample(self.gap).min() < 0:
            raise ValueError(f"Contact.gap must be >= 0 on Γ3, its minimum is {side.sample(self.gap).min():.3g} m")
        self.phi_gamma = as_cf(contact.foundation_potential, 1, "Contact.foundation_potential")
        self.beta = BondingField(side, contact)
        self._u_normal = self.u * ngs.specialcf.normal(body.dim)
        enforcement = dict(nitsche=NitscheContact, penalty=PenaltyContact, active_set=NodalContact)
        self.enforcement = enforcement[contact.method](body, contact, self.beta.gf, self.inv_dt, self.gap)
        v, xi = body.X.TestFunction()

        def terms(u, phi):
            integrand = self.enforcement.residual(u, phi, v, xi, self.u_old)
            if contact.conducts:
                integrand = integrand + electric_contact.residual(contact, u, phi, xi, self.gap, self.phi_gamma)
            return integrand
        self.form.add_boundary_terms(terms, side.ds, realcompile=self.realcompile)
        self._observables = self._contact_observables()
        self._rigid_modes = []
        for i in range(body.dim + 1):
            w = ngs.GridFunction(body.X)
            if i < body.dim:
                w.components[0].Set(ngs.CF(tuple(float(i == j) for j in range(body.dim))))
            else:
                w.components[1].Set(1.0)
            self._rigid_modes.append(w.vec)

    def _contact_observables(self):
        """Facet integrals over Γ3 of the recorded quantities, built once."""
        side, nitsche, u, phi, u_old = self.side, self.enforcement, self.u, self.phi, self.u_old
        n = ngs.specialcf.normal(self.body.dim)
        lam = nitsche.multiplier(u, phi, u_old)
        pressure = lam + nitsche.surface_traction(u)          # −σ_ν = λ_h + p − γ_ν β² R_ν
        opening = u * n - self.gap
        quantities = dict(
            pressure=pressure, multiplier=lam, raw_pressure=-nitsche.sigma_n(u, phi, u_old),
            potential=phi, current_density=electric_contact.flux_density(
                self.contact, u, phi, self.gap, self.phi_gamma),
            contact_length=ngs.IfPos(pressure, 1, 0), active_length=nitsche.active(u, phi, u_old),
            complementarity=ngs.IfPos(lam * opening, lam * opening, -lam * opening))
        return {name: side.facet_integrals(cf) for name, cf in quantities.items()}

    def _contact_record(self):
        side = self.side
        integrals = {name: assemble() for name, assemble in self._observables.items()}
        # force and current through Γ3 as −R_Γ3(u_h; w) for w = (e_i, 0) and w = (0, 1):
        # the residual's own Γ3 terms (at the last Newton residual, the converged state) and
        # quadrature, so that the balances hold to round-off
        r = self.form.boundary_residual
        force_and_current = [-ngs.InnerProduct(r, w) for w in self._rigid_modes]
        if isinstance(self.newton, ActiveSetNewton):                 # Bᵀλ: the nodal contact forces
            force_and_current = [f - ngs.InnerProduct(self.newton.constraint_vector, w)
                                 for f, w in zip(force_and_current, self._rigid_modes)]
        averages = {name: integrals[name] / side.measure for name in
                    ("pressure", "multiplier", "raw_pressure", "potential", "current_density")}
        return ContactRecord(
            **averages, contact_set=integrals["contact_length"] / side.measure,
            beta=self.beta.values.copy(), current=force_and_current[-1],
            contact_length=integrals["contact_length"].sum(),
            active_length=integrals["active_length"].sum(),
            max_penetration=float((side.normal_displacement(self.u) - side.sample(self.gap)).max()),
            complementarity=integrals["complementarity"].sum(),
            force=np.array(force_and_current[:-1]),
            beta_clipped=self.beta.clipped)

    def _boundary_tests(self):
        """Test functions equal to e_i on Γ1 (resp. 1 on one electrode of Γa) and 0 at the
        other boundary DOFs: R(w) is then the reaction ∫_Γ1 σν·e_i (resp. the flux ∫ D·ν
        through that electrode; exact when electrodes held at different potentials do not touch)."""
        body = self.body

        def test(component, value, names):
            w = ngs.GridFunction(body.X)
            w.components[component].Set(value, ngs.BND, definedon=body.mesh.Boundaries(names))
            return w.vec

        reaction = [test(0, ngs.CF(tuple(float(i == j) for j in range(body.dim))),
                         body.region_names("clamped")) for i in range(body.dim)]
        charge = {name: test(1, 1.0, name) for name in body.boundaries["grounded"]}
        return reaction, charge

    def _set_dirichlet(self):
        """φ on the electrodes Γa at the current time (0 where no potential is given)."""
        phi = self.phi
        for names, value in self.loads.potential.items():
            phi.Set(as_cf(value, 1, f"potential[{names!r}]"), ngs.BND,
                    definedon=self.body.mesh.Boundaries(names))

    def _set_initial(self, u0):
        self.time.Set(0.0)
        if u0 is not None:
            u0 = as_cf(u0, self.body.dim, "u0")
            mesh, square = self.body.mesh, ngs.InnerProduct(u0, u0)
            on_gamma1 = ngs.Integrate(square * ngs.ds(self.body.region("clamped")), mesh)
            if on_gamma1 > 1e-20 * (1 + ngs.Integrate(square, mesh)):
                raise ValueError("u0 must vanish on the clamped boundary Γ1 "
                                 f"({self.body.region_names('clamped')!r})")
            if self.contact is not None:
                excess = (self.side.normal_displacement(u0) - self.side.sample(self.gap)).max()
                if excess > 1e-12 * (1 + np.abs(self.side.sample(u0)).max()):
                    raise ValueError(f"u0 must be admissible, u0_ν <= g on Γ3; it exceeds g by {excess:.3g} m")
            self.u.Set(u0)
            clamped = ~np.array(list(self.body.V.FreeDofs()), dtype=bool)
            self.u.vec.FV().NumPy()[clamped] = 0.0
        self.u_old.vec.data = self.u.vec
        self._set_dirichlet()
        self.form.begin_step()
        start = wallclock.perf_counter()
        phi_only = ngs.BitArray(self.body.X.FreeDofs())
        phi_only[self.body.X.Range(0)] = False
        result = Newton(self.form, self.gfu, freedofs=phi_only, inverse=self.inverse, condense=False,
                        rtol=self.newton.rtol, maxit=self.newton.maxit).solve(step=0, time=0.0)
        self._record(0, result, start)

    def _record(self, n, result, start):
        """Append the StepRecord of step n; ``start``: wall clock at the start of the step."""
        r = result.residual_vector
        reaction, charge = self._tests
        record = StepRecord(
            step=n, time=self.time.Get(), newton_iterations=result.iterations,
            residuals=result.residuals, wall_s=0.0,
            reaction=np.array([ngs.InnerProduct(r, w) for w in reaction]),
            charge={name: ngs.InnerProduct(r, w) for name, w in charge.items()},
            state=self.gfu.vec.FV().NumPy().copy() if self.keep_states else None,
            contact=self._contact_record() if self.contact is not None else None)
        record.wall_s = wallclock.perf_counter() - start
        record.timings = dict(result.timings, other=record.wall_s - sum(result.timings.values()))
        self.history.append(record)

    def step(self, dt):
        """Advance by one backward Euler step of length dt (s); returns its StepRecord."""
        if not dt > 0:
            raise ValueError(f"time step dt must be > 0 s, got {dt}")
        n = len(self.history)
        start = wallclock.perf_counter()
        if self.contact is not None:
            self.beta.update(self._u_normal, dt)          # (4.5), from u_{n-1}
        self.u_old.vec.data = self.u.vec
        if self.predictor:
            self._predict(dt)
        self.time.Set(self.time.Get() + dt)
        self.inv_dt.Set(1.0 / dt)
        self._set_dirichlet()
        self.form.begin_step()
        result = self.newton.solve(step=n, time=self.time.Get())
        self._record(n, result, start)
        return self.history[-1]

    def _predict(self, dt):
        """x_n -> x_n + (dt / k_n)(x_n − x_{n−1}), the start of Newton for step n + 1."""
        x = self.gfu.vec.FV().NumPy()
        last, self._last = self._last, (x.copy(), dt)
        if last is not None:
            x += (dt / last[1]) * (x - last[0])

    def run(self, dt, T, *, vtk=None, progress=False, max_cutbacks=6):
        """Step from the current time to T with steps dt; returns the History.

        vtk : file name stem for NGSolve's VTKOutput (one file per step), or None.
        progress : print a line per step.
        max_cutbacks : a step whose Newton iteration fails is retried as two half steps,
            down to dt / 2^max_cutbacks; the next nominal step uses dt again (recovery).
            Each cut-back is listed in ``self.cutbacks``.
        If even the smallest step fails, the NewtonError is raised with the attempts in its
        message and ``error.history`` holding every step computed so far (also kept in
        ``self.history``); the state is that of the last computed step.
        """
        if not dt > 0:
            raise ValueError(f"time step dt must be > 0 s, got {dt}")
        if not T > self.time.Get():
            raise ValueError(f"final time T must be > the current time {self.time.Get()} s, got {T}")
        if int(max_cutbacks) != max_cutbacks or max_cutbacks < 0:
            raise ValueError(f"max_cutbacks must be an integer >= 0, got {max_cutbacks}")
        start = self.time.Get()
        nsteps = int(np.ceil((T - start) / dt - 1e-9))
        writer = None
        if vtk:
            writer = ngs.VTKOutput(self.body.mesh, coefs=[self.u, self.phi],
                                   names=["displacement", "potential"], filename=str(vtk),
                                   subdivision=max(self.body.order, self.body.order_phi) - 1)
            writer.Do(time=self.time.Get())
        for i in range(nsteps):
            target = start + (T - start) * (i + 1) / nsteps
            try:
                records = self._advance(target, max_cutbacks)
            except NewtonError as err:
                err.history = self.history
                raise
            for rec in records:
                if writer:
                    writer.Do(time=rec.time)
                if progress:
                    print(f"step {rec.step:4d}  t = {rec.time:.4g} s ({i + 1}/{nsteps})  newton "
                          f"{rec.newton_iterations}  wall {rec.wall_s:.3f} s", flush=True)
        return self.history

    def _advance(self, target, cutbacks_left):
        """Reach time ``target`` in one step, or in halves after a failure; returns the records."""
        saved = self._snapshot()
        dt = target - self.time.Get()
        try:
            return [self.step(dt)]
        except NewtonError as err:
            self._restore(saved)
            self.cutbacks.append(dict(step=len(self.history), time=target, dt=dt,
                                      iterations=err.iteration, residuals=err.residuals))
            if cutbacks_left == 0:
                tried = ", ".join(f"{c['dt']:.3g}" for c in self.cutbacks if c["step"] == len(self.history))
                err.args = (f"{err.args[0]}. Time steps tried for step {len(self.history)} (t -> "
                            f"{target:.6g} s): k = {tried} s; the state is that of step "
                            f"{len(self.history) - 1}",)
                raise
            middle = self.time.Get() + dt / 2
            return self._advance(middle, cutbacks_left - 1) + self._advance(target, cutbacks_left - 1)

    def _snapshot(self):
        beta = self.beta.values.copy() if self.contact is not None else None
        return (self.gfu.vec.FV().NumPy().copy(), self.u_old.vec.FV().NumPy().copy(), beta,
                self.time.Get(), self.inv_dt.Get(), self._last)

    def _restore(self, saved):
        state, u_old, beta, time, inv_dt, self._last = saved
        self.gfu.vec.FV().NumPy()[:] = state
        self.u_old.vec.FV().NumPy()[:] = u_old
        if beta is not None:
            self.beta.values[:] = beta
        self.time.Set(time)
        self.inv_dt.Set(inv_dt)

    def state(self, n):
        """GridFunction of (u, φ) at step n (needs keep_states)."""
        gf = ngs.GridFunction(self.body.X)
        gf.vec.FV().NumPy()[:] = self.history[n].state
        return gf
