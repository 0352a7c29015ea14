#!/usr/bin/env python3
"""Newton's starts on the Hertz half-disk (docs/speed.md, "Starts that know contact"): Newton
iterations on the finest level, step time and pressure error for each order and refinement,
displacement control from the warm start u = 0, from ``guess="nested"`` and (order >= 2)
from ``guess="p1"``, force control
(F = 0.01 N/m) from ``Starts.touch`` and from the informed start a²/2R. One process per run,
so that no run inherits another's compiled code or caches.

    python docs/speed/starts_table.py [--orders 1 2 3] [--refine 1 2 3]
"""
import argparse
import json
import subprocess
import sys
import time

RUN = """
import json, sys, time
from ngcontact.scenes import hertz
order, refine, control, start = {order}, {refine}, {control!r}, {start!r}
begin = time.perf_counter()
sim = hertz.simulation(order=order, refine=refine, control=control)
setup = time.perf_counter() - begin
guess = {{"warm": None, "nested": "nested", "p1": "p1", "informed": hertz.informed_start(0.01)}}[start]
begin = time.perf_counter()
record = sim.step(1.0, guess=guess)
step = time.perf_counter() - begin
levels = {{"nested": sim.starts._nested, "p1": sim.starts._first_order}}.get(start)
nested = levels.iterations if levels is not None else None
print(json.dumps(dict(ndof=sim.body.V.ndof, its=record.newton_iterations, coarse=nested, setup=setup, step=step,
                      error=hertz.errors(sim)["pressure_L2"], start=sim.starts.last)))
"""


def run(**case):
    out = subprocess.run([sys.executable, "-c", RUN.format(**case)], capture_output=True, text=True, check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--orders", type=int, nargs="+", default=[1, 2, 3])
    parser.add_argument("--refine", type=int, nargs="+", default=[1, 2, 3])
    args = parser.parse_args()
    columns = [("displacement", "warm"), ("displacement", "nested"), ("displacement", "p1"), ("force", "warm"),
               ("force", "informed")]
    print("| P | refine | DOFs | " + " | ".join(f"{c}: {s}" for c, s in columns) + " | pressure L2 (disp. / force) |")
    print("|" + "---|" * (4 + len(columns)))
    for order in args.orders:
        for refine in args.refine:
            cells, errors, ndof = [], [], None
            for control, start in columns:
                if start == "p1" and order == 1:
                    cells.append("")
                    continue
                r = run(order=order, refine=refine, control=control, start=start)
                ndof = r["ndof"]
                coarse = f" {r['coarse']}" if r["coarse"] else ""
                cells.append(f"{r['its']} its, {r['step']:.2f} s{coarse}")
                errors.append(r["error"])
            print(f"| {order} | {refine} | {ndof} | " + " | ".join(cells) +
                  f" | {100 * errors[0]:.1f} % / {100 * errors[-2]:.1f} % |", flush=True)


if __name__ == "__main__":
    main()
