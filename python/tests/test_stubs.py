"""The type stubs stay true: the Params fields in pmon/_params.pyi are the run-time fields, and every public name
of the extension module has a stub."""

import ast
from pathlib import Path

import pmon
import pmon._pmon

PKG = Path(__file__).resolve().parents[1] / "pmon"


def stub_names(path, cls=None):
    tree = ast.parse(path.read_text())
    body = tree.body
    if cls:
        body = next(n for n in body if isinstance(n, ast.ClassDef) and n.name == cls).body
    return [n.target.id for n in body if isinstance(n, ast.AnnAssign)], {
        n.name for n in body if isinstance(n, (ast.FunctionDef, ast.ClassDef))
    }


def test_params_stub_lists_the_runtime_fields_in_order():
    fields, _ = stub_names(PKG / "_params.pyi", "Params")
    assert fields == pmon.Params.fields()


def test_extension_stub_covers_the_extension():
    _, names = stub_names(PKG / "_pmon.pyi")
    public = {n for n in dir(pmon._pmon) if not n.startswith("_")}
    assert public <= names, public - names
