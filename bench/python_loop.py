#!/usr/bin/python3
"""The 1,000-render loop from Python (docs/benchmarks.md#python): one weft.Renderer, a knob
changed before every render, ms per render and RSS after the loop.

    PYTHONPATH=build/python /usr/bin/python3 bench/python_loop.py [--renders 1000] [--size 64x48]
        [--scene examples/fur/scenes/fur_spot.json] [--material fur] [--knob layers] [--values 4,8,15,32]

Prints the median, 10th and 90th percentile ms per render (the whole render() call: prepare,
graph, execute, readback into a NumPy array) over the first and the last 100 renders, RSS after
the warm-up (the first cycle of values) and after the loop, the peak RSS of the first and last
100 renders, and the renderer's cache counters. --same renders without changing the knob.
"""
import argparse
import pathlib
import statistics
import time

import weft


def rss_mib():
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * 4096 / 2**20


def percentile(values, q):
    values = sorted(values)
    return values[min(len(values) - 1, int(q * len(values)))]


def main():
    root = pathlib.Path(__file__).resolve().parents[1]
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--renders", type=int, default=1000)
    p.add_argument("--size", default="64x48")
    p.add_argument("--scene", default=str(root / "examples/fur/scenes/fur_spot.json"))
    p.add_argument("--material", default="fur")
    p.add_argument("--knob", default="layers")
    p.add_argument("--values", default="4,8,15,32")
    p.add_argument("--same", action="store_true", help="do not change the knob")
    a = p.parse_args()
    size = tuple(int(v) for v in a.size.split("x"))
    values = [int(v) if v.lstrip("-").isdigit() else float(v) for v in a.values.split(",")]
    r = weft.Renderer()
    scene = weft.load_scene(a.scene)
    material = scene.materials[a.material]
    times, rss = [], []
    for i in range(a.renders):
        if not a.same:
            material[a.knob] = values[i % len(values)]
        t0 = time.perf_counter()
        r.render(scene, size=size)
        times.append((time.perf_counter() - t0) * 1e3)
        rss.append(rss_mib())
    warm = len(values)
    first, last = times[:100], times[-100:]
    print(f"weft.Renderer on {r.device.adapter['name']}: {a.renders} renders of {pathlib.Path(a.scene).name} at {a.size}, "
          f"{'no knob change' if a.same else f'{a.material}.{a.knob} cycling {a.values}'}")
    print(f"ms per render: median {statistics.median(times):.1f} (p10 {percentile(times, 0.1):.1f}, p90 {percentile(times, 0.9):.1f}); "
          f"first 100: median {statistics.median(first):.1f}, last 100: median {statistics.median(last):.1f}")
    print(f"RSS: {rss[warm - 1]:.1f} MiB after the first {warm} renders, {rss[-1]:.1f} MiB after {a.renders}; "
          f"peak {max(rss[:100]):.1f} MiB over the first 100, {max(rss[-100:]):.1f} MiB over the last 100")
    print(f"cache counters: {r.cache_stats()}")


if __name__ == "__main__":
    main()
