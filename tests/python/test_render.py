"""Renders from Python are the renders of `weft render`, byte for byte."""
import numpy as np
import pytest

import weft
from conftest import FUR_SPOT, SCENES, SIZE, run_cli

DEFAULT = SCENES / "default.json"


def test_render_equals_weft_render_png_byte_for_byte(renderer, tmp_path):
    run_cli("render", DEFAULT, "--size", "64x48", "--quality", "low", "-o", tmp_path / "cli.png")
    image = renderer.render(weft.load_scene(DEFAULT), size=SIZE, quality="low")
    assert image.dtype == np.uint8 and image.shape == (48, 64, 4)
    np.testing.assert_array_equal(image, weft.load_image(tmp_path / "cli.png"))
    weft.save_image(tmp_path / "py.png", image)
    assert (tmp_path / "py.png").read_bytes() == (tmp_path / "cli.png").read_bytes()


def test_hdr_render_equals_weft_render_exr(renderer, tmp_path):
    run_cli("render", FUR_SPOT, "--size", "64x48", "--exposure", "2", "-o", tmp_path / "cli.exr")
    hdr = renderer.render(weft.load_scene(FUR_SPOT), size=SIZE, output="hdr", exposure=2.0)
    assert hdr.dtype == np.float32 and hdr.shape == (48, 64, 4)
    assert np.isfinite(hdr).all() and hdr[..., :3].max() > 0.0
    np.testing.assert_array_equal(hdr, weft.load_image(tmp_path / "cli.exr"))
    weft.save_image(tmp_path / "py.exr", hdr)
    assert (tmp_path / "py.exr").read_bytes() == (tmp_path / "cli.exr").read_bytes()


def test_any_resource_by_name_equals_weft_render_output(renderer, tmp_path):
    run_cli("render", DEFAULT, "--size", "64x48", "--quality", "low", "--output", "scene.depth", "-o", tmp_path / "depth.exr")
    depth = renderer.render(weft.load_scene(DEFAULT), size=SIZE, quality="low", output="scene.depth")
    assert depth.dtype == np.float32 and depth.shape == (48, 64, 4)
    cli = weft.load_image(tmp_path / "depth.exr")
    np.testing.assert_array_equal(depth[..., : cli.shape[2]], cli)


def test_render_frame_gives_stats_passes_and_outputs(renderer):
    frame = renderer.render_frame(weft.load_scene(FUR_SPOT), size=SIZE, outputs=["shadow_map.depth"], hdr=True)
    assert frame["image"].shape == (48, 64, 4) and frame["hdr"].shape == (48, 64, 4)
    assert "shell_fur" in frame["passes"] and frame["passes"][-1] == "tonemap"
    names = [p["name"] for p in frame["stats"]["passes"]]
    assert names == frame["passes"]
    assert all(p["cpu_record_us"] >= 0 for p in frame["stats"]["passes"])
    assert frame["stats"]["transient_bytes"] > 0
    assert frame["stats"]["transient_bytes"] <= frame["stats"]["transient_bytes_unaliased"]
    assert frame["output_formats"]["shadow_map.depth"].startswith("depth")
    depth = frame["outputs"]["shadow_map.depth"]
    assert depth.ndim == 3 and depth.shape[2] == 4 and 0.0 <= depth[..., 0].min() <= depth[..., 0].max() <= 1.0


def test_arrays_own_weft_memory_without_a_copy(renderer):
    image = renderer.render(weft.load_scene(DEFAULT), size=SIZE, quality="low")
    # The array wraps the frame's buffer (its base is the capsule that owns it), not a copy.
    assert not image.flags["OWNDATA"] and image.base is not None and image.flags["C_CONTIGUOUS"]


def test_metrics_on_arrays(renderer):
    scene = weft.load_scene(FUR_SPOT)
    low = renderer.render(scene, size=SIZE, quality="low")
    high = renderer.render(scene, size=SIZE, quality="high")
    a, b = weft.srgb_to_linear(low), weft.srgb_to_linear(high)
    assert weft.rmse(a, a) == 0.0 and weft.psnr(a, a) == float("inf") and weft.ssim(a, a) == pytest.approx(1.0)
    rmse = weft.rmse(a, b)
    assert rmse == pytest.approx(float(np.sqrt(np.mean((a.astype(np.float64) - b) ** 2))), rel=1e-5)
    assert weft.max_abs_diff(a, b) == pytest.approx(float(np.abs(a - b).max()))
    everywhere = weft.compare(low, high)
    assert everywhere["pixels"] == 64 * 48 and everywhere["rmse"] > 0
    mask = np.zeros((48, 64), np.uint8)
    mask[10:20, 10:30] = 1
    masked = weft.compare(low, high, mask)
    assert masked["pixels"] == 200
    with pytest.raises(ValueError, match="size|same"):
        weft.rmse(a, a[:10])


def test_pipelines_from_python(renderer):
    scene = weft.load_scene(DEFAULT)
    default = weft.Pipeline.default()
    assert default.outputs == ["tonemap.color"] and "tonemap" in [p["name"] for p in default.passes]
    brighter = default.with_options("tonemap", exposure=4.0)
    again = weft.Pipeline.from_dict(brighter.to_dict())
    assert again.to_json() == brighter.to_json()
    base = renderer.render(scene, size=SIZE, quality="low", pipeline=default)
    bright = renderer.render(scene, size=SIZE, quality="low", pipeline=brighter)
    assert bright[..., :3].astype(int).sum() > base[..., :3].astype(int).sum()
    bloom = weft.Pipeline.load(weft_source() / "examples" / "pipelines" / "bloom_outline.json")
    assert renderer.render(scene, size=SIZE, quality="low", pipeline=bloom).shape == (48, 64, 4)
    with pytest.raises(ValueError, match=r"\$\.passes\.tonemap\.options\.exposure"):
        default.with_options("tonemap", exposure=-1.0)
    broken = default.to_dict()
    broken["connections"].append("scene.depth -> tonemap.color")
    with pytest.raises(ValueError, match=r"\$\.connections"):
        weft.Pipeline.from_dict(broken)


def weft_source():
    from conftest import SOURCE
    return SOURCE


def test_describe_lists_what_render_can_read_back(renderer):
    report = renderer.describe(weft.load_scene(FUR_SPOT), size=SIZE)
    assert "shell_fur" in report["passes"] and "shadow_map.depth" in report["slots"]
    assert "scene_color" in report["resources"] and report["dot"].startswith("digraph")
