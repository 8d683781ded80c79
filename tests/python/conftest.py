"""Fixtures of weft's Python tests (ctest's test_python runs them: ./weft.sh test).

ctest sets PYTHONPATH to build/python, WEFT_SOURCE_DIR, WEFT_CLI (build/bin/weft) and
WEFT_VALIDATION=1 with WEFT_SYNC_VALIDATION=1: every device a test makes has the Khronos
validation layer with synchronization validation on, and a test fails on any message it
reported (the `renderer` fixture checks its device after the test; tests that make their own
renderers call `expect_clean(renderer)`).
"""
import os
import pathlib
import subprocess

import pytest

import weft

SOURCE = pathlib.Path(os.environ.get("WEFT_SOURCE_DIR", pathlib.Path(__file__).resolve().parents[2]))
CLI = os.environ.get("WEFT_CLI", str(SOURCE / "build" / "bin" / "weft"))
SCENES = SOURCE / "examples" / "scenes"
FUR_SPOT = SOURCE / "examples" / "fur" / "scenes" / "fur_spot.json"
SIZE = (64, 48)


def validation_expected():
    return os.environ.get("WEFT_VALIDATION") == "1"


def expect_clean(renderer):
    """Fails the test if the renderer's device's validation layer reported anything."""
    device = renderer.device
    if validation_expected():
        assert device.validation, "WEFT_VALIDATION=1 but the device has no validation layer"
    messages = device.validation_messages()
    assert messages == [], "validation layer:\n" + "\n".join(messages)


@pytest.fixture
def renderer():
    r = weft.Renderer()
    yield r
    expect_clean(r)


def run_cli(*args, cwd=None):
    """Runs build/bin/weft with these arguments; fails the test with its stderr on a non-zero exit."""
    done = subprocess.run([CLI, *map(str, args)], cwd=cwd, capture_output=True, text=True)
    assert done.returncode == 0, f"weft {' '.join(map(str, args))} exited {done.returncode}:\n{done.stderr}"
    return done
