"""Scenes built in code, from NumPy arrays, through weft's scene reader."""
import numpy as np
import pytest

import weft
from conftest import SOURCE, SIZE, FUR_SPOT


def test_a_scene_built_in_code_renders_like_the_same_scene_file(renderer, tmp_path):
    document = {
        "camera": {"position": [0, 0.6, 2.0], "target": [0, 0, 0], "fov": 38},
        "environment": {"color": [0.2, 0.22, 0.25]},
        "lights": [{"type": "directional", "name": "key", "direction": [-0.8, -0.4, -0.6], "intensity": 3.0}],
        "meshes": {"ball": {"primitive": "sphere", "radius": 0.5, "segments": 32}},
        "materials": {"fur": {"type": "fur", "photo": str(SOURCE / "examples/fur/synthetic_fur.png"), "layers": 8}},
        "objects": [{"name": "ball", "mesh": "ball", "material": "fur"}],
    }
    from_dict = weft.Scene.from_dict(document)
    built = weft.Scene()
    built.camera = {"position": [0, 0.6, 2.0], "target": [0, 0, 0], "fov": 38}
    built.set_environment(color=[0.2, 0.22, 0.25])
    built.add_light("directional", name="key", direction=[-0.8, -0.4, -0.6], intensity=3.0)
    built.add_primitive("ball", "sphere", radius=0.5, segments=32)
    built.add_material("fur", "fur", photo=str(SOURCE / "examples/fur/synthetic_fur.png"), layers=8)
    built.add_object("ball", "fur", name="ball")
    a = renderer.render(from_dict, size=SIZE)
    b = renderer.render(built, size=SIZE)
    np.testing.assert_array_equal(a, b)
    assert built.uses("shell_fur") and built.camera["fov"] == pytest.approx(38)


def test_meshes_from_numpy_arrays(renderer):
    scene = weft.Scene()
    positions = np.array([[-1, 0, -1], [1, 0, -1], [1, 0, 1], [-1, 0, 1]], np.float32)
    quad = np.array([[0, 2, 1], [0, 3, 2]])
    assert scene.add_mesh("quad", positions, quad) == 0
    scene.add_material("red", base_color=[0.9, 0.1, 0.1], roughness=0.4)
    scene.add_object("quad", "red")
    scene.camera = {"position": [0, 3, 0.01], "target": [0, 0, 0]}
    scene.set_environment(color=[1, 1, 1])
    image = renderer.render(scene, size=SIZE)
    centre = image[24, 32].astype(int)
    assert centre[0] > centre[1] + 60 and centre[0] > centre[2] + 60, f"the red quad is not red at the centre: {centre}"
    assert scene.meshes[0]["triangles"] == 2 and scene.objects == [{"name": "object 0", "mesh": "quad", "material": "red"}]
    scene.materials["red"]["base_color"] = (0.1, 0.1, 0.9)
    blue = renderer.render(scene, size=SIZE)[24, 32].astype(int)
    assert blue[2] > blue[0] + 60, f"the quad is not blue after the edit: {blue}"


def test_materials_read_and_set_by_name():
    scene = weft.load_scene(FUR_SPOT)
    fur = scene.materials["fur"]
    assert fur.type == "shell_fur" and fur["layers"] == 15 and fur["uv_scale"] == [3, 3]
    assert [k["name"] for k in fur.knobs()] == [k["name"] for k in weft.knobs("shell_fur")]
    fur.update({"layers": 32, "fins": False})
    assert fur["layers"] == 32 and fur["fins"] is False
    with pytest.raises(ValueError):
        fur.update({"layers": 8, "fins": "sometimes"})
    assert fur["layers"] == 32, "a refused update changed a field"
    del fur["layers"]
    with pytest.raises(KeyError, match="quality preset"):
        fur["layers"]
    assert fur.get("layers", 7) == 7
    copy = scene.copy()
    copy.materials["fur"]["layers"] = 4
    assert "layers" not in scene.materials["fur"]
    assert sorted(scene.materials) == ["floor", "fur"]
