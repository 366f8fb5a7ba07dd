"""The type stubs (trilevel/_trilevel.pyi) against the compiled module: the same public names, and for
every function and method the same parameters in the same order, the same keyword-only markers and
the same defaults (from the signature line pybind11 puts at the top of each docstring). Also the
package's re-exports (trilevel/__init__.py)."""
import ast
import os
import unittest

import numpy as np

import trilevel
from trilevel import _trilevel


def stub_tree():
    path = os.path.join(os.path.dirname(_trilevel.__file__), "_trilevel.pyi")
    with open(path) as f:
        return ast.parse(f.read(), path)


def public(names):
    return {n for n in names if not n.startswith("_")} | ({"__version__"} & set(names))


def split_top_level(text):
    """Splits "a: x[1, 2], b = (3, 4)" at the commas outside brackets and quotes."""
    parts, depth, quote, start = [], 0, None, 0
    for i, c in enumerate(text):
        if quote:
            quote = None if c == quote else quote
        elif c in "'\"":
            quote = c
        elif c in "([{":
            depth += 1
        elif c in ")]}":
            depth -= 1
        elif c == "," and depth == 0:
            parts.append(text[start:i].strip())
            start = i + 1
    if text[start:].strip():
        parts.append(text[start:].strip())
    return parts


def module_signature(obj, name):
    """[(name, keyword_only, default text or None)] from pybind11's "name(a: T = d, *, b: U) -> R"."""
    line = obj.__doc__.splitlines()[0]
    assert line.startswith(name + "("), line
    inner, depth = line[len(name) + 1:], 1
    for i, c in enumerate(inner):
        depth += {"(": 1, ")": -1}.get(c, 0)
        if depth == 0:
            inner = inner[:i]
            break
    params, keyword_only = [], False
    for part in split_top_level(inner):
        if part == "*":
            keyword_only = True
            continue
        head, _, default = part.partition(" = ")
        params.append((head.split(":")[0].strip(), keyword_only, default or None))
    if params and params[0][0] == "self":
        params.pop(0)
    return params


def stub_signature(function):
    """The same list for a stub's FunctionDef (self dropped)."""
    a = function.args
    positional = a.posonlyargs + a.args
    defaults = [None] * (len(positional) - len(a.defaults)) + list(a.defaults)
    params = [(arg.arg, False, d) for arg, d in zip(positional, defaults)]
    params += [(arg.arg, True, d) for arg, d in zip(a.kwonlyargs, a.kw_defaults)]
    if params and params[0][0] == "self":
        params.pop(0)
    return params


def same_default(module_text, stub_node):
    if module_text is None or stub_node is None:
        return module_text is None and stub_node is None
    ours, theirs = ast.literal_eval(stub_node), ast.literal_eval(module_text)
    if isinstance(ours, float):  # the module's floats are float32: 0.32 shows as 0.3199999928474426
        return np.float32(ours) == np.float32(theirs)
    return ours == theirs and type(ours) is type(theirs)


class StubTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.tree = stub_tree()
        cls.stub = {}  # name -> [nodes] (overloads give several)
        for node in cls.tree.body:
            if isinstance(node, (ast.FunctionDef, ast.ClassDef)):
                cls.stub.setdefault(node.name, []).append(node)
            elif isinstance(node, ast.AnnAssign):
                cls.stub.setdefault(node.target.id, []).append(node)
            elif isinstance(node, ast.Assign):
                for target in node.targets:
                    cls.stub.setdefault(target.id, []).append(node)

    def test_the_stub_has_every_public_name_of_the_module_and_no_other(self):
        self.assertEqual(public(self.stub), public(dir(_trilevel)))

    def test_the_package_reexports_the_module(self):
        self.assertEqual(set(trilevel.__all__), public(dir(_trilevel)))
        for name in trilevel.__all__:
            self.assertIs(getattr(trilevel, name), getattr(_trilevel, name))
        self.assertEqual(trilevel.Error.__module__, "trilevel")

    def assert_same_signature(self, what, obj, name, stub_nodes):
        """Every overload takes the module's parameters, in order, keyword-only where they are; a
        default it gives is the module's, and one overload (the general one) gives them all. An
        overload may leave a default out to narrow its case (read_particles with attribute names)."""
        self.assertTrue(stub_nodes, what + " is missing in the stub")
        expected = module_signature(obj, name)
        complete = 0
        for node in stub_nodes:
            got = stub_signature(node)
            self.assertEqual([p[:2] for p in got], [p[:2] for p in expected], what)
            for (param, _, stub_default), (_, _, module_default) in zip(got, expected):
                if stub_default is None and module_default is not None and len(stub_nodes) > 1:
                    continue
                self.assertTrue(same_default(module_default, stub_default),
                                f"{what}: default of {param}: stub {ast.unparse(stub_default) if stub_default else None}, "
                                f"module {module_default}")
            complete += all((s is None) == (m is None) for (_, _, s), (_, _, m) in zip(got, expected))
        self.assertGreater(complete, 0, what + ": no overload has all the module's defaults")

    def test_functions_take_the_module_parameters(self):
        functions = [n for n in public(dir(_trilevel)) if callable(getattr(_trilevel, n)) and not isinstance(getattr(_trilevel, n), type)]
        self.assertGreaterEqual(len(functions), 9)
        for name in functions:
            nodes = [n for n in self.stub.get(name, []) if isinstance(n, ast.FunctionDef)]
            self.assert_same_signature(name, getattr(_trilevel, name), name, nodes)

    def test_reconstructor_methods_and_properties(self):
        cls = next(n for n in self.stub["Reconstructor"] if isinstance(n, ast.ClassDef))
        members = {}
        for node in cls.body:
            if isinstance(node, ast.FunctionDef):
                members.setdefault(node.name, []).append(node)
        real = {n for n in vars(_trilevel.Reconstructor) if not n.startswith("_")} | {"__init__"}
        self.assertEqual(set(members), real)
        for name, nodes in members.items():
            member = vars(_trilevel.Reconstructor)[name]
            if isinstance(member, property):
                self.assertTrue(all(any(isinstance(d, ast.Name) and d.id == "property" for d in n.decorator_list)
                                    for n in nodes), name + " is a property")
                continue
            self.assert_same_signature("Reconstructor." + name, member, name, nodes)

    def test_error_derives_from_runtime_error_in_the_stub_too(self):
        cls = next(n for n in self.stub["Error"] if isinstance(n, ast.ClassDef))
        self.assertEqual([ast.unparse(b) for b in cls.bases], ["RuntimeError"])


if __name__ == "__main__":
    unittest.main()
