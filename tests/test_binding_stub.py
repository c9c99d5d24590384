"""The type stub ``beamslider/_core.pyi`` holds the documentation of the compiled binding (its Rust
doc comments are one line each): every export of ``beamslider._core`` has a stub, and the stub's
parameters are the compiled function's, by name, kind and order."""

import ast
import inspect
from pathlib import Path

import pytest

from beamslider import _core

STUB = Path(_core.__file__).with_name("_core.pyi")


def _stub():
    tree = ast.parse(STUB.read_text(encoding="utf-8"))
    funcs, classes = {}, {}
    for node in tree.body:
        if isinstance(node, ast.FunctionDef):
            funcs[node.name] = node
        elif isinstance(node, ast.ClassDef):
            classes[node.name] = {n.name: n for n in node.body if isinstance(n, ast.FunctionDef)}
    return funcs, classes


def _params(node: ast.FunctionDef, skip_self: bool):
    a = node.args
    out = [(p.arg, "POSITIONAL_ONLY") for p in a.posonlyargs] + [(p.arg, "POSITIONAL_OR_KEYWORD") for p in a.args]
    if skip_self and out and out[0][0] in ("self", "cls"):
        out = out[1:]
    if a.vararg:
        out.append((a.vararg.arg, "VAR_POSITIONAL"))
    out += [(p.arg, "KEYWORD_ONLY") for p in a.kwonlyargs]
    if a.kwarg:
        out.append((a.kwarg.arg, "VAR_KEYWORD"))
    return out


def _same(stub, runtime):
    """The stub's parameters are the runtime's in order; where the runtime takes ``**options`` (the
    core's settings read by serde), the stub may spell them out as keyword-only parameters."""
    names = [n for n, _ in runtime]
    options = bool(runtime) and runtime[-1][1] == "VAR_KEYWORD"
    shared = [p for p in stub if p[0] in names]
    extra = [p for p in stub if p[0] not in names]
    fixed = [p for p in runtime if p[1] != "VAR_KEYWORD"] if options and extra else runtime
    return shared == fixed and all(kind == "KEYWORD_ONLY" for _, kind in extra) and (options or not extra)


def _runtime(obj):
    try:
        sig = inspect.signature(obj)
    except (TypeError, ValueError):
        return None
    return [(p.name, p.kind.name) for p in sig.parameters.values()]


EXPORTS = sorted(n for n in dir(_core) if not n.startswith("__") and (inspect.isclass(getattr(_core, n)) or callable(getattr(_core, n))))


@pytest.mark.parametrize("name", EXPORTS)
def test_every_export_has_its_stub_with_the_same_parameters(name):
    funcs, classes = _stub()
    obj = getattr(_core, name)
    if inspect.isclass(obj):
        assert name in classes, f"_core.{name} has no class in {STUB.name}"
        if issubclass(obj, BaseException):
            return
        for meth, node in classes[name].items():
            if meth.startswith("__") and meth != "__init__":
                continue  # protocol methods: their parameters are Python's
            target = obj if meth == "__init__" else getattr(obj, meth, None)
            assert target is not None, f"{STUB.name} names {name}.{meth}, which the binding lacks"
            want = _runtime(target)
            if want is not None and not isinstance(inspect.getattr_static(obj, meth, None), property):
                got = _params(node, skip_self=not isinstance(inspect.getattr_static(obj, meth), staticmethod))
                assert _same(got, [w for w in want if w[0] not in ("self", "cls")]), f"{name}.{meth}: {got} against {want}"
    else:
        assert name in funcs, f"_core.{name} has no stub in {STUB.name}"
        want = _runtime(obj)
        assert want is not None, f"_core.{name} has no text signature"
        got = _params(funcs[name], skip_self=False)
        assert _same(got, want), f"{name}: {got} against {want}"
