#!/usr/bin/python3
"""The paper's first example from Python (docs/python.md): the forced Duffing oscillator x' = y,
y' = x - x^3 + 0.08 cos t over T = 8 pi. Draws its FTLE field with the elliptic barriers (generalized KAM tori) that
the elliptic extractor finds, then sweeps the forcing amplitude over five values and draws the FTLE of each.

    PYTHONPATH=build/python /usr/bin/python3 examples/python/paper_first_example.py [--images DIR] [--threads N]

Writes python-ftle-elliptic.png and python-amplitude-sweep.png into DIR (default docs/images) and prints what it
found. Run from the repository root (it reads experiments/duffing-kam.json)."""

import argparse
import json
import pathlib

import matplotlib

matplotlib.use("Agg")  # files only, no window
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import geobarrier  # noqa: E402

ROOT = pathlib.Path(__file__).resolve().parents[2]
AMPLITUDES = [0.0, 0.04, 0.08, 0.12, 0.16]


def ftle_with_elliptic_barriers(images, threads):
    # The paper's section 3.1, case 1, exactly as the program runs it (experiments/duffing-kam.json).
    experiment = json.loads((ROOT / "experiments" / "duffing-kam.json").read_text())
    result = geobarrier.run(experiment, threads=threads, progress=True)
    ftle = result.fields.ftle
    elliptic = [b for b in result.barriers if b.kind == "elliptic"]
    print(f"FTLE on {ftle.shape[1]} x {ftle.shape[0]} points, max {float(ftle.max()):.3f}; "
          f"{len(elliptic)} elliptic barriers")

    fig, ax = plt.subplots(figsize=(9, 5.4), constrained_layout=True)
    ftle.plot.pcolormesh(ax=ax, x="x", y="y", cmap="viridis", cbar_kwargs={"label": "FTLE [1/time]"})
    for barrier in elliptic:
        closed = np.vstack([barrier.points, barrier.points[:1]])
        ax.plot(closed[:, 0], closed[:, 1], color="red", linewidth=1.2)
    ax.set_title(f"Duffing + 0.08 cos t, T = 8\u03c0: FTLE and {len(elliptic)} elliptic barriers (red)")
    ax.set_aspect("equal")
    fig.savefig(images / "python-ftle-elliptic.png", dpi=110)
    plt.close(fig)


def amplitude_sweep(images, threads):
    base = json.loads((ROOT / "experiments" / "duffing-ftle.json").read_text())
    base["grid"]["n"] = [381, 221]
    fig, axes = plt.subplots(1, len(AMPLITUDES), figsize=(17, 3.4), sharey=True, constrained_layout=True)
    for ax, amplitude in zip(axes, AMPLITUDES):
        experiment = json.loads(json.dumps(base))
        experiment["forcing"]["params"]["amplitude"] = amplitude
        ftle = geobarrier.run(experiment, threads=threads).fields.ftle
        # The share of the box in strong stretching (the chaotic tangle, FTLE above 0.2).
        strong = float((ftle > 0.2).mean())
        print(f"amplitude {amplitude:.2f}: mean FTLE {float(ftle.mean()):.4f}, FTLE > 0.2 on {100 * strong:.1f}%")
        mesh = ftle.plot.pcolormesh(ax=ax, x="x", y="y", cmap="viridis", vmin=0, vmax=0.35, add_colorbar=False)
        ax.set_title(f"amplitude {amplitude:g}")
        ax.set_aspect("equal")
        if ax is not axes[0]:
            ax.set_ylabel("")
    fig.colorbar(mesh, ax=axes, label="FTLE [1/time]", shrink=0.9)
    fig.savefig(images / "python-amplitude-sweep.png", dpi=90)
    plt.close(fig)


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--images", type=pathlib.Path, default=ROOT / "docs" / "images")
    parser.add_argument("--threads", type=int, default=0, help="worker threads (default: all cores)")
    args = parser.parse_args()
    args.images.mkdir(parents=True, exist_ok=True)
    ftle_with_elliptic_barriers(args.images, args.threads)
    amplitude_sweep(args.images, args.threads)
    print(f"wrote {args.images / 'python-ftle-elliptic.png'} and {args.images / 'python-amplitude-sweep.png'}")


if __name__ == "__main__":
    main()
