"""The package explains itself: ``help()`` shows the stubs' docstrings and
signatures, errors are wavrad's own types, and it knows its version."""

from __future__ import annotations

import ast
import importlib.metadata
import inspect
import pydoc
from pathlib import Path

import pytest

import wavrad
from wavrad import _docs

CORNELL_BOX = Path(__file__).resolve().parent.parent / "scenes" / "cornell-box" / "scene.xml"


def stub_docstrings() -> dict[str, str]:
    """Every docstring of ``_native.pyi`` by qualified name."""
    tree = ast.parse(_docs.STUBS.read_text(encoding="utf-8"))
    found = {}
    for node in tree.body:
        if isinstance(node, (ast.FunctionDef, ast.ClassDef)) and not node.name.startswith("_"):
            found[node.name] = ast.get_docstring(node)
        if isinstance(node, ast.ClassDef):
            for member in node.body:
                if isinstance(member, ast.FunctionDef) and not member.name.startswith("__"):
                    found[f"{node.name}.{member.name}"] = ast.get_docstring(member)
    return found


def test_every_public_name_is_documented_as_its_stub() -> None:
    docs = stub_docstrings()
    public = {name for name in wavrad.__all__ if name != "__version__"}
    assert public <= {name.split(".")[0] for name in docs}
    for qualname, doc in docs.items():
        assert doc, f"{qualname} has no docstring in the stubs"
        obj = wavrad
        for part in qualname.split("."):
            obj = getattr(obj, part)
        assert inspect.getdoc(obj) == doc, qualname


def test_help_shows_parameters_and_errors() -> None:
    text = pydoc.render_doc(wavrad.solve, renderer=pydoc.plaintext)
    for needle in ["threshold", "max_level", "oracle", "progress", "Raises", "SolveError"]:
        assert needle in text, needle
    params = inspect.signature(wavrad.solve).parameters
    assert params["threshold"].kind is inspect.Parameter.KEYWORD_ONLY
    assert params["threshold"].default is None
    render = inspect.signature(wavrad.Solution.render).parameters
    assert list(render)[:3] == ["self", "mode", "spp"]
    assert "Statistics of the solve" in pydoc.render_doc(wavrad.Solution, renderer=pydoc.plaintext)


def test_documented_functions_call_the_native_ones() -> None:
    native = wavrad.relative_rmse.__wrapped__
    assert type(native).__name__ == "builtin_function_or_method"
    assert wavrad.relative_rmse([1.0, 3.0], [1.0, 2.0]) == native([1.0, 3.0], [1.0, 2.0]) > 0
    assert wavrad.solve.__module__ == "wavrad"


def test_errors_are_wavrad_errors() -> None:
    scene = wavrad.load_scene(CORNELL_BOX, res=8)
    with pytest.raises(wavrad.SolveError, match="oracle"):
        wavrad.solve(scene, oracle="kernal")
    with pytest.raises(wavrad.SolveError, match="solver"):
        wavrad.solve(scene, solver="bounce")
    # A wrongly typed setting is wavrad's ArgumentError, still a ValueError.
    with pytest.raises(wavrad.ArgumentError, match="max_level") as raised:
        wavrad.solve(scene, max_level=2.5)
    assert isinstance(raised.value, wavrad.WavradError)
    assert isinstance(raised.value, ValueError)
    with pytest.raises(wavrad.SceneError, match="rez=8 is used nowhere"):
        wavrad.load_scene(CORNELL_BOX, rez=8)


def test_version_is_the_package_version() -> None:
    assert wavrad.__version__ == importlib.metadata.version("wavrad")
    assert wavrad.__version__[0].isdigit()
