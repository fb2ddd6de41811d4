"""Every public call has a docstring and a stub; the stubs parse."""

import ast
import os

import cube_collision as cc

STUBS = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "cube_collision",
                     "_core.pyi")


def stub_names():
    tree = ast.parse(open(STUBS).read())
    names = {}
    for node in tree.body:
        if isinstance(node, ast.ClassDef):
            names[node.name] = {n.name for n in node.body if isinstance(n, ast.FunctionDef)}
        elif isinstance(node, ast.FunctionDef):
            names[node.name] = set()
    return names


def public(obj):
    """The public members a class defines (an exception's inherited ones, args and the like,
    are Python's)."""
    inherited = set(dir(BaseException)) if issubclass(obj, BaseException) else set()
    return [n for n in dir(obj) if not n.startswith("_") and n not in inherited]


def test_every_public_call_is_documented_and_stubbed():
    stubs = stub_names()
    for name in cc.__all__:
        obj = getattr(cc, name)
        if name == "ALL_BITS":
            continue
        assert obj.__doc__ and obj.__doc__.strip(), name
        assert name in stubs, name
        if isinstance(obj, type):
            for member in public(obj):
                attr = getattr(obj, member)
                assert attr.__doc__ and attr.__doc__.strip(), f"{name}.{member}"
                assert member in stubs[name], f"{name}.{member} missing from the stub"
