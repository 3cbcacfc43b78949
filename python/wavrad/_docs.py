"""What ``help()`` shows for the native module: the docstrings and
signatures of ``_native.pyi``, the one place the API is documented (editors
read it too), given to the functions and classes of ``wavrad._native`` when
the package is imported.

PyO3 functions and methods do not let their ``__doc__`` be set, so each
documented one is replaced by a thin Python function that calls it, with
the stub's docstring and signature; classes and properties take theirs in
place.
"""

from __future__ import annotations

import ast
import functools
import inspect
from pathlib import Path
from types import ModuleType
from typing import Any, Callable

STUBS = Path(__file__).with_name("_native.pyi")


class _Source:
    """A default value shown as the stub writes it."""

    def __init__(self, text: str) -> None:
        self.text = text

    def __repr__(self) -> str:
        return self.text


def _annotation(node: ast.expr | None) -> Any:
    return inspect.Parameter.empty if node is None else ast.unparse(node)


def _default(node: ast.expr | None) -> Any:
    if node is None:
        return inspect.Parameter.empty
    try:
        return ast.literal_eval(node)
    except ValueError:
        return _Source(ast.unparse(node))


def signature(stub: ast.FunctionDef) -> inspect.Signature:
    """The signature the stub `stub` declares, annotations as written."""
    P = inspect.Parameter
    a = stub.args
    positional = a.posonlyargs + a.args
    defaults: list[ast.expr | None] = [None] * (len(positional) - len(a.defaults))
    defaults += a.defaults
    params = [
        P(
            arg.arg,
            P.POSITIONAL_ONLY if i < len(a.posonlyargs) else P.POSITIONAL_OR_KEYWORD,
            default=_default(default),
            annotation=_annotation(arg.annotation),
        )
        for i, (arg, default) in enumerate(zip(positional, defaults))
    ]
    if a.vararg:
        vararg = a.vararg
        params.append(P(vararg.arg, P.VAR_POSITIONAL, annotation=_annotation(vararg.annotation)))
    params += [
        P(arg.arg, P.KEYWORD_ONLY, default=_default(d), annotation=_annotation(arg.annotation))
        for arg, d in zip(a.kwonlyargs, a.kw_defaults)
    ]
    if a.kwarg:
        params.append(P(a.kwarg.arg, P.VAR_KEYWORD, annotation=_annotation(a.kwarg.annotation)))
    return inspect.Signature(params, return_annotation=_annotation(stub.returns))


def _calling(native: Callable[..., Any], stub: ast.FunctionDef, qualname: str) -> Callable:
    """A Python function that calls `native`, documented by `stub`."""

    @functools.wraps(native)
    def documented(*args: Any, **kwargs: Any) -> Any:
        return native(*args, **kwargs)

    documented.__doc__ = ast.get_docstring(stub)
    documented.__signature__ = signature(stub)  # type: ignore[attr-defined]
    documented.__module__ = "wavrad"
    documented.__qualname__ = qualname
    return documented


def _document_class(cls: type, stub: ast.ClassDef) -> None:
    cls.__doc__ = ast.get_docstring(stub)
    for node in stub.body:
        if not isinstance(node, ast.FunctionDef) or ast.get_docstring(node) is None:
            continue
        native = cls.__dict__.get(node.name)
        if native is None or node.name.startswith("__"):
            continue  # dunders keep their slots (len(), repr())
        is_property = any(
            isinstance(d, ast.Name) and d.id == "property" for d in node.decorator_list
        )
        if is_property:
            setattr(cls, node.name, property(native.__get__, doc=ast.get_docstring(node)))
        else:
            setattr(cls, node.name, _calling(native, node, f"{cls.__name__}.{node.name}"))


def document(module: ModuleType, stubs: Path = STUBS) -> None:
    """Give every function and class of `module` that `stubs` documents its
    docstring and signature (functions replaced in `module`)."""
    tree = ast.parse(stubs.read_text(encoding="utf-8"))
    for node in tree.body:
        native = getattr(module, getattr(node, "name", ""), None)
        if native is None:
            continue  # stub-only helpers (TypedDicts, aliases)
        if isinstance(node, ast.FunctionDef):
            setattr(module, node.name, _calling(native, node, node.name))
        elif isinstance(node, ast.ClassDef):
            _document_class(native, node)
