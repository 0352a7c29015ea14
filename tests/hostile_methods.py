"""Hostile inputs of class ``methods`` (``tests/test_hostile.py``): the enforcement method of
``Contact(method=...)`` and the parameters θ, γ0 and penalty beside it.

* A Contact keyword that contradicts the method object's own field (also where the keyword has
  the value that used to be its default), and one the chosen method does not take (θ, γ0 or
  penalty with a method without it), are refused at ``Contact()`` naming the keyword and the
  method; agreeing values are accepted.
* A method object of the user's is checked member by member at ``Contact()`` (the protocol
  ``enforcement.Method``): each missing member, one of the wrong type, the class passed for an
  instance, a ``build`` with another signature, a ``check_obstacle`` that does not refuse; what
  its ``build`` returns is checked where the simulation first calls it (None, expressions
  without a member, a Newton hook without a member), naming the class and what it returned.
* A run of a user method resumed with another parameter of the same method (or another class of
  the same name) is refused naming the parameter (the class); with the same parameters it resumes.
"""
import time

import pytest

import ngcontact as ngc
from support import METHOD_MEMBERS as MEMBERS, StiffLayer, without
from ngcontact.scenes import reference as scene

CLASSES = ("methods",)


class OtherLayer(StiffLayer):
    """Another class with the same name and parameters."""


def returning(value):
    """A StiffLayer whose build returns ``value(terms)``."""
    class Returning(StiffLayer):
        def build(self, body, contact, side, **kw):
            return value(StiffLayer.build(self, body, contact, side, **kw))
    return Returning()


def register(h):
    VE, TE = h.VE, h.TE

    def contact(**data):
        return lambda ctx: repr(ngc.Contact(**data))

    def refused(label, call, kind, *words):
        h.case("methods", label, call, h.Error(kind, *words))

    # ------------------------------------------------------------------ contradictions with a method object

    for label, data, words in [
            ("Nitsche(theta=-1), theta=1", dict(method=ngc.Nitsche(theta=-1), theta=1), ("theta", "Nitsche")),
            ("Nitsche(theta=0), theta=-1", dict(method=ngc.Nitsche(theta=0), theta=-1), ("theta", "Nitsche")),
            ("Nitsche(gamma0=5), gamma0=10", dict(method=ngc.Nitsche(gamma0=5.0), gamma0=10.0), ("gamma0", "Nitsche")),
            ("Nitsche(gamma0=100), gamma0=1e3", dict(method=ngc.Nitsche(gamma0=100.0), gamma0=1e3),
             ("gamma0", "Nitsche")),
            ("Penalty(1e4), penalty=1e3", dict(method=ngc.Penalty(1e4), penalty=1e3), ("penalty", "Penalty")),
            ("Penalty(1e3), penalty=1e4", dict(method=ngc.Penalty(1e3), penalty=1e4), ("penalty", "Penalty"))]:
        refused(f"contradiction {label}", contact(**data), VE, *words, "contradicts")

    # ------------------------------------------------------------------ a parameter the method does not take

    for label, data, words in [
            ("'penalty', theta=1", dict(method="penalty", theta=1), ("theta", "penalty")),
            ("'penalty', gamma0=10", dict(method="penalty", gamma0=10.0), ("gamma0", "penalty")),
            ("'penalty', gamma0=5", dict(method="penalty", gamma0=5.0), ("gamma0", "penalty")),
            ("'active_set', theta=-1", dict(method="active_set", theta=-1), ("theta", "active_set")),
            ("'active_set', gamma0=10", dict(method="active_set", gamma0=10.0), ("gamma0", "active_set")),
            ("'active_set', penalty=1e3", dict(method="active_set", penalty=1e3), ("penalty", "active_set")),
            ("'nitsche', penalty=1e4", dict(method="nitsche", penalty=1e4), ("penalty", "nitsche")),
            ("penalty=1e3 alone", dict(penalty=1e3), ("penalty", "nitsche")),
            ("Penalty(), theta=1", dict(method=ngc.Penalty(), theta=1), ("theta", "Penalty")),
            ("Penalty(), gamma0=10", dict(method=ngc.Penalty(), gamma0=10.0), ("gamma0", "Penalty")),
            ("NodalConstraint(), gamma0=10", dict(method=ngc.NodalConstraint(), gamma0=10.0),
             ("gamma0", "NodalConstraint")),
            ("NodalConstraint(), penalty=1e3", dict(method=ngc.NodalConstraint(), penalty=1e3),
             ("penalty", "NodalConstraint")),
            ("Nitsche(), penalty=1e3", dict(method=ngc.Nitsche(), penalty=1e3), ("penalty", "Nitsche"))]:
        refused(f"ignored {label}", contact(**data), VE, *words, "means nothing")
    refused("ignored user method, theta=1", lambda ctx: repr(ngc.Contact(method=StiffLayer(), theta=1)), VE,
            "theta", "StiffLayer")

    def agrees(ctx):
        c = ngc.Contact(method=ngc.Nitsche(theta=-1, gamma0=50.0), theta=-1, gamma0=50.0)
        p = ngc.Contact(method=ngc.Penalty(1e4), penalty=1e4)
        return dict(theta=c.theta, gamma0=c.gamma0, method_theta=c.enforcement_method.theta, penalty=p.penalty)

    def agreed(v, references):
        expected = dict(theta=-1, gamma0=50.0, method_theta=-1, penalty=1e4)
        return None if v == expected else f"{v}, expected {expected}"
    h.case("methods", "agreeing values accepted", agrees, h.Correct(agreed))

    # ------------------------------------------------------------------ a user method lacking members

    for name in MEMBERS:
        refused(f"user method without {name}", lambda ctx, n=name: repr(ngc.Contact(method=without(n))), TE,
                name, "Broken")
    refused("user method without serial_only, not distributable",
            lambda ctx: repr(ngc.Contact(method=without(distributable=False))), TE, "serial_only", "Broken")
    refused("user method without check_obstacle, takes no obstacle",
            lambda ctx: repr(ngc.Contact(method=without(takes_obstacle=False))), TE, "check_obstacle", "Broken")
    refused("user method without every member but build",
            lambda ctx: repr(ngc.Contact(method=without(*MEMBERS[:-1]))), TE, "name", "condensable", "flags",
            "Broken")
    refused("the class StiffLayer for an instance", lambda ctx: repr(ngc.Contact(method=StiffLayer)), TE,
            "method", "StiffLayer", "class")

    # ------------------------------------------------------------------ members of the wrong type

    for label, changes, words in [
            ("name=3", dict(name=3), ("name",)),
            ("name=''", dict(name=""), ("name",)),
            ("condensable='yes'", dict(condensable="yes"), ("condensable",)),
            ("takes_obstacle=None", dict(takes_obstacle=None), ("takes_obstacle",)),
            ("keeps_symmetry=1", dict(keeps_symmetry=1), ("keeps_symmetry",)),
            ("serial_only='one rank'", dict(distributable=False, serial_only="one rank"), ("serial_only",)),
            ("flags a property of str", dict(flags="the stiff layer penetrates"), ("flags",)),
            ("build=None", dict(build=None), ("build",)),
            ("contact_fields returning a list", dict(contact_fields=lambda self: []), ("contact_fields",)),
            ("contact_fields with 'gamma'", dict(contact_fields=lambda self: {"gamma": 1.0}), ("contact_fields",)),
            ("stiffness_factors returning None", dict(stiffness_factors=lambda self: None), ("stiffness_factors",)),
            ("stiffness_factors of str", dict(stiffness_factors=lambda self: {"k": "big"}), ("stiffness_factors",)),
            ("flags returning a str", dict(flags=lambda self: "penetrates"), ("flags",)),
            ("build(self) only", dict(build=lambda self: None), ("build",)),
            ("build without keywords", dict(build=lambda self, body, contact, side: None), ("build",))]:
        refused(f"user method {label}", lambda ctx, c=changes: repr(ngc.Contact(method=without(**c))), TE,
                *words, "Broken")

    def no_refusal(ctx):
        method = without(takes_obstacle=False, check_obstacle=lambda self: None)
        return repr(ngc.Contact(method=method, obstacle=ngc.obstacles.Plane((0.0, -2e-5), (0.0, 1.0))))
    refused("user method whose check_obstacle refuses nothing", no_refusal, VE, "obstacle", "check_obstacle")

    # ------------------------------------------------------------------ what build returns

    def simulated(method):
        return lambda ctx: h.built(h.simulation(contact=ngc.Contact(gap=2e-5, method=method)))

    refused("build returning None", simulated(returning(lambda terms: None)), TE, "build", "None", "Returning")
    refused("build returning 0", simulated(returning(lambda terms: 0)), TE, "build", "0", "Returning")
    refused("build returning its method", simulated(returning(lambda terms: StiffLayer())), TE, "build",
            "signorini", "Returning")

    class NoMultiplier:
        newton_hook = None

        def __init__(self, terms):
            self.signorini, self.active, self.contact_distance = terms.signorini, terms.active, terms.contact_distance

    class NoHook:
        def __init__(self, terms):
            self.signorini, self.active = terms.signorini, terms.active
            self.multiplier, self.contact_distance = terms.multiplier, terms.contact_distance

    class HalfHook(NoHook):
        def __init__(self, terms):
            super().__init__(terms)
            self.newton_hook = type("Hook", (), dict(start=lambda self: None))()

    refused("build returning expressions without multiplier", simulated(returning(NoMultiplier)), TE,
            "multiplier", "Returning")
    refused("build returning expressions without newton_hook", simulated(returning(NoHook)), TE,
            "newton_hook", "Returning")
    refused("build returning a newton_hook without residual", simulated(returning(HalfHook)), TE,
            "newton_hook", "residual", "correct", "Returning")

    # ------------------------------------------------------------------ a whole user method runs

    def runs(ctx):
        mine = h.reference_run(ngc.Contact(**dict(scene.CONTACT, method=StiffLayer(1e4))))
        theirs = h.reference_run(ngc.Contact(**dict(scene.CONTACT, method=ngc.Penalty(1e4))))
        return dict(mine, penalty_force=theirs["force"])

    def as_penalty(v, references):
        if abs(v["force"] - v["penalty_force"]) > 1e-12 * abs(v["penalty_force"]):
            return f"contact force {v['force']!r} N/m, Penalty(1e4) gives {v['penalty_force']!r}"
        return h._balance(v)
    h.case("methods", "user method StiffLayer(1e4) runs as Penalty(1e4)", runs, h.Correct(as_penalty))

    # ------------------------------------------------------------------ resumed with another user method

    @pytest.fixture(scope="module")
    def methods_resume_base(tmp_path_factory):
        """The coarse reference scene with StiffLayer(1e4), streamed and stopped after step 2."""
        directory = tmp_path_factory.mktemp("hostile_methods") / "run"
        h.interrupted(user_scene(StiffLayer(1e4)), directory)
        return str(directory)
    h.methods_resume_base = methods_resume_base

    def user_scene(method):
        return scene.simulation(1, 0.01, contact=ngc.Contact(**dict(scene.CONTACT, method=method)))

    def resumed(method):
        """The base run resumed by the scene with ``method``: the outcome as a value (the error's
        type and message, and the seconds the resume took)."""
        def call(ctx):
            directory = h.copied(ctx, "methods_resume_base")
            sim = user_scene(method())
            start = time.perf_counter()
            try:
                sim.resume(directory)
            except ValueError as err:
                return dict(raised="ValueError", message=str(err), seconds=time.perf_counter() - start)
            return dict(raised="", t=sim.t, seconds=time.perf_counter() - start)
        return call

    def refusal(*words):
        def check(v, references):
            if v["raised"] != "ValueError":
                return f"resumed to t = {v['t']} s, not refused"
            missing = h._named(v["message"], words)
            if missing:
                return f"the ValueError does not name {'/'.join(missing)}: {h._line(v['message'])}"
            if v["seconds"] > h.BEFORE_WORK:
                return f"refused after {v['seconds']:.1f} s"
            return None
        return check

    def continued(v, references):
        return f"refused: {h._line(v['message'])}" if v["raised"] else (
            None if abs(v["t"] - 0.1) < 1e-12 else f"resumed at t = {v['t']} s, not 0.1 s")

    for label, make, check in [
            ("StiffLayer(2e4) into a run of StiffLayer(1e4)", lambda: StiffLayer(2e4),
             refusal("contact.method.parameters.factor", "not the same scene")),
            ("StiffLayer(1e4 * (1 + 1e-6)) into a run of StiffLayer(1e4)", lambda: StiffLayer(1e4 * (1 + 1e-6)),
             refusal("contact.method.parameters.factor")),
            ("OtherLayer(1e4) of the same name", lambda: OtherLayer(1e4), refusal("contact.method.class", "OtherLayer")),
            ("Penalty(1e4) into a run of StiffLayer(1e4)", lambda: ngc.Penalty(1e4), refusal("contact.method")),
            ("StiffLayer(1e4) again", lambda: StiffLayer(1e4), continued)]:
        h.case("methods", f"resume {label}", resumed(make), h.Correct(check), needs=("methods_resume_base",))

