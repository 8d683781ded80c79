"""Knob changes re-prepare only what they touch; long loops stay flat; renderers in threads."""
import threading
import time

import numpy as np

import weft
from conftest import FUR_SPOT, SCENES, SIZE, expect_clean


def rss_bytes():
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * 4096


def test_a_knob_change_re_prepares_only_that_feature(renderer):
    scene = weft.load_scene(FUR_SPOT)
    first = renderer.render(scene, size=SIZE)
    after_first = renderer.cache_stats()
    assert after_first["mesh_uploads"] == 2 and after_first["pass_creations"] > 0
    renderer.render(scene, size=SIZE)
    steady = renderer.cache_stats()
    # An unchanged scene: nothing uploaded, created or planned again.
    assert {k: v for k, v in steady.items() if k != "graph_plans_reused"} == \
           {k: v for k, v in after_first.items() if k != "graph_plans_reused"}
    assert steady["graph_plans_reused"] == after_first["graph_plans_reused"] + 1

    scene.materials["fur"]["layers"] = 32
    changed = renderer.render(scene, size=SIZE)
    after_knob = renderer.cache_stats()
    assert not np.array_equal(first, changed), "32 layers drew the same image as 15"
    # The fur feature re-prepared (its band table: a new graph plan); no mesh, environment map,
    # texture or pass instance of the scene was made again.
    for cache in ("mesh_uploads", "environment_uploads", "texture_uploads", "pass_creations"):
        assert after_knob[cache] == steady[cache], cache
    assert after_knob["graph_plans"] <= steady["graph_plans"] + 1
    # Setting it back gives the first image again, still with nothing rebuilt.
    scene.materials["fur"]["layers"] = 15
    np.testing.assert_array_equal(renderer.render(scene, size=SIZE), first)
    assert renderer.cache_stats()["mesh_uploads"] == steady["mesh_uploads"]


def test_a_long_knob_loop_keeps_memory_and_time_flat(renderer):
    # The full 1,000-render loop is bench/python_loop.py (docs/benchmarks.md); 60 here. RSS
    # swings with the layer count of the moment (the fur's buffers are freed and made again, ~25
    # MiB on lavapipe with validation), so the bound is on the peak over equal windows of renders.
    scene = weft.load_scene(FUR_SPOT)
    fur = scene.materials["fur"]
    layers = [4, 8, 15, 32]
    times, rss = [], []
    for i in range(60):
        fur["layers"] = layers[i % len(layers)]
        t0 = time.perf_counter()
        renderer.render(scene, size=SIZE)
        times.append(time.perf_counter() - t0)
        rss.append(rss_bytes())
    growth = max(rss[40:60]) - max(rss[10:30])
    assert growth < 8 * 2**20, f"peak RSS grew {growth / 2**20:.1f} MiB from renders 10-30 to renders 40-60"
    early, late = np.median(times[10:25]), np.median(times[45:60])
    assert late < 2.0 * early + 0.005, f"renders slowed down: median {early * 1e3:.1f} ms -> {late * 1e3:.1f} ms"
    stats = renderer.cache_stats()
    assert stats["mesh_uploads"] == 2 and stats["environment_uploads"] == 1


def test_two_renderers_in_two_threads_with_the_gil_released():
    scenes = [weft.load_scene(FUR_SPOT), weft.load_scene(SCENES / "default.json")]
    renderers = [weft.Renderer(), weft.Renderer()]
    expected = [r.render(s, size=SIZE) for r, s in zip(renderers, scenes)]
    results = [[], []]
    errors = []

    def work(i):
        try:
            for _ in range(4):
                results[i].append(renderers[i].render(scenes[i], size=SIZE))
        except Exception as e:  # reported below; a thread's exception would be lost
            errors.append(e)

    threads = [threading.Thread(target=work, args=(i,)) for i in range(2)]
    for t in threads:
        t.start()
    # While both render, this thread keeps running Python: the GIL is released during rendering.
    spins = 0
    while any(t.is_alive() for t in threads):
        spins += 1
    for t in threads:
        t.join()
    assert errors == []
    assert spins > 10000, f"the main thread ran only {spins} loop iterations while the renders ran"
    for i in range(2):
        assert len(results[i]) == 4
        for image in results[i]:
            np.testing.assert_array_equal(image, expected[i])
        expect_clean(renderers[i])


def test_one_renderer_from_two_threads_takes_turns():
    scene = weft.load_scene(SCENES / "default.json")
    r = weft.Renderer()
    expected = r.render(scene, size=SIZE, quality="low")
    out = []
    threads = [threading.Thread(target=lambda: out.append(r.render(scene, size=SIZE, quality="low"))) for _ in range(3)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert len(out) == 3
    for image in out:
        np.testing.assert_array_equal(image, expected)
    expect_clean(r)


def test_renderers_sharing_a_device():
    device = weft.Device()
    a, b = weft.Renderer(device), weft.Renderer(device)
    scene = weft.load_scene(SCENES / "default.json")
    images = []
    threads = [threading.Thread(target=lambda r=r: images.append(r.render(scene, size=SIZE, quality="low"))) for r in (a, b)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    np.testing.assert_array_equal(images[0], images[1])
    expect_clean(a)
