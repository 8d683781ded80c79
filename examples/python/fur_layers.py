"""Sweep the shell-fur layer count on Spot: error against the reference against render time.

    PYTHONPATH=build/python /usr/bin/python3 examples/python/fur_layers.py [out.png]

docs/python.md walks through it; its plot is docs/images/python_fur_layers.png.
"""
import pathlib
import sys
import time

import matplotlib

matplotlib.use("Agg")  # no display needed
import matplotlib.pyplot as plt
import numpy as np

import weft

root = pathlib.Path(__file__).resolve().parents[2]
out = pathlib.Path(sys.argv[1]) if len(sys.argv) > 1 else root / "docs/images/python_fur_layers.png"
size = (320, 240)

renderer = weft.Renderer()
scene = weft.load_scene(root / "examples/fur/scenes/fur_spot.json")
fur = scene.materials["fur"]
print(f"{fur.name}: {fur.type} on {renderer.device.adapter['name']}")
print("knobs:", ", ".join(f"{k['name']} ({k['kind']})" for k in fur.knobs()))


def render(frames=5):
    """The image (aces=False: the plain clamp, so decoded pixels are linear radiance) and the
    median wall time of `frames` render() calls after a first one that prepares the setting."""
    image = renderer.render(scene, size=size, aces=False)
    times = []
    for _ in range(frames):
        t0 = time.perf_counter()
        image = renderer.render(scene, size=size, aces=False)
        times.append((time.perf_counter() - t0) * 1e3)
    return weft.srgb_to_linear(image)[..., :3], float(np.median(times))


# The reference: the feature registry's most accurate setting (256 layers, no fins).
reference_knobs = weft.reference("shell_fur")
fur.update(reference_knobs)
reference, reference_ms = render()
print(f"reference {reference_knobs}: {reference_ms:.1f} ms")
del fur["fins"]  # back to the scene's default

layers = [k for k in weft.knobs("shell_fur") if k["name"] == "layers"][0]["sweep"]
images, times = [], []
for n in layers:
    fur["layers"] = n  # checked against the knob's range; the next render re-prepares only the fur
    image, ms = render()
    images.append(image)
    times.append(ms)

# The fur's pixels: where any setting differs from the reference (what `weft tradeoff` also counts).
mask = np.zeros(reference.shape[:2], bool)
for image in images:
    mask |= np.any(image != reference, axis=2)
errors = [float(np.sqrt(np.mean((image[mask] - reference[mask]) ** 2))) for image in images]
for n, ms, e in zip(layers, times, errors):
    print(f"layers {n:4d}: {ms:7.1f} ms  RMSE {e:.4f}")
print(f"{mask.sum()} of {mask.size} pixels compared; cache counters {renderer.cache_stats()}")

fig, ax = plt.subplots(figsize=(6.4, 4.2), dpi=110)
ax.plot(times, errors, "o-", color="#b5651d")
for n, ms, e in zip(layers, times, errors):
    ax.annotate(f"{n}", (ms, e), textcoords="offset points", xytext=(5, 4), fontsize=8)
ax.axvline(reference_ms, color="grey", ls="--", lw=1)
ax.text(reference_ms, max(errors), "reference \n(256 layers) ", fontsize=8, va="top", ha="right", color="grey")
ax.set_xscale("log")
ax.set_yscale("log")
ax.set_xlabel(f"render() wall time per frame, ms ({size[0]}x{size[1]}, {renderer.device.adapter['driver']})")
ax.set_ylabel("RMSE against the reference (linear RGB, fur pixels)")
ax.set_title("Shell fur on Spot: error against time, by layer count")
ax.grid(True, which="both", alpha=0.3)
fig.tight_layout()
fig.savefig(out)
print(f"wrote {out}")
