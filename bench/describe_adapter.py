#!/usr/bin/python3
"""The showcase's frame described on an adapter (lavapipe without a GPU): Renderer.describe,
which prepares every feature as a render does (bakes from their caches, or baked). The
baseline of `weft graph check`'s declared frame (docs/benchmarks.md, "Checking a frame
without a device"). Run: PYTHONPATH=build/python /usr/bin/python3 bench/describe_adapter.py"""
import argparse
import os
import sys
import time

parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
parser.add_argument("scene", nargs="?", default="examples/scenes/showcase.json")
args = parser.parse_args()
if not os.path.exists(args.scene):
    sys.exit(f"describe_adapter: no scene at {args.scene} (run from the repository root)")
import weft  # noqa: E402  (after --help, which needs no module)

t0 = time.time()
scene = weft.load_scene(args.scene)
renderer = weft.Renderer()
t1 = time.time()
report = renderer.describe(scene)
t2 = time.time()
print(f"describe on the adapter: {t2 - t1:.2f} s (scene and renderer {t1 - t0:.2f} s), {len(report['passes'])} passes")
