"""weft.tradeoff gives the rows `weft tradeoff` writes."""
import csv
import json

import pytest

import weft
from conftest import FUR_SPOT, run_cli


def test_tradeoff_rows_have_the_clis_errors(tmp_path):
    run_cli("tradeoff", FUR_SPOT, "--feature", "shell_fur", "--size", "32x24", "--frames", "1", "--values", "layers=4,8",
            "-o", tmp_path / "cli")
    with open(tmp_path / "cli" / "tradeoff.csv") as f:
        cli = [row for row in csv.DictReader(line for line in f if not line.startswith("#"))]
    device = weft.Device()
    rows = weft.tradeoff(weft.load_scene(FUR_SPOT), "fur", size=(32, 24), frames=1, values={"layers": [4, 8]},
                         device=device, out=tmp_path / "py")
    assert device.validation_messages() == []
    assert [r["setting"] for r in rows] == [c["setting"] for c in cli]
    assert rows[0]["is_reference"] and rows[0]["rmse"] == 0.0 and rows[0]["pareto"]
    for r, c in zip(rows, cli):
        assert r["values"] == json.loads(c["values"])
        assert f"{r['rmse']:.6f}" == c["rmse_linear"], r["setting"]
        assert f"{r['ssim']:.5f}" == c["ssim"], r["setting"]
        assert r["pixels"] == int(c["pixels"])
        assert r["frame_ms"] > 0 and r["cold_frame_ms"] > 0
    assert (tmp_path / "py" / "tradeoff.svg").exists() and (tmp_path / "py" / "reference.png").exists()


def test_tradeoff_refuses_what_the_cli_refuses():
    scene = weft.load_scene(FUR_SPOT)
    with pytest.raises(ValueError, match="knob 'layers'"):
        weft.tradeoff(scene, "fur", values={"layers": [0]})
    with pytest.raises(ValueError, match="no \"skin_sss\" material"):
        weft.tradeoff(scene, "skin")
    with pytest.raises(LookupError, match="velvet"):
        weft.tradeoff(scene, "velvet")
