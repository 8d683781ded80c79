"""The module itself: import, adapters, the registries, help() on everything."""
import inspect

import weft


def test_adapters_lists_at_least_one_vulkan_adapter():
    adapters = weft.adapters()
    assert adapters, "no Vulkan adapter (lavapipe should always be there)"
    for a in adapters:
        assert a["name"] and a["driver"] and a["api_version"].startswith("1.")


def test_registry_lists_the_builtin_features_with_their_knob_tables():
    names = [f["name"] for f in weft.features()]
    assert names[:4] == ["shell_fur", "skin_sss", "neural_btf", "ssdf_lighting"]
    fur = weft.feature("fur")  # an alias finds the feature
    assert fur["name"] == "shell_fur" and "fur" in fur["aliases"]
    layers = next(k for k in weft.knobs("shell_fur") if k["name"] == "layers")
    assert layers["kind"] == "integer" and layers["min"] == 1 and layers["max"] == 256
    assert weft.presets("shell_fur")["medium"] == {"layers": 15, "msaa_hair": "coverage"}
    assert weft.reference("shell_fur")["layers"] == 256
    assert "tonemap" in [t["name"] for t in weft.pass_types()]


def test_unknown_feature_names_the_registered_ones():
    try:
        weft.knobs("velvet")
    except LookupError as e:
        assert "velvet" in str(e) and "shell_fur" in str(e)
    else:
        raise AssertionError("no error for an unknown feature")


def _public(obj):
    for name, member in inspect.getmembers(obj):
        if name.startswith("_") and name not in ("__getitem__", "__setitem__", "__init__"):
            continue
        if callable(member) or isinstance(member, property):
            yield name, member


def test_help_on_every_function_and_method_says_what_it_takes_and_returns():
    missing = []
    for name, member in _public(weft):
        if inspect.isclass(member):
            if not (member.__doc__ or "").strip():
                missing.append(name)
            for mname, m in _public(member):
                if mname in ("__init__",) and member is weft.NotFoundError:
                    continue
                doc = (m.__doc__ or "").strip()
                if not doc or doc.startswith("(self") and "\n" not in doc:
                    missing.append(f"{name}.{mname}")
        else:
            doc = (member.__doc__ or "").strip()
            # pybind11 puts the signature (with py::arg names) first; the text after it is ours.
            if "->" not in doc or len(doc.splitlines()) < 3:
                missing.append(name)
    missing = [m for m in missing if not m.startswith("NotFoundError")]
    assert missing == [], f"without a docstring saying what they take and return: {missing}"
    assert "quality" in weft.Renderer.render.__doc__ and "numpy.ndarray" in weft.Renderer.render.__doc__


def test_docs_python_md_shows_the_example_script_as_it_is():
    from conftest import SOURCE
    doc = (SOURCE / "docs" / "python.md").read_text()
    script = (SOURCE / "examples" / "python" / "fur_layers.py").read_text().rstrip("\n")
    assert "```python\n" + script + "\n```" in doc, "docs/python.md's script differs from examples/python/fur_layers.py"
