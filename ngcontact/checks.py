"""Checks of user input: numbers in their range, and the time Parameter a scene's data use.

Each failure names the parameter, the value and the allowed range, before any work starts.
"""
import math
import numbers

import ngsolve as ngs


def number(name, value, low=-math.inf, high=math.inf, *, low_open=False, high_open=False, unit=""):
    """``value`` as a float, checked: a real number (TypeError otherwise: strings, None,
    booleans), finite, in [low, high] (or open at either end). Returns it."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise TypeError(f"{name} must be a number{_range(low, high, low_open, high_open, unit)}, got {value!r} "
                        f"({type(value).__name__})")
    value = float(value)
    below = value <= low if low_open else value < low
    above = value >= high if high_open else value > high
    if not math.isfinite(value) or below or above:
        raise ValueError(f"{name} must be a finite number{_range(low, high, low_open, high_open, unit)}, "
                         f"got {value!r}")
    return value


def integer(name, value, low=1, high=None):
    """``value`` as an int >= low (<= high): TypeError for non-integers (a float with an
    integer value is accepted), ValueError out of range."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real) or not math.isfinite(value) \
            or int(value) != value:
        raise TypeError(f"{name} must be an integer >= {low}, got {value!r} ({type(value).__name__})")
    if value < low or (high is not None and value > high):
        limit = f"in [{low}, {high}]" if high is not None else f">= {low}"
        raise ValueError(f"{name} must be an integer {limit}, got {value!r}")
    return int(value)


def _range(low, high, low_open, high_open, unit):
    unit = f" {unit}" if unit else ""
    if low == -math.inf and high == math.inf:
        return ""
    if high == math.inf:
        return f" {'>' if low_open else '>='} {low:g}{unit}"
    if low == -math.inf:
        return f" {'<' if high_open else '<='} {high:g}{unit}"
    return f" in {'(' if low_open else '['}{low:g}, {high:g}{')' if high_open else ']'}{unit}"


def parameters(cf):
    """The ngsolve.Parameter objects in the expression tree of a CoefficientFunction."""
    found, stack = [], [cf]
    while stack:
        node = stack.pop()
        if isinstance(node, ngs.Parameter):
            found.append(node)
        elif not isinstance(node, ngs.GridFunction):     # a GridFunction holds no Parameter
            try:
                stack.extend(node.data["childs"])
            except Exception:                            # NGSolve raises a plain Exception for a
                continue                                 # node it cannot archive (no Parameter in it)
    return found


def uses_only(time, named_cfs):
    """Every Parameter in the named CoefficientFunctions must be ``time`` (the simulation's):
    a load on another Parameter would never move."""
    for name, cf in named_cfs:
        if isinstance(cf, ngs.CoefficientFunction) and any(p is not time for p in parameters(cf)):
            raise ValueError(f"{name} depends on an ngsolve.Parameter that is not the simulation's time: it "
                             "would never change; pass that Parameter as Simulation(time=...)")
