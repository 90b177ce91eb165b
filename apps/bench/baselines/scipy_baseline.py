#!/usr/bin/env python3
"""The SciPy baseline of the bench: the FTLE of workload W (README.md beside this file) as a researcher writes it
with NumPy and SciPy and no geobarrier.

All auxiliary trajectories (four around each grid point, offset 1e-4 dx) go into ONE solve_ivp call on the stacked
state [x_1..x_M, y_1..y_M] with RK45 at the paper's tolerances (rtol 1e-6, atol 1e-4): the vectorised way to use
SciPy, one shared step size for all trajectories and one error norm over the whole state. t_eval=[t_end] keeps
only the end states. DF from centred differences, FTLE = log(lambda_max(DF^T DF)) / (2 T).

    scipy_baseline.py --N N [--reference DIR] [--tag TAG]

Appends one JSON record (times, right-hand-side evaluations over all trajectories and, when DIR holds the exact
reference ref_N<N>_DF.bin written by the `reference` program, the FTLE errors against it) to
results/scipy_vec_aux_RK45_N<N>[_TAG].jsonl beside this file, and prints it. DIR defaults to $PEERS_DATA.
"""
import argparse
import json
import os
import time

import numpy as np
import scipy
from scipy.integrate import solve_ivp

FORCING_AMPLITUDE = 0.08
T_START, T_END = 0.0, 8.0 * np.pi
X_RANGE, Y_RANGE = (-1.8, 1.8), (-1.2, 1.2)
RELATIVE_OFFSET = 1e-4


def auxiliary_starts(n):
    """(4, n*n, 2): the +dx, -dx, +dy, -dy neighbours of every grid point, rows of the grid along y."""
    xs = np.linspace(*X_RANGE, n)
    ys = np.linspace(*Y_RANGE, n)
    gx, gy = np.meshgrid(xs, ys)
    centre = np.column_stack((gx.ravel(), gy.ravel()))
    d = RELATIVE_OFFSET * (xs[1] - xs[0])
    shifts = np.array([[d, 0.0], [-d, 0.0], [0.0, d], [0.0, -d]])
    return centre[None, :, :] + shifts[:, None, :], d


def ftle_of_gradient(a, b, c, e):
    """FTLE from DF = [[a, b], [c, e]] (arrays): the larger eigenvalue of C = DF^T DF."""
    c11, c12, c22 = a * a + c * c, a * b + c * e, b * b + e * e
    lam_max = 0.5 * (c11 + c22) + np.hypot(0.5 * (c11 - c22), c12)
    return np.log(lam_max) / (2.0 * abs(T_END - T_START))


def integrate_stacked(starts, rtol, atol):
    count = starts.shape[0]

    def velocity(t, state):
        x, y = state[:count], state[count:]
        return np.concatenate((y, x - x**3 + FORCING_AMPLITUDE * np.cos(t)))

    solution = solve_ivp(velocity, (T_START, T_END), np.concatenate((starts[:, 0], starts[:, 1])), method="RK45",
                         rtol=rtol, atol=atol, t_eval=[T_END])
    if not solution.success:
        raise RuntimeError(solution.message)
    end = solution.y[:, -1]
    return np.column_stack((end[:count], end[count:])), int(solution.nfev)


def error_record(ftle, exact):
    error = np.abs(ftle - exact)
    finite = np.isfinite(error)
    kept = error[finite]
    return {"mean_abs_err": float(kept.mean()), "p99_abs_err": float(np.percentile(kept, 99)),
            "max_abs_err": float(kept.max()), "interior_max_abs_err": float(np.nanmax(error[1:-1, 1:-1])),
            "n_nonfinite": int((~finite).sum())}


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--N", type=int, required=True, help="grid points per direction")
    parser.add_argument("--grid", choices=["aux"], default="aux", help="gradient from the auxiliary grid")
    parser.add_argument("--mode", choices=["vec"], default="vec", help="one stacked solve over all trajectories")
    parser.add_argument("--rtol", type=float, default=1e-6)
    parser.add_argument("--atol", type=float, default=1e-4)
    parser.add_argument("--reference", default=os.environ.get("PEERS_DATA", ""),
                        help="folder with ref_N<N>_DF.bin (default: $PEERS_DATA)")
    parser.add_argument("--tag", default="", help="suffix of the result file")
    args = parser.parse_args()
    n = args.N
    if n < 2:
        parser.error("--N must be at least 2")

    starts, d = auxiliary_starts(n)
    clock = time.perf_counter()
    ends, solver_evaluations = integrate_stacked(starts.reshape(-1, 2), args.rtol, args.atol)
    integrate_seconds = time.perf_counter() - clock
    ends = ends.reshape(4, n * n, 2)
    gradient = [(ends[0, :, 0] - ends[1, :, 0]) / (2 * d), (ends[2, :, 0] - ends[3, :, 0]) / (2 * d),
                (ends[0, :, 1] - ends[1, :, 1]) / (2 * d), (ends[2, :, 1] - ends[3, :, 1]) / (2 * d)]
    ftle = ftle_of_gradient(*gradient).reshape(n, n)

    record = {"program": "scipy_baseline", "N": n, "method": "RK45", "rtol": args.rtol, "atol": args.atol,
              "trajectories": 4 * n * n, "integrate_seconds": integrate_seconds, "solver_nfev": solver_evaluations,
              "traj_rhs_evals": solver_evaluations * 4 * n * n, "numpy": np.__version__, "scipy": scipy.__version__}
    reference = os.path.join(args.reference, f"ref_N{n}_DF.bin")
    if args.reference and os.path.exists(reference):
        df = np.fromfile(reference, dtype=np.float64).reshape(n * n, 4)
        record["vs_true"] = error_record(ftle, ftle_of_gradient(*df.T).reshape(n, n))

    results = os.path.join(os.path.dirname(os.path.abspath(__file__)), "results")
    os.makedirs(results, exist_ok=True)
    name = f"scipy_vec_aux_RK45_N{n}" + (f"_{args.tag}" if args.tag else "")
    with open(os.path.join(results, name + ".jsonl"), "a") as out:
        out.write(json.dumps(record, sort_keys=True) + "\n")
    print(json.dumps(record))


if __name__ == "__main__":
    main()
