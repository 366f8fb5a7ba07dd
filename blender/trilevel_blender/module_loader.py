"""Finds the `trilevel` Python module: first a directory named in the add-on preferences, then
one in the TRILEVEL_PYTHON_PATH environment variable (headless runs and tests), then Blender's
own Python (a `pip install` into it, or its site-packages). Each named directory is put at the
front of sys.path before the import.
"""
import importlib
import os
import sys

ENV_VAR = "TRILEVEL_PYTHON_PATH"

_module = None


def load(preferences_path=""):
    """The imported trilevel module. Raises ImportError with a one-line message saying where it
    looked and how to make it findable."""
    global _module
    if _module is not None:
        return _module
    looked = []
    for directory in (preferences_path, os.environ.get(ENV_VAR, "")):
        if not directory:
            continue
        directory = os.path.abspath(os.path.expanduser(directory))
        looked.append(directory)
        if directory not in sys.path:
            sys.path.insert(0, directory)
    try:
        _module = importlib.import_module("trilevel")
    except ImportError as e:
        where = ", ".join(looked + ["Blender's Python"])
        raise ImportError(
            f"cannot import the trilevel module (looked in {where}: {e}); install it into Blender's "
            f"Python, or set its directory in the add-on preferences or in {ENV_VAR}") from None
    return _module


def loaded():
    """The module when load() has succeeded, else None."""
    return _module


def reconstruct_keywords(module):
    """The keyword arguments Reconstructor.reconstruct accepts, read from its pybind11 signature
    line (`reconstruct(self, positions, ..., *, mode: str = 'adaptive', ...)`), so that newer
    options such as smoothing are offered only by a module that has them."""
    doc = module.Reconstructor.reconstruct.__doc__ or ""
    first = doc.strip().splitlines()[0] if doc.strip() else ""
    names = set()
    depth = 0
    token = ""
    for ch in first[first.find("(") + 1:]:
        if ch in "([{":
            depth += 1
        elif ch in ")]}":
            if depth == 0:
                break
            depth -= 1
        if depth == 0 and ch == ",":
            names.add(token.split(":")[0].split("=")[0].strip())
            token = ""
        else:
            token += ch
    names.add(token.split(":")[0].split("=")[0].strip())
    return {n for n in names if n.isidentifier()}
