"""Particle file patterns: `{}` in the file name stands for a frame number of any number of
digits, as the trilevel CLI reads them (`drop_{}.vtk` matches drop_7.vtk and drop_0007.vtk).

No bpy here: the functions take and return plain paths.
"""
import os


def is_sequence(pattern):
    """True when `pattern` holds `{}` (a frame sequence), False for a single file."""
    return "{}" in pattern


def list_frames(pattern):
    """{frame number: path} of the files matching `pattern` (a `{}` sequence).

    Raises ValueError with a one-line message when `{}` is in a directory name or the directory
    does not exist. When two files give the same number (7 and 0007) the shorter name wins
    (the CLI would reconstruct both).
    """
    directory, name = os.path.split(pattern)
    if "{}" not in name:
        raise ValueError(f"{pattern}: '{{}}' must be in the file name, not in a directory")
    at = name.index("{}")
    prefix, suffix = name[:at], name[at + 2:]
    directory = directory or "."
    if not os.path.isdir(directory):
        raise ValueError(f"{pattern}: directory '{directory}' does not exist")
    frames = {}
    for f in sorted(os.listdir(directory), key=lambda f: (len(f), f)):
        if len(f) <= len(prefix) + len(suffix) or not f.startswith(prefix) or not f.endswith(suffix):
            continue
        digits = f[len(prefix):len(f) - len(suffix)]
        if digits.isascii() and digits.isdigit():
            frames.setdefault(int(digits), os.path.join(directory, f))
    return frames


def file_for_frame(pattern, number):
    """The file that frame `number` shows: the single file for a pattern without `{}`, else the
    matching file of that number; None when the sequence has no such frame.

    Raises ValueError as list_frames does, or when a single file does not exist.
    """
    if not is_sequence(pattern):
        if not os.path.isfile(pattern):
            raise ValueError(f"{pattern}: no such file")
        return pattern
    return list_frames(pattern).get(number)


def sequence_pattern(path):
    """`path` with the last run of digits in its file name replaced by `{}` (drop_0007.vtk ->
    drop_{}.vtk), for picking a sequence by one of its files; `path` itself when it already is a
    pattern or its name has no digits."""
    if is_sequence(path):
        return path
    directory, name = os.path.split(path)
    end = len(name)
    while end > 0 and not name[end - 1].isdigit():
        end -= 1
    start = end
    while start > 0 and name[start - 1].isdigit():
        start -= 1
    if start == end:
        return path
    return os.path.join(directory, name[:start] + "{}" + name[end:])
