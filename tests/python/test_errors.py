"""Bad input gives weft's one-line messages as Python exceptions, never a crash."""
import numpy as np
import pytest

import weft
from conftest import FUR_SPOT, SIZE


def test_knob_out_of_range_is_the_registrys_message_and_changes_nothing():
    scene = weft.load_scene(FUR_SPOT)
    fur = scene.materials["fur"]
    layers = next(k for k in weft.knobs(fur.type) if k["name"] == "layers")
    with pytest.raises(ValueError) as e:
        fur["layers"] = 1000
    assert str(e.value) == (
        f"invalid argument: shell_fur material 'fur': knob 'layers': 1000 is not an integer in "
        f"[{layers['min']:g}, {layers['max']:g}]")
    assert fur["layers"] == 15
    with pytest.raises(ValueError, match="knob 'layers'"):
        fur["layers"] = 2.5
    with pytest.raises(ValueError, match=r"\$\.materials\.fur\.layout: 'diagonal' is not one of: band, strand"):
        fur["layout"] = "diagonal"
    with pytest.raises(ValueError, match=r"\$\.materials\.fur\.nonsense: unknown field"):
        fur["nonsense"] = 1
    assert "nonsense" not in fur and "layout" not in fur  # refused values left nothing behind
    with pytest.raises(ValueError, match=r"\$\.materials\.floor\.roughness: 3 is out of range \[0, 1\]"):
        scene.materials["floor"]["roughness"] = 3
    assert scene.materials["floor"]["roughness"] == pytest.approx(0.8)
    with pytest.raises(KeyError, match="no material 'velvet'"):
        scene.materials["velvet"]


def test_missing_files_are_file_not_found_naming_the_file():
    with pytest.raises(FileNotFoundError, match="no_such_scene.json"):
        weft.load_scene("no_such_scene.json")
    with pytest.raises(FileNotFoundError, match="no_such_mesh.obj"):
        weft.Scene().add_mesh_file("m", "no_such_mesh.obj")
    with pytest.raises(FileNotFoundError, match="no_such_pipeline.json"):
        weft.Pipeline.load("no_such_pipeline.json")
    with pytest.raises(FileNotFoundError, match="no_such_image.png"):
        weft.load_image("no_such_image.png")
    with pytest.raises(ValueError, match=r"\$\.materials\.fur\.photo"):
        weft.Scene().add_material("fur", "fur", photo="no_such_photo.png")


def test_bad_scene_dict_reports_every_problem_at_its_json_path():
    with pytest.raises(ValueError) as e:
        weft.Scene.from_dict({
            "meshes": {"ball": {"primitive": "sphere", "radius": -1}},
            "materials": {"fur": {"type": "fur", "layers": "many"}},
            "objects": [{"mesh": "cube"}],
            "lights": [{"type": "laser"}],
            "colour": 1,
        })
    text = str(e.value)
    assert text.startswith("parse error: scene dict: ")
    for expected in ["$.meshes.ball.radius: -1 is out of range", "$.objects[0].mesh: object 'object 0' uses unknown mesh 'cube'",
                     "$.lights[0].type:", "$.colour: unknown field"]:
        assert expected in text, f"'{expected}' not in:\n{text}"


def test_bad_render_arguments():
    r = weft.Renderer()
    scene = weft.load_scene(FUR_SPOT)
    with pytest.raises(ValueError, match=r"size expects \(width, height\) with each side 1 to 8192"):
        r.render(scene, size=(0, 48))
    with pytest.raises(ValueError, match="size expects"):
        r.render(scene, size=(64,))
    with pytest.raises(ValueError, match="unknown quality 'ultra'"):
        r.render(scene, size=SIZE, quality="ultra")
    with pytest.raises(ValueError, match=r"exposure .* must be a number in \(0, 1e6\]"):
        r.render(scene, size=SIZE, exposure=float("nan"))
    with pytest.raises(LookupError, match="'nope.slot'.*slots: shadow_map.depth"):
        r.render(scene, size=SIZE, output="nope.slot")
    with pytest.raises(ValueError, match="mesh 'tri'"):
        weft.Scene().add_mesh("tri", np.zeros((3, 3)), [0, 1, 7])
    with pytest.raises(ValueError, match="positions must be an array of shape"):
        weft.Scene().add_mesh("tri", np.zeros((3, 2)), [0, 1, 2])
    with pytest.raises(ValueError, match="unknown mesh 'nope'"):
        weft.Scene().add_object("nope", "default")
    with pytest.raises(ValueError, match=r"\$\.camera\.fov"):
        weft.Scene().camera = {"fov": 500}
    with pytest.raises(ValueError, match="uint8"):
        weft.compare(np.zeros((4, 4, 4), np.float32), np.zeros((4, 4, 4), np.uint8))
    assert r.device.validation_messages() == []


def test_feature_material_fields_are_checked_when_the_scene_is_read():
    from conftest import SOURCE
    with pytest.raises(ValueError) as e:
        weft.Scene.from_dict({
            "meshes": {"ball": {"primitive": "sphere"}},
            "materials": {"fur": {"type": "fur", "photo": str(SOURCE / "examples/fur/synthetic_fur.png"), "layers": 0,
                                  "layout": "diagonal"}},
            "objects": [{"mesh": "ball", "material": "fur"}],
        })
    assert "$.materials.fur.layers" in str(e.value) and "$.materials.fur.layout" in str(e.value)
