"""Frame sequences on a dask.distributed cluster: one task per frame, one Reconstructor per worker process.

    from trilevel.dask import reconstruct_frames
    results = reconstruct_frames("sim/fluid_{}.bgeo", "mesh/fluid_{}.ply", 0.025,
                                 scheduler="tcp://head:8786", skip_existing=True)

or from a shell, with the same arguments:

    python3 -m trilevel.dask 'sim/fluid_{}.bgeo' -r 0.025 -o 'mesh/fluid_{}.ply' --scheduler tcp://head:8786 --skip-existing

Frames are found as the CLI finds them: "{}" in the file name stands for the frame number with any
zero padding, frames run in numeric order, and each output name is the output pattern with the
frame number as the input wrote it.

Every frame is reconstructed on its own (level hysteresis 0, the history reset before each frame):
tasks land on any worker in any order, so there is no previous frame to hold levels against. Each
mesh is therefore byte-identical to the CLI's for that frame alone (`trilevel reconstruct FILE ...`)
or for the sequence with `--level-hysteresis 0`; the CLI's default 0.2 across a sequence may give
a few cells another level (docs/many_frames.md).

The workers need trilevel installed (`pip install .`, the same version) and an OpenCL device. Each
worker process keeps one Reconstructor (its OpenCL context and compiled kernels) for all the frames
it is given. Outputs are written to a temporary file and renamed, so a file that exists is
complete: with skip_existing, a rerun after an interruption does only the missing frames. A frame
whose worker process dies is rerun on another worker by the scheduler (up to the scheduler's
`distributed.scheduler.allowed-failures`, default 3); a frame that raises is retried `retries`
times, then reported as failed while the other frames go on.
"""
from __future__ import annotations

import argparse
import dataclasses
import json
import os
import re
import socket
import sys
import tempfile
import threading
import uuid
from typing import Any, Callable, Mapping, Sequence

import distributed

from . import _trilevel

__all__ = ["FrameJob", "FrameResult", "find_frames", "plan_frames", "reconstruct_frame", "reconstruct_frames", "main"]

# Reconstructor keywords a frame may be given; level_hysteresis and return_levels are set here.
_OPTIONS = ("mode", "cell", "kernel_radius", "curvature_threshold", "level2_tolerance", "memory_limit",
            "crack_closing", "remove_components_below", "particle_box", "clip_box", "smooth", "smooth_iterations",
            "sliver_cleanup", "normals")


@dataclasses.dataclass(frozen=True)
class FrameJob:
    """One frame: its number as the input file writes it, and its paths (stats: "" for none)."""

    number: str
    input: str
    output: str
    stats: str = ""

    def outputs_exist(self) -> bool:
        return os.path.exists(self.output) and (not self.stats or os.path.exists(self.stats))


@dataclasses.dataclass
class FrameResult:
    """What happened to a frame. status: "done", "skipped" (its outputs existed) or "failed"."""

    number: str
    output: str
    status: str
    triangles: int = 0
    closed: bool = False
    error: str = ""
    worker: str = ""  # host:pid of the process that reconstructed it
    reconstructor: int = 0  # id() of that process's Reconstructor: the same for all its frames
    frames_on_reconstructor: int = 0  # frames that Reconstructor had done, this one included


def _check_job(job: "FrameJob") -> None:
    """ValueError for a frame whose outputs would overwrite its input, or each other: the files
    written, links resolved (writes go through them), as the CLI checks; trilevel.Error for a mesh
    extension write_mesh does not write, ValueError for statistics not named .json (the CLI's rule)."""
    written = {name: os.path.realpath(path) for name, path in
               (("input", job.input), ("mesh", job.output), ("stats", job.stats)) if path}
    if written["mesh"] == written["input"]:
        raise ValueError(f"frame {job.number}: the mesh {job.output} would overwrite the input")
    for other in ("input", "mesh"):
        if written.get("stats") == written[other]:
            raise ValueError(f"frame {job.number}: the stats {job.stats} would overwrite the {other}")
    _trilevel._check_mesh_extension(job.output)
    if job.stats and os.path.splitext(job.stats)[1].lower() != ".json":
        raise ValueError(f"{job.stats}: unknown statistics extension '{os.path.splitext(job.stats)[1][1:]}', expected .json")


def _names(attributes: Sequence[str]) -> list[str]:
    """The attribute names as a list; a lone string is a mistake for [name], not its letters."""
    if isinstance(attributes, (str, bytes)):
        raise TypeError(f"attributes must be a sequence of names, got the string {attributes!r} (use [{attributes!r}])")
    return list(attributes)


def _frame_path(pattern: str, number: str) -> str:
    return pattern.replace("{}", number, 1) if pattern else ""


def find_frames(pattern: str) -> list[str]:
    """The frame numbers (as written) of the files matching `pattern`, in numeric order (equal
    values by their text), as the CLI finds them. Raises ValueError for a pattern without "{}" in
    its file name, FileNotFoundError when its directory is missing or nothing matches."""
    directory, name = os.path.split(pattern)
    if "{}" not in name:
        raise ValueError(f"{pattern}: '{{}}' must be in the file name, not in a directory")
    prefix, suffix = name.split("{}", 1)
    directory = directory or "."
    if not os.path.isdir(directory):
        raise FileNotFoundError(f"{pattern}: directory '{directory}' does not exist")
    digits = re.compile(re.escape(prefix) + r"([0-9]+)" + re.escape(suffix) + r"\Z")
    numbers = [m.group(1) for m in map(digits.match, os.listdir(directory)) if m]
    if not numbers:
        raise FileNotFoundError(f"{pattern}: no frame files match")
    return sorted(numbers, key=lambda n: (int(n), n))


def plan_frames(input_pattern: str, output_pattern: str, stats_pattern: str = "", start: int | None = None,
                end: int | None = None) -> list[FrameJob]:
    """The frames of `input_pattern` in [start, end] (inclusive; None: open) with their output paths."""
    for name, pattern in (("output", output_pattern), ("stats", stats_pattern)):
        if pattern and "{}" not in pattern:
            raise ValueError(f"the {name} pattern must contain '{{}}' when the input is a frame sequence")
    numbers = find_frames(input_pattern)
    jobs = [FrameJob(n, _frame_path(input_pattern, n), _frame_path(output_pattern, n), _frame_path(stats_pattern, n))
            for n in numbers if (start is None or int(n) >= start) and (end is None or int(n) <= end)]
    if not jobs:
        raise ValueError(f"{input_pattern}: no frame in [{'first' if start is None else start}, "
                         f"{'last' if end is None else end}]; the files hold frames {numbers[0]} to {numbers[-1]}")
    for job in jobs:
        _check_job(job)
    return jobs


# One Reconstructor per worker process and device, made by the first frame the process is given.
_reconstructors: dict[int, list] = {}  # device -> [Reconstructor, frames done]
_reconstructors_lock = threading.Lock()


def _worker_reconstructor(device: int) -> list:
    with _reconstructors_lock:
        if device not in _reconstructors:
            _reconstructors[device] = [_trilevel.Reconstructor(device), 0]
        return _reconstructors[device]


def _write_atomically(path: str, text: str) -> None:
    """Writes `text` to a temporary file beside `path` and renames it into place."""
    fd, tmp = tempfile.mkstemp(dir=os.path.dirname(path) or ".", prefix=os.path.basename(path) + ".tmp.")
    try:
        with os.fdopen(fd, "w") as f:
            f.write(text)
        os.replace(tmp, path)
    except BaseException:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        raise


def reconstruct_frame(job: FrameJob, particle_radius: float, options: Mapping[str, Any] | None = None,
                      attributes: Sequence[str] = (), color_levels: bool = False, drop_invalid: bool = False,
                      skip_existing: bool = False, device: int = -1) -> FrameResult:
    """Reconstructs one frame with this process's Reconstructor and writes its mesh (and stats).

    The task each worker runs; also callable directly. options: keywords of
    Reconstructor.reconstruct (mode, cell, kernel_radius, curvature_threshold, level2_tolerance,
    memory_limit, crack_closing, normals). attributes: particle attributes to read and interpolate
    (the CLI's --attribute). The mesh file is what the CLI writes for this frame alone, byte for byte.
    """
    options = dict(options or {})
    unknown = sorted(set(options) - set(_OPTIONS))
    if unknown:
        raise ValueError(f"unknown reconstruct options {unknown}; frames take {list(_OPTIONS)} "
                         "(each frame is independent: no level_hysteresis)")
    attributes = _names(attributes)
    _check_job(job)
    worker = f"{socket.gethostname()}:{os.getpid()}"
    if skip_existing and job.outputs_exist():  # e.g. a rerun of a task whose worker died after writing
        return FrameResult(job.number, job.output, "skipped", worker=worker)
    if attributes:
        positions, particle_attributes = _trilevel.read_particles(job.input, list(attributes), drop_invalid=drop_invalid)
    else:
        positions, particle_attributes = _trilevel.read_particles(job.input, drop_invalid=drop_invalid), None
    if len(positions) == 0:
        raise _trilevel.Error(job.input + ": holds no particles")
    slot = _worker_reconstructor(device)
    rec = slot[0]
    # Serialised by the Reconstructor; the reset makes this frame independent of the process's last one.
    rec.reset_history()
    v, t, stats, vertex_level, _, *extra = rec.reconstruct(
        positions, particle_radius, level_hysteresis=0.0, return_levels=True, attributes=particle_attributes, **options)
    normals = extra.pop(0) if options.get("normals") else None
    vertex_attributes = extra.pop(0) if attributes else None
    _trilevel.write_mesh(job.output, v, t, vertex_level=vertex_level, color_levels=color_levels, normals=normals,
                         attributes=vertex_attributes)  # a temporary file renamed into place
    if job.stats:
        _write_atomically(job.stats, json.dumps(stats, indent=2) + "\n")
    with _reconstructors_lock:
        slot[1] += 1
        done = slot[1]
    return FrameResult(job.number, job.output, "done", triangles=len(t), closed=bool(stats["closed"]), worker=worker,
                       reconstructor=id(rec), frames_on_reconstructor=done)


def _client(scheduler, workers: int):
    """(client, things to close): a given Client, a Client of a scheduler address or scheduler file,
    or a LocalCluster of `workers` single-threaded processes on this machine."""
    if isinstance(scheduler, distributed.Client):
        return scheduler, []
    if scheduler is None:
        cluster = distributed.LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                                           dashboard_address=None)
        client = distributed.Client(cluster)
        return client, [client, cluster]
    scheduler = os.fspath(scheduler)
    if scheduler.endswith(".json") and os.path.isfile(scheduler):  # dask-scheduler --scheduler-file
        client = distributed.Client(scheduler_file=scheduler)
    else:
        client = distributed.Client(scheduler)
    return client, [client]


def reconstruct_frames(input_pattern: str, output_pattern: str, particle_radius: float, *,
                       scheduler: "distributed.Client | str | None" = None, workers: int = 2, stats_pattern: str = "",
                       start: int | None = None, end: int | None = None, skip_existing: bool = False,
                       attributes: Sequence[str] = (), color_levels: bool = False, drop_invalid: bool = False,
                       retries: int = 2, device: int = -1, progress: Callable[[FrameResult], None] | None = None,
                       **options: Any) -> list[FrameResult]:
    """Reconstructs the frames of a sequence on a dask.distributed cluster, one task per frame.

    input_pattern, output_pattern, stats_pattern: file names with "{}" for the frame number (as the
        CLI takes them; stats_pattern "" writes no statistics, else JSON of the --stats keys).
    particle_radius: r, world units.
    scheduler: a distributed.Client, a scheduler address ("tcp://head:8786"), the JSON file of
        `dask-scheduler --scheduler-file`, or None for a LocalCluster of `workers` processes with
        one thread each on this machine (closed at the end).
    start, end: the inclusive range of frame numbers (None: all).
    skip_existing: frames whose outputs all exist are not redone (the CLI's --skip-existing).
    attributes, color_levels, drop_invalid: the CLI's --attribute, --color-levels, --drop-invalid.
    retries: how often a frame that raised is retried (on any worker) before it counts as failed.
    device: OpenCL device index on the workers (< 0: TRILEVEL_DEVICE, else the first GPU, else CPU).
    progress: called on this process with each FrameResult as it arrives.
    options: Reconstructor.reconstruct keywords (mode, cell, kernel_radius, curvature_threshold,
        level2_tolerance, memory_limit, crack_closing, normals); not level_hysteresis, as every
        frame is reconstructed on its own.

    Returns a FrameResult per frame in the range, in frame order. Raises before any work for a bad
    pattern, range or option (trilevel.Error for an option value, as reconstruct would), or outputs
    that would overwrite a frame's input or each other; a frame that fails is reported in its
    result, not raised.
    """
    unknown = sorted(set(options) - set(_OPTIONS))
    if unknown:
        raise ValueError(f"unknown reconstruct options {unknown}; frames take {list(_OPTIONS)} "
                         "(each frame is independent: no level_hysteresis)")
    attributes = _names(attributes)
    _trilevel._check_params(particle_radius, **options)  # no device needed: the client may have none
    jobs = plan_frames(input_pattern, output_pattern, stats_pattern, start, end)
    results: dict[str, FrameResult] = {}
    todo = []
    for job in jobs:
        if skip_existing and job.outputs_exist():
            results[job.number] = FrameResult(job.number, job.output, "skipped")
            if progress:
                progress(results[job.number])
        else:
            todo.append(job)
    if todo:
        client, owned = _client(scheduler, workers)
        try:
            run = uuid.uuid4().hex[:8]
            futures = client.map(reconstruct_frame, todo, key=[f"trilevel-frame-{job.number}-{run}" for job in todo],
                                 retries=retries, pure=False, particle_radius=particle_radius, options=options,
                                 attributes=list(attributes), color_levels=color_levels, drop_invalid=drop_invalid,
                                 skip_existing=skip_existing, device=device)
            job_of = {future.key: job for future, job in zip(futures, todo)}
            for future in distributed.as_completed(futures):
                job = job_of[future.key]
                if future.status == "finished":
                    result = future.result()
                else:  # raised retries + 1 times, or killed too many workers (KilledWorker)
                    error = future.exception()
                    message = " ".join(str(error).split()) or type(error).__name__
                    result = FrameResult(job.number, job.output, "failed", error=f"frame {job.number}: {message}")
                results[job.number] = result
                if progress:
                    progress(result)
        finally:
            for thing in owned:
                thing.close()
    return [results[job.number] for job in jobs]


def _add_option(parser: argparse.ArgumentParser, keyword: str, **kwargs: Any) -> None:
    """An option for a Reconstructor keyword, named and helped as the CLI's (the parameter table of
    trilevel/params_table.hpp). Not given: None, and the keyword keeps the module's default."""
    entry = next(e for e in _trilevel._parameter_table() if e["python"] == keyword)
    shown = entry["default_means"] or entry["default"]
    shown = f"{shown:g}" if isinstance(shown, float) else "none" if shown is None else shown
    parser.add_argument(*entry["cli"].split(","), dest=keyword, default=None,
                        help=f"{entry['help']} (default: {shown})", **kwargs)


def _box(text: str) -> list[float]:
    """X0,Y0,Z0,X1,Y1,Z1 as the CLI takes a box (the library checks the numbers)."""
    try:
        values = [float(v) for v in text.split(",")]
    except ValueError:
        raise argparse.ArgumentTypeError(f"a box is six numbers X0,Y0,Z0,X1,Y1,Z1, got '{text}'") from None
    if len(values) != 6:
        raise argparse.ArgumentTypeError(f"a box is six numbers X0,Y0,Z0,X1,Y1,Z1, got {len(values)}")
    return values


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="python3 -m trilevel.dask", description=(
        "Reconstructs the frames of a sequence on a dask.distributed cluster, one task per frame and one "
        "Reconstructor per worker process. Every frame is independent (level hysteresis 0)."))
    parser.add_argument("input", help="particle files, '{}' for the frame number: 'sim/fluid_{}.bgeo'")
    parser.add_argument("-r", "--radius", type=float, required=True, help="particle radius r, world units")
    parser.add_argument("-o", "--output", required=True, help="mesh files, '{}' for the frame number")
    parser.add_argument("--stats", default="", help="statistics JSON files, '{}' for the frame number")
    parser.add_argument("--scheduler", default=None,
                        help="scheduler address (tcp://head:8786) or scheduler file; default: a local cluster")
    parser.add_argument("--workers", type=int, default=2, help="local cluster: worker processes (default 2)")
    parser.add_argument("--start", type=int, default=None, help="first frame number")
    parser.add_argument("--end", type=int, default=None, help="last frame number")
    parser.add_argument("--skip-existing", action="store_true", help="skip frames whose outputs exist (resume)")
    parser.add_argument("--retries", type=int, default=2, help="retries of a frame that raised (default 2)")
    parser.add_argument("--device", type=int, default=-1, help="OpenCL device index on the workers")
    _add_option(parser, "mode", choices=["adaptive", "uniform"])
    _add_option(parser, "cell", type=float)
    _add_option(parser, "kernel_radius", type=float)
    _add_option(parser, "curvature_threshold", type=float)
    _add_option(parser, "level2_tolerance", type=float)
    _add_option(parser, "crack_closing", choices=["collapse", "patches"])
    _add_option(parser, "memory_limit", type=int)
    _add_option(parser, "remove_components_below", type=float)
    _add_option(parser, "particle_box", type=_box)
    _add_option(parser, "clip_box", type=_box)
    _add_option(parser, "smooth", action="store_const", const=True)
    _add_option(parser, "smooth_iterations", type=int)
    _add_option(parser, "sliver_cleanup", action="store_const", const=True)
    _add_option(parser, "normals", nargs="?", const="gradient", choices=["gradient", "area"])
    parser.add_argument("--attribute", action="append", default=[], help="particle attribute to interpolate")
    parser.add_argument("--color-levels", action="store_true")
    parser.add_argument("--drop-invalid", action="store_true")
    parser.add_argument("-q", "--quiet", action="store_true", help="report failures only")
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """`python3 -m trilevel.dask`: the CLI's sequence options, on a dask.distributed cluster."""
    a = _parser().parse_args(argv)
    options = {k: getattr(a, k) for k in _OPTIONS if getattr(a, k) is not None}  # the others: Params{}'s
    if options.get("smooth_iterations"):
        options["smooth"] = True  # as the CLI: --smooth-iterations implies --smooth

    def report(result: FrameResult) -> None:
        if result.status == "failed":
            print(f"trilevel: error: {result.error}", file=sys.stderr, flush=True)
        elif not a.quiet and result.status == "done":
            print(f"frame {result.number}: {result.triangles} triangles, "
                  f"{'closed' if result.closed else 'NOT closed'}, on {result.worker}", flush=True)

    try:
        results = reconstruct_frames(a.input, a.output, a.radius, scheduler=a.scheduler, workers=a.workers,
                                     stats_pattern=a.stats, start=a.start, end=a.end, skip_existing=a.skip_existing,
                                     attributes=a.attribute, color_levels=a.color_levels, drop_invalid=a.drop_invalid,
                                     retries=a.retries, device=a.device, progress=report, **options)
    except (ValueError, OSError, _trilevel.Error) as e:
        print(f"trilevel: error: {e}", file=sys.stderr)
        return 2 if isinstance(e, ValueError) else 1
    counts = {s: sum(r.status == s for r in results) for s in ("done", "failed", "skipped")}
    failed = [r.error for r in results if r.status == "failed"]
    print(f"{len(results)} frames: {counts['done']} ok, {counts['failed']} failed"
          + (f" ({failed[0]}{', ...' if len(failed) > 1 else ''})" if failed else "") + f", {counts['skipped']} skipped")
    return 1 if failed else 0


if __name__ == "__main__":
    # The classes the workers unpickle must be trilevel.dask's, not this __main__ copy's.
    from trilevel.dask import main as package_main

    sys.exit(package_main())
