"""The .pyi stubs describe the real API: same functions, parameters and defaults."""
import ast
import inspect
import pathlib

import tetopt


def stub_functions():
    path = pathlib.Path(tetopt.__file__).with_name("__init__.pyi")
    tree = ast.parse(path.read_text())
    out = {}
    for node in tree.body:
        if isinstance(node, ast.FunctionDef):
            out.setdefault(node.name, []).append(node)
    return out


def params(fn: ast.FunctionDef):
    a = fn.args
    names = [x.arg for x in a.posonlyargs + a.args] + [x.arg for x in a.kwonlyargs]
    pos_defaults = [None] * (len(a.posonlyargs + a.args) - len(a.defaults)) + list(a.defaults)
    defaults = pos_defaults + list(a.kw_defaults)
    return names, [None if d is None or (isinstance(d, ast.Constant) and d.value is Ellipsis) else
                   ast.literal_eval(d) for d in defaults], [x.arg for x in a.kwonlyargs]


def test_every_public_function_has_a_stub():
    stubs = stub_functions()
    public = [n for n in tetopt.__all__ if n not in ("Mesh", "__version__")]
    assert sorted(public) == sorted(stubs)


def test_stub_signatures_match_runtime():
    for name, defs in stub_functions().items():
        sig = inspect.signature(getattr(tetopt, name))
        rt_names = list(sig.parameters)
        rt_kwonly = [p.name for p in sig.parameters.values() if p.kind is p.KEYWORD_ONLY]
        # The widest overload must name every runtime parameter, keyword-only ones as such.
        widest = max(defs, key=lambda f: len(params(f)[0]))
        names, defaults, kwonly = params(widest)
        assert names == rt_names, name
        assert kwonly == rt_kwonly, name
        for pname, d in zip(names, defaults):
            rt = sig.parameters[pname].default
            if d is not None:
                assert rt == d, (name, pname, rt, d)


def test_mesh_fields_match_stub():
    path = pathlib.Path(tetopt.__file__).with_name("__init__.pyi")
    cls = next(n for n in ast.parse(path.read_text()).body if isinstance(n, ast.ClassDef) and n.name == "Mesh")
    annotated = [n.target.id for n in cls.body if isinstance(n, ast.AnnAssign)]
    import dataclasses
    assert annotated == [f.name for f in dataclasses.fields(tetopt.Mesh)]
