"""The public surface: every name documented, and the type stubs naming exactly what the module has."""

import ast
import inspect
from pathlib import Path

import prismatic
from prismatic import _prismatic

STUBS = Path(prismatic.__file__).with_name("_prismatic.pyi")


def public(names):
    return {n for n in names if not n.startswith("_")}


def test_every_public_name_has_a_docstring():
    assert prismatic.__doc__ and "render" in prismatic.__doc__
    for name in prismatic.__all__:
        obj = getattr(prismatic, name)
        if name == "__version__":
            assert isinstance(obj, str)
            continue
        assert inspect.getdoc(obj), name
        if inspect.isclass(obj):
            for member in public(dir(obj)) - public(dir(Exception)):
                assert inspect.getdoc(getattr(obj, member)), f"{name}.{member}"


def test_the_stubs_name_what_the_module_has():
    tree = ast.parse(STUBS.read_text())
    classes = {node.name: node for node in tree.body if isinstance(node, ast.ClassDef)}
    functions = {node.name for node in tree.body if isinstance(node, ast.FunctionDef)}
    module = {n for n in dir(_prismatic) if not n.startswith("__")}
    assert set(classes) | functions | {"__version__"} == module | {"__version__"}
    for name, node in classes.items():
        stubbed = public(item.name for item in node.body if isinstance(item, (ast.FunctionDef, ast.AnnAssign))
                         if not isinstance(item, ast.AnnAssign)) | public(
            item.target.id for item in node.body if isinstance(item, ast.AnnAssign))
        actual = public(dir(getattr(_prismatic, name))) - public(dir(Exception) if name == "SceneError" else [])
        if name == "SceneError":
            actual |= {"file", "line", "column", "message"}
        assert stubbed == actual, f"{name}: stubs {sorted(stubbed - actual)} extra, {sorted(actual - stubbed)} missing"
        # Keyword arguments of the stubbed methods are those the module takes.
        for item in node.body:
            if isinstance(item, ast.FunctionDef) and not item.name.startswith("_") and name != "SceneError":
                runtime = getattr(getattr(_prismatic, name), item.name)
                sig = getattr(runtime, "__text_signature__", None)
                if sig:
                    stub_args = [a.arg for a in item.args.args + item.args.kwonlyargs if a.arg != "self"]
                    for arg in stub_args:
                        assert arg in sig, f"{name}.{item.name}: {arg} not in {sig}"
